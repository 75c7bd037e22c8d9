#!/usr/bin/env bash
# Map-sharing benchmark with real processes on this host: a leader maps a whole log over DDS,
# follower A listens from the start (tile latency), follower B joins after the log ended
# (late-joiner time to the full map). Prints the figures and writes them as one JSON object
# (last line of stdout too).
#
# usage: bench/map_sharing_bench.sh LOG [OUTPUT_JSON] [PROFILE] [DOMAIN] [-- leader flags...]
#   e.g. bench/map_sharing_bench.sh data/mit-csail/mit-csail.clf.gz csail.json \
#          tests/fastdds/localhost-shm.xml 60 -- --odometry on
set -euo pipefail
cd "$(dirname "$0")/.."
log=$1
out=${2:-esfleet-bench-map-sharing.json}
profile=${3:-tests/fastdds/localhost-shm.xml}
domain=${4:-60}
shift $(($# < 4 ? $# : 4))
[ "${1:-}" = "--" ] && shift
bin=build/bin
work=$(mktemp -d "${TMPDIR:-/tmp}/esfleet-bench-sharing.XXXXXX")
trap 'kill -INT $(jobs -p) 2>/dev/null || true; rm -rf "$work"' EXIT
common=(--domain "$domain" --profile "$profile")

"$bin/esfleet-follower" "${common[@]}" --save-map "$work/a" --exit-when-complete --timeout 3600 \
  >"$work/a.log" 2>&1 &
pid_a=$!
"$bin/esfleet-leader" --log "$log" "$@" "${common[@]}" --out "$work/leader" --linger 600 \
  >"$work/leader.log" 2>&1 &
pid_leader=$!
echo "mapping $log over DDS domain $domain ($profile) ..." >&2
until grep -qs "log ended" "$work/leader.log"; do
  kill -0 "$pid_leader" 2>/dev/null || { tail "$work/leader.log" >&2; exit 1; }
  sleep 0.5
done
wait "$pid_a"
start=$(date +%s%N)
"$bin/esfleet-follower" "${common[@]}" --save-map "$work/b" --exit-when-complete --timeout 120 \
  >"$work/b.log" 2>&1
late_wall=$(( ($(date +%s%N) - start) / 1000000 ))  # ms
kill -INT "$pid_leader"
wait "$pid_leader" || true

for f in a b; do
  cmp -s "$work/leader/map.digest" "$work/$f/map.digest" || { echo "follower $f map differs" >&2; exit 1; }
done
python3 - "$work" "$log" "$late_wall" "$out" <<'PY'
import json, sys
work, log, late_wall, out = sys.argv[1], sys.argv[2], float(sys.argv[3]) / 1e3, sys.argv[4]
leader = json.load(open(f"{work}/leader/stats.json"))
a = json.load(open(f"{work}/a/stats.json"))
b = json.load(open(f"{work}/b/stats.json"))
d = leader["dds"]
r = {
    "log": log,
    "scans": leader["scans"],
    "tiles": leader["map"]["tiles"],
    "publish_period_s": d["publish_period_s"],
    "log_duration_s": d["log_duration_s"],
    "bytes_total": d["bytes_total"],
    "bytes_per_log_s": d["bytes_per_log_s"],
    "full_map_bytes": d["full_map_bytes"],
    "full_map_over_tiles": d["full_map_over_tiles"],
    "tiles_published": d["tiles_published"],
    "tile_bytes": d["tile_bytes"],
    "deltas_published": d.get("deltas_published", 0),
    "delta_bytes": d.get("delta_bytes", 0),
    "tile_latency_ms_median": a["latency_ms_median"],
    "tile_latency_ms_p99": a["latency_ms_p99"],
    "late_joiner_time_to_complete_s": b["time_to_complete_s"],
    "late_joiner_process_wall_s": late_wall,
    "late_joiner_bytes": b["bytes_received"],
    "maps_identical": True,
    # Publishes the mapping thread handed over, and the changed tiles it handed over that a
    # newer copy replaced before the publisher thread sent them: a leader that maps faster than
    # it can send sends fewer, larger deltas, and the bytes then depend on timing.
    "publishes": d["publishes"],
    "tiles_handed_over": d["publisher"]["tiles_handed_over"],
    "tiles_coalesced": d["publisher"]["coalesced"],
}
print(f"{log}: {r['scans']} scans, {r['tiles']} tiles")
print(f"  sent {r['bytes_total']/1e6:.2f} MB ({r['bytes_per_log_s']/1e3:.1f} kB per log second); "
      f"whole map every {r['publish_period_s']} s would be {r['full_map_bytes']/1e6:.1f} MB "
      f"({r['full_map_over_tiles']:.1f}x more)")
print(f"  {r['tiles_published']} whole tiles ({r['tile_bytes']/1e6:.2f} MB), "
      f"{r['deltas_published']} tile deltas ({r['delta_bytes']/1e6:.2f} MB)")
print(f"  {r['publishes']} publishes handed over {r['tiles_handed_over']} changed tiles, "
      f"{r['tiles_coalesced']} of them replaced by a newer copy before being sent")
print(f"  tile latency leader publish -> follower applied: median {r['tile_latency_ms_median']:.2f} ms, "
      f"p99 {r['tile_latency_ms_p99']:.2f} ms")
print(f"  late joiner: full map after {r['late_joiner_time_to_complete_s']:.2f} s "
      f"({r['late_joiner_bytes']/1e6:.2f} MB)")
open(out, "w").write(json.dumps(r, indent=2) + "\n")
print(json.dumps(r))
PY
