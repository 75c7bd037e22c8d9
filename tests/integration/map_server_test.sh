#!/usr/bin/env bash
# The map server (esfleet-leader --map) with real processes. An --offline leader maps the first
# MAX_SCANS scans of a log (checkpoint, map.yaml, map.digest); then
#   1. a leader serves that checkpoint (given as its --out directory, with --ros): follower f1
#      (no scans, --exit-when-complete) must end with exactly the checkpoint's counters
#      (map.digest); follower a localises its own scans (the same log from FIRST_SCAN) in the
#      served map and must declare a pose; the server's stats.json says what it served;
#   2. a leader serves the map.yaml instead: follower f2, started after the first publish, must
#      end with the server's counters and its saved map.pgm must show the same occupied / free /
#      unknown cells as the served map.pgm, cell for cell;
#   3. --map with a mapping input, or a missing PATH, is a usage error (exit 2) naming them.
#
# usage: map_server_test.sh BIN_DIR LOG PROFILE DOMAIN [MAX_SCANS] [FIRST_SCAN]
set -euo pipefail
bin=$1 log=$2 profile=$3 domain=$4 max_scans=${5:-300} first=${6:-150}
source "$(dirname "$0")/common.sh" map-server

common=(--domain "$domain" --profile "$profile")
scans=(--log "$log" --odometry on --max-scans "$max_scans")

# 3. Usage errors, before any DDS participant.
rc=0
"$bin/esfleet-leader" --map "$work/live" --log "$log" --offline >"$work/usage.log" 2>&1 || rc=$?
[ "$rc" = 2 ] || fail "--map with --log and --offline exited with $rc, not 2"
grep -q "excludes --log, --scan-topic, --ros-scan, --resume and --offline (given: --log, --offline)" \
  "$work/usage.log" || fail "--map with --log: no message naming the flags"
rc=0
"$bin/esfleet-leader" --map "$work/nothing.yaml" --out "$work/x" >"$work/usage.log" 2>&1 || rc=$?
[ "$rc" = 2 ] || fail "--map with a missing file exited with $rc, not 2"
grep -q -- "--map $work/nothing.yaml: no such file or directory" "$work/usage.log" ||
  fail "--map with a missing file: no message naming it"

# The map to serve.
"$bin/esfleet-leader" "${scans[@]}" --seed 7 --offline --out "$work/live" \
  >"$work/live.log" 2>&1 || fail "offline leader failed"
[ -s "$work/live/checkpoint/manifest.json" ] || fail "the offline leader wrote no checkpoint"

# stop_server PID NAME: SIGINT, and the server must exit 0.
stop_server() {
  kill -INT "$1"
  local rc=0
  wait "$1" || rc=$?
  [ "$rc" = 0 ] || fail "$2 exited with $rc on SIGINT"
}

# 1. The checkpoint.
t0=$(date +%s.%N)
"$bin/esfleet-leader" --map "$work/live" --linger 30 --ros --ros-map-period 1 "${common[@]}" \
  --out "$work/served-checkpoint" >"$work/server-checkpoint.log" 2>&1 &
pid_server=$!
pids+=("$pid_server")
"$bin/esfleet-follower" "${common[@]}" --save-map "$work/f1" --exit-when-complete --timeout 30 \
  >"$work/f1.log" 2>&1 &
pid_f1=$!
pids+=("$pid_f1")
"$bin/esfleet-follower" "${common[@]}" "${scans[@]}" --first-scan "$first" --rate 0 \
  --wait-complete --robot-id a --seed 1 --save-map "$work/a" --timeout 40 \
  >"$work/a.log" 2>&1 &
pid_a=$!
pids+=("$pid_a")
wait_for "$pid_f1" 30 "follower f1"
t1=$(date +%s.%N)
wait_for "$pid_a" 40 "follower a"
stop_server "$pid_server" "checkpoint server"

cmp -s "$work/live/map.digest" "$work/f1/map.digest" ||
  fail "follower f1's map differs from the checkpoint's: $(diff "$work/live/map.digest" "$work/f1/map.digest" | head -5)"
cmp -s "$work/live/map.digest" "$work/served-checkpoint/map.digest" ||
  fail "the server's map.digest differs from the checkpoint's"
grep -q '"complete": true' "$work/f1/stats.json" || fail "follower f1 did not report complete"

# 2. The ROS map YAML.
"$bin/esfleet-leader" --map "$work/live/map.yaml" --linger 30 "${common[@]}" \
  --out "$work/served-yaml" >"$work/server-yaml.log" 2>&1 &
