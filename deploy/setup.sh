#!/usr/bin/env bash
# Installs the Debian 12 packages regolith needs. Idempotent: packages already present are
# skipped, and `apt-get update` runs only when something is missing. Profiles:
#   run    build and run `regolith` (toolchain + libraries): README command 1, the lean first run
#   test   run + tests, benchmarks, the driver-test VM (QEMU, vcan / vivid / vimc), the Debian
#          package checks, clang (the asan preset, the fuzzers), the npm-pinned MCAP cross-check, chromium
#   cross  the arm64 cross toolchain and emulator (deploy/cross/build-arm64.sh)
#   all    test + cross (the default; README command 2 and .ci/run)
# Usage: bash deploy/setup.sh [run|test|cross|all]
# apt-get runs as root directly, else through sudo when sudo exists (else: a clear error).
set -euo pipefail

profile=${1:-all}
RUN_PACKAGES=(
  # toolchain
  build-essential cmake ninja-build pkg-config git ccache
  # libraries
  libopencv-dev libopencv-contrib-dev libeigen3-dev libyaml-cpp-dev
  cyclonedds-dev cyclonedds-tools
  libcamera-dev libcamera-ipa libcamera-tools libv4l-dev linux-libc-dev
  libcli11-dev libspdlog-dev libfmt-dev nlohmann-json3-dev libsystemd-dev
  libzstd-dev                # record/: MCAP chunk compression
  zlib1g-dev                 # saliency/: the rock model file (.yml.gz) is gunzipped and gzipped
  libfftw3-dev               # sfs/: FFTW plans made once (allocation-free Pentland)
  libwebsocketpp-dev libboost-dev  # runtime/live: Foxglove WebSocket server (header-only; optional)
)
TEST_PACKAGES=(
  # tests and benchmarks
  libgtest-dev libgmock-dev googletest libbenchmark-dev
  graphviz                   # `regolith config check --dot` output is parsed by dot in the tests
  clang libclang-rt-14-dev   # the asan preset's compiler; libFuzzer + ASan/UBSan runtimes (tests/fuzz/run.sh)
  clang-format               # style.clang_format: every C++ file formatted with .clang-format
  # driver tests (tests/hw): QEMU VM with Debian's kernel (downloaded with apt-get download and
  # cached in ~/.cache/regolith-vm), vimc built out of tree, can-utils / v4l-utils / cam in the guest
  qemu-system-x86 kmod cpio xz-utils libelf1 iproute2 busybox-static can-utils v4l-utils python3
  # packaging and service checks (tests/deploy): cpack DEB, lintian, systemd-analyze verify
  dpkg-dev lintian systemd
  chromium                   # headless browser: the live page test (tests/live/test_live_page.cpp)
  python3-yaml               # bench/fuzz/param_bounds.py: every deployment parameter at its bounds
)
CROSS_PACKAGES=(
  # arm64 cross-build and emulated unit tests (deploy/cross/build-arm64.sh)
  crossbuild-essential-arm64 qemu-user mmdebstrap
)
case "$profile" in
  run) PACKAGES=("${RUN_PACKAGES[@]}") ;;
  test) PACKAGES=("${RUN_PACKAGES[@]}" "${TEST_PACKAGES[@]}") ;;
  cross) PACKAGES=("${RUN_PACKAGES[@]}" "${CROSS_PACKAGES[@]}") ;;
  all) PACKAGES=("${RUN_PACKAGES[@]}" "${TEST_PACKAGES[@]}" "${CROSS_PACKAGES[@]}") ;;
  *) echo "regolith setup: unknown profile '$profile' (run, test, cross or all)" >&2; exit 2 ;;
esac

# Root runs apt-get itself; anyone else needs sudo.
as_root() {
  if [[ $(id -u) -eq 0 ]]; then
    "$@"
  elif command -v sudo >/dev/null 2>&1; then
    sudo "$@"
  else
    echo "regolith setup: installing packages needs root: run this script as root, or install sudo" >&2
    exit 1
  fi
}

missing=()
for p in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if ((${#missing[@]})); then
  echo "regolith setup ($profile): installing ${#missing[@]} Debian packages: ${missing[*]}"
  as_root apt-get update -qq
  as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${missing[@]}"
else
  echo "regolith setup ($profile): all ${#PACKAGES[@]} Debian packages already installed"
fi
[[ $profile == run || $profile == cross ]] && exit 0

# The independent MCAP check (tests/record/mcap_js): the TypeScript @mcap/core reader, pinned by
# package-lock.json. Debian's nodejs + npm are installed only when no npm is on PATH (a machine
# with another Node.js, e.g. nodesource's, keeps it: Debian's npm package conflicts with it).
if ! command -v npm >/dev/null 2>&1; then
  echo "regolith setup: installing Debian's nodejs and npm for tests/record/mcap_js"
  as_root apt-get update -qq
  as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends nodejs npm
fi
mcap_js="$(dirname "$0")/../tests/record/mcap_js"
if [[ -d $mcap_js/node_modules/@mcap/core && $mcap_js/node_modules/.package-lock.json -nt $mcap_js/package-lock.json ]]; then
  echo "regolith setup: tests/record/mcap_js node modules up to date"
else
  echo "regolith setup: npm ci in tests/record/mcap_js (@mcap/core for the MCAP cross-check)"
  (cd "$mcap_js" && npm ci --no-audit --no-fund --loglevel=error)
fi
# The independent Foxglove WebSocket client of tests/live (@foxglove/ws-protocol over ws, the
# @foxglove/rosmsg2-serialization decoder), pinned by package-lock.json.
live_js="$(dirname "$0")/../tests/live/js"
if [[ -d $live_js/node_modules/@foxglove/ws-protocol && $live_js/node_modules/.package-lock.json -nt $live_js/package-lock.json ]]; then
  echo "regolith setup: tests/live/js node modules up to date"
else
  echo "regolith setup: npm ci in tests/live/js (@foxglove/ws-protocol for the live-view check)"
  (cd "$live_js" && npm ci --no-audit --no-fund --loglevel=error)
fi
