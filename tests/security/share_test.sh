#!/usr/bin/env bash
# Secure map sharing (docs/security.md): a leader and two followers, each with its own
# certificate and permissions from make-fleet-certs.sh. Follower robot-1 starts before the
# leader, robot-2 after the leader finished the log (transient-local history over the encrypted
# link). Both maps must equal the leader's counter for counter. Also: a --secure directory with
# a missing file is refused with a message naming the file, before Fast DDS is asked.
#
# usage: share_test.sh BIN_DIR SRC_DIR LOG PROFILE DOMAIN [MAX_SCANS]
set -euo pipefail
bin=$1 src=$2 log=$3 profile=$4 domain=$5 max_scans=${6:-300}
source "$src/tests/integration/common.sh" security-share
source "$(dirname "$0")/secure_common.sh"
common=(--domain "$domain" --profile "$profile")

make_certs "$work/certs" leader robot-1 robot-2

# A missing file is named (and nothing else starts).
mkdir -p "$work/broken" && cp "$work/certs/robot-1"/*.pem "$work/broken/" && rm "$work/broken/key.pem"
rc=0
"$bin/esfleet-follower" "${common[@]}" --secure "$work/broken" --timeout 5 >"$work/broken.out" 2>&1 || rc=$?
[ "$rc" = 2 ] || fail "follower with a broken --secure dir exited with $rc, expected 2"
grep -q "security file '.*key.pem' is missing" "$work/broken.out" ||
  fail "no message naming key.pem: $(cat "$work/broken.out")"

"$bin/esfleet-follower" "${common[@]}" --secure "$work/certs/robot-1" --save-map "$work/a" \
  --exit-when-complete --timeout 120 >"$work/a.log" 2>&1 &
pid_a=$!
pids+=("$pid_a")
start_leader leader --secure "$work/certs/leader"
wait_log_ended leader
"$bin/esfleet-follower" "${common[@]}" --secure "$work/certs/robot-2" --save-map "$work/b" \
  --exit-when-complete --timeout 60 >"$work/b.log" 2>&1 || fail "late follower exited with $?"
wait "$pid_a" || fail "early follower exited with $?"
kill -INT "$leader_pid"
wait "$leader_pid" || fail "leader exited with $? on SIGINT"

check_same_map leader a
check_same_map leader b
echo "OK: secure leader == early follower == late follower ($(wc -l <"$work/leader/map.digest") tiles)"
grep -h "map complete" "$work"/a.log "$work"/b.log || true
