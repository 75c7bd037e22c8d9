#!/usr/bin/env bash
# The TF tree of a follower with odometry, as an independent DDS implementation (Cyclone DDS)
# sees it: Cyclone publishes robot f1's LaserScan, nav_msgs/Odometry on /f1/odom and the
# odom -> base transform on /tf (as a robot base does); esfleet-follower --ros-odom odom
# localises and publishes TF map -> f1/odom and its pose. On the Cyclone side, for every pose
# received: map -> f1/odom (esfleet's) composed with f1/odom -> f1/base_link (the robot's, same
# stamp) equals the pose (REP 105), and the pose lies within 0.3 m of the leader's.
#
# usage: tf_test.sh BIN_DIR LOG DOMAIN
set -euo pipefail
bin=$1 log=$2 domain=$3
here=$(cd "$(dirname "$0")" && pwd)
source "$here/../integration/common.sh" ros2-tf
source "$here/ros2_common.sh"
zcat -f "$log" >"$work/log.txt"
start_leader "$log" "$domain" 600

"$bin/esfleet-follower" --domain "$domain" --robot-id f1 --ros --ros-scan scan --ros-odom odom \
  --laser-pose 0,0,0 --odometry on --idle-exit 4 --timeout 150 --save-map "$work/f1" \
  >"$work/f1.log" 2>&1 &
pid_f1=$!
pids+=("$pid_f1")
"$bin/esfleet-ros2-peer" pose-reader --domain "$domain" --topic rt/f1/pose --tf --count 10 \
  --timeout 120 --out "$work/f1-poses.jsonl" >"$work/f1-poses.log" 2>&1 &
pid_poses=$!
pids+=("$pid_poses")
cyclone_scans scans-f1 "$domain" f1 400 --odom-topic rt/f1/odom --odom-frame f1/odom \
  --base-frame f1/base_link --tf

wait_for "$pid_poses" 130 "the Cyclone pose and TF reader"
wait_for "$pid_f1" 120 "follower f1"
python3 "$here/ros2_check.py" tf-consistent "$work/f1-poses.jsonl" map f1/odom f1/base_link ||
  fail "the TF tree does not give the published pose"
python3 "$here/ros2_check.py" poses-near "$work/f1-poses.jsonl" "$work/leader/trajectory.txt" 0.3 ||
  fail "f1's ROS poses are not the leader's"
echo "PASS"
