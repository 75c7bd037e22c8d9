#!/usr/bin/env bash
# esfleet-leader says where the SLAM may have lost track (docs/slam.md, "Telling a lost run").
# The paper's configuration misses a fast turn in the first 160 CSAIL scans (scans ~110-150);
# the default follows it. The paper's run must warn and list the stretch in stats.json, the
# default's must not.
#
# usage: poor_stretches_test.sh BIN_DIR DATA_DIR
set -euo pipefail
bin=$1 data=$2
work=$(mktemp -d /tmp/esfleet-poor.XXXXXX)
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*"; exit 1; }
stretches() { python3 -c "import json, sys; print(json.load(open(sys.argv[1]))['poor_stretches'])" "$1"; }
run=(--offline --log "$data/mit-csail/mit-csail.clf.gz" --max-scans 160 --seed 1)

"$bin/esfleet-leader" "${run[@]}" --paper --out "$work/paper" >"$work/paper.log" 2>&1 ||
  fail "paper run exited with $?: $(tail -3 "$work/paper.log")"
grep -m1 "matched the map poorly" "$work/paper.log" || fail "no warning in the paper run's log"
grep -q "the scans matched the map poorly in 1 stretch (scans [0-9]*-[0-9]*; stats.json" \
  "$work/paper.log" || fail "no summary of the stretch at the end"
python3 - "$work/paper/stats.json" <<'PY' || fail "paper run: stats.json poor_stretches $(stretches "$work/paper/stats.json")"
import json, sys
s = json.load(open(sys.argv[1]))["poor_stretches"]
assert len(s) == 1, s
p = s[0]
assert 100 <= p["first"] <= 150 and p["first"] <= p["last"] <= 160, p
assert 10 <= p["weak"] <= p["last"] - p["first"] + 1, p
PY
echo "paper: $(stretches "$work/paper/stats.json")"

"$bin/esfleet-leader" "${run[@]}" --out "$work/default" >"$work/default.log" 2>&1 ||
  fail "default run exited with $?"
! grep "matched the map poorly" "$work/default.log" || fail "the default run warned"
[ "$(stretches "$work/default/stats.json")" = "[]" ] ||
  fail "default run: poor_stretches $(stretches "$work/default/stats.json")"
echo "OK: the paper's run names its stretch, the default's has none"
