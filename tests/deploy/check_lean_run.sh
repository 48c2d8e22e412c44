#!/usr/bin/env bash
# deploy.lean_run: README command 1 (the lean first run) from a clean copy of the source tree in a
# fresh build directory. `setup.sh run` checks its profile's packages (all present on a machine
# that runs the tests; otherwise it installs the missing ones as root or through sudo), the `run`
# preset configures and builds only the `regolith` tool, and the embedded mocked rover runs (on the
# simulated clock: 5 s of rover time, no wall-clock waiting) and publishes its terrain topics.
# Prints the time of each step: the README's first-run figure is measured with this script, with
# CCACHE_DISABLE=1 (the build compiles through ccache when it is installed: in command 2 the lean
# build takes the objects of the release build made just before, 13 s instead of 3.5 min).
# Usage: check_lean_run.sh SOURCE_DIR          (exit 77 = skipped: SOURCE_DIR is not a git checkout)
set -euo pipefail
src=$(cd "$1" && pwd)
if ! git -C "$src" rev-parse --is-inside-work-tree >/dev/null 2>&1; then
  echo "SKIP: $src is not a git checkout (the clean copy is made of its tracked files)"
  exit 77
fi
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
tree="$work/regolith"
mkdir "$tree"
# What a clone holds (the tracked files), as they are in the working tree: uncommitted edits are
# tested too, build directories and untracked files are not copied.
git -C "$src" ls-files -z | tar -C "$src" --null --ignore-failed-read -T - -cf - | tar -C "$tree" -xf -
cd "$tree"

step() {  # step NAME COMMAND...: run it, its output into NAME.log, shown when it fails
  local name=$1 t0 t1
  shift
  t0=$(date +%s)
  if ! "$@" >"$work/$name.log" 2>&1; then
    echo "FAIL: $name: $*"
    tail -n 40 "$work/$name.log"
    exit 1
  fi
  t1=$(date +%s)
  echo "$name: $((t1 - t0)) s"
}

start=$(date +%s)
step setup bash deploy/setup.sh run
step configure cmake --preset run
step build cmake --build --preset run
step run build/run/tools/regolith run --sim-time --duration 5
total=$(($(date +%s) - start))

# Only the tool was built: no test or benchmark programs in the lean build tree.
extra=$(find build/run -type f -perm -u+x \( -name 'test_*' -o -name 'bench_*' \) | head -n 3)
if [[ -n $extra ]]; then
  echo "FAIL: the run preset built test or benchmark programs: $extra"
  exit 1
fi
# The rover ran: its terrain map and rock topics were published (counts from the stop summary).
for topic in terrain/grid_map terrain/rocks terrain/wheel_sinkage odom; do
  if ! grep -Eq "^/[a-z0-9_]+/$topic published [1-9][0-9]* " "$work/run.log"; then
    echo "FAIL: the mocked rover published nothing on $topic"
    tail -n 40 "$work/run.log"
    exit 1
  fi
done
echo "OK: lean first run from a clean tree in $total s (setup, configure, build, 5 s simulated run)"
