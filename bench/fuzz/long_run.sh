#!/usr/bin/env bash
# The fuzzing long run (issue 20's goal: >= 10 million executions per target with no crash and no
# sanitizer report). Runs every libFuzzer target (or the ones named) to RUNS executions each with
# ASan + UBSan, one per core, each from the seed corpus plus what earlier runs found
# (build/fuzz/corpus/<target>), and prints executions per second and total executions per target.
# The table is also appended, with the date and commit, to build/fuzz/long_run.md.
#   bench/fuzz/long_run.sh [RUNS] [TARGET...]      RUNS defaults to 10000000
# Expect hours: image ~1,700 executions / s and deployment_yaml ~1,100 on one core of the 2-core
# development machine (tests/fuzz/README.md has the measured table).
set -euo pipefail
cd "$(dirname "$0")/../.."
runs=10000000
if [[ "${1:-}" =~ ^[0-9]+$ ]]; then
  runs="$1"
  shift
fi
out=build/fuzz/long_run.md
set +e
table=$(tests/fuzz/run.sh --runs "$runs" "$@")
status=$?
set -e
echo "$table"
mkdir -p build/fuzz
{
  echo "## $(date -u +%Y-%m-%dT%H:%MZ), commit $(git rev-parse --short HEAD 2>/dev/null || echo unknown), $runs executions per target"
  echo '```'
  echo "$table" | grep -E '^(target|[a-z_]+ +[0-9]+ +[0-9]+ )' || true
  echo '```'
} >>"$out"
exit $status
