#!/usr/bin/env bash
# What DDS Security costs (docs/security.md): throughput of map tiles from one process to another
# and the discovery time (writer start until the reader is matched), plain and secure, RUNS runs
# each (alternating), medians printed.
#
# usage: tests/security/security_cost.sh BIN_DIR PROFILE [RUNS] [COUNT] [BYTES] [DOMAIN]
#   e.g. tests/security/security_cost.sh build/bin tests/fastdds/localhost-shm.xml 5 5000 1024
#   (BYTES at most 1024, one tile part: protocol 3 bounds it; the figures of docs/security.md
#   were measured with 16384-byte tiles of protocol 1)
set -euo pipefail
bin=$1 profile=$2 runs=${3:-5} count=${4:-5000} bytes=${5:-1024} domain=${6:-215}
src=$(cd "$(dirname "$0")/../.." && pwd)
work=$(mktemp -d "${TMPDIR:-/tmp}/esfleet-security-cost.XXXXXX")
trap 'rm -rf "$work"' EXIT
"$src/deploy/security/make-fleet-certs.sh" "$work/certs" leader robot-1 >/dev/null
common=(--domain "$domain" --profile "$profile" --count "$count" --bytes "$bytes")

one() {  # mode -> appends "discovery tiles_per_s mb_per_s" to $work/mode.txt
  local sec_r=() sec_w=()
  if [ "$1" = secure ]; then
    sec_r=(--secure "$work/certs/robot-1")
    sec_w=(--secure "$work/certs/leader")
  fi
  "$bin/security_cost" --role reader "${common[@]}" "${sec_r[@]}" >/dev/null &
  local reader=$!
  sleep 1  # the reader is up: discovery is measured from the writer's start
  "$bin/security_cost" --role writer "${common[@]}" "${sec_w[@]}" |
    awk '{print $2, $4, $6}' >>"$work/$1.txt"
  wait "$reader" || echo "reader of a $1 run missed samples" >&2
}
for _ in $(seq 1 "$runs"); do
  one plain
  one secure
done
median() { sort -n | awk '{a[NR]=$1} END {print (NR%2) ? a[(NR+1)/2] : (a[NR/2]+a[NR/2+1])/2}'; }
printf "%-7s %14s %12s %9s   (%s, %d runs of %d tiles of %d B)\n" mode discovery_ms tiles/s MB/s \
  "$(basename "$profile")" "$runs" "$count" "$bytes"
for m in plain secure; do
  printf "%-7s %14s %12s %9s\n" "$m" "$(cut -d' ' -f1 "$work/$m.txt" | median)" \
    "$(cut -d' ' -f2 "$work/$m.txt" | median)" "$(cut -d' ' -f3 "$work/$m.txt" | median)"
done
