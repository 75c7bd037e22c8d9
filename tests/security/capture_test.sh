#!/usr/bin/env bash
# No plaintext on the wire (docs/security.md): leader and follower over UDP on loopback
# (localhost-udp.xml) with tcpdump capturing the domain's ports. The map id, a long random
# canary, is in every tile message: it must appear in the capture of a plain run (the check
# works) and must not appear in the capture of a secure run. Needs root and tcpdump: skipped
# (exit 77) otherwise.
#
# usage: capture_test.sh BIN_DIR SRC_DIR LOG UDP_PROFILE DOMAIN [MAX_SCANS]
set -euo pipefail
bin=$1 src=$2 log=$3 profile=$4 domain=$5 max_scans=${6:-100}
if ! command -v tcpdump >/dev/null || [ "$(id -u)" != 0 ]; then
  echo "SKIP: needs root and tcpdump (apt-get install tcpdump)"
  exit 77
fi
source "$src/tests/integration/common.sh" security-capture
source "$(dirname "$0")/secure_common.sh"
common=(--domain "$domain" --profile "$profile")
canary="esfleet-plaintext-canary-$(od -An -N8 -tx1 /dev/urandom | tr -d ' \n')"
# RTPS ports of the domain: 7400 + 250 * domain, then unicast ports per participant above it.
base=$((7400 + 250 * domain))

make_certs "$work/certs" leader robot-1

run() {  # name [--secure]: leader + follower, capturing
  local name=$1 secure_leader=() secure_follower=()
  if [ "${2:-}" = --secure ]; then
    secure_leader=(--secure "$work/certs/leader")
    secure_follower=(--secure "$work/certs/robot-1")
  fi
  tcpdump -i lo -U -s 0 -w "$work/$name.pcap" "udp and portrange $base-$((base + 249))" \
    >"$work/tcpdump-$name.log" 2>&1 &
  local tcpdump_pid=$!
  pids+=("$tcpdump_pid")
  for _ in $(seq 1 50); do
    grep -q "listening on" "$work/tcpdump-$name.log" && break
    sleep 0.1
  done
  "$bin/esfleet-follower" "${common[@]}" "${secure_follower[@]}" --map-id "$canary" \
    --save-map "$work/$name-follower" --exit-when-complete --timeout 120 \
    >"$work/$name-follower.log" 2>&1 &
  local follower_pid=$!
  pids+=("$follower_pid")
  start_leader "$name-leader" "${secure_leader[@]}" --map-id "$canary"
  wait_log_ended "$name-leader"
  wait "$follower_pid" || fail "$name follower exited with $?"
  kill -INT "$leader_pid"
  wait "$leader_pid" || fail "$name leader exited with $? on SIGINT"
  check_same_map "$name-leader" "$name-follower"
  sleep 0.5
  kill -INT "$tcpdump_pid"
  wait "$tcpdump_pid" || true
  [ -s "$work/$name.pcap" ] || fail "$name: empty capture"
}

run plain
plain_hits=$(LC_ALL=C grep -caF "$canary" "$work/plain.pcap" || true)
[ "$plain_hits" -gt 0 ] || fail "the plain capture does not contain the canary: the check is broken"
run secure --secure
secure_hits=$(LC_ALL=C grep -caF "$canary" "$work/secure.pcap" || true)
[ "$secure_hits" = 0 ] || fail "the secure capture contains the map id in plaintext ($secure_hits)"
echo "OK: canary in $plain_hits packets of the plain capture ($(stat -c %s "$work/plain.pcap") B)," \
  "in none of the secure one ($(stat -c %s "$work/secure.pcap") B)"
