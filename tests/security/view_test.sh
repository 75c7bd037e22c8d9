#!/usr/bin/env bash
# esfleet-view under DDS Security (docs/view.md, docs/security.md): with the "view" identity
# from make-fleet-certs.sh it reads the secure leader's map (its map.pgm download equals the
# leader's map.pgm byte for byte) and may write nothing: its permissions hold no publish rule,
# and its identity trying to write map tiles or a pose is refused by its own participant.
#
# usage: view_test.sh BIN_DIR SRC_DIR LOG PROFILE DOMAIN [MAX_SCANS]
set -euo pipefail
bin=$1 src=$2 log=$3 profile=$4 domain=$5 max_scans=${6:-300}
port=$((18000 + domain))
source "$src/tests/integration/common.sh" security-view
source "$(dirname "$0")/secure_common.sh"
common=(--domain "$domain" --profile "$profile")

make_certs "$work/certs" leader view
grep -q "<publish>" "$work/certs/view/permissions.xml" && fail "the view's permissions grant a publish"
grep -q "<subscribe>" "$work/certs/view/permissions.xml" || fail "the view's permissions grant no subscribe"

"$bin/esfleet-view" "${common[@]}" --secure "$work/certs/view" --port "$port" --bind 127.0.0.1 \
  >"$work/view.log" 2>&1 &
pid_view=$!
pids+=("$pid_view")
start_leader leader --secure "$work/certs/leader"
wait_log_ended leader
tiles=$(wc -l <"$work/leader/map.digest")
for _ in $(seq 1 300); do
  state=$(curl -s "http://127.0.0.1:$port/stats.json" || true)
  python3 -c 'import json,sys; s=json.loads(sys.argv[1] or "{}"); sys.exit(0 if s.get("complete") and s.get("tiles")==int(sys.argv[2]) else 1)' \
    "$state" "$tiles" && break
  sleep 0.1
done
python3 -c 'import json,sys; s=json.loads(sys.argv[1] or "{}"); sys.exit(0 if s.get("complete") else 1)' "$state" ||
  fail "the secure view never held the complete map: $state"
curl -sf "http://127.0.0.1:$port/download/map.pgm" -o "$work/view.pgm" || fail "map.pgm download"
cmp -s "$work/leader/map.pgm" "$work/view.pgm" || fail "the view's map.pgm differs from the leader's"

rogue() {  # name args...
  local name=$1
  shift
  "$bin/rogue_writer" "${common[@]}" --map-id map --seconds 3 "$@" >"$work/$name.log" 2>&1 || true
}
rogue tiles --secure "$work/certs/view" --topic tiles
grep -q "rogue: refused locally" "$work/tiles.log" || fail "the view identity created a tile writer: $(cat "$work/tiles.log")"
rogue pose --secure "$work/certs/view" --topic pose --partition view --robot-id view
grep -q "rogue: refused locally" "$work/pose.log" || fail "the view identity wrote a pose: $(cat "$work/pose.log")"

kill -INT "$pid_view"
rc=0
wait "$pid_view" || rc=$?
[ "$rc" = 130 ] || fail "esfleet-view exited $rc on SIGINT"
kill -INT "$leader_pid"
wait "$leader_pid" || fail "leader exited with $? on SIGINT"
echo "OK: secure view holds the leader's map ($tiles tiles, map.pgm identical); its identity may write nothing"
