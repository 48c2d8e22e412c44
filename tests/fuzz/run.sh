#!/usr/bin/env bash
# Runs every libFuzzer target for SECONDS each (default 60) with ASan + UBSan, starting from the
# seed corpus in tests/fuzz/corpus/<target>/. New interesting inputs go to build/fuzz/corpus/<target>
# (merge the useful ones into the repository's corpus by hand); a crash writes its input to
# tests/fuzz/crashes/<target>-<hash> and fails the run: add it to corpus/<target>/ once fixed, so
# that FuzzCorpus.<target> replays it in every test build.
# Prints executions per second and total executions per target. Targets run concurrently, one per
# core (REGOLITH_FUZZ_JOBS=N to change).
#   tests/fuzz/run.sh [SECONDS] [TARGET...]   time-bound, a new random seed each run (long runs)
#   tests/fuzz/run.sh --runs N [TARGET...]     execution-bound long run (bench/fuzz/long_run.sh):
#                                              N executions per target, a new random seed, the
#                                              corpus of earlier runs kept in build/fuzz/corpus
#   tests/fuzz/run.sh --ci [TARGET...]         what CI runs: seed 1 and a fixed number of executions
#                                              per target (about 60 s each on a 2-core CI machine),
#                                              so a CI result is reproducible bit for bit
set -euo pipefail
cd "$(dirname "$0")/../.."
ci=0
runs=0
if [[ "${1:-}" == "-h" || "${1:-}" == "--help" ]]; then
  sed -n '2,/^set -euo/{/^#/s/^# \{0,1\}//p}' "$0"
  exit 0
fi
if [[ "${1:-}" == "--ci" ]]; then
  ci=1
  shift
elif [[ "${1:-}" == "--runs" ]]; then
  if ! [[ "${2:-}" =~ ^[1-9][0-9]*$ ]]; then
    echo "tests/fuzz/run.sh: --runs needs a positive number of executions per target (got '${2:-}')" >&2
    exit 2
  fi
  runs="$2"
  shift 2
fi
seconds=60
if ((!ci && !runs)) && [[ "${1:-}" =~ ^[0-9]+$ ]]; then
  seconds="$1"
  shift
fi
# Long runs: a small ASan quarantine (16 MB instead of 256). With the default, deployment_yaml's
# resident size climbs past 1 GB within 15 minutes (held-back freed blocks of the YAML parser, not a
# leak: the same input 100 k times with no quarantine stays at 40 MB) and -rss_limit_mb would stop
# the run. And no allocation stacks (malloc_context_size=0): ASan unwinds the stack at every malloc
# for them, and deployment_yaml (yaml-cpp: many small nodes) runs 27 % faster without (1,339 against
# 1,052 executions / s, 25 s each from one corpus, 2026-12-04); a finding's input is saved, and
# replaying it (FuzzCorpus, or the target on the file) gives the full report. CI's fixed runs keep
# ASan's defaults.
if ((!ci)); then
  export ASAN_OPTIONS="${ASAN_OPTIONS:-quarantine_size_mb=16:malloc_context_size=0}"
fi
# Executions per target under --ci: about 60 s each on this project's 2-core machines (measured
# 2026-11-27: image 44-57 exec/s, deployment_yaml 840-1666, can_decoder 15-22 k; the earlier budgets
# of 8000 / 100000 / 2000000 took 140-180 s, 60-120 s and 90-130 s). image: 150000 since its pixel
# kernels are built without comparison tracing and its detector runs on images up to 128 x 128
# (2026-11-29: 92 s with both cores shared by three fuzzers; it was 3000). With -seed=1 a run is
# a prefix of any longer one, so a smaller budget never finds what a larger one missed.
# deployment_check configures a whole deployment per input (every component; ~0.3-1 s for a
# shipped one under ASan, ~10-15 exec/s on mutants): 1000 took 60-115 s (2026-12-01).
# terrain (rectification, ground SfS, traversability layers, SAMS and ranging per input: ~105
# exec/s) and soil_fit (a whole rut analysis per input: ~50 exec/s), measured 2026-12-02 alone
# on one core of the idle machine; sfs and terrain doubled on 2026-12-05 when their pixel libraries
# lost comparison tracing (~450 and ~170 exec/s).
# sfs 20000 -> 50000 on 2026-12-06, when Bichsel-Pentland's slope table became one walk per
# direction (869 exec/s in a fresh-clone CI run, where 20000 took 23 s).
declare -A ci_runs=([candump]=10000000 [can_decoder]=1000000 [deployment_yaml]=60000 [deployment_check]=1000
                    [pixel_convert]=5000000 [soil_scene]=100000 [drive]=100000 [sfs]=50000 [image]=150000 [mcap]=100000
                    [hal_messages]=1000000 [live_messages]=2000000 [terrain]=8000 [soil_fit]=5000
                    [rock_model]=60000 [mapper]=200)
