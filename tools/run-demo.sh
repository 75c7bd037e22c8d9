#!/usr/bin/env bash
# The main job on bundled data:
#  1. build; map the MIT CSAIL log with the leader (offline, with odometry), write the map and
#     trajectory to out/csail, and score it against the relations;
#  2. share a map over DDS on this host (UDP on 127.0.0.1): a leader maps the first 1000 scans and
#     publishes them as tiles; a follower robot that has never seen the place receives the map
#     and finds its own pose in it from its scans 600-1000 (no hint), then tracks itself. Its
#     map must equal the leader's counter for counter;
#  3. a simulated fleet (esfleet-fleet): the leader maps the log again and shares the map, the
#     simulator drives 4 robots through the log's world at 5 Hz, and 4 followers localise from
#     their simulated scans with no hint and track; live status against the simulator's truth,
#     summary in out/csail/fleet/summary.json.
set -euo pipefail
cd "$(dirname "$0")/.."
# Only the programs the demo runs (the test suite is built by tools/run-tests.sh).
tools/build.sh esfleet-leader esfleet-eval esfleet-follower esfleet-fleet esfleet-sim esfleet-view
out=${1:-out/csail}
log=data/mit-csail/mit-csail.clf.gz
build/bin/esfleet-leader --offline --log "$log" --odometry on --out "$out"
build/bin/esfleet-eval --trajectory "$out/trajectory.txt" --relations data/mit-csail/mit-csail.relations
echo "map: $out/map.png (ROS map_server files: $out/map.yaml, $out/map.pgm)"

echo
echo "== map sharing: leader and follower over DDS (domain ${ESFLEET_DEMO_DOMAIN:-77}) =="
# UDP on the loopback, not shared memory: a program killed here (Ctrl-C twice, kill -9) does
# not cut later ones off (docs/faults.md, "Shared memory and killed processes").
dds=(--domain "${ESFLEET_DEMO_DOMAIN:-77}" --profile deploy/fastdds/localhost-udp.xml)
build/bin/esfleet-leader --log "$log" --odometry on --max-scans 1000 "${dds[@]}" \
  --out "$out/shared/leader" --linger 120 >"$out/leader.log" 2>&1 &
leader=$!
trap 'kill -INT $leader 2>/dev/null || true' EXIT
build/bin/esfleet-follower "${dds[@]}" --log "$log" --odometry on --first-scan 600 \
  --max-scans 1000 --rate 0 --wait-complete --robot-id follower-1 \
  --save-map "$out/shared/follower-1" --trajectory "$out/shared/follower-1/trajectory.txt" \
  --timeout 120 2>&1 | grep -E "map complete|localised|lost|scans ended|saved|error"
kill -INT $leader
wait $leader || true
trap - EXIT
if cmp -s "$out/shared/leader/map.digest" "$out/shared/follower-1/map.digest"; then
  echo "follower-1's map equals the leader's ($(wc -l <"$out/shared/leader/map.digest") tiles," \
    "every counter); its track: $out/shared/follower-1/map.png"
else
  echo "follower-1's map differs from the leader's" >&2
  exit 1
fi

echo
echo "== a simulated fleet: leader, simulator, 4 followers (domain ${ESFLEET_DEMO_FLEET_DOMAIN:-76}, 90 s) =="
# With a browser view on ESFLEET_DEMO_VIEW_PORT (default 8080; 0 = none): open the address.
view_port=${ESFLEET_DEMO_VIEW_PORT:-8080}
view=()
if [ "$view_port" != 0 ]; then
  view=(--view "$view_port")
  echo "watch it live in a browser: http://localhost:$view_port/ (or http://$(hostname):$view_port/" \
    "from another machine on this network; ESFLEET_DEMO_VIEW_PORT=0 turns the view off)"
fi
build/bin/esfleet-fleet --robots 4 --duration 90 --domain "${ESFLEET_DEMO_FLEET_DOMAIN:-76}" \
  --out "$out/fleet" "${view[@]}"

robots=$(ls -d "$out"/fleet/robot-*/ 2>/dev/null | wc -l)
cat <<RECAP

== what the demo produced ==
- $out/map.png: the leader's offline map of the whole log with its trajectory (start green,
  end blue); map.pgm + map.yaml for ROS map_server, nav2 and RViz; trajectory.txt (t x y theta
  per scan) and stats.json (the run's figures)
- $out/shared/leader/: the map a leader shared over DDS (the first 1000 scans)
- $out/shared/follower-1/: what follower-1 received (its map.digest equals the leader's) and,
  in map.png and trajectory.txt, its own track
- $out/fleet/summary.json: the simulated fleet, per robot the time to localise, the error
  against the simulator's truth, CPU and memory
- $out/fleet/robot-1/ .. robot-$robots/: each robot's copy of the map with its track (map.png)
- $out/fleet/*.log: every program's log (view.log: esfleet-view, the browser view)
RECAP

