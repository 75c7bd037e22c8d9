#!/usr/bin/env bash
# ROS 2 /map and /map_updates, checked by an independent DDS implementation (Cyclone DDS,
# esfleet-ros2-peer): the leader maps MAX_SCANS scans of a log at 8x recorded speed with --ros;
# a Cyclone reader joins late (after the leader's first /map), keeps the first /map it gets and
# applies /map_updates to it. At the end
#  1. the last /map it received equals, cell for cell, the leader's saved map.pgm read the way
#     map_server reads it (map.yaml, trinary);
#  2. its first /map with every update applied equals that last /map.
#
# usage: map_test.sh BIN_DIR LOG DOMAIN [MAX_SCANS]
# (Fast DDS with its default transports: Cyclone DDS reaches it over UDP.)
set -euo pipefail
bin=$1 log=$2 domain=$3 max_scans=${4:-600}
here=$(cd "$(dirname "$0")" && pwd)
source "$here/../integration/common.sh" ros2-map

"$bin/esfleet-leader" --log "$log" --max-scans "$max_scans" --rate 8 --ros --linger 60 \
  --domain "$domain" --seed 3 --out "$work/leader" >"$work/leader.log" 2>&1 &
pid_leader=$!
pids+=("$pid_leader")

# Join late: once the leader has mapped a while.
for _ in $(seq 1 300); do
  grep -q "scan [0-9]*/$max_scans" "$work/leader.log" && break
  kill -0 "$pid_leader" 2>/dev/null || fail "leader exited early"
  sleep 0.1
done
sleep 3
grep -q "map complete" "$work/leader.log" && fail "the leader finished before the reader joined"

"$bin/esfleet-ros2-peer" map-reader --domain "$domain" --out "$work/peer" --timeout 150 \
  --idle-exit 8 >"$work/peer.log" 2>&1 &
pid_peer=$!
pids+=("$pid_peer")

wait_for "$pid_peer" 170 "the Cyclone map reader"
grep -q "map complete" "$work/leader.log" || fail "the leader did not finish its map"
cat "$work/peer.log"
python3 "$here/ros2_check.py" grid-equals-pgm "$work/peer.last" "$work/leader/map.yaml" ||
  fail "the last /map is not the saved map"
python3 "$here/ros2_check.py" grids-equal "$work/peer.applied" "$work/peer.last" ||
  fail "the first /map with the updates applied is not the last /map"
grep -Eq '"updates_applied": *[1-9]' "$work/peer.applied.json" || fail "no update was applied"
echo "PASS"
