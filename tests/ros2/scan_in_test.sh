#!/usr/bin/env bash
# ROS 2 scans in, from an independent DDS implementation: Cyclone DDS (esfleet-ros2-peer
# scan-writer) publishes the first MAX_SCANS scans of a log as best-effort
# sensor_msgs/LaserScan + nav_msgs/Odometry under namespace /r1; esfleet-leader --ros-scan maps
# them. With every scan delivered (counted in stats.json), its trajectory equals an --offline
# run over the same log with the same seed:
#  1. laser only: bit for bit (as written, 6 decimals);
#  2. with the odometry (--ros-odom odom --odometry on): within 1 mm (the heading crosses a
#     quaternion and back).
#
# usage: scan_in_test.sh BIN_DIR LOG DOMAIN [MAX_SCANS]
set -euo pipefail
bin=$1 log=$2 domain=$3 max_scans=${4:-300}
here=$(cd "$(dirname "$0")" && pwd)
source "$here/../integration/common.sh" ros2-scan-in
zcat -f "$log" >"$work/log.txt"

# run NAME TOLERANCE SLAM_FLAGS...: one leader fed by Cyclone, one offline, compared.
run() {
  local name=$1 tol=$2
  shift 2
  "$bin/esfleet-leader" --offline --log "$log" --max-scans "$max_scans" --seed 7 "$@" \
    --out "$work/$name-offline" >"$work/$name-offline.log" 2>&1 || fail "offline leader ($name)"
  local ros=(--ros-scan scan --ros-namespace /r1 --laser-pose 0,0,0)
  [ "$name" = odometry ] && ros+=(--ros-odom odom)
  "$bin/esfleet-leader" "${ros[@]}" --idle-exit 3 --linger 0 --domain "$domain" --seed 7 "$@" \
    --checkpoint-every 0 --out "$work/$name" >"$work/$name.log" 2>&1 &
  local pid_leader=$!
  pids+=("$pid_leader")
  "$bin/esfleet-ros2-peer" scan-writer --domain "$domain" --log "$work/log.txt" \
    --max-scans "$max_scans" --best-effort --scan-topic rt/r1/scan --odom-topic rt/r1/odom \
    --frame r1/laser --odom-frame r1/odom --base-frame r1/base_link --wait-timeout 60 \
    >"$work/$name-peer.log" 2>&1 || fail "the Cyclone scan writer ($name)"
  wait_for "$pid_leader" 120 "leader ($name)"
  local used
  used=$(grep -o '"scans_used": [0-9]*' "$work/$name/stats.json" | grep -o '[0-9]*$')
  [ "$used" = "$max_scans" ] || fail "$name: the leader used $used of $max_scans scans"
  python3 "$here/ros2_check.py" trajectories-equal "$work/$name-offline/trajectory.txt" \
    "$work/$name/trajectory.txt" "$tol" || fail "$name: the trajectories differ"
}
run laser 0
run odometry 0.001 --odometry on
echo "PASS"
