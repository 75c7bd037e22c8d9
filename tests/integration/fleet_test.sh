#!/usr/bin/env bash
# The fleet launcher end to end with real processes: esfleet-fleet starts a leader mapping the
# bundled log, the simulator with ROBOTS virtual robots in that log's world, and one follower
# per robot; after DURATION seconds it stops them and writes its summary. Checks: every
# follower localised with no hint, none declared a wrong pose, tracking error against the
# simulator's truth is small, every follower ended with the leader's map, and the summary's
# fields are there.
#
# usage: fleet_test.sh BIN_DIR SOURCE_DIR DOMAIN [ROBOTS] [DURATION]
set -euo pipefail
bin=$1 src=$2 domain=$3 robots=${4:-2} duration=${5:-75}
source "$(dirname "$0")/common.sh" fleet

cd "$src"
"$bin/esfleet-fleet" --robots "$robots" --duration "$duration" --domain "$domain" \
  --out "$work/fleet" --summary "$work/summary.json" --live false >"$work/fleet.log" 2>&1 ||
  fail "esfleet-fleet exited with $?"
tail -n "$((robots + 6))" "$work/fleet.log"
cp "$work"/fleet/*.log "$work/" 2>/dev/null || true

python3 - "$work/summary.json" "$robots" <<'PY' || fail "fleet summary check"
import json, sys
s = json.load(open(sys.argv[1]))
robots = int(sys.argv[2])
ok = s["robots"] == robots and len(s["followers"]) == robots and s["failure"] == ""
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
