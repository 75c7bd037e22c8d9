#!/usr/bin/env bash
# esfleet-fleet --view: the launcher starts esfleet-view with the fleet; the view hears the
# leader and every simulated robot (robots.json names robot-1 and robot-2, status.json the map)
# and stops with the fleet.
#
# usage: fleet_view_test.sh BIN_DIR SRC_DIR DOMAIN PORT
set -euo pipefail
bin=$1 src=$2 domain=$3 port=$4
source "$src/tests/integration/common.sh" fleet-view
cd "$src"
"$bin/esfleet-fleet" --robots 2 --duration 40 --domain "$domain" \
  --profile deploy/fastdds/localhost-udp.xml --out "$work/fleet" --view "$port" \
  --view-args "--bind 127.0.0.1" --live false >"$work/fleet.log" 2>&1 &
fleet=$!
pids+=("$fleet")
ok=0
for _ in $(seq 1 350); do
  robots=$(curl -s "http://127.0.0.1:$port/robots.json" || true)
  status=$(curl -s "http://127.0.0.1:$port/status.json" || true)
  if python3 - "$robots" "$status" <<'PY'
import json, sys
robots = json.loads(sys.argv[1] or "{}").get("robots", [])
status = json.loads(sys.argv[2] or "{}")
ids = {r["id"] for r in robots}
sys.exit(0 if {"robot-1", "robot-2"} <= ids and status.get("tiles", 0) > 0 else 1)
PY
  then
    ok=1
    break
  fi
  sleep 0.1
done
[ "$ok" = 1 ] || fail "the fleet's view never showed robot-1, robot-2 and the map: $robots $status"
grep -q "the fleet in a browser: http://.*:$port/" "$work/fleet.log" || fail "no address printed"
kill -INT "$fleet"
wait "$fleet" || true
curl -s "http://127.0.0.1:$port/" >/dev/null && fail "esfleet-view still serving after the fleet stopped"
grep -q "stopped:" "$work/fleet/view.log" || fail "esfleet-view did not stop cleanly: $(tail -5 "$work/fleet/view.log")"
echo "OK: esfleet-fleet --view served the map and both robots, and stopped the view with the fleet"
