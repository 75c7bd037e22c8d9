#!/usr/bin/env bash
# Map sharing with real processes: a leader replays a recorded log over DDS; follower A starts
# before the leader, follower B after the leader has finished the log. Both must end with maps
# whose counters equal the leader's final map exactly (one digest per tile), and the leader's
# trajectory must equal an --offline run's (publishing does not change the SLAM).
#
# usage: map_sharing_test.sh BIN_DIR LOG PROFILE DOMAIN [MAX_SCANS]
set -euo pipefail
bin=$1 log=$2 profile=$3 domain=$4 max_scans=${5:-300}
source "$(dirname "$0")/common.sh" map-sharing

common=(--domain "$domain" --profile "$profile")
slam=(--log "$log" --odometry on --max-scans "$max_scans" --seed 7)

"$bin/esfleet-follower" "${common[@]}" --save-map "$work/a" --exit-when-complete --timeout 120 \
  >"$work/a.log" 2>&1 &
pid_a=$!
pids+=("$pid_a")

"$bin/esfleet-leader" "${slam[@]}" "${common[@]}" --out "$work/leader" --linger 120 \
  >"$work/leader.log" 2>&1 &
pid_leader=$!
pids+=("$pid_leader")

# Wait until the leader has mapped the whole excerpt and published the final map.
for _ in $(seq 1 1200); do
  grep -q "log ended" "$work/leader.log" && break
  kill -0 "$pid_leader" 2>/dev/null || fail "leader exited early"
  sleep 0.1
done
grep -q "log ended" "$work/leader.log" || fail "leader did not finish the log in 120 s"

# The late joiner: started after the leader finished; gets the whole map from the writer's
# transient-local history.
"$bin/esfleet-follower" "${common[@]}" --save-map "$work/b" --exit-when-complete --timeout 60 \
  >"$work/b.log" 2>&1 || fail "late follower exited with $?"
wait "$pid_a" || fail "early follower exited with $?"

kill -INT "$pid_leader"
wait "$pid_leader" || fail "leader exited with $? on SIGINT"

for f in a b; do
  [ -s "$work/$f/map.digest" ] || fail "follower $f saved no map digest"
  cmp -s "$work/leader/map.digest" "$work/$f/map.digest" ||
    fail "follower $f map differs from the leader's: $(diff "$work/leader/map.digest" "$work/$f/map.digest" | head -5)"
  grep -q '"complete": true' "$work/$f/stats.json" || fail "follower $f did not report complete"
  grep -q '"tiles_rejected": 0' "$work/$f/stats.json" || fail "follower $f rejected tiles"
done
tiles=$(wc -l <"$work/leader/map.digest")

# Publishing must not change the SLAM: same trajectory as an offline run with the same seed.
"$bin/esfleet-leader" "${slam[@]}" --offline --out "$work/offline" >"$work/offline.log" 2>&1 ||
  fail "offline leader failed"
cmp -s "$work/leader/trajectory.txt" "$work/offline/trajectory.txt" ||
  fail "trajectory with DDS publishing differs from the offline one"
cmp -s "$work/leader/map.digest" "$work/offline/map.digest" ||
  fail "map with DDS publishing differs from the offline one"

echo "OK: $tiles tiles, leader == early follower == late follower == offline run"
grep -h "map complete" "$work"/a.log "$work"/b.log || true
