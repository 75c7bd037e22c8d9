#!/usr/bin/env bash
# Fault: a network partition. A leader and a follower in two network namespaces over UDP
# (deploy/netns/testbed.sh, lan-udp.xml: multicast discovery). The follower's link is cut for
# CUT seconds while the leader keeps mapping (its log ends during the cut), then healed: the
# follower must converge to the leader's final map bit for bit. Reports the convergence time
# after healing (heal -> the follower holds every tile at the leader's final version) and the
# bytes it took: the leader's eth0 transmit counter and the follower's received tile bytes, in
# the window from healing to convergence, against the whole run.
#   plain  no loss, no rate cap
#   lossy  20 % of the UDP datagrams dropped at random on arrival, 1 Mbit/s per link
#
# usage: partition_test.sh BIN_DIR LOG DOMAIN [plain|lossy] [CUT_S] [SCANS] [RATE]
# Exit 77 (skipped) without root, network namespaces, tc or nft.
set -euo pipefail
bin=$1 log=$2 domain=$3 mode=${4:-plain} cut_s=${5:-30} scans=${6:-1000} rate=${7:-5}
here=$(cd "$(dirname "$0")" && pwd)
testbed=$here/../../deploy/netns/testbed.sh
profile=$here/../../deploy/fastdds/lan-udp.xml

skip() { echo "SKIP: $*"; exit 77; }
[ "$(id -u)" -eq 0 ] || skip "needs root (network namespaces)"
command -v ip >/dev/null || skip "no 'ip' (package iproute2)"
command -v bridge >/dev/null || skip "no 'bridge' (package iproute2)"
if [ "$mode" = lossy ]; then
  command -v tc >/dev/null || skip "no 'tc' (package iproute2)"
  command -v nft >/dev/null || skip "no 'nft' (package nftables)"
fi
case $mode in
  plain) netem=() subnet=$domain ;;
  lossy) netem=(--loss 20 --rate 1mbit) subnet=$((domain + 1)) ;;
  *) echo "mode must be plain or lossy" >&2; exit 2 ;;
esac
# Testbeds left by a run of this case that was killed (CTest timeout): remove them.
for ns in $(ip netns list 2>/dev/null | awk '{print $1}' | grep "^esf-p${mode}${domain}_[0-9]*-br$"); do
  old=${ns#esf-}
  old=${old%-br}
  kill -0 "${old##*_}" 2>/dev/null || "$testbed" down "$old"
done
source "$here/../integration/common.sh" "partition-$mode"
run=p${mode}${domain}_$$
trap 'cleanup; "$testbed" down "$run" >/dev/null 2>&1' EXIT
rc=0
"$testbed" up "$run" 2 --subnet "$subnet" "${netem[@]}" >"$work/testbed.log" 2>&1 || rc=$?
[ $rc -ne 77 ] || skip "$(cat "$work/testbed.log")"
[ $rc -eq 0 ] || fail "testbed up failed: $(cat "$work/testbed.log")"
cat "$work/testbed.log"

now() { date +%s.%N; }
json() { python3 -c "import json, sys; d = json.load(open(sys.argv[1])); print(eval(sys.argv[2]))" "$@"; }
tx_bytes() { "$testbed" exec "$run" 1 cat /sys/class/net/eth0/statistics/tx_bytes; }
common=(--domain "$domain" --profile "$profile")

"$testbed" exec "$run" 1 "$bin/esfleet-leader" --log "$log" --odometry on --max-scans "$scans" \
  --seed 7 --rate "$rate" "${common[@]}" --out "$work/leader" --linger 150 \
  >"$work/leader.log" 2>&1 &
pid_leader=$!
pids+=("$pid_leader")
t_start=$(now)
"$testbed" exec "$run" 2 "$bin/esfleet-follower" "${common[@]}" --save-map "$work/follower" \
  --exit-when-complete --timeout 150 >"$work/follower.log" 2>&1 &
pid_f=$!
pids+=("$pid_f")

# Cut once tiles flow, so that the log ends about 5 s before the cut is healed.
scan_rate=$(python3 -c "print($rate * 4.7)")  # the CSAIL log has ~4.7 scans per second
cut_after=$(python3 -c "print(max(8.0, $scans / $scan_rate + 5 - $cut_s))")
sleep "$cut_after"
kill -0 "$pid_leader" 2>/dev/null || fail "leader exited early"
kill -USR1 "$pid_f"
sleep 0.3
"$testbed" cut "$run" 2
t_cut=$(now)
bytes_before=$(json "$work/follower/stats.json" "d['bytes_received']")
tiles_before=$(json "$work/follower/stats.json" "d['tiles']")
echo "$mode: cut the follower off for $cut_s s at $(python3 -c "print(round($t_cut - $t_start, 1))") s" \
  "(it had $tiles_before tiles, $bytes_before bytes)"
sleep "$cut_s"
grep -q "log ended" "$work/leader.log" || echo "note: the leader is still mapping at the heal"
tx_heal=$(tx_bytes)
"$testbed" heal "$run" 2
t_heal=$(now)

wait_for "$pid_f" 120 "follower"
tx_done=$(tx_bytes)
grep -q "log ended" "$work/leader.log" || fail "the leader did not finish its log"
done_s=$(json "$work/follower/stats.json" "d['time_to_complete_s']")
# time_to_complete_s counts from the follower's start (a few ms after t_start).
converge=$(python3 -c "print(round($t_start + $done_s - $t_heal, 2))")
bytes_total=$(json "$work/follower/stats.json" "d['bytes_received']")
kill -INT "$pid_leader"
wait "$pid_leader" || fail "leader exited with $? on SIGINT"
leader_bytes=$(json "$work/leader/stats.json" "d['dds']['bytes_total']")
cmp -s "$work/leader/map.digest" "$work/follower/map.digest" ||
  fail "follower map differs: $(diff "$work/leader/map.digest" "$work/follower/map.digest" | head -5)"
[ "$mode" = plain ] || "$testbed" stats "$run"
echo "OK: $mode: converged $converge s after healing a $cut_s s cut;" \
  "leader eth0 sent $((tx_done - tx_heal)) bytes from heal to convergence;" \
  "follower received $((bytes_total - bytes_before)) tile/meta bytes after the cut began" \
  "($bytes_total in all; the leader published $leader_bytes);" \
  "$(wc -l <"$work/leader/map.digest") tiles identical"
