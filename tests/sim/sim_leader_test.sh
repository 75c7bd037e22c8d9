#!/usr/bin/env bash
# The simulator feeding a live leader, with real processes: esfleet-sim drives one robot through
# the bundled world for DURATION s of sim time, publishing its scans (with noisy odometry) on the
# scan topic and writing its true poses (--out-log); esfleet-leader --scan-topic robot-1 maps
# them. The leader must receive every scan, and its trajectory, aligned on the first pose (the
# SLAM's frame starts at its first scan), must follow the truth: every pose within MAX_ERR m.
#
# usage: sim_leader_test.sh BIN_DIR WORLD_YAML PROFILE DOMAIN COMMON_SH [DURATION] [MAX_ERR]
set -euo pipefail
bin=$1 world=$2 profile=$3 domain=$4 common_sh=$5 duration=${6:-20} max_err=${7:-0.3}
source "$common_sh" sim-leader
seed=${ESFLEET_SIM_SEED:-1}
echo "seed $seed, $duration s of sim time, bound $max_err m"

common=(--domain "$domain" --profile "$profile")
"$bin/esfleet-leader" --scan-topic robot-1 --idle-exit 3 --odometry on "${common[@]}" \
  --out "$work/leader" >"$work/leader.log" 2>&1 &
pid_leader=$!
pids+=("$pid_leader")

# The simulator waits (up to 60 s) until the leader's scan reader is matched, then runs in real
# time at 5 Hz.
"$bin/esfleet-sim" --world "$world" --robots 1 --seed "$seed" --duration "$duration" \
  --wait-subscribers 1 --wait-timeout 60 --out-log "$work/sim" "${common[@]}" \
  >"$work/sim.log" 2>&1 &
pid_sim=$!
pids+=("$pid_sim")
wait_for "$pid_sim" $((duration + 90)) "esfleet-sim"

# The leader ends 3 s after the last scan (--idle-exit) and serves the map until the linger ends.
for _ in $(seq 1 600); do
  grep -q "map complete" "$work/leader.log" && break
  kill -0 "$pid_leader" 2>/dev/null || break
  sleep 0.1
done
grep -q "map complete" "$work/leader.log" || fail "leader did not finish the map"
kill -INT "$pid_leader" 2>/dev/null || true
wait "$pid_leader" || true

truth=$work/sim/robot-1.truth
traj=$work/leader/trajectory.txt
[ -s "$traj" ] || fail "leader wrote no trajectory"
n_truth=$(grep -vc '^#' "$truth")
n_traj=$(grep -vc '^#' "$traj")
[ "$n_traj" = "$n_truth" ] || fail "leader mapped $n_traj scans, the simulator sent $n_truth"

# compare TRUTH OTHER: pairs poses by stamp (both files print the same double with %.6f),
# expresses each in the frame of the first pair's pose and prints the position errors; fails
# (status 1) if the worst exceeds max_err or a pose has no truth.
compare() {
  awk -v max_err="$max_err" '
  /^#/ || NF == 0 { next }
  FNR == NR { tx[$1] = $2; ty[$1] = $3; tt[$1] = $4; next }
  !($1 in tx) { missing++; next }
  n == 0 { x0 = $2; y0 = $3; t0 = $4; X0 = tx[$1]; Y0 = ty[$1]; T0 = tt[$1] }
  {
    dx = $2 - x0; dy = $3 - y0; lx = cos(t0) * dx + sin(t0) * dy; ly = -sin(t0) * dx + cos(t0) * dy
    dX = tx[$1] - X0; dY = ty[$1] - Y0
    gx = cos(T0) * dX + sin(T0) * dY; gy = -sin(T0) * dX + cos(T0) * dY
    e = sqrt((lx - gx) ^ 2 + (ly - gy) ^ 2); sum += e; n++
    if (e > worst) { worst = e; at = $1 }
    path += (n > 1) ? sqrt((gx - px) ^ 2 + (gy - py) ^ 2) : 0; px = gx; py = gy
  }
  END {
    printf "%d poses, %.1f m driven, position error after aligning the first pose: mean %.3f m, worst %.3f m (stamp %s), %d unmatched\n", n, path, sum / n, worst, at, missing
    exit (n > 0 && missing == 0 && worst <= max_err) ? 0 : 1
  }' "$1" "$2"
}
result=$(compare "$truth" "$traj") || fail "trajectory check: $result"
# For scale: the simulated odometry alone (dead reckoning) against the same truth.
awk '$1 == "ODOM" { print $8, $2, $3, $4 }' "$work/sim/robot-1.log" >"$work/odom.txt"
odom_result=$(compare "$truth" "$work/odom.txt") || true
echo "odometry alone: $odom_result"
echo "OK (seed $seed): $result"
grep -h "ticks (" "$work/sim.log" || true
