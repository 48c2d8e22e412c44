#!/bin/bash
# tests/hw/run.sh BUILD_DIR [CTEST_ARGS...]
#
# Runs regolith's driver tests (CTest label `hw`) against real kernel drivers — vcan, vivid, vimc —
# in ONE boot of Debian's own kernel under QEMU, on a host whose kernel has no CAN / V4L2.
#   * first use: builds the VM assets with tests/hw/vm/setup.sh (cached in $REGOLITH_VM_DIR,
#     default ~/.cache/regolith-vm; ~1 min, downloads Debian kernel packages with apt-get download);
#   * boots with the host's / as a throw-away copy-on-write root and BUILD_DIR shared read-write at
#     the same path, then runs `ctest -L hw --output-on-failure --timeout <per-test>` in BUILD_DIR
#     (or `ctest CTEST_ARGS...` when given);
#   * exits with ctest's exit code; 124 when the VM hit the hard time limit, 125 when the VM
#     failed before the tests ran.
#
# Knobs (environment):
#   REGOLITH_VM_DIR          VM asset cache                          (~/.cache/regolith-vm)
#   REGOLITH_HW_TIMEOUT      hard limit for the whole boot, seconds  (900)
#   REGOLITH_HW_TEST_TIMEOUT per-test ctest timeout, seconds         (180)
#   REGOLITH_HW_MODULES      drivers to load ("vcan can-raw can-bcm vivid vimc")
#   REGOLITH_HW_VCAN         vcan interfaces to create               ("vcan0")
#   REGOLITH_HW_MEM / REGOLITH_HW_SMP   guest MiB / vCPUs            (1024 / 2)
#   REGOLITH_HW_ACCEL        auto | tcg | kvm                        (auto)
#   REGOLITH_HW_CONSOLE=1    print the guest kernel log afterwards (always printed on VM failure)
set -uo pipefail

HERE=$(cd "$(dirname "$0")" && pwd)
if [ $# -lt 1 ] || [ "$1" = -h ] || [ "$1" = --help ]; then
  sed -n '2,22p' "$0" | sed 's/^# \{0,1\}//' >&2
  exit 2
fi
BUILD=$(cd "$1" 2> /dev/null && pwd -P) || { echo "hw: build directory '$1' does not exist" >&2; exit 2; }
shift
[ -f "$BUILD/CTestTestfile.cmake" ] || { echo "hw: $BUILD is not a CMake build tree with tests" >&2; exit 2; }

VMDIR=${REGOLITH_VM_DIR:-${XDG_CACHE_HOME:-$HOME/.cache}/regolith-vm}
export REGOLITH_VM_DIR=$VMDIR
HARD=${REGOLITH_HW_TIMEOUT:-900}
PER_TEST=${REGOLITH_HW_TEST_TIMEOUT:-180}
MODULES=${REGOLITH_HW_MODULES-"vcan can-raw can-bcm vivid vimc"}
VCAN=${REGOLITH_HW_VCAN-vcan0}
MEM=${REGOLITH_HW_MEM:-1024}
SMP=${REGOLITH_HW_SMP:-2}
ACCEL=${REGOLITH_HW_ACCEL:-auto}
if [ "$ACCEL" = auto ]; then
  # KVM only with hardware virtualisation: a PVM host offers /dev/kvm but cannot boot a stock kernel
  if [ -w /dev/kvm ] && grep -qwE 'vmx|svm' /proc/cpuinfo && [ ! -d /sys/module/kvm_pvm ]; then
    ACCEL=kvm
  else
    ACCEL=tcg
  fi
fi

clock() { date +%s.%N; }
T_START=$(clock)
timeout 900 "$HERE/vm/setup.sh" || { echo "hw: VM setup failed" >&2; exit 125; }
T_SETUP=$(clock)
command -v qemu-system-x86_64 > /dev/null || { echo "hw: qemu-system-x86_64 missing (apt-get install qemu-system-x86)" >&2; exit 125; }

CTL=$(mktemp -d "${TMPDIR:-/tmp}/regolith-hw.XXXXXX") || exit 125
trap 'rm -rf "$CTL"' EXIT
printf 'HW_SHARE=%q\nHW_MODULES=%q\nHW_VCAN=%q\nHW_VM_DIR=%q\n' \
  "$BUILD" "$MODULES" "$VCAN" "$(cd "$VMDIR" && pwd -P)" > "$CTL/env"
if [ $# -eq 0 ]; then
  set -- ctest -L hw --output-on-failure --timeout "$PER_TEST"
fi
{
  echo 'export PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin HOME=/root USER=root'
  echo 'export REGOLITH_HW_VM=1 CTEST_OUTPUT_ON_FAILURE=1 GTEST_COLOR=no'
  for v in LANG CI; do [ -n "${!v+x}" ] && printf 'export %s=%q\n' "$v" "${!v}"; done
  printf 'cd %q || exit 126\n' "$BUILD"
  # the command gets the hard limit minus a margin for boot and power-off, so ctest's own output
  # (which test hung) reaches the log before the VM is killed
  printf 'exec timeout -k 5 %d' "$((HARD > 60 ? HARD - 45 : HARD))"
  printf ' %q' "$@"
  printf '\n'
} > "$CTL/cmd.sh"

case $ACCEL in
  kvm) ACCEL_ARGS=(-accel kvm -cpu host) ;;
  *) ACCEL_ARGS=(-accel tcg,thread=multi -cpu max) ;;
