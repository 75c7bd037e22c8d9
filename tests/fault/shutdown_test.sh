#!/usr/bin/env bash
# Clean shutdown: each program is stopped with SIGINT and with SIGTERM while it works, over the
# shared-memory profile. It must exit with its documented status, write its outputs, and leave
# nothing in /dev/shm: every /dev/shm file any of our processes had mapped or open (read from
# /proc/PID/maps and /proc/PID/fd while they ran, so files of tests running in parallel are not
# counted) must be gone once they have exited.
#   leader    esfleet-leader --log, stopped while mapping: exit 130, map + stats + checkpoint
#   follower  esfleet-follower --log tracking in a leader's map: exit 0, map + stats +
#             trajectory saved "because signal"
#   replay    esfleet-replay publishing to a leader --scan-topic: exit 130
#   sim       esfleet-sim with --out-log, 2 robots: exit 130, logs written
#   fleet     esfleet-fleet (leader, sim, 1 follower): exit 0 or 1 (a robot that had no time
#             to localise is a failure in its summary), summary.json written, children gone
#
# usage: shutdown_test.sh BIN_DIR SOURCE_DIR PROFILE DOMAIN PROGRAM...
set -euo pipefail
bin=$1 src=$2 profile=$3 domain=$4
shift 4
programs=("$@")
source "$(dirname "$0")/../integration/common.sh" shutdown
log=$src/data/mit-csail/mit-csail.clf.gz
world=$src/data/worlds/mit-csail/map.yaml
common=(--domain "$domain" --profile "$profile")

