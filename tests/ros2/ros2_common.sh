# Shared steps of the ROS 2 interop scripts (sourced after ../integration/common.sh): a leader
# that maps the first scans of a log and serves the complete map, and Cyclone DDS scan writers.

# start_leader LOG DOMAIN MAX_SCANS: maps the log's first MAX_SCANS scans as fast as it can,
# then serves the map (with --ros) until stopped; waits until the map is complete.
start_leader() {
  "$bin/esfleet-leader" --log "$1" --max-scans "$3" --ros --linger 600 --domain "$2" --seed 3 \
    --checkpoint-every 0 --out "$work/leader" >"$work/leader.log" 2>&1 &
  pid_leader=$!
  pids+=("$pid_leader")
  for _ in $(seq 1 600); do
    grep -q "map complete" "$work/leader.log" && return 0
    kill -0 "$pid_leader" 2>/dev/null || fail "leader exited early"
    sleep 0.1
  done
  fail "the leader did not complete its map in 60 s"
}

# cyclone_scans NAME DOMAIN NS MAX_SCANS [extra scan-writer flags]: publishes the log's first
# MAX_SCANS scans as robot NS's LaserScan (frame NS/laser) at 10 scans per second, in the
# background ($work/NAME.log).
cyclone_scans() {
  local name=$1 domain=$2 ns=$3 n=$4
  shift 4
  "$bin/esfleet-ros2-peer" scan-writer --domain "$domain" --log "$work/log.txt" --max-scans "$n" \
    --rate 10 --scan-topic "rt/$ns/scan" --frame "$ns/laser" --wait-timeout 60 "$@" \
    >"$work/$name.log" 2>&1 &
  pids+=("$!")
}

# json_number FILE KEY: the first number after "KEY": in FILE.
json_number() {
  grep -o "\"$2\": *[-0-9.e]*" "$1" | head -n 1 | sed 's/.*: *//'
}
