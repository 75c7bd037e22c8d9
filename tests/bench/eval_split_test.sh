#!/usr/bin/env bash
# esfleet-eval --split-gap: the relations closer than the gap in time (local) and the rest
# (revisits) are scored apart. A straight trajectory, two exact local relations and one revisit
# off by 0.3 m: the split must put the whole error on the revisit, and the overall mean stays
# the mean of all three.
# Usage: eval_split_test.sh BIN_DIR
set -euo pipefail
bin="$1"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT

for t in 0 1 2 3 4 5 6 7 8 9; do echo "$t $t 0 0"; done > "$work/traj.txt"
cat > "$work/rel.txt" <<'REL'
0 1 1 0 0 0 0 0
1 2 1 0 0 0 0 0
0 9 9.3 0 0 0 0 0
REL

"$bin/esfleet-eval" --trajectory "$work/traj.txt" --relations "$work/rel.txt" --split-gap 5 \
    --json > "$work/out.txt"
cat "$work/out.txt"
python3 - "$work/out.txt" <<'PY'
import json, sys
j = json.loads(open(sys.argv[1]).read().strip().splitlines()[-1])
s = j["split"]
def near(a, b): return abs(a - b) < 1e-9
assert s["gap_s"] == 5.0, s
assert s["local"]["matched"] == 2 and near(s["local"]["trans_mean"], 0.0), s
assert s["revisits"]["matched"] == 1 and near(s["revisits"]["trans_mean"], 0.3), s
assert j["matched"] == 3 and near(j["trans_mean"], 0.1), j
print("ok")
PY

# A negative gap is bad usage: exit 2, naming the flag.
set +e
"$bin/esfleet-eval" --trajectory "$work/traj.txt" --relations "$work/rel.txt" --split-gap -1 \
    2> "$work/err.txt"
rc=$?
set -e
[ "$rc" -eq 2 ] || { echo "--split-gap -1 exited $rc, expected 2"; exit 1; }
grep -q -- "--split-gap" "$work/err.txt" || { echo "the error does not name --split-gap"; cat "$work/err.txt"; exit 1; }
echo "ok: bad gap refused"