declare -A shm_seen=()
# note_shm PID...: records the /dev/shm files the processes (and their children) map or hold open.
note_shm() {
  local p c f
  for p in "$@"; do
    for c in $p $(ps -o pid= --ppid "$p" 2>/dev/null); do
      while read -r f; do
        [ -n "$f" ] && shm_seen[$f]=1
      done < <({ awk '$6 ~ /^\/dev\/shm\// {print $6}' "/proc/$c/maps" 2>/dev/null
        find "/proc/$c/fd" -maxdepth 1 -lname '/dev/shm/*' -printf '%l\n' 2>/dev/null; } | sort -u)
    done
  done
}
# run_until PID PATTERN FILE SECONDS: waits for PATTERN in FILE, noting /dev/shm use meanwhile.
run_until() {
  for _ in $(seq 1 $(($4 * 10))); do
    note_shm "$1"
    grep -q "$2" "$3" && return 0
    kill -0 "$1" 2>/dev/null || fail "$(basename "$3" .log) exited before '$2'"
    sleep 0.1
  done
  fail "no '$2' in $(basename "$3") after $4 s"
}
# stop PID SIGNAL WHAT EXPECTED...: sends the signal, waits (15 s) and checks the exit status.
stop() {
  local pid=$1 sig=$2 what=$3 rc=0
  shift 3
  note_shm "$pid"
  local t0
  t0=$(date +%s%N)
  kill -s "$sig" "$pid"
  for _ in $(seq 1 150); do
    kill -0 "$pid" 2>/dev/null || break
    sleep 0.1
  done
  kill -0 "$pid" 2>/dev/null && fail "$what still running 15 s after $sig"
  wait "$pid" || rc=$?
  local ok=0 e
  for e in "$@"; do [ "$rc" = "$e" ] && ok=1; done
  [ $ok = 1 ] || fail "$what exited with $rc on $sig (expected $*)"
  echo "  $what: $sig -> exit $rc after $((($(date +%s%N) - t0) / 1000000)) ms"
}
need() { for f in "$@"; do [ -s "$f" ] || fail "missing output $f"; done; }
check_shm() {  # every /dev/shm file our processes used is gone
  local left=() f
  for f in "${!shm_seen[@]}"; do [ -e "$f" ] && left+=("$f"); done
  [ ${#left[@]} = 0 ] || fail "$1: left in /dev/shm: ${left[*]}"
  echo "  $1: ${#shm_seen[@]} /dev/shm files used, none left"
}

leader_run() {  # leader_run DIR EXTRA...: a leader mapping the log at 5x, in the background
  local dir=$1
  shift
  "$bin/esfleet-leader" --log "$log" --odometry on --max-scans 1500 --rate 5 "${common[@]}" \
    --out "$dir" --linger 60 "$@" >"$dir.log" 2>&1 &
  pids+=($!)
}

for prog in "${programs[@]}"; do
  for sig in INT TERM; do
    shm_seen=()
    d=$work/$prog-$sig
    case $prog in
      leader)
        leader_run "$d"
        p=${pids[-1]}
        run_until "$p" "scan 150/" "$d.log" 60
        stop "$p" "$sig" "esfleet-leader" 130
        need "$d/map.digest" "$d/stats.json" "$d/map.pgm" "$d/trajectory.txt" \
          "$d/checkpoint/manifest.json"
        grep -q "interrupted" "$d.log" || fail "leader did not report the interruption"
        ;;
      follower)
        leader_run "$d-leader"
        pl=${pids[-1]}
        run_until "$pl" "scan 150/" "$d-leader.log" 60
        "$bin/esfleet-follower" "${common[@]}" --log "$log" --odometry on --first-scan 20 \
          --max-scans 1500 --rate 5 --save-map "$d" --trajectory "$d/trajectory.txt" \
          >"$d.log" 2>&1 &
        pids+=($!)
        pf=${pids[-1]}
        run_until "$pf" "localised at" "$d.log" 40
        sleep 1
        stop "$pf" "$sig" "esfleet-follower" 0
        need "$d/map.digest" "$d/stats.json" "$d/trajectory.txt" "$d/map.pgm"
        grep -q '"saved_because": "signal"' "$d/stats.json" || fail "follower stats not saved on $sig"
        stop "$pl" "$sig" "its leader" 130
        ;;
      replay)
        "$bin/esfleet-leader" --scan-topic r1 --odometry on "${common[@]}" --out "$d-leader" \
          >"$d-leader.log" 2>&1 &
        pids+=($!)
        ;;
      sim)
        "$bin/esfleet-sim" --world "$world" --robots 2 --seed 1 "${common[@]}" \
          --wait-subscribers 0 --out-log "$d" >"$d.log" 2>&1 &
        pids+=($!)
        p=${pids[-1]}
        for _ in $(seq 1 30); do note_shm "$p"; sleep 0.1; done
        kill -0 "$p" 2>/dev/null || fail "esfleet-sim exited early: $(tail -3 "$d.log")"
        stop "$p" "$sig" "esfleet-sim" 130
        need "$d/robot-1.log" "$d/robot-2.log"
        ;;
      fleet)
        "$bin/esfleet-fleet" --robots 1 "${common[@]}" --out "$d" --live false \
          --bin-dir "$bin" --world "$world" --log "$log" >"$d.log" 2>&1 &
        pids+=($!)
        p=${pids[-1]}
        for _ in $(seq 1 80); do note_shm "$p"; sleep 0.1; done
        kill -0 "$p" 2>/dev/null || fail "esfleet-fleet exited early"
        stop "$p" "$sig" "esfleet-fleet" 0 1
        need "$d/summary.json"
        ;;
    esac
    if [ "$prog" = replay ]; then
      # The replay publishes to a leader mapping its scans; stopped mid-log.
      pl=${pids[-1]}
      run_until "$pl" "mapping the scans" "$d-leader.log" 30
      "$bin/esfleet-replay" --log "$log" --robot-id r1 --rate 5 "${common[@]}" >"$d.log" 2>&1 &
      pids+=($!)
      p=${pids[-1]}
      for _ in $(seq 1 40); do note_shm "$p" "$pl"; sleep 0.1; done
      kill -0 "$p" 2>/dev/null || fail "esfleet-replay exited early"
      stop "$p" "$sig" "esfleet-replay" 130
      stop "$pl" "$sig" "its leader (--scan-topic)" 130
      need "$d-leader/map.digest" "$d-leader/stats.json"
    fi
    sleep 0.5
    check_shm "$prog $sig"
  done
done
echo "OK: ${programs[*]}: clean exits on SIGINT and SIGTERM, outputs written, /dev/shm clean"
