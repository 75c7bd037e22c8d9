#!/usr/bin/env bash
# esfleet-leader says when it tracks with the short laser's hold (docs/slam.md item 10) and
# writes the laser's reach to stats.json: on with odometry and an 8 m laser, not with CSAIL's
# full range (its first scan has a 12 m beam), not laser only.
#
# usage: short_laser_test.sh BIN_DIR DATA_DIR
set -euo pipefail
bin=$1 data=$2
work=$(mktemp -d /tmp/esfleet-short.XXXXXX)
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*"; exit 1; }
said="no beam of 10 m or more so far"
run() {  # NAME FLAGS...: a short offline run into $work/NAME
  local name=$1
  shift
  "$bin/esfleet-leader" --offline --log "$data/mit-csail/mit-csail.clf.gz" --max-scans 60 \
    --seed 1 --out "$work/$name" "$@" >"$work/$name.log" 2>&1 ||
    fail "$name run exited with $?: $(tail -3 "$work/$name.log")"
}
stats() {  # NAME: laser_reach_m and short_view_hold from its stats.json
  python3 -c "import json, sys; s = json.load(open(sys.argv[1])); print(round(s['laser_reach_m'], 2), s['short_view_hold'])" "$work/$1/stats.json"
}

run short --odometry on --max-range 8
grep -q "scan 1: $said" "$work/short.log" || fail "the short laser's run did not say so: $(grep -c . "$work/short.log") lines"
read -r reach hold <<<"$(stats short)"
python3 -c "import sys; r = float(sys.argv[1]); assert 5.0 < r < 8.0, r" "$reach" ||
  fail "short: laser_reach_m $reach, expected under the 8 m cut"
[ "$hold" = True ] || fail "short: short_view_hold $hold"
echo "short: reach $reach m, hold $hold"

run full --odometry on
! grep -q "$said" "$work/full.log" || fail "the full-range run said it holds"
read -r reach hold <<<"$(stats full)"
python3 -c "import sys; r = float(sys.argv[1]); assert r >= 11.9, r" "$reach" ||
  fail "full: laser_reach_m $reach"
[ "$hold" = False ] || fail "full: short_view_hold $hold"
echo "full: reach $reach m, hold $hold"

run laser --max-range 8
! grep -q "$said" "$work/laser.log" || fail "the laser-only run said it holds"
[ "$(stats laser | cut -d' ' -f2)" = False ] || fail "laser only: short_view_hold $(stats laser)"
echo "OK: said and recorded with odometry and a short laser only"
