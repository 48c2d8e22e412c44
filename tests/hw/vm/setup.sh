#!/bin/bash
# tests/hw/vm/setup.sh — build the driver-test VM assets from Debian packages (no root needed once
# the host packages are installed). Idempotent: does nothing when $VMDIR/ready matches.
#
#   REGOLITH_VM_DIR=~/.cache/regolith-vm tests/hw/vm/setup.sh [--force | --initrd]
#
# Produces in $REGOLITH_VM_DIR (default ${XDG_CACHE_HOME:-~/.cache}/regolith-vm):
#   vmlinux / vmlinuz   Debian's amd64 kernel (vmlinux = uncompressed ELF, boots faster under TCG)
#   initrd.img          busybox + virtio/9p/overlay modules + tests/hw/vm/init.sh as /init
#   kroot/lib/modules   the full module tree plus extra/vimc.ko (Debian does not build vimc)
#   ready               stamp: kernel release + hash of init.sh
# Host packages: qemu-system-x86 kmod cpio xz-utils gcc-12 make libelf1 python3 (see tests/hw/README.md).
set -euo pipefail

VMDIR=${REGOLITH_VM_DIR:-${XDG_CACHE_HOME:-$HOME/.cache}/regolith-vm}
HERE=$(cd "$(dirname "$0")" && pwd)
export PATH=$PATH:/usr/sbin:/sbin
START=$(date +%s.%N)
say() { printf '[hw-setup %5.1fs] %s\n' "$(awk -v a="$(date +%s.%N)" -v b="$START" 'BEGIN{print a-b}')" "$*" >&2; }

mkdir -p "$VMDIR"
exec 9> "$VMDIR/.lock"
flock -w 600 9 || { echo "hw-setup: another setup holds $VMDIR/.lock" >&2; exit 1; }

INIT_HASH=$(sha256sum "$HERE/init.sh" | cut -c1-16)

pack_initrd() {
  install -m 0755 "$HERE/init.sh" "$VMDIR/initrd/init"
  (cd "$VMDIR/initrd" && find . | cpio -o -H newc --quiet | gzip -1 > "$VMDIR/initrd.img.new")
  mv "$VMDIR/initrd.img.new" "$VMDIR/initrd.img"
}

if [ "${1:-}" = --initrd ]; then
  pack_initrd
  echo "$(cat "$VMDIR/kernel.version") $INIT_HASH" > "$VMDIR/ready"
  say "initrd re-packed"; exit 0
fi

