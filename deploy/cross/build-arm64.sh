#!/usr/bin/env bash
# Cross-build regolith for arm64 (aarch64) on a Debian 12 amd64 machine and run its unit tests
# under qemu-aarch64 user emulation. Idempotent: every step is skipped when already done.
#
#   bash deploy/cross/build-arm64.sh [--no-tests] [--all-tests] [--tests REGEX] [--jobs N]
#
# Steps
#   1. host tools (apt): crossbuild-essential-arm64, qemu-user, mmdebstrap, cyclonedds-tools (idlc
#      runs on the host), cmake, ninja-build, pkg-config;
#   2. arm64 sysroot: Debian 12's arm64 -dev packages and their dependencies extracted (not
#      installed: no maintainer scripts, nothing added to the host's dpkg database) with
#      `mmdebstrap --variant=extract` into $REGOLITH_ARM64_SYSROOT (default
#      /var/cache/regolith/arm64-sysroot), re-made only when the package list changes. A sysroot
#      instead of `dpkg --add-architecture arm64` + apt, because on Debian 12 libopencv-dev,
#      libopencv-contrib-dev, libopencv-imgcodecs-dev, libopencv-highgui-dev and libyaml-cpp-dev
#      for arm64 are not co-installable with their amd64 versions (apt removes the amd64 ones);
#   3. configure with the `cross-arm64` preset (deploy/cross/aarch64-linux-gnu.cmake), build;
#   4. by default only the `regolith` binary and the `arm64_tests` suites are built (tests/CMakeLists.txt:
#      the suites where the architecture can change the result: memory ordering, byte order, FFT
#      and SfS numerics, the parsers' fuzz corpora), and ctest -L unit runs them under
#      qemu-aarch64. The algorithm and pipeline suites cost most of the cross compile and many
#      minutes of emulated CPU: the host run scores them on the same code. With --all-tests
#      everything is built and every test runs except the `hw`, `deploy` and `arm64` labels
#      ($heavy below, the dataset-level runs, is then included); --tests REGEX: the built unit tests matching REGEX. Cyclone DDS cannot
#      create a participant under qemu-user 7.2 (setsockopt IP_MULTICAST_IF is not emulated), so
#      DDS tests only pass natively.
# Environment: REGOLITH_ARM64_SYSROOT, REGOLITH_ARM64_BUILD_DIR (default build/cross-arm64).
set -euo pipefail

here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
src=$(cd "$here/../.." && pwd)
jobs=2
run_tests=1
# Dataset-level accuracy tests left to the host run by default (see step 4).
heavy='^(DriveMapper[.]VisionCorrectsWheelDriftOnARenderedDrive|DevelopmentDrives[.]CorrectedPosesBeatWheelOdometry|Dataset[.]ContrastGroupedCrossValidationOnMarsData|TerrainStereo[.]RockSizesSfsDirectDepthVsStereo|SinkageMisalignment[.].*)$'
label_args=(-L unit -E "_NOT_BUILT\$|$heavy")  # _NOT_BUILT: suites outside arm64_tests
build_targets=(--target regolith arm64_tests)
while (($#)); do
  case "$1" in
    --no-tests) run_tests=0 ;;
    --all-tests) label_args=(-LE "hw|deploy|arm64"); build_targets=() ;;
    --tests) label_args=(-L unit -E "_NOT_BUILT\$" -R "$2"); shift ;;  # a subset of the unit tests, e.g. '^(Watchdog|Channels)'

    --jobs) jobs="$2"; shift ;;
    -h|--help) sed -n '2,28p' "${BASH_SOURCE[0]}"; exit 0 ;;
    *) echo "build-arm64.sh: unknown argument '$1'" >&2; exit 2 ;;
  esac
  shift
done
export REGOLITH_ARM64_SYSROOT=${REGOLITH_ARM64_SYSROOT:-/var/cache/regolith/arm64-sysroot}
build=${REGOLITH_ARM64_BUILD_DIR:-$src/build/cross-arm64}
SUDO=""
if [[ $(id -u) -ne 0 ]]; then SUDO="sudo"; fi
t0=$SECONDS
step() { printf '[arm64 %4ds] %s\n' $((SECONDS - t0)) "$*"; }

