#!/usr/bin/env bash
# Repeats the Wi-Fi deployment test (tests/integration/deploy_netns_test.sh wifi: a leader and
# two followers in three network namespaces, wifi-initial-peers.xml with 1400-byte messages,
# 2 Mbit/s per link) RUNS times per loss rate and counts the runs in which both followers
# converged to the leader's exact map, the runs in which a process aborted (a Fast DDS
# assertion, exit 134; before tiles travelled in parts: DataReaderHistory.cpp:822, 2 of 3 runs
# at 10 %) and the other failures. Runs one at a time (each ~30-60 s; heavy). Root only.
# Prints one line per run and a summary line per loss rate; exit 0 when every run converged.
#
# usage: tools/lossy-deploy-runs.sh BIN_DIR RUNS LOSS [LOSS...]
#   e.g. tools/lossy-deploy-runs.sh build/bin 20 10 20
# Failed runs' output is kept in /tmp/esfleet-lossy-runs.XXXXXX (printed at the end).
set -uo pipefail
[ $# -ge 3 ] || { sed -n 2,12p "$0" >&2; exit 2; }
bin=$1 runs=$2
shift 2
root=$(cd "$(dirname "$0")/.." && pwd)
test=$root/tests/integration/deploy_netns_test.sh
log=$root/data/mit-csail/mit-csail.clf.gz
keep=$(mktemp -d /tmp/esfleet-lossy-runs.XXXXXX)
all_ok=1
for loss in "$@"; do
  converged=0 aborted=0 other=0
  for run in $(seq 1 "$runs"); do
    out=$keep/loss$loss-run$run.txt
    t0=$(date +%s)
    "$test" "$bin" "$log" 230 wifi "$loss" >"$out" 2>&1
    rc=$?
    secs=$(($(date +%s) - t0))
    if [ $rc -eq 77 ]; then
      echo "skipped: $(tail -1 "$out")"
      exit 77
    elif [ $rc -eq 0 ]; then
      converged=$((converged + 1))
      echo "loss $loss % run $run: converged in $secs s; $(grep -c 'first pose' "$out") followers localised"
      rm -f "$out"
    elif grep -qE "Assertion|exited with 134|Aborted" "$out"; then
      aborted=$((aborted + 1))
      echo "loss $loss % run $run: ABORT ($(grep -m1 -oE "[A-Za-z]+\.cpp:[0-9]+[^']*" "$out"))"
    else
      other=$((other + 1))
      echo "loss $loss % run $run: failed: $(grep -m1 FAIL "$out")"
    fi
  done
  echo "loss $loss %: $converged of $runs converged, $aborted aborted, $other other failures"
  [ "$converged" -eq "$runs" ] || all_ok=0
done
if [ $all_ok = 1 ]; then rmdir "$keep" 2>/dev/null; else echo "failed runs' output: $keep"; fi
[ $all_ok = 1 ]
