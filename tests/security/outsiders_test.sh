#!/usr/bin/env bash
# Participants outside the fleet get nothing (docs/security.md): while a secure follower gets the
# secure leader's whole map, a follower without --secure and one whose certificate comes from
# another CA (a complete fleet directory of their own, same ids) apply no tile within the time;
# nor does a fleet member whose certificate was revoked (make-fleet-certs.sh --revoke: the
# others have crl.pem, the revoked one not).
#
# usage: outsiders_test.sh BIN_DIR SRC_DIR LOG PROFILE DOMAIN [MAX_SCANS]
set -euo pipefail
bin=$1 src=$2 log=$3 profile=$4 domain=$5 max_scans=${6:-300}
source "$src/tests/integration/common.sh" security-outsiders
source "$(dirname "$0")/secure_common.sh"
common=(--domain "$domain" --profile "$profile")

make_certs "$work/certs" leader robot-1 robot-2
"$src/deploy/security/make-fleet-certs.sh" --revoke robot-2 "$work/certs" >"$work/certs-revoke.log" 2>&1 ||
  fail "make-fleet-certs.sh --revoke failed"
rm "$work/certs/robot-2/crl.pem"  # the revoked robot does not get the new list
make_certs "$work/other" leader robot-1  # same names, another CA

outsider() {  # name args...: a follower that must get nothing in 40 s
  local name=$1
  shift
  "$bin/esfleet-follower" "${common[@]}" "$@" --save-map "$work/$name" --exit-when-complete \
    --timeout 40 >"$work/$name.log" 2>&1 &
  eval "pid_$name=$!"
  pids+=("$!")
}
outsider plain
outsider other --secure "$work/other/robot-1"
outsider revoked --secure "$work/certs/robot-2"
"$bin/esfleet-follower" "${common[@]}" --secure "$work/certs/robot-1" --save-map "$work/member" \
  --exit-when-complete --timeout 120 >"$work/member.log" 2>&1 &
pid_member=$!
pids+=("$pid_member")
start_leader leader --secure "$work/certs/leader"
wait_log_ended leader
wait "$pid_member" || fail "secure follower exited with $?"
check_same_map leader member

for name in plain other revoked; do
  pid_var=pid_$name
  rc=0
  wait "${!pid_var}" || rc=$?
  # 3: timed out; 1: timed out with no map to save
  [ "$rc" = 3 ] || [ "$rc" = 1 ] || fail "$name follower exited with $rc, expected 1 or 3 (timeout)"
  if [ -f "$work/$name/stats.json" ]; then
    grep -q '"tiles_applied": 0' "$work/$name/stats.json" || fail "$name follower applied tiles"
  fi
  grep -q "map complete" "$work/$name.log" && fail "$name follower reports a complete map"
done
kill -INT "$leader_pid"
wait "$leader_pid" || fail "leader exited with $? on SIGINT"
echo "OK: secure follower has the leader's map; a plain follower, one from another CA and a"
echo "    revoked one got none"