esac
KERNEL=$VMDIR/vmlinux
[ -r "$KERNEL" ] || KERNEL=$VMDIR/vmlinuz
echo "hw: booting $(cat "$VMDIR/kernel.version") [$ACCEL, ${MEM} MiB, $SMP vCPU], running: $* (in $BUILD)" >&2

timeout -k 10 "$HARD" qemu-system-x86_64 -nodefaults -no-user-config -M pc "${ACCEL_ARGS[@]}" \
  -smp "$SMP" -m "$MEM" -display none -vga none -nic none -no-reboot \
  -kernel "$KERNEL" -initrd "$VMDIR/initrd.img" \
  -append "console=ttyS0 loglevel=4 panic=-1 mitigations=off random.trust_cpu=on i8042.noaux i8042.nokbd" \
  -chardev "file,id=klog,path=$CTL/console.log" -serial chardev:klog \
  -chardev stdio,id=out,signal=on -serial chardev:out \
  -fsdev "local,id=fsroot,path=/,security_model=none,readonly=on,multidevs=remap" \
  -device virtio-9p-pci,fsdev=fsroot,mount_tag=hostroot \
  -fsdev "local,id=fsctl,path=$CTL,security_model=none" \
  -device virtio-9p-pci,fsdev=fsctl,mount_tag=hwctl \
  -fsdev "local,id=fsshare,path=$BUILD,security_model=none,multidevs=remap" \
  -device virtio-9p-pci,fsdev=fsshare,mount_tag=hwshare \
  -device virtio-rng-pci < /dev/null
qrc=$?
T_END=$(clock)
if [ -s "$CTL/rc" ]; then
  rc=$(cat "$CTL/rc")
elif [ $qrc -eq 124 ] || [ $qrc -eq 137 ]; then
  rc=124
  echo "hw: the VM exceeded REGOLITH_HW_TIMEOUT=${HARD}s and was killed" >&2
else
  rc=125
fi
if [ "${REGOLITH_HW_CONSOLE:-0}" = 1 ] || [ ! -s "$CTL/rc" ] || [ "$rc" = 125 ]; then
  echo "----- hw: guest kernel log (qemu exit $qrc) -----" >&2
  cat "$CTL/console.log" >&2
fi
awk -v rc="$rc" -v t0="$T_START" -v ts="$T_SETUP" -v t1="$T_END" \
  -v tm="$(cat "$CTL/t_modules" 2> /dev/null)" -v tc="$(cat "$CTL/t_cmd_start" 2> /dev/null)" \
  -v te="$(cat "$CTL/t_cmd_end" 2> /dev/null)" 'BEGIN {
    printf "hw: rc=%s total=%.1fs (setup check %.1fs, VM %.1fs", rc, t1 - t0, ts - t0, t1 - ts
    if (tc != "") printf ", boot-to-tests %.1fs, drivers %.1fs", tc, tc - tm
    if (te != "") printf ", tests %.1fs", te - tc
    printf ")\n" }' >&2
exit "$rc"
