#!/usr/bin/env bash
# Follower localisation with real processes: a leader replays a recorded excerpt over DDS;
# followers take their own scans from the same excerpt, starting part-way in, and must find
# their pose in the shared map with no prior knowledge:
#   A  no hint, scans held until the map is complete: declares a pose within 0.3 m and 5 deg of
#      the leader's pose for the same scan (the reference; only this test reads it), tracks,
#      and ends with the leader's map;
#   B  a wrong hint (8 m off) that never widens to the global search: must not declare a
#      wrong pose;
#   C  no hint, its scans from esfleet-replay over the scan topic, started with the leader:
#      localises while the map is still growing.
#
# usage: localise_test.sh BIN_DIR LOG PROFILE DOMAIN [MAX_SCANS] [FIRST_SCAN]
set -euo pipefail
bin=$1 log=$2 profile=$3 domain=$4 max_scans=${5:-400} first=${6:-150}
source "$(dirname "$0")/common.sh" localise

common=(--domain "$domain" --profile "$profile")
scans=(--log "$log" --odometry on --max-scans "$max_scans")

"$bin/esfleet-follower" "${common[@]}" --scan-topic c --idle-exit 3 --odometry on \
  --robot-id c --seed 3 --save-map "$work/c" --timeout 150 >"$work/c.log" 2>&1 &
pid_c=$!
pids+=("$pid_c")
"$bin/esfleet-replay" "${common[@]}" --log "$log" --robot-id c --first-scan "$first" \
  --max-scans "$max_scans" --rate 4 >"$work/replay.log" 2>&1 &
pids+=($!)

"$bin/esfleet-leader" "${scans[@]}" --seed 7 "${common[@]}" --out "$work/leader" --linger 150 \
  >"$work/leader.log" 2>&1 &
pid_leader=$!
pids+=("$pid_leader")

"$bin/esfleet-follower" "${common[@]}" "${scans[@]}" --first-scan "$first" --rate 0 \
  --wait-complete --robot-id a --seed 1 --save-map "$work/a" --trajectory "$work/a/track.txt" \
  --timeout 150 >"$work/a.log" 2>&1 &
pid_a=$!
pids+=("$pid_a")
"$bin/esfleet-follower" "${common[@]}" "${scans[@]}" --first-scan "$first" --rate 0 \
  --wait-complete --robot-id b --seed 2 --hint -8,8,90,1,20 --localise-hint-scans 100000 \
  --save-map "$work/b" --timeout 150 >"$work/b.log" 2>&1 &
pid_b=$!
pids+=("$pid_b")

for f in a b c; do
  eval "wait \$pid_$f" || fail "follower $f exited with $?"
done
kill -INT "$pid_leader"
wait "$pid_leader" || fail "leader exited with $? on SIGINT"

python3 - "$work" <<'PY' || fail "localisation check"
import json, math, sys
work = sys.argv[1]
ref = {}
for line in open(f"{work}/leader/trajectory.txt"):
    t, x, y, th = map(float, line.split())
    ref[round(t, 6)] = (x, y, th)

def error(pose):
    r = ref[round(pose["stamp"], 6)]
    d = math.hypot(pose["x"] - r[0], pose["y"] - r[1])
    a = abs((pose["theta"] - r[2] + math.pi) % (2 * math.pi) - math.pi)
    return d, math.degrees(a)

ok = True
for f, must_declare in (("a", True), ("b", False), ("c", True)):
    loc = json.load(open(f"{work}/{f}/stats.json"))["localisation"]
    if "first_pose" not in loc:
        print(f"follower {f}: no pose declared after {loc['scans']} scans ({loc['state']})")
        ok = ok and not must_declare
        continue
    d, a = error(loc["first_pose"])
    good = d <= 0.3 and a <= 5.0
    print(f"follower {f}: pose declared after {loc['scans_to_first_pose']} scans, "
          f"{loc['cpu_s_to_first_pose']:.2f} s CPU: error {d:.3f} m, {a:.2f} deg "
          f"-> {'right' if good else 'WRONG'}; {loc['tracked_scans']} scans tracked")
    ok = ok and good
# A tracked the rest of the excerpt: its poses stay near the leader's.
worst = 0.0
for line in open(f"{work}/a/track.txt"):
    t, x, y, th = map(float, line.split())
    r = ref[round(t, 6)]
    worst = max(worst, math.hypot(x - r[0], y - r[1]))
print(f"follower a: worst tracking error {worst:.3f} m")
ok = ok and worst <= 0.3
sys.exit(0 if ok else 1)
PY
cmp -s "$work/leader/map.digest" "$work/a/map.digest" || fail "follower a's map differs from the leader's"
echo "OK"
