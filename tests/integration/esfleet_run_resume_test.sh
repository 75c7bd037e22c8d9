#!/usr/bin/env bash
# deploy/bin/esfleet-run leader with ESFLEET_RESUME (the systemd unit's restart): "on" continues
# the map checkpointed in ESFLEET_OUT (same map id and epoch, the log after the checkpointed
# scan), "off" starts a new map and moves the checkpoint aside, anything else is refused.
# Real esfleet-leader processes on DDS domain DOMAIN.
# usage: esfleet_run_resume_test.sh BIN_DIR LOG PROFILE DOMAIN
set -euo pipefail
bin=$1 log=$2 profile=$3 domain=$4
run=$(cd "$(dirname "$0")/../../deploy/bin" && pwd)/esfleet-run
work=$(mktemp -d /tmp/esfleet-run-resume.XXXXXX)
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*"; for f in "$work"/*.log; do echo "--- $f"; cat "$f"; done; exit 1; }
export ESFLEET_ROBOT_ID=leader ESFLEET_DOMAIN=$domain ESFLEET_PROFILE=$profile
export ESFLEET_OUT=$work/out ESFLEET_LOG=$log ESFLEET_BIN_DIR=$bin
epoch() { python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))["epoch"])' "$1"; }

# A crash-free first run: 100 scans, checkpointed at the end.
ESFLEET_RESUME=on ESFLEET_ARGS="--max-scans 100 --linger 0 --rate 0 --seed 4" \
  "$run" leader >"$work/first.log" 2>&1 || fail "first run exited $?"
e1=$(epoch "$work/out/checkpoint/manifest.json")
grep -q "resumed map" "$work/first.log" && fail "the first run resumed from nothing"

# Restarted with ESFLEET_RESUME=on: the same map continues with the checkpoint's parameters.
ESFLEET_RESUME=on ESFLEET_ARGS="--max-scans 200 --linger 0 --rate 0" \
  "$run" leader >"$work/second.log" 2>&1 || fail "resumed run exited $?"
grep -q "esfleet-run: .* --resume $work/out" "$work/second.log" || fail "esfleet-run did not pass --resume"
grep -q "resumed map 'map' epoch $e1 .*: 100 scans" "$work/second.log" || fail "did not resume map epoch $e1 at scan 100"
grep -q "seed = 4" "$work/second.log" || fail "the resumed run did not take the checkpoint's seed"
lines=$(wc -l <"$work/out/trajectory.txt")
[ "$lines" -eq 200 ] || fail "trajectory has $lines poses, expected 200"
[ "$(epoch "$work/out/checkpoint/manifest.json")" = "$e1" ] || fail "the epoch changed"

# ESFLEET_RESUME=off: a new map; the old checkpoint is kept aside.
ESFLEET_RESUME=off ESFLEET_ARGS="--max-scans 50 --linger 0 --rate 0" \
  "$run" leader >"$work/fresh.log" 2>&1 || fail "fresh run exited $?"
grep -q "resumed map" "$work/fresh.log" && fail "ESFLEET_RESUME=off resumed"
[ -f "$work/out/checkpoint.old/manifest.json" ] || fail "the old checkpoint was not moved aside"
[ "$(wc -l <"$work/out/trajectory.txt")" -eq 50 ] || fail "the fresh run's trajectory is not 50 poses"

# A bad value is a usage error naming the variable.
set +e
ESFLEET_RESUME=maybe "$run" leader >"$work/bad.log" 2>&1
rc=$?
set -e
[ "$rc" -eq 2 ] || fail "ESFLEET_RESUME=maybe exited $rc, expected 2"
grep -q "ESFLEET_RESUME must be on or off, not 'maybe'" "$work/bad.log" || fail "no message naming ESFLEET_RESUME"
echo "OK: resumed epoch $e1 at scan 100 to 200 poses; off made a new map (old checkpoint kept)"
