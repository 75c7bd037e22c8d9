#!/usr/bin/env bash
# Does a follower that joins after another one was SIGKILLed still get the map? Over Fast DDS
# 2.9 shared memory it often does not (docs/faults.md, "Shared memory and killed processes").
#
# A leader maps SCANS (default 200) scans of the CSAIL log and serves the map; then ROUNDS
# (default 20) times: follower A starts, is SIGKILLed after 2 s, follower B starts with
# --exit-when-complete --timeout 15.
# Prints one line per round (B's exit code, seconds to the whole map) and the failures.
#
# A discovery-client profile (discovery-client.xml) gets a copy pointing at a
# fast-discovery-server on 127.0.0.1, port 11000 + DOMAIN, which the script starts and stops.
#
# usage: tools/kill-rejoin-check.sh BIN_DIR PROFILE DOMAIN [ROUNDS] [SCANS]
#   e.g. tools/kill-rejoin-check.sh build/bin deploy/fastdds/localhost-udp.xml 201 20
set -uo pipefail
[ $# -ge 3 ] || { sed -n 2,14p "$0" >&2; exit 2; }
bin=$1 profile=$2 domain=$3 rounds=${4:-20} scans=${5:-200}
root=$(cd "$(dirname "$0")/.." && pwd)
work=$(mktemp -d /tmp/esfleet-kill-rejoin.XXXXXX)
server=
if grep -q "<discoveryProtocol>CLIENT</discoveryProtocol>" "$profile"; then
  port=$((11000 + domain))
  sed -e "s|<address>[0-9.]*</address>|<address>127.0.0.1</address>|" \
    -e "s|<port>[0-9]*</port>|<port>$port</port>|" "$profile" >"$work/profile.xml"
  profile=$work/profile.xml
  fast-discovery-server -i 0 -l 127.0.0.1 -p "$port" >"$work/server.log" 2>&1 &
  server=$!
fi
dds=(--domain "$domain" --profile "$profile")
"$bin/esfleet-leader" --log "$root/data/mit-csail/mit-csail.clf.gz" --odometry on \
  --max-scans "$scans" --seed 7 "${dds[@]}" --out "$work/leader" --linger 900 \
  >"$work/leader.log" 2>&1 &
leader=$!
# The server stops on SIGINT (on SIGTERM it leaves its shared-memory files).
trap 'kill -INT $leader $server 2>/dev/null; wait $leader $server 2>/dev/null' EXIT
for _ in $(seq 1 600); do
  grep -q "serving it" "$work/leader.log" && break
  if ! kill -0 $leader 2>/dev/null; then
    echo "leader failed: $(tail -3 "$work/leader.log")" >&2
    exit 1
  fi
  sleep 0.1
done
failures=0 times=()
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
  [ $rc -eq 0 ] && times+=($(((t1 - t0) / 1000000)))
  if [ $rc -ne 0 ]; then
    failures=$((failures + 1))
    cp "$work/b.log" "$work/failed-$round.log"
  fi
done
range=$(printf '%s\n' "${times[@]}" | sort -n | sed -n '1p;$p' | paste -sd- -)
echo "$failures of $rounds late joiners got no map; the others had it in ${range:-?} ms (logs in $work)"
