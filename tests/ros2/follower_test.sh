#!/usr/bin/env bash
# A follower localises from ROS 2 scans published by an independent DDS implementation
# (Cyclone DDS, esfleet-ros2-peer), and ROS 2 sees where it is:
#  1. no hint: follower f1 reads the LaserScans Cyclone publishes on /f1/scan, localises in the
#     leader's map and its geometry_msgs/PoseWithCovarianceStamped arrive on the Cyclone side on
#     /f1/pose, each within 0.3 m of the leader's own pose at the same scan, with a positive
#     covariance;
#  2. /initialpose from Cyclone acts as a hint: follower f2 gets one (the start pose, RViz2's
#     default covariance), localises around it (its log says so, stats.json counts it used)
#     and tracks within 0.3 m of the leader.
#
# usage: follower_test.sh BIN_DIR LOG DOMAIN
set -euo pipefail
bin=$1 log=$2 domain=$3
here=$(cd "$(dirname "$0")" && pwd)
source "$here/../integration/common.sh" ros2-follower
source "$here/ros2_common.sh"
zcat -f "$log" >"$work/log.txt"
start_leader "$log" "$domain" 600

for f in f1 f2; do
  "$bin/esfleet-follower" --domain "$domain" --robot-id "$f" --ros --ros-scan scan \
    --idle-exit 4 --timeout 150 --save-map "$work/$f" >"$work/$f.log" 2>&1 &
  eval "pid_$f=$!"
  pids+=("$!")
done
"$bin/esfleet-ros2-peer" pose-reader --domain "$domain" --topic rt/f1/pose --count 5 \
  --timeout 120 --out "$work/f1-poses.jsonl" >"$work/f1-poses.log" 2>&1 &
pid_poses=$!
pids+=("$pid_poses")
"$bin/esfleet-ros2-peer" initialpose --domain "$domain" --topic rt/f2/initialpose --x 0 --y 0 \
  --yaw 0 --sigma-xy 0.5 --sigma-yaw 0.26 --repeat 1 >"$work/initialpose.log" 2>&1 ||
  fail "the Cyclone /initialpose writer"
cyclone_scans scans-f1 "$domain" f1 400
cyclone_scans scans-f2 "$domain" f2 400

wait_for "$pid_poses" 130 "the Cyclone pose reader"
wait_for "$pid_f1" 120 "follower f1"
wait_for "$pid_f2" 120 "follower f2"
python3 "$here/ros2_check.py" poses-near "$work/f1-poses.jsonl" "$work/leader/trajectory.txt" 0.3 ||
  fail "f1's ROS poses are not the leader's"
grep -q "/initialpose: localising around (0.00, 0.00, 0.0 deg) within 1.00 m" "$work/f2.log" ||
  fail "f2 did not take the /initialpose hint"
[ "$(json_number "$work/f2/stats.json" used)" = 1 ] || fail "f2 counts no /initialpose used"
for f in f1 f2; do
  [ "$(json_number "$work/$f/stats.json" declarations)" -ge 1 ] || fail "$f never localised"
done
echo "PASS"
