#!/usr/bin/env bash
# Contributions under DDS Security (docs/contribute.md): only an identity made with the
# contributor role may write scans into the leader's map. robot-1 (contributor) drives on past
# where the leader stopped and its scans are accepted; robot-2 (a plain follower) asks for
# --contribute and is refused at the start, naming the contribution topic, with exit code 2.
#
# usage: contribute_test.sh BIN_DIR SRC_DIR LOG PROFILE DOMAIN [MAX_SCANS]
set -euo pipefail
bin=$1 src=$2 log=$3 profile=$4 domain=$5 max_scans=${6:-300}
source "$src/tests/integration/common.sh" security-contribute
source "$(dirname "$0")/secure_common.sh"
common=(--domain "$domain" --profile "$profile")

"$src/deploy/security/make-fleet-certs.sh" --role robot-1=contributor "$work/certs" leader \
  robot-1 robot-2 >"$work/certs.log" 2>&1 || fail "make-fleet-certs.sh failed: $(tail -3 "$work/certs.log")"

start_leader leader --secure "$work/certs/leader" --accept-contributions
wait_log_ended leader

# A plain follower may not contribute: refused when its writer is created.
rc=0
"$bin/esfleet-follower" "${common[@]}" --secure "$work/certs/robot-2" --log "$log" \
  --first-scan 200 --max-scans 250 --contribute --robot-id robot-2 --timeout 30 \
  >"$work/robot-2.log" 2>&1 || rc=$?
[ "$rc" = 2 ] || fail "robot-2 (no contribute permission) exited with $rc, expected 2"
grep -q "contribution" "$work/robot-2.log" ||
  fail "robot-2's error does not name the contribution topic: $(tail -3 "$work/robot-2.log")"

# The contributor: scans 200-549 of the log, past the leader's last scan.
"$bin/esfleet-follower" "${common[@]}" --secure "$work/certs/robot-1" --log "$log" \
  --first-scan 200 --max-scans 550 --rate 4 --contribute --robot-id robot-1 \
  --save-map "$work/robot-1" --timeout 150 >"$work/robot-1.log" 2>&1 ||
  fail "robot-1 exited with $?: $(tail -3 "$work/robot-1.log")"
sleep 2
kill -INT "$leader_pid"
wait "$leader_pid" || fail "leader exited with $? on SIGINT"

accepted=$(python3 -c "
import json; c = json.load(open('$work/leader/stats.json')).get('contributions', {})
print(c.get('robot-1', {}).get('accepted', 0), 1 if 'robot-2' in c else 0)")
read -r ok rogue <<<"$accepted"
[ "$ok" -gt 20 ] || fail "the leader accepted only $ok contributions from robot-1"
[ "$rogue" = 0 ] || fail "the leader has contributions from robot-2"
echo "OK: robot-1 (contributor) $ok scans accepted; robot-2 (follower) refused with exit 2"
