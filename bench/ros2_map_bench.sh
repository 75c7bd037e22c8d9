#!/usr/bin/env bash
# What the ROS 2 map outputs cost and how fast a ROS reader gets the map, with real processes on
# this host (docs/results.md, "ROS 2"):
#  1. a leader maps a whole log as fast as it can with --ros and no reader: stats.json "ros"
#     gives the bytes of /map + /map_updates per log second against republishing the whole
#     OccupancyGrid at every publish, and the CPU of the ROS outputs against the SLAM's;
#  2. the same leader then serves the complete map; RUNS times, a Cyclone DDS reader
#     (esfleet-ros2-peer map-reader, an independent DDS implementation) joins and waits for
#     its first /map: the time from its start to the whole map, median and range.
# Prints the figures and writes them as one JSON object (also the last line of stdout).
#
# usage: bench/ros2_map_bench.sh LOG [OUTPUT_JSON] [DOMAIN] [RUNS] [-- leader flags...]
#   e.g. bench/ros2_map_bench.sh data/mit-csail/mit-csail.clf.gz ros2-csail.json 61 5
set -euo pipefail
cd "$(dirname "$0")/.."
log=$1
out=${2:-esfleet-bench-ros2.json}
domain=${3:-61}
runs=${4:-5}
shift $(($# < 4 ? $# : 4))
[ "${1:-}" = "--" ] && shift
bin=build/bin
[ -x "$bin/esfleet-ros2-peer" ] || {
  echo "needs build/bin/esfleet-ros2-peer (Cyclone DDS: tools/install-deps.sh, then build)" >&2
  exit 2
}
work=$(mktemp -d "${TMPDIR:-/tmp}/esfleet-bench-ros2.XXXXXX")
trap 'kill -INT $(jobs -p) 2>/dev/null || true; rm -rf "$work"' EXIT

"$bin/esfleet-leader" --log "$log" --ros --domain "$domain" --linger 600 --out "$work/leader" \
  "$@" >"$work/leader.log" 2>&1 &
echo "mapping $log with --ros on DDS domain $domain ..." >&2
until grep -qs "map complete" "$work/leader.log"; do
  kill -0 %1 2>/dev/null || { tail "$work/leader.log" >&2; exit 1; }
  sleep 0.5
done
sleep 1
joins=()
for i in $(seq 1 "$runs"); do
  "$bin/esfleet-ros2-peer" map-reader --domain "$domain" --out "$work/peer$i" --until-maps 1 \
    --timeout 60 >"$work/peer$i.log" 2>&1
  joins+=("$(grep -o '"first_map_after_s": *[0-9.]*' "$work/peer$i.last.json" | sed 's/.*: *//')")
done
python3 - "$log" "$work/leader/stats.json" "$out" "${joins[@]}" <<'PY'
import json, statistics, sys
log, stats_path, out = sys.argv[1:4]
joins = [float(v) for v in sys.argv[4:]]
s = json.load(open(stats_path))
r = s["ros"]
sent = r["map_bytes"] + r["update_bytes"]
result = {
    "log": log,
    "scans": s["scans"],
    "ros_map_period_s": r["map_period_s"],
    "map_messages": r["maps"],
    "maps_because_grown": r["maps_because_grown"],
    "update_messages": r["updates"],
    "bytes_map": r["map_bytes"],
    "bytes_updates": r["update_bytes"],
    "bytes_per_log_s": r["bytes_per_log_s"],
    "whole_map_every_publish_bytes": r["whole_map_every_publish_bytes"],
    "whole_over_sent": r["whole_map_every_publish_bytes"] / sent if sent else 0,
    "ros_cpu_s": r["cpu_s"] + r["pose_cpu_s"],
    "ros_cpu_share_of_slam": r["cpu_share_of_slam"],
    "join_to_map_s_median": statistics.median(joins),
    "join_to_map_s_min": min(joins),
    "join_to_map_s_max": max(joins),
    "join_runs": len(joins),
}
print(f"{log}: /map + /map_updates {sent / 1e3:.0f} kB, {result['bytes_per_log_s'] / 1e3:.1f} kB "
      f"per log second; a whole /map at every publish: {r['whole_map_every_publish_bytes'] / 1e3:.0f}"
      f" kB ({result['whole_over_sent']:.1f}x more); ROS outputs {result['ros_cpu_s']:.2f} s CPU "
      f"= {100 * result['ros_cpu_share_of_slam']:.1f} % of the SLAM's; a Cyclone reader joining "
      f"had the whole map after {result['join_to_map_s_median']:.2f} s (median of {len(joins)}, "
      f"{min(joins):.2f}-{max(joins):.2f})", file=sys.stderr)
with open(out, "w") as f:
    json.dump(result, f, indent=2)
print(json.dumps(result))
PY
