#!/usr/bin/env bash
# Mapping from the DDS scan topic with real processes: esfleet-replay publishes the first
# MAX_SCANS scans of a log as robot r1 as fast as they are acknowledged (--rate 0); a leader
# with --scan-topic r1 maps them and ends 3 s after the last one (--idle-exit); a follower
# rebuilds the leader's map. No scan may be lost and the SLAM must see them in log order: the
# leader processed exactly MAX_SCANS scans, its trajectory and map equal an --offline run's over
# the same log with the same seed, and the follower's map equals the leader's.
#
# usage: scan_topic_test.sh BIN_DIR LOG PROFILE DOMAIN [MAX_SCANS]
set -euo pipefail
bin=$1 log=$2 profile=$3 domain=$4 max_scans=${5:-300}
source "$(dirname "$0")/common.sh" scan-topic
# json_int FILE KEY: the integer value of the first "KEY": N in FILE.
json_int() {
  grep -o "\"$2\": [0-9]*" "$1" | head -n 1 | grep -o '[0-9]*$'
}

common=(--domain "$domain" --profile "$profile")
slam=(--odometry on --seed 7)

"$bin/esfleet-follower" "${common[@]}" --save-map "$work/follower" --exit-when-complete \
  --timeout 200 >"$work/follower.log" 2>&1 &
pid_follower=$!
pids+=("$pid_follower")

"$bin/esfleet-leader" --scan-topic r1 --idle-exit 3 --linger 30 "${slam[@]}" "${common[@]}" \
  --out "$work/leader" >"$work/leader.log" 2>&1 &
pid_leader=$!
pids+=("$pid_leader")

# The replay waits (up to 60 s) until the leader's scan reader is matched before the first scan.
"$bin/esfleet-replay" --log "$log" --robot-id r1 --rate 0 --max-scans "$max_scans" \
  --wait-subscribers 1 --wait-timeout 60 "${common[@]}" >"$work/replay.log" 2>&1 &
pid_replay=$!
pids+=("$pid_replay")
wait_for "$pid_replay" 90 "esfleet-replay"
grep -q "all acknowledged" "$work/replay.log" || fail "the leader did not acknowledge every scan"

# The leader maps what it received, waits 3 s for more, publishes the final map and serves it.
for _ in $(seq 1 1500); do
  grep -q "map complete" "$work/leader.log" && break
  kill -0 "$pid_leader" 2>/dev/null || fail "leader exited early"
  sleep 0.1
done
grep -q "map complete" "$work/leader.log" || fail "leader did not finish the map in 150 s"

wait_for "$pid_follower" 60 "follower"
if kill -INT "$pid_leader" 2>/dev/null; then :; fi  # it may be done lingering already
wait_for "$pid_leader" 15 "leader"

stats=$work/leader/stats.json
[ "$(json_int "$stats" scans)" = "$max_scans" ] ||
  fail "leader processed $(json_int "$stats" scans) scans, not $max_scans"
[ "$(json_int "$stats" received)" = "$max_scans" ] || fail "leader received scans twice?"
[ "$(json_int "$stats" seq_gaps)" = 0 ] || fail "scans missing according to their seq numbers"
[ "$(json_int "$stats" malformed)" = 0 ] || fail "the leader dropped malformed scans"
grep -q '"interrupted": false' "$stats" || fail "leader reports an interrupted run"
grep -q '"ended_idle": true' "$stats" || fail "leader did not end through --idle-exit"

[ -s "$work/follower/map.digest" ] || fail "follower saved no map digest"
cmp -s "$work/leader/map.digest" "$work/follower/map.digest" ||
  fail "follower map differs from the leader's: $(diff "$work/leader/map.digest" "$work/follower/map.digest" | head -5)"
grep -q '"complete": true' "$work/follower/stats.json" || fail "follower did not report complete"

# Same scans in the same order: same trajectory and map as the offline run over the log.
"$bin/esfleet-leader" --offline --log "$log" --max-scans "$max_scans" "${slam[@]}" \
  --out "$work/offline" >"$work/offline.log" 2>&1 || fail "offline leader failed"
cmp -s "$work/leader/trajectory.txt" "$work/offline/trajectory.txt" ||
  fail "trajectory from the scan topic differs from the offline one"
cmp -s "$work/leader/map.digest" "$work/offline/map.digest" ||
  fail "map from the scan topic differs from the offline one"

echo "OK: $max_scans scans replayed, none lost; leader == follower == offline run" \
  "($(wc -l <"$work/leader/map.digest") tiles)"
grep -h "sent .* scans" "$work/replay.log" || true
