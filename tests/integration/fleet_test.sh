#!/usr/bin/env bash
# The fleet launcher end to end with real processes: esfleet-fleet starts a leader mapping the
# bundled log, the simulator with ROBOTS virtual robots in that log's world, and one follower
# per robot; after DURATION seconds it stops them and writes its summary. Checks: every
# follower localised with no hint, none declared a wrong pose, tracking error against the
# simulator's truth is small, every follower ended with the leader's map, and the summary's
# fields are there.
# KILL_AT > 0: robot-1's follower is SIGKILLed KILL_AT seconds after the launcher started; the
# launcher must restart it (one restart, death code 137 in the summary), and it must localise
# again and end with the leader's map like the others.
#
# usage: fleet_test.sh BIN_DIR SOURCE_DIR DOMAIN [ROBOTS] [DURATION] [KILL_AT]
set -euo pipefail
bin=$1 src=$2 domain=$3 robots=${4:-2} duration=${5:-75} kill_at=${6:-0}
source "$(dirname "$0")/common.sh" fleet

cd "$src"
"$bin/esfleet-fleet" --robots "$robots" --duration "$duration" --domain "$domain" \
  --out "$work/fleet" --summary "$work/summary.json" --live false >"$work/fleet.log" 2>&1 &
fleet=$!
if [ "$kill_at" -gt 0 ]; then
  sleep "$kill_at"
  victim=$(pgrep -f -- "esfleet-follower --scan-topic robot-1 .*--domain $domain " | head -n 1)
  [ -n "$victim" ] || fail "robot-1's follower is not running after $kill_at s"
  kill -KILL "$victim"
  echo "robot-1's follower (pid $victim) SIGKILLed after $kill_at s"
fi
wait $fleet || fail "esfleet-fleet exited with $?"
tail -n "$((robots + 6))" "$work/fleet.log"
cp "$work"/fleet/*.log "$work/" 2>/dev/null || true

python3 - "$work/summary.json" "$robots" "$kill_at" <<'PY' || fail "fleet summary check"
import json, sys
s = json.load(open(sys.argv[1]))
robots, kill_at = int(sys.argv[2]), int(sys.argv[3])
ok = s["robots"] == robots and len(s["followers"]) == robots and s["failure"] == ""
restarts = [f["restarts"] for f in s["followers"]]
print(f"follower restarts {restarts}, total {s['follower_restarts']}, "
      f"codes {[f['exit_codes_before_restarts'] for f in s['followers']]}")
want = [1 if kill_at > 0 and k == 0 else 0 for k in range(robots)]
ok = ok and restarts == want and s["follower_restarts"] == sum(want)
if kill_at > 0:
    ok = ok and s["followers"][0]["exit_codes_before_restarts"] == [137]
for f in s["followers"]:
    print(f"{f['robot_id']}: localised {f['localised']} after {f['time_to_localise_s']:.1f} s, "
          f"first pose error {f['first_pose_error_m']:.3f} m / {f['first_pose_error_deg']:.2f} deg, "
          f"tracking error median {f['tracking_error_m_median']:.3f} m p95 "
          f"{f['tracking_error_m_p95']:.3f} m over {f['tracking_poses_scored']} poses, "
          f"{f['bytes_received']} bytes, realtime {f['realtime']}")
    ok = ok and f["localised"] and f["wrong_declarations"] == 0
    ok = ok and f["tracking_poses_scored"] >= 20 and f["tracking_error_m_median"] < 0.15
    ok = ok and f["bytes_received"] > 0 and f["exit_code"] == 0
print(f"leader exit {s['leader']['exit_code']}, sim exit {s['sim']['exit_code']}")
ok = ok and s["leader"]["exit_code"] == 0 and s["sim"]["exit_code"] in (0, 130)  # 130: stopped by SIGINT
sys.exit(0 if ok else 1)
PY
for k in $(seq 1 "$robots"); do
  cmp -s "$work/fleet/leader/map.digest" "$work/fleet/robot-$k/map.digest" ||
    fail "robot-$k's map differs from the leader's"
done
echo "OK"