# ---- 1. host tools --------------------------------------------------------------------------------
HOST_PACKAGES=(crossbuild-essential-arm64 qemu-user mmdebstrap cyclonedds-tools cmake ninja-build pkg-config)
missing=()
for p in "${HOST_PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  step "installing host packages: ${missing[*]}"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi

# ---- 2. arm64 sysroot -----------------------------------------------------------------------------
# The arm64 counterparts of deploy/setup.sh's libraries (header-only ones included: CMake looks for
# their package files inside the sysroot only).
SYSROOT_PACKAGES=(
  libc6-dev libstdc++-12-dev
  libopencv-dev libopencv-contrib-dev libeigen3-dev libyaml-cpp-dev
  cyclonedds-dev libcamera-dev libv4l-dev
  libcli11-dev libspdlog-dev libfmt-dev nlohmann-json3-dev libsystemd-dev libzstd-dev libfftw3-dev
  libgtest-dev libgmock-dev libbenchmark-dev
)
stamp="$REGOLITH_ARM64_SYSROOT/.regolith-sysroot"
want="bookworm arm64 ${SYSROOT_PACKAGES[*]}"
if [[ ! -f $stamp || $(cat "$stamp") != "$want" ]]; then
  step "creating the arm64 sysroot in $REGOLITH_ARM64_SYSROOT (${#SYSROOT_PACKAGES[@]} packages + dependencies)"
  $SUDO rm -rf "$REGOLITH_ARM64_SYSROOT"
  $SUDO mkdir -p "$(dirname "$REGOLITH_ARM64_SYSROOT")"
  # The host's own apt sources (same mirror and suites: bookworm, -updates, -security).
  mirrors=()
  for f in /etc/apt/sources.list.d/*.sources /etc/apt/sources.list; do
    [[ -s $f ]] && grep -q "^[^#]*debian" "$f" && mirrors+=("$f")
  done
  include=$(IFS=,; echo "${SYSROOT_PACKAGES[*]}")
  $SUDO mmdebstrap --quiet --arch=arm64 --variant=extract --include="$include" \
    --skip=output/dev,output/mknod bookworm "$REGOLITH_ARM64_SYSROOT" "${mirrors[@]}"
  # Absolute symbolic links (e.g. lib*.so -> /lib/aarch64-linux-gnu/...) must point inside the
  # sysroot for the cross linker: make them relative.
  while IFS= read -r -d '' link; do
    target=$(readlink "$link")
    if [[ $target == /* ]]; then
      $SUDO ln -sfn "$(realpath -m --relative-to="$(dirname "$link")" "$REGOLITH_ARM64_SYSROOT$target")" "$link"
    fi
  done < <(find "$REGOLITH_ARM64_SYSROOT" -type l -print0)
  echo "$want" | $SUDO tee "$stamp" >/dev/null
  step "sysroot ready: $(du -sh "$REGOLITH_ARM64_SYSROOT" | cut -f1)"
else
  step "arm64 sysroot up to date ($REGOLITH_ARM64_SYSROOT)"
fi

# ---- 3. configure and build -----------------------------------------------------------------------
step "configuring $build"
mkdir -p "$(dirname "$build")"
cmake -S "$src" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_TOOLCHAIN_FILE="$src/deploy/cross/aarch64-linux-gnu.cmake" \
  -DREGOLITH_ARM64_SYSROOT="$REGOLITH_ARM64_SYSROOT" -DREGOLITH_BUILD_BENCH=OFF >"$build.configure.log" 2>&1 ||
  { cat "$build.configure.log"; exit 1; }
step "building (-j$jobs) ${build_targets[*]:-everything}"
cmake --build "$build" -j "$jobs" "${build_targets[@]}"
file "$build/tools/regolith" | sed 's/^/  /'

# ---- 4. unit tests under emulation --------------------------------------------------------------
if ((run_tests)); then
  step "running tests under qemu-aarch64: ctest ${label_args[*]}"
  ctest --test-dir "$build" "${label_args[@]}" -j "$jobs" --output-on-failure --timeout 600
fi
step "done"