pid_server=$!
pids+=("$pid_server")
# f2 joins late, after the first publish: the tiles come from the transient-local history.
for _ in $(seq 1 100); do
  grep -q "published map" "$work/server-yaml.log" && break
  kill -0 "$pid_server" 2>/dev/null || fail "yaml server exited early"
  sleep 0.1
done
"$bin/esfleet-follower" "${common[@]}" --save-map "$work/f2" --exit-when-complete --timeout 30 \
  >"$work/f2.log" 2>&1 &
pid_f2=$!
pids+=("$pid_f2")
wait_for "$pid_f2" 30 "follower f2"
stop_server "$pid_server" "yaml server"
cmp -s "$work/served-yaml/map.digest" "$work/f2/map.digest" ||
  fail "follower f2's map differs from the yaml server's"

python3 - "$work" "$t0" "$t1" <<'PY' || fail "map server check"
import json, sys

work, t0, t1 = sys.argv[1], float(sys.argv[2]), float(sys.argv[3])


def load(yaml_path):
    """The cells of a map_server map (mode trinary, negate 0) as {(x, y): class}."""
    meta = {}
    for line in open(yaml_path):
        if ":" in line:
            k, v = line.split(":", 1)
            meta[k.strip()] = v.strip()
    res = float(meta["resolution"])
    ox, oy = (float(v) for v in meta["origin"].strip("[]").split(",")[:2])
    occ_t, free_t = float(meta["occupied_thresh"]), float(meta["free_thresh"])
    data = open(yaml_path.rsplit("/", 1)[0] + "/" + meta["image"], "rb").read()
    fields, pos = [], 0
    while len(fields) < 4:  # P5 width height maxval, whitespace separated
        while data[pos:pos + 1].isspace():
            pos += 1
        start = pos
        while not data[pos:pos + 1].isspace():
            pos += 1
        fields.append(data[start:pos])
    assert fields[0] == b"P5" and fields[3] == b"255", fields
    w, h = int(fields[1]), int(fields[2])
    pixels = data[pos + 1:pos + 1 + w * h]
    x0, y0 = round(ox / res), round(oy / res)
    cells = {}
    for r in range(h):
        for c in range(w):
            occ = 1.0 - pixels[r * w + c] / 255.0
            cls = "occupied" if occ > occ_t else "free" if occ < free_t else None
            if cls:
                cells[(x0 + c, y0 + h - 1 - r)] = cls
    return res, cells


res_a, served = load(f"{work}/live/map.yaml")
res_b, got = load(f"{work}/f2/map.yaml")
ok = True
if abs(res_a - res_b) > 1e-6:  # the wire's cell size is a float (0.05 -> 0.0500000007)
    print(f"resolution {res_b} instead of {res_a}")
    ok = False
wrong = [k for k in set(served) | set(got) if served.get(k) != got.get(k)]
counts = {c: sum(1 for v in served.values() if v == c) for c in ("occupied", "free")}
print(f"yaml: {counts['occupied']} occupied and {counts['free']} free cells served; "
      f"{len(wrong)} differ in follower f2's map.pgm")
ok = ok and not wrong and counts["occupied"] > 0

stats = json.load(open(f"{work}/served-checkpoint/stats.json"))
for key, want in (("kind", "checkpoint"), ("complete", True)):
    if stats[key] != want:
        print(f"checkpoint server stats.json: {key} {stats[key]!r}, not {want!r}")
        ok = False
live = json.load(open(f"{work}/live/stats.json"))
ok = ok and stats["scans"] == live["scans"] and stats["tiles"] == live["map"]["tiles"]
ok = ok and stats["publishes"] >= 1 and stats["ros"]["maps"] >= 1
ok = ok and stats["cells"]["occupied"] == counts["occupied"]
ok = ok and stats["cells"]["free"] == counts["free"]
ystats = json.load(open(f"{work}/served-yaml/stats.json"))
ok = ok and ystats["kind"] == "ros_yaml" and ystats["scans"] == 0
ok = ok and ystats["cells"]["occupied"] == counts["occupied"]
f1 = json.load(open(f"{work}/f1/stats.json"))
print(f"checkpoint: {stats['tiles']} tiles, {stats['publishes']} publishes, "
      f"{stats['ros']['maps']} /map; follower f1 complete {f1['time_to_complete_s']:.2f} s "
      f"after it started, {t1 - t0:.2f} s from the server's start to f1's exit")
loc = json.load(open(f"{work}/a/stats.json"))["localisation"]
print(f"follower a: {loc['declarations']} declarations, state {loc['state']}, "
      f"{loc['tracked_scans']} of {loc['scans']} scans tracked")
ok = ok and loc["declarations"] >= 1
sys.exit(0 if ok else 1)
PY
echo "OK"