KPKG=${REGOLITH_KERNEL_PKG:-$(apt-cache depends linux-image-amd64 2>/dev/null | awk '/Depends: linux-image-[0-9]/{print $2; exit}')}
[ -n "$KPKG" ] || { echo "hw-setup: cannot resolve linux-image-amd64 (apt-get update first)" >&2; exit 1; }
KREL=${KPKG#linux-image-}            # e.g. 6.1.0-56-amd64
KABI=${KREL%-amd64}                  # 6.1.0-56
KMM=$(echo "$KREL" | cut -d. -f1-2)  # 6.1

if [ "${1:-}" != --force ] && [ -f "$VMDIR/ready" ]; then
  read -r have_rel have_hash < "$VMDIR/ready" || true
  if [ "$have_rel" = "$KREL" ] && [ "$have_hash" = "$INIT_HASH" ] && [ -r "$VMDIR/initrd.img" ]; then
    exit 0
  fi
  if [ "$have_rel" = "$KREL" ] && [ -d "$VMDIR/initrd" ]; then
    pack_initrd; echo "$KREL $INIT_HASH" > "$VMDIR/ready"; say "init.sh changed: initrd re-packed"; exit 0
  fi
fi
rm -f "$VMDIR/ready"

missing=()
for tool in qemu-system-x86_64:qemu-system-x86 depmod:kmod cpio:cpio xz:xz-utils gcc-12:gcc-12 make:make python3:python3; do
  command -v "${tool%%:*}" > /dev/null || missing+=("${tool#*:}")
done
[ -e /usr/lib/x86_64-linux-gnu/libelf.so.1 ] || missing+=(libelf1)
if [ ${#missing[@]} -gt 0 ]; then
  echo "hw-setup: missing host packages: ${missing[*]} (apt-get install -y --no-install-recommends ${missing[*]})" >&2
  exit 1
fi

PKGS=("$KPKG" "linux-headers-$KREL" "linux-headers-$KABI-common" "linux-kbuild-$KMM" "linux-source-$KMM" busybox-static)
# The first five must be one kernel: the same upstream version (the package names already carry
# the ABI). Their Debian revisions can differ: the signed image is built by another source
# package and can lag (Debian security once had linux-image-6.1.0-56-amd64 6.1.192-2 beside
# linux-kbuild-6.1 and linux-source-6.1 6.1.192-3, and -2 of those was gone). Each is fetched at
# the newest revision of the image's upstream version that the archive has (`apt-cache madison`);
# a cached .deb of another upstream version is replaced.
KVER=$(apt-cache policy "$KPKG" 2>/dev/null | awk '/Candidate:/{print $2; exit}')
[ -n "$KVER" ] && [ "$KVER" != "(none)" ] || { echo "hw-setup: no candidate version of $KPKG (apt-get update first)" >&2; exit 1; }
upstream() { echo "${1%-*}"; }  # 6.1.192-2 -> 6.1.192
mkdir -p "$VMDIR/debs"
cd "$VMDIR/debs"
download() { apt-get download "$1" 2>&1 | grep -v -e unsandboxed -e '^Get:' >&2 || true; }
for i in "${!PKGS[@]}"; do
  p=${PKGS[$i]}
  if [ "$i" -lt 5 ]; then
    for f in "${p}"_*.deb; do
      if [ -e "$f" ] && [ "$(upstream "$(dpkg-deb -f "$f" Version)")" != "$(upstream "$KVER")" ]; then rm -f "$f"; fi
    done
    if ! compgen -G "${p}_*.deb" > /dev/null; then
      v=$(apt-cache madison "$p" 2>/dev/null | awk -F'|' -v u="$(upstream "$KVER")" '{gsub(/ /, "", $2); if (index($2, u "-") == 1) {print $2; exit}}')
      [ -n "$v" ] && download "$p=$v"
    fi
  fi
  compgen -G "${p}_*.deb" > /dev/null || download "$p"
  compgen -G "${p}_*.deb" > /dev/null || { echo "hw-setup: apt-get download $p failed" >&2; exit 1; }
done
nver=$(for p in "${PKGS[@]:0:5}"; do upstream "$(dpkg-deb -f "${p}"_*.deb Version)"; done | sort -u | wc -l)
[ "$nver" = 1 ] || {
  echo "hw-setup: the kernel packages come from different upstream versions:" >&2
  for p in "${PKGS[@]:0:5}"; do echo "  ${p} $(dpkg-deb -f "${p}"_*.deb Version)" >&2; done
  exit 1
}
say "kernel $KREL: packages present"
cd "$VMDIR"

rm -rf kroot initrd vimc-build
mkdir kroot
for p in "$KPKG" "linux-headers-$KREL" "linux-headers-$KABI-common" "linux-kbuild-$KMM" busybox-static; do
  dpkg-deb -x debs/"${p}"_*.deb kroot
done
cp "kroot/boot/vmlinuz-$KREL" vmlinuz
echo "$KREL" > kernel.version

# The bzImage carries an xz-compressed ELF; booting the ELF directly (PVH entry) skips the
# decompressor, which is slow under TCG.
python3 - vmlinuz vmlinux <<'PY'
import lzma, sys
blob = open(sys.argv[1], "rb").read()
at = blob.find(b"\xfd7zXZ\x00")
if at < 0:
    sys.exit("no xz stream in the kernel image")
elf = lzma.LZMADecompressor().decompress(blob[at:])
if elf[:4] != b"\x7fELF":
    sys.exit("decompressed kernel is not an ELF file")
open(sys.argv[2], "wb").write(elf)
PY
say "kernel unpacked"

# vimc: compiled out of tree from linux-source against the matching headers.
HDRS=$VMDIR/kroot/usr/src/linux-headers-$KREL
echo "include $VMDIR/kroot/usr/src/linux-headers-$KABI-common/Makefile" > "$HDRS/Makefile"
mkdir vimc-build
dpkg-deb --fsys-tarfile debs/linux-source-"$KMM"_*.deb |
  tar -xO "./usr/src/linux-source-$KMM.tar.xz" |
  tar -xJ -C vimc-build --strip-components=5 "linux-source-$KMM/drivers/media/test-drivers/vimc"
sed 's/obj-$(CONFIG_VIDEO_VIMC)/obj-m/' vimc-build/Makefile > vimc-build/Kbuild
rm vimc-build/Makefile
make -s -C "$HDRS" M="$VMDIR/vimc-build" -j"$(nproc)" modules >&2
MODDIR=$VMDIR/kroot/lib/modules/$KREL
mkdir -p "$MODDIR/extra"
cp vimc-build/vimc.ko "$MODDIR/extra/"
depmod -b "$VMDIR/kroot" "$KREL"
rm -rf vimc-build
say "vimc.ko built"

# initramfs: busybox, the modules needed to reach the host root (virtio, 9p, overlay) and, as a
# fallback, the test drivers with their dependencies.
EARLY="virtio_pci 9pnet_virtio 9p overlay virtio_rng"
TESTMODS="vcan can-raw can-bcm vivid vimc"
mkdir -p initrd/{bin,proc,sys,dev,lower,rw,newroot,etc/hw,lib/modules/"$KREL"}
for m in $EARLY $TESTMODS; do
  modprobe -d "$VMDIR/kroot" -S "$KREL" --show-depends "$m" | awk '$1 == "insmod" {print $2}'
done | awk '!seen[$0]++' | while read -r ko; do
  rel=${ko#"$MODDIR"/}
  mkdir -p "initrd/lib/modules/$KREL/$(dirname "$rel")"
  cp "$ko" "initrd/lib/modules/$KREL/$rel"
done
cp "$MODDIR"/modules.order "$MODDIR"/modules.builtin* "initrd/lib/modules/$KREL/"
depmod -b "$VMDIR/initrd" "$KREL"
for m in $EARLY; do
  modprobe -d "$VMDIR/initrd" -S "$KREL" --show-depends "$m" | awk '$1 == "insmod" {print $2}'
done | awk '!seen[$0]++' | sed "s#^$VMDIR/initrd##" > initrd/etc/hw/early.order
cp kroot/bin/busybox initrd/bin/busybox
pack_initrd
echo "$KREL $INIT_HASH" > ready
say "ready: $VMDIR ($(du -sh initrd.img | cut -f1) initrd)"
