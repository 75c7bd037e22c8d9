#!/usr/bin/env bash
# How many simulated followers this host runs in real time: for each N, esfleet-fleet starts
# the leader (maps the bundled CSAIL log), waits for its map (--wait-map), starts the simulator
# with N robots at 5 Hz and N followers, and stops once all of them have tracked for WINDOW
# seconds (or after TIMEOUT seconds). One summary JSON per N in OUT_DIR; a table on stdout and
# in OUT_DIR/scale.md.
#
# usage: bench/fleet_scale.sh OUT_DIR "N1 N2 ..." [WINDOW_S] [TIMEOUT_S] [DOMAIN]
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:?usage: fleet_scale.sh OUT_DIR "N1 N2 ..." [WINDOW_S] [TIMEOUT_S] [DOMAIN]}
counts=${2:?list of robot counts}
window=${3:-60} timeout=${4:-400} domain=${5:-79}
mkdir -p "$out"
for n in $counts; do
  echo "== $n robots =="
  build/bin/esfleet-fleet --robots "$n" --wait-map --window "$window" --duration "$timeout" \
    --domain "$domain" --out "$out/run-$n" --summary "$out/summary-$n.json" --live false \
    >"$out/fleet-$n.log" 2>&1 || echo "esfleet-fleet exited with $? (see $out/fleet-$n.log)"
  tail -n 1 "$out/fleet-$n.log"
done
python3 - "$out" $counts <<'PY'
import json, statistics, sys
out, counts = sys.argv[1], sys.argv[2:]
rows = ["| robots | localised | wrong | real time | all tracking after (s) | time to localise median / max (s) "
        "| scans processed in window, worst | lag p95 worst (ms) | tracking error median / p95 worst (m) "
        "| follower CPU % in window, median | follower RSS MB, median | leader / sim CPU % |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|"]
for n in counts:
    s = json.load(open(f"{out}/summary-{n}.json"))
    f = s["followers"]
    loc = [x["time_to_localise_s"] for x in f if x["localised"]]
    rows.append(
        f"| {n} | {s['localised']} | {s['robots_with_wrong_pose']} | {s['realtime']} "
        f"| {s['all_tracking_s']:.1f} "
        f"| {statistics.median(loc) if loc else -1:.1f} / {max(loc) if loc else -1:.1f} "
        f"| {min(x['window_processed'] for x in f):.3f} "
        f"| {max(x['tracking_lag_ms_p95'] for x in f):.0f} "
        f"| {statistics.median(x['tracking_error_m_median'] for x in f):.3f} / "
        f"{max(x['tracking_error_m_p95'] for x in f):.3f} "
        f"| {statistics.median(x['cpu_percent_window'] for x in f):.1f} "
        f"| {statistics.median(x['rss_mb_max'] for x in f):.0f} "
        f"| {s['leader']['cpu_percent_window']:.1f} / {s['sim']['cpu_percent_window']:.1f} |")
open(f"{out}/scale.md", "w").write("\n".join(rows) + "\n")
print("\n".join(rows))
PY
