#!/usr/bin/env bash
# Fault: a follower is killed (SIGKILL) and restarted; it must get the whole current map again
# as a late joiner (transient-local tiles) and end with the leader's map.
#   1. the leader maps SCANS scans at --rate RATE; the follower is killed mid-run and restarted
#      at once: it catches up while the map still grows and ends equal to the final map;
#   2. it is killed again after the map is complete and restarted: time to the full map.
#
# usage: follower_restart_test.sh BIN_DIR LOG PROFILE DOMAIN [SCANS] [RATE]
set -euo pipefail
bin=$1 log=$2 profile=$3 domain=$4 scans=${5:-700} rate=${6:-5}
source "$(dirname "$0")/../integration/common.sh" follower-restart
common=(--domain "$domain" --profile "$profile")
json() { python3 -c "import json, sys; d = json.load(open(sys.argv[1])); print(eval(sys.argv[2]))" "$@"; }

"$bin/esfleet-leader" --log "$log" --odometry on --max-scans "$scans" --seed 7 --rate "$rate" \
  "${common[@]}" --out "$work/leader" --linger 100 >"$work/leader.log" 2>&1 &
pid_leader=$!
pids+=("$pid_leader")
follower() {  # follower NAME EXTRA...: runs in the background, pid in $pid_f
  "$bin/esfleet-follower" "${common[@]}" --save-map "$work/$1" --leader-timeout 0 "${@:2}" \
    >"$work/$1.log" 2>&1 &
  pid_f=$!
  pids+=("$pid_f")
}
follower f1 --timeout 100
# Mid-run: once tiles flow, SIGKILL, restart at once.
for _ in $(seq 1 300); do
  grep -q "scan $((scans / 20 * 6))/" "$work/leader.log" && break
  sleep 0.1
done
kill -KILL "$pid_f"
wait "$pid_f" 2>/dev/null || true
t0=$(date +%s%N)
follower f2 --exit-when-complete --timeout 100
# SIGUSR1 before the follower installed its handler would kill it (seen on a loaded machine,
# 0.2 s after the start): wait for the line it logs after installing its handlers.
for _ in $(seq 1 100); do
  grep -q "following map" "$work/f2.log" 2>/dev/null && break
  sleep 0.1
done
grep -q "following map" "$work/f2.log" || fail "restarted follower did not start: $(tail -3 "$work/f2.log")"
for _ in $(seq 1 50); do  # SIGUSR1 saves its map and stats: poll until it has tiles
  sleep 0.2
  kill -USR1 "$pid_f"
  sleep 0.1
  [ -s "$work/f2/stats.json" ] && [ "$(json "$work/f2/stats.json" "d['tiles']")" -gt 0 ] && break
done
first_tile=$(json "$work/f2/stats.json" "d['first_tile_s']")
tiles_then=$(json "$work/f2/stats.json" "d['tiles']")
echo "restarted mid-run: first tile after $first_tile s, $tiles_then tiles at once"
wait_for "$pid_f" 100 "restarted follower"
cmp -s "$work/leader/map.digest" "$work/f2/map.digest" ||
  fail "restarted follower's map differs: $(diff "$work/leader/map.digest" "$work/f2/map.digest" | head -5)"

# After the map is complete: kill a running follower, restart it, time to the full map.
follower f3 --timeout 60
sleep 2
kill -KILL "$pid_f"
wait "$pid_f" 2>/dev/null || true
follower f4 --exit-when-complete --timeout 60
wait_for "$pid_f" 60 "late-joining follower"
cmp -s "$work/leader/map.digest" "$work/f4/map.digest" || fail "late joiner's map differs"
kill -INT "$pid_leader"
wait "$pid_leader" || fail "leader exited with $? on SIGINT"
echo "OK: $(wc -l <"$work/leader/map.digest") tiles;" \
  "restarted mid-run: complete $(json "$work/f2/stats.json" "round(d['time_to_complete_s'], 2)") s after restart (map final then);" \
  "restarted after the end: full map after $(json "$work/f4/stats.json" "round(d['time_to_complete_s'], 2)") s," \
  "$(json "$work/f4/stats.json" "d['bytes_received']") bytes"
