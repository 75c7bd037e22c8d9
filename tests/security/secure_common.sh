# Shared part of the security test scripts (sourced after tests/integration/common.sh):
#   make_certs DIR ID...      fleet certificates with deploy/security/make-fleet-certs.sh
#   start_leader NAME ARGS... a secure or plain leader in the background ($work/NAME.log)
#   wait_log_ended NAME       waits until that leader has published its final map
#   check_same_map A B        fails unless $work/A/map.digest == $work/B/map.digest
# Needs: $bin, $log, $src (source tree), $max_scans, common=(--domain .. --profile ..).
make_certs() {
  local dir=$1
  shift
  "$src/deploy/security/make-fleet-certs.sh" "$dir" "$@" >"$work/certs-$(basename "$dir").log" 2>&1 ||
    fail "make-fleet-certs.sh $dir $* failed"
}
start_leader() {
  local name=$1
  shift
  "$bin/esfleet-leader" --log "$log" --odometry on --max-scans "$max_scans" --seed 7 \
    "${common[@]}" --out "$work/$name" --linger 120 "$@" >"$work/$name.log" 2>&1 &
  leader_pid=$!
  pids+=("$leader_pid")
}
wait_log_ended() {
  for _ in $(seq 1 1200); do
    grep -q "log ended" "$work/$1.log" && return 0
    kill -0 "$leader_pid" 2>/dev/null || fail "leader $1 exited early"
    sleep 0.1
  done
  fail "leader $1 did not finish the log in 120 s"
}
check_same_map() {
  [ -s "$work/$2/map.digest" ] || fail "$2 saved no map digest"
  cmp -s "$work/$1/map.digest" "$work/$2/map.digest" ||
    fail "$2's map differs from $1's: $(diff "$work/$1/map.digest" "$work/$2/map.digest" | head -5)"
  grep -q '"complete": true' "$work/$2/stats.json" || fail "$2 did not report complete"
  grep -q '"tiles_rejected": 0' "$work/$2/stats.json" || fail "$2 rejected tiles"
}