# rock_model (the model file through yaml-cpp): ~1,500 exec/s on one core beside other work
# (2026-12-07). mapper (a whole DriveMapper over up to nine rendered frames per input): ~4 exec/s
# on one core (2026-12-07), so 200 is ~50 s.
# Seconds one input may take before libFuzzer calls it a hang: 10, except deployment_check, which
# builds a whole rover's configure-time tables per input (0.3-1 s in a release build, several
# seconds under ASan on a shared core).
declare -A timeout_s=([deployment_check]=60)
build=build/fuzz
all_targets=(candump can_decoder deployment_yaml deployment_check pixel_convert soil_scene drive mapper sfs image mcap
             hal_messages live_messages terrain soil_fit rock_model)
targets=("$@")
if ((${#targets[@]} == 0)); then
  targets=("${all_targets[@]}")
fi
for t in "${targets[@]}"; do
  if [[ " ${all_targets[*]} " != *" $t "* ]]; then
    echo "tests/fuzz/run.sh: unknown target '$t' (the targets: ${all_targets[*]}; --help for the usage)" >&2
    exit 2
  fi
done
if [[ ! -f "$build/CMakeCache.txt" ]]; then
  CC=clang CXX=clang++ cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DREGOLITH_FUZZ=ON \
    -DREGOLITH_BUILD_BENCH=OFF -DREGOLITH_WITH_LIBCAMERA=OFF >/dev/null
fi
cmake --build "$build" --target "${targets[@]/#/fuzz_}"
mkdir -p tests/fuzz/crashes
# One fuzzer per core at a time (each is single-threaded): on a 2-core CI machine the eight targets
# take four minutes of wall time, each still getting its full budget. REGOLITH_FUZZ_JOBS overrides.
jobs=${REGOLITH_FUZZ_JOBS:-$(nproc)}
((jobs >= 1)) || jobs=1

# Runs one target and writes its table row to $build/fuzz_<target>.row; returns libFuzzer's status.
run_target() {
  local t="$1" work="$build/corpus/$1" log="$build/fuzz_$1.log" budget rc execs rate result
  mkdir -p "$work"
  if ((ci)); then
    rm -rf "$work" && mkdir -p "$work"  # the same start every time
    budget=(-seed=1 -runs="${ci_runs[$t]}")
  elif ((runs)); then
    budget=(-runs="$runs")
  else
    budget=(-max_total_time="$seconds")
  fi
  set +e
  "$build/tests/fuzz/fuzz_$t" "$work" "tests/fuzz/corpus/$t" "${budget[@]}" -print_final_stats=1 \
    -artifact_prefix="tests/fuzz/crashes/$t-" -rss_limit_mb=2048 -timeout="${timeout_s[$t]:-10}" >"$log" 2>&1
  rc=$?
  set -e
  execs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' || echo 0)
  rate=$(grep -o 'stat::average_exec_per_sec: *[0-9]*' "$log" | grep -o '[0-9]*$' || echo 0)
  if ((rc == 0)); then result=ok; else result="FAILED (see $log)"; fi
  printf '%-16s %10s %12s %s\n' "$t" "$rate" "$execs" "$result" >"$build/fuzz_$t.row"
  return "$rc"
}

status=0
running=0
for t in "${targets[@]}"; do
  rm -f "$build/fuzz_$t.row"
  if ((running >= jobs)); then
    wait -n || status=1
    running=$((running - 1))
  fi
  run_target "$t" &
  running=$((running + 1))
done
while ((running > 0)); do
  wait -n || status=1
  running=$((running - 1))
done
printf '%-16s %10s %12s %s\n' target "exec/s" executions result
for t in "${targets[@]}"; do
  cat "$build/fuzz_$t.row" 2>/dev/null || { printf '%-16s %10s %12s %s\n' "$t" 0 0 "FAILED (no result)"; status=1; }
done
exit $status
