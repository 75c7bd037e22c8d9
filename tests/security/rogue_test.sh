#!/usr/bin/env bash
# A fleet member that publishes what its permissions do not allow gets nothing through
# (docs/security.md). With a secure leader and a secure follower (robot-2) sharing the map,
# robot-1's identity (tests/security/rogue_writer) tries:
#   1. map tiles with its own signed permissions: refused by its own participant;
#   2. map tiles with permissions it signed itself with another permissions CA granting it the
#      leader's rights (its certificate stays the fleet's): the leader and robot-2 refuse it, so
#      its writer never matches a reader;
#   3. robot-2's pose in robot-2's partition: refused by its own participant.
# The follower's map must still equal the leader's, with no tile rejected.
#
# usage: rogue_test.sh BIN_DIR SRC_DIR LOG PROFILE DOMAIN [MAX_SCANS]
set -euo pipefail
bin=$1 src=$2 log=$3 profile=$4 domain=$5 max_scans=${6:-300}
source "$src/tests/integration/common.sh" security-rogue
source "$(dirname "$0")/secure_common.sh"
common=(--domain "$domain" --profile "$profile")

make_certs "$work/certs" leader robot-1 robot-2
# The forgery: robot-1's real identity with leader permissions from a CA of its own.
"$src/deploy/security/make-fleet-certs.sh" --role robot-1=leader "$work/forge" robot-1 \
  >"$work/certs-forge.log" 2>&1 || fail "make-fleet-certs.sh --role failed"
mkdir -p "$work/forged"
cp "$work/certs/robot-1"/{identity_ca.pem,cert.pem,key.pem} "$work/forged/"
cp "$work/forge/robot-1"/{permissions_ca.pem,governance.p7s,permissions.p7s} "$work/forged/"

"$bin/esfleet-follower" "${common[@]}" --secure "$work/certs/robot-2" --save-map "$work/victim" \
  --exit-when-complete --timeout 120 >"$work/victim.log" 2>&1 &
pid_victim=$!
pids+=("$pid_victim")
start_leader leader --secure "$work/certs/leader"

rogue() {  # name args...
  local name=$1
  shift
  "$bin/rogue_writer" "${common[@]}" --map-id map --seconds 8 "$@" >"$work/$name.log" 2>&1 || true
}
rogue honest --secure "$work/certs/robot-1" --topic tiles
grep -q "rogue: refused locally" "$work/honest.log" || fail "robot-1 created a tile writer: $(cat "$work/honest.log")"
rogue forged --secure "$work/forged" --topic tiles
grep -q "rogue: matched at most 0 reader" "$work/forged.log" ||
  fail "forged tile writer: $(tail -3 "$work/forged.log")"
rogue pose --secure "$work/certs/robot-1" --topic pose --partition robot-2 --robot-id robot-2
grep -q "rogue: refused locally" "$work/pose.log" || fail "robot-1 wrote robot-2's pose: $(cat "$work/pose.log")"

wait_log_ended leader
wait "$pid_victim" || fail "follower exited with $?"
kill -INT "$leader_pid"
wait "$leader_pid" || fail "leader exited with $? on SIGINT"
check_same_map leader victim
echo "OK: rogue tile writer refused (own permissions) / never matched (forged permissions);"
echo "    pose in another robot's partition refused; follower map == leader map"
