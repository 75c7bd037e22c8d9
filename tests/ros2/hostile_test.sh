#!/usr/bin/env bash
# Hostile and broken ROS 2 input from an independent DDS implementation (Cyclone DDS,
# esfleet-ros2-peer hostile): on robot h1's topics it sends, three times each, LaserScans whose
# ranges do not match their angles, with NaN or zero increments, NaN angle_min, 10^6 beams,
# 20,000 and 10^6 beams, stamps going backwards, a frame that is not the laser's; Odometry with a NaN quaternion;
# /initialpose with NaN x or in the odom frame; then 5 valid scans. A leader maps h1's scans and
# a follower (with odometry and --ros) reads the same scans, the odometry and /initialpose.
# Both must drop every broken message, count it by kind in stats.json exactly as many times as
# it was sent, log each kind once per sender, map (leader) the valid scans, and exit normally.
# (The 4 MB scans of 10^6 beams reach esfleet's best-effort reader only when the UDP receive
# buffer holds them; those that arrive must be refused and counted too.)
#
# usage: hostile_test.sh BIN_DIR LOG DOMAIN
set -euo pipefail
bin=$1 log=$2 domain=$3
here=$(cd "$(dirname "$0")" && pwd)
source "$here/../integration/common.sh" ros2-hostile

ros=(--ros-scan scan --ros-namespace /h1 --laser-frame h1/laser --idle-exit 4)
"$bin/esfleet-leader" "${ros[@]}" --linger 30 --domain "$domain" --checkpoint-every 0 \
  --out "$work/leader" >"$work/leader.log" 2>&1 &
pid_leader=$!
pids+=("$pid_leader")
"$bin/esfleet-follower" "${ros[@]}" --robot-id h2 --ros --ros-odom odom --laser-pose 0,0,0 \
  --domain "$domain" --timeout 90 --save-map "$work/follower" >"$work/follower.log" 2>&1 &
pid_follower=$!
pids+=("$pid_follower")

"$bin/esfleet-ros2-peer" hostile --domain "$domain" --scan-topic rt/h1/scan \
  --odom-topic rt/h1/odom --initialpose-topic rt/h1/initialpose --frame h1/laser \
  --odom-frame h1/odom --base-frame h1/base_link --map-frame map --wait-readers 2 --repeat 3 \
  >"$work/hostile.out" 2>"$work/hostile.log" || fail "the Cyclone hostile writer"

# The leader ends 4 s after the last scan and serves; the follower ends 4 s after its last scan.
for _ in $(seq 1 300); do
  grep -q "map complete" "$work/leader.log" && break
  kill -0 "$pid_leader" 2>/dev/null || fail "leader exited early"
  sleep 0.1
done
wait_for "$pid_follower" 60 "follower"
kill -INT "$pid_leader"
wait_for "$pid_leader" 15 "leader"

python3 - "$work/hostile.out" "$work/leader/stats.json" "$work/follower/stats.json" <<'PY' ||
import json, sys
sent = json.loads(open(sys.argv[1]).read().strip().splitlines()[-1])
leader, follower = (json.load(open(p)) for p in sys.argv[2:4])
scan_kinds = {
    "scan_ranges_mismatch": sent["scan_ranges_mismatch"],
    "scan_bad_angles": sent["scan_nan_increment"] + sent["scan_zero_increment"]
                       + sent["scan_nan_angle_min"],
    # 4 MB best-effort samples may be lost in transport (UDP receive buffers): counted
    # here only when they arrived (checked below).
    "scan_too_many_beams": sent["scan_many_beams"],
    "scan_stamp_backwards": sent["scan_stamp_backwards"],
    "scan_wrong_frame": sent["scan_wrong_frame"],
}
ok = True
def expect(what, got, want):
    global ok
    print(f"{what}: {got} (sent {want})")
    if got != want:
        ok = False
for who, stats in (("leader", leader), ("follower", follower)):
    dropped = dict(stats["ros_scan"]["dropped"])
    huge = dropped.get("scan_too_many_beams", 0) - sent["scan_many_beams"]
    print(f"{who}: {huge} of the {sent['scan_huge']} scans of 10^6 beams arrived (refused)")
    if 0 <= huge <= sent["scan_huge"]:
        dropped["scan_too_many_beams"] -= huge
    for kind, n in scan_kinds.items():
        expect(f"{who} {kind}", dropped.get(kind, 0), n)
# The leader uses every valid scan: the first of each backwards pair and the 5 at the end.
expect("leader scans used", leader["ros_scan"]["scans_used"],
       sent["scan_stamp_backwards"] + sent["valid_scans"])
expect("leader scans mapped", leader["scans"], sent["scan_stamp_backwards"] + sent["valid_scans"])
expect("follower bad_odom", follower["ros_scan"]["dropped"].get("bad_odom", 0),
       sent["odom_nan_quaternion"])
ip = follower["ros"]["initialpose"]["dropped"]
expect("follower bad_initialpose", ip.get("bad_initialpose", 0), sent["initialpose_nan"])
expect("follower initialpose_wrong_frame", ip.get("initialpose_wrong_frame", 0),
       sent["initialpose_wrong_frame"])
sys.exit(0 if ok else 1)
PY
  fail "the drops counted are not the messages sent"
for kind in scan_ranges_mismatch scan_bad_angles scan_too_many_beams scan_wrong_frame; do
  n=$(grep -c "dropping $kind from" "$work/leader.log" || true)
  [ "$n" = 1 ] || fail "the leader logged $kind $n times, not once"
done
echo "PASS"
