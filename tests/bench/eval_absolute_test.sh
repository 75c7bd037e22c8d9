#!/usr/bin/env bash
# esfleet-eval --reference: the absolute error against a corrected log's poses. A trajectory
# that is the corrected path in another frame scores zero; with one pose 0.5 m off, that pose
# carries the error. A key-scan log takes its stamps from the raw log (--reference-raw): without
# it its rounded stamps cannot be matched by time (exit 2, naming the file and the flag), nor
# can a trajectory whose stamps repeat, unless --by-index gives it the reference's stamps.
# Bad usage exits 2 naming the flag or file.
# Usage: eval_absolute_test.sh BIN_DIR
set -euo pipefail
bin="$1"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT

# Five scans of four beams, 0.2 s apart; the raw log's own odometry is anything.
stamps=(1134864629.1 1134864629.3 1134864629.5 1134864629.7 1134864629.9)
xs=(0 1 2 3 4)
for i in 0 1 2 3 4; do
  echo "${stamps[$i]} ${xs[$i]} 0 0"                                   # estimate: along x
done > "$work/traj.txt"
for i in 0 1 2 3 4; do
  r="1.$i 2.$i 3.$i 4.$i"
  echo "FLASER 4 $r 9 9 0 9 9 0 ${stamps[$i]} host ${stamps[$i]}" >> "$work/raw.log"
  # corrected: the same path turned 90 degrees and moved to (10, 5)
  echo "FLASER 4 $r 10 $((5 + i)) 1.5708 10 $((5 + i)) 1.5708 ${stamps[$i]} host ${stamps[$i]}" \
      >> "$work/corrected.log"
done
# A key-scan log of scans 0, 2 and 4, its stamps printed to 6 significant digits; scan 4's
# corrected pose 0.5 m farther on.
echo "FLASER 4 1.0 2.0 3.0 4.0 10 5 1.5708 10 5 1.5708 1.13486e+09 host 1.13486e+09" > "$work/keys.log"
echo "FLASER 4 1.2 2.2 3.2 4.2 10 7 1.5708 10 7 1.5708 1.13486e+09 host 1.13486e+09" >> "$work/keys.log"
echo "FLASER 4 1.4 2.4 3.4 4.4 10 9.5 1.5708 10 9.5 1.5708 1.13486e+09 host 1.13486e+09" >> "$work/keys.log"

"$bin/esfleet-eval" --trajectory "$work/traj.txt" --reference "$work/corrected.log" --json \
    > "$work/out1.txt"
"$bin/esfleet-eval" --trajectory "$work/traj.txt" --reference "$work/keys.log" \
    --reference-raw "$work/raw.log" --json > "$work/out2.txt"
# A run on the key-scan log itself: its trajectory has the log's rounded stamps, so its poses
# take the key scans' stamps by index (the same three estimates as above).
awk 'NR % 2 == 1 { $1 = "1134860000.000000"; print }' "$work/traj.txt" > "$work/keys-run.txt"
"$bin/esfleet-eval" --trajectory "$work/keys-run.txt" --by-index --reference "$work/keys.log" \
    --reference-raw "$work/raw.log" --json > "$work/out3.txt"
cat "$work/out1.txt" "$work/out2.txt" "$work/out3.txt"
cmp <(tail -n 1 "$work/out2.txt") <(tail -n 1 "$work/out3.txt") ||
    { echo "--by-index scored the key-scan run differently"; exit 1; }
python3 - "$work/out1.txt" "$work/out2.txt" <<'PY'
import json, math, sys
a = json.loads(open(sys.argv[1]).read().strip().splitlines()[-1])["absolute"]
assert a["matched"] == 5 and a["total"] == 5, a
assert a["rms"] < 1e-4 and a["max"] < 1e-4 and abs(a["scale"] - 1) < 1e-4, a
b = json.loads(open(sys.argv[2]).read().strip().splitlines()[-1])["absolute"]
assert b["matched"] == 3, b
# Estimate at 0, 2, 4 m along a line, the reference at 0, 2, 4.5 m: after matching the
# centroids (2 and 13/6) the errors are 1/6, 1/6 and 1/3 m; the best scale is 9/8.
assert abs(b["max"] - 1 / 3) < 1e-3 and abs(b["mean"] - 2 / 9) < 1e-3, b
assert abs(b["scale"] - 9 / 8) < 1e-3, b
print("ok")
PY

expect_usage() {  # expect_usage WHAT_TO_NAME ARGS... (ARGS without --trajectory: traj.txt)
  local name="$1"; shift
  local args=("$@")
  [[ " $* " == *" --trajectory "* ]] || args=(--trajectory "$work/traj.txt" "$@")
  set +e
  "$bin/esfleet-eval" "${args[@]}" 2> "$work/err.txt"
  local rc=$?
  set -e
  [ "$rc" -eq 2 ] || { echo "$* exited $rc, expected 2"; exit 1; }
  grep -q -- "$name" "$work/err.txt" || { echo "$* : the error does not name $name"; cat "$work/err.txt"; exit 1; }
}
# The key-scan log's own (rounded) stamps are all equal: refused, and the error says why.
expect_usage "keys.log: 2 of 3 poses are not stamped after" --reference "$work/keys.log"
grep -q -- "--reference-raw" "$work/err.txt" || { echo "the error does not say --reference-raw"; cat "$work/err.txt"; exit 1; }
# A trajectory whose stamps repeat (written from a log with rounded stamps) cannot be matched.
awk '{ $1 = "1134860000.000000"; print }' "$work/traj.txt" > "$work/same.txt"
expect_usage "same.txt: 4 of 5 poses are not stamped after the pose before them" \
    --trajectory "$work/same.txt" --reference "$work/corrected.log"
expect_usage "keys-run.txt: 2 of 3 poses are not stamped after" \
    --trajectory "$work/keys-run.txt" --reference "$work/keys.log" --reference-raw "$work/raw.log"
grep -q -- "--by-index" "$work/err.txt" || { echo "the error does not say --by-index"; cat "$work/err.txt"; exit 1; }
expect_usage "--by-index: .*same.txt has 5 poses but .*keys.log has 3 laser scans" \
    --trajectory "$work/same.txt" --by-index --reference "$work/keys.log" --reference-raw "$work/raw.log"
expect_usage "--by-index needs --reference" --relations "$work/missing.rel" --by-index
expect_usage "--reference" --reference-raw "$work/raw.log"
expect_usage "--relations"
expect_usage "missing.log" --reference "$work/missing.log"
echo "ok: bad usage refused"
