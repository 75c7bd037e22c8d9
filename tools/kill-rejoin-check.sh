#!/usr/bin/env bash
# Does a follower that joins after another one was SIGKILLed still get the map? Over Fast DDS
# 2.9 shared memory it often does not (docs/faults.md, "Shared memory and killed processes").
#
# A leader maps SCANS (default 200) scans of the CSAIL log and serves the map; then ROUNDS
# (default 20) times: follower A starts, is SIGKILLed after 2 s, follower B starts with
# --exit-when-complete --timeout 15.
# Prints one line per round (B's exit code, seconds to the whole map) and the failures.
#
# usage: tools/kill-rejoin-check.sh BIN_DIR PROFILE DOMAIN [ROUNDS] [SCANS]
#   e.g. tools/kill-rejoin-check.sh build/bin deploy/fastdds/localhost-shm.xml 201 20
set -uo pipefail
[ $# -ge 3 ] || { sed -n 2,11p "$0" >&2; exit 2; }
bin=$1 profile=$2 domain=$3 rounds=${4:-20} scans=${5:-200}
root=$(cd "$(dirname "$0")/.." && pwd)
work=$(mktemp -d /tmp/esfleet-kill-rejoin.XXXXXX)
dds=(--domain "$domain" --profile "$profile")
"$bin/esfleet-leader" --log "$root/data/mit-csail/mit-csail.clf.gz" --odometry on \
  --max-scans "$scans" --seed 7 "${dds[@]}" --out "$work/leader" --linger 900 \
  >"$work/leader.log" 2>&1 &
leader=$!
trap 'kill -INT $leader 2>/dev/null; wait $leader 2>/dev/null' EXIT
for _ in $(seq 1 600); do
  grep -q "serving it" "$work/leader.log" && break
  if ! kill -0 $leader 2>/dev/null; then
    echo "leader failed: $(tail -3 "$work/leader.log")" >&2
    exit 1
  fi
  sleep 0.1
done
failures=0
for round in $(seq 1 "$rounds"); do
  "$bin/esfleet-follower" "${dds[@]}" --leader-timeout 0 --timeout 60 >"$work/a.log" 2>&1 &
  a=$!
  sleep 2
  kill -KILL $a
  wait $a 2>/dev/null
  t0=$(date +%s%N)
  "$bin/esfleet-follower" "${dds[@]}" --save-map "$work/b" --leader-timeout 0 \
    --exit-when-complete --timeout 15 >"$work/b.log" 2>&1
  rc=$?
  t1=$(date +%s%N)
  echo "round $round: exit $rc after $(((t1 - t0) / 1000000)) ms"
  if [ $rc -ne 0 ]; then
    failures=$((failures + 1))
    cp "$work/b.log" "$work/failed-$round.log"
  fi
done
echo "$failures of $rounds late joiners got no map (logs in $work)"
