#!/usr/bin/env bash
# The main job on bundled data: build, map the MIT CSAIL log with the leader (offline, with
# odometry), write the map and trajectory to out/csail, and score it against the relations.
set -euo pipefail
cd "$(dirname "$0")/.."
tools/build.sh
out=${1:-out/csail}
build/bin/esfleet-leader --offline --log data/mit-csail/mit-csail.clf.gz --odometry on --out "$out"
build/bin/esfleet-eval --trajectory "$out/trajectory.txt" --relations data/mit-csail/mit-csail.relations
echo "map: $out/map.png (ROS map_server files: $out/map.yaml, $out/map.pgm)"
