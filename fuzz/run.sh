#!/usr/bin/env bash
# Runs one libFuzzer target of the fuzz build (docs/fuzzing.md) for a while and reports.
#
# usage: fuzz/run.sh TARGET SECONDS [JOBS]
#   TARGET  fuzz_carmen | fuzz_map_loader | fuzz_tile | fuzz_ros_msg | fuzz_slam
#   JOBS    parallel fuzzing processes (default 1)
# Environment: ESFLEET_FUZZ_BUILD (default <repo>/build-fuzz) holds the built targets.
#
# Starts from the committed seeds (fuzz/corpus/TARGET, read only) plus what earlier runs found
# (BUILD/fuzz-work/TARGET); crashes, leaks and timeouts go to BUILD/fuzz-artifacts/TARGET/.
# Prints the executions and the corpus size; exits 1 when the target found anything (the
# offending inputs are listed: each becomes a regression test and joins fuzz/corpus/TARGET).
# Inputs are bounded (-max_len, the largest seed for fuzz_carmen is a 3 kB line), every input
# must finish in -timeout seconds and the process stays under -rss_limit_mb.
set -euo pipefail
fuzz_dir=$(cd "$(dirname "$0")" && pwd)
target=${1:?usage: run.sh TARGET SECONDS [JOBS]}
seconds=${2:?usage: run.sh TARGET SECONDS [JOBS]}
jobs=${3:-1}
build=${ESFLEET_FUZZ_BUILD:-$fuzz_dir/../build-fuzz}
bin=$build/bin/$target
[ -x "$bin" ] || { echo "run.sh: $bin not built (docs/fuzzing.md)" >&2; exit 2; }
seeds=$fuzz_dir/corpus/$target
work=$build/fuzz-work/$target
artifacts=$build/fuzz-artifacts/$target
logs=$build/fuzz-logs/$target
mkdir -p "$work" "$artifacts" "$logs"
rm -f "$logs"/*.log

case $target in
  fuzz_carmen) max_len=8192 ;;
  fuzz_map_loader) max_len=8192 ;;
  fuzz_tile) max_len=70000 ;;
  fuzz_slam) max_len=16384 ;;
  *) max_len=4096 ;;
esac
opts=(-max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 -max_len="$max_len"
      -artifact_prefix="$artifacts/" -print_final_stats=1)
[ -f "$fuzz_dir/$target.dict" ] && opts+=(-dict="$fuzz_dir/$target.dict")

before=$(find "$artifacts" -type f | wc -l)
status=0
if [ "$jobs" -le 1 ]; then
  "$bin" "${opts[@]}" "$work" "$seeds" >"$logs/fuzz-0.log" 2>&1 || status=$?
else
  (cd "$logs" && "$bin" "${opts[@]}" -jobs="$jobs" -workers="$jobs" "$work" "$seeds" \
    >"$logs/main.log" 2>&1) || status=$?
fi

# "stat::number_of_executed_units: N" once per process (print_final_stats).
execs=$(cat "$logs"/*.log | sed -n 's/^stat::number_of_executed_units: *//p' |
        awk '{s += $1} END {print s + 0}')
found=$(find "$artifacts" -type f | wc -l)
echo "$target: $execs executions in ${seconds} s x $jobs job(s), corpus $(ls "$work" | wc -l) new + $(ls "$seeds" | wc -l) seeds, $((found - before)) new finding(s)"
if [ "$status" -ne 0 ] || [ "$found" -gt "$before" ]; then
  grep -h -m5 -E "ERROR: |runtime error|fuzz invariant|SUMMARY" "$logs"/*.log >&2 || true
  echo "findings in $artifacts:" >&2
  ls -t "$artifacts" >&2
  echo "full logs in $logs" >&2
  exit 1
fi
