#!/bin/busybox sh
# /init of the regolith driver-test initramfs (PID 1 in the guest; packed by tests/hw/vm/setup.sh).
#  1. loads virtio/9p/overlay, mounts the control dir (9p "hwctl") and the host's / (9p "hostroot",
#     read-only) under a tmpfs overlay: the guest runs the host's userland, writes are discarded;
#  2. mounts the shared dir (9p "hwshare", read-write) at the same absolute path as on the host, so
#     CMake build trees work unchanged;
#  3. loads the test drivers (vcan, can-raw, vivid, vimc, ...), creates the vcan interfaces, writes
#     udev database stubs (libcamera enumerates only "initialized" devices and there is no udevd);
#  4. runs /run/hwctl/cmd.sh with output on the second serial port, stores its exit status in the
#     control dir, powers off.
/bin/busybox --install -s /bin
export PATH=/bin
mount -t proc proc /proc
mount -t sysfs sysfs /sys
mount -t devtmpfs devtmpfs /dev
OUT=/dev/ttyS1
stty -F $OUT raw -echo 2> /dev/null
uptime_s() { cut -d' ' -f1 /proc/uptime; }
abort() {
  echo "hw-init: $*" > $OUT
  echo "hw-init: $*"
  [ -d /ctl ] && echo 125 > /ctl/rc
  sync
  poweroff -f
}

while read -r ko; do insmod "$ko" || echo "hw-init: insmod $ko failed"; done < /etc/hw/early.order
NINEP="trans=virtio,version=9p2000.L,msize=512000"
mkdir -p /ctl
mount -t 9p -o "$NINEP,cache=none" hwctl /ctl || abort "control dir not mountable"
. /ctl/env
mount -t 9p -o "$NINEP,ro,cache=loose" hostroot /lower || abort "host root not mountable"
mount -t tmpfs -o mode=0755 tmpfs /rw
mkdir -p /rw/upper /rw/work
R=/newroot
mount -t overlay overlay -o lowerdir=/lower,upperdir=/rw/upper,workdir=/rw/work $R ||
  abort "overlay root failed"
mount -t proc proc $R/proc
mount -t sysfs sysfs $R/sys
mount -t devtmpfs devtmpfs $R/dev
mkdir -p $R/dev/pts $R/dev/shm
mount -t devpts devpts $R/dev/pts
mount -t tmpfs tmpfs $R/dev/shm
mount -t tmpfs tmpfs $R/run
mount -t tmpfs tmpfs $R/tmp
mkdir -p $R/run/hwctl && mount --bind /ctl $R/run/hwctl
KREL=$(uname -r)
mkdir -p $R/lib/modules/$KREL
if [ -f "$R$HW_VM_DIR/kroot/lib/modules/$KREL/modules.dep" ]; then
  mount --bind "$R$HW_VM_DIR/kroot/lib/modules/$KREL" $R/lib/modules/$KREL
else
  mount --bind /lib/modules/$KREL $R/lib/modules/$KREL
fi
# module requests from the kernel (e.g. socket(PF_CAN, ...)) go to the guest's kmod
printf '#!/bin/sh\nexec /bin/chroot /newroot /usr/sbin/modprobe "$@"\n' > /bin/hw-modprobe
chmod +x /bin/hw-modprobe
echo /bin/hw-modprobe > /proc/sys/kernel/modprobe
if [ -n "$HW_SHARE" ]; then
  mkdir -p "$R$HW_SHARE"
  mount -t 9p -o "$NINEP,cache=mmap" hwshare "$R$HW_SHARE" || abort "share $HW_SHARE not mountable"
fi
hostname regolith-hw
ip link set lo up
uptime_s > /ctl/t_modules
for m in $HW_MODULES; do
  name=${m%%:*}
  args=
  [ "$name" != "$m" ] && args=$(echo "${m#*:}" | tr ',' ' ')
  modprobe "$name" $args > /dev/null 2>&1 || chroot $R /usr/sbin/modprobe "$name" $args > /dev/null 2>&1 ||
    echo "hw-init: modprobe $m failed" > $OUT
done
IPCMD="chroot $R /usr/sbin/ip"
[ -x $R/usr/sbin/ip ] || IPCMD=ip
for i in $HW_VCAN; do
  $IPCMD link add dev "$i" type vcan && $IPCMD link set "$i" up || echo "hw-init: vcan $i failed" > $OUT
done
mkdir -p $R/usr/local/sbin
cat > $R/usr/local/sbin/hw-udev-db << 'EOF'
#!/bin/sh
# Minimal udev database entries for every character device (libcamera needs them; no udevd here).
# Call again after (re)loading media drivers.
mkdir -p /run/udev/data
for f in /sys/dev/char/*; do
  [ -e "/run/udev/data/c${f##*/}" ] || printf 'I:1000000\nV:1\n' > "/run/udev/data/c${f##*/}"
done
EOF
chmod +x $R/usr/local/sbin/hw-udev-db
chroot $R /usr/local/sbin/hw-udev-db
uptime_s > /ctl/t_cmd_start
chroot $R /bin/bash /run/hwctl/cmd.sh < /dev/null > $OUT 2>&1
rc=$?
uptime_s > /ctl/t_cmd_end
echo $rc > /ctl/rc
sync
[ -n "$HW_SHARE" ] && umount "$R$HW_SHARE" 2> /dev/null
umount /ctl 2> /dev/null
poweroff -f
