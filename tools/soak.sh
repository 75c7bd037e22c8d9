#!/usr/bin/env bash
# The fleet soak: a simulated fleet over the network-namespace testbed, with datagram loss and
# processes SIGKILLed on a schedule, for long enough to see leaks and rare failures.
#
#   - deploy/netns/testbed.sh: ROBOTS + 2 hosts; every host drops LOSS % of the UDP datagrams it
#     receives. esfleet-fleet --netns puts the leader on host 1, the simulator on host 2 and
#     robot k's follower on host k + 2 (the launcher runs on host 1), all with lan-udp.xml.
#   - Every LEADER_KILL seconds the leader is SIGKILLed; the launcher restarts it with --resume
#     from its checkpoint, as its systemd unit would. Every FOLLOWER_KILL seconds one follower is
#     SIGKILLed (in turn, from robot SEED mod ROBOTS + 1); the launcher restarts it.
#     No kill in the last QUIET seconds, so that the last victims can rejoin.
#   - Every 10 s the resident memory of each process goes to OUT/rss.tsv.
#
# At the end (checked, and written to OUT/soak.json):
#   - every death was one of our SIGKILLs (exit code 137): no abort, no crash;
#   - every follower's map equals the leader's (map.digest) and every robot is tracking, its
#     last error against the simulator's truth below 0.3 m (wrong poses declared on the way are
#     reported, not failed: docs/faults.md, "The soak");
#   - the memory slope of each process, MB per hour, fitted after its first 60 s (reported;
#     with --max-slope also checked for the processes that lived at least 10 minutes).
#
# usage: tools/soak.sh [--robots 16] [--minutes 30] [--loss 10] [--leader-kill 300]
#                      [--follower-kill 60] [--quiet 120] [--domain 91] [--seed 1]
#                      [--max-slope MB_PER_HOUR] [--out out/soak] BIN_DIR
# Run from the repository (the fleet's default world and log are relative paths).
# Exit 0: all checks hold; 1: a check failed; 2: bad usage; 77: no network namespaces here.
set -euo pipefail
# A command that fails out of turn ends the soak: say where, never silently.
trap 'echo "soak: ${BASH_SOURCE[0]}:$LINENO: a command failed (exit $?)" >&2' ERR

usage() { sed -n '2,/^set -euo/p' "$0" | sed -e '$d' -e 's/^# \{0,1\}//' >&2; exit 2; }
robots=16 minutes=30 loss=10 leader_kill=300 follower_kill=60 quiet=120 domain=91 seed=1
max_slope= out=out/soak
while [ $# -gt 1 ]; do
  case $1 in
    --robots) robots=$2 ;;
    --minutes) minutes=$2 ;;
    --loss) loss=$2 ;;
    --leader-kill) leader_kill=$2 ;;
    --follower-kill) follower_kill=$2 ;;
    --quiet) quiet=$2 ;;
    --domain) domain=$2 ;;
    --seed) seed=$2 ;;
    --max-slope) max_slope=$2 ;;
    --out) out=$2 ;;
    *) usage ;;
  esac
  shift 2
done
[ $# -eq 1 ] || usage
bin=$(cd "$1" && pwd)
for v in robots loss leader_kill follower_kill quiet domain seed; do
  [[ ${!v} =~ ^[0-9]+$ ]] || { echo "soak: --${v//_/-} must be a whole number" >&2; exit 2; }
done
[[ $minutes =~ ^[0-9]+([.][0-9]+)?$ ]] || { echo "soak: --minutes must be a number" >&2; exit 2; }
[ "$robots" -ge 1 ] && [ "$robots" -le 64 ] || { echo "soak: --robots must be 1-64" >&2; exit 2; }
[ "$domain" -le 232 ] || { echo "soak: --domain must be 0-232" >&2; exit 2; }
here=$(cd "$(dirname "$0")" && pwd)
testbed=$here/../deploy/netns/testbed.sh
duration=$(python3 -c "print(round($minutes * 60))")

run=soak${domain}
mkdir -p "$out"
out=$(cd "$out" && pwd)
rm -rf "$out/fleet" "$out/rss.tsv" "$out/kills.tsv"
"$testbed" down "$run" >/dev/null 2>&1 || true
rc=0
"$testbed" up "$run" $((robots + 2)) --subnet "$domain" --loss "$loss" >"$out/testbed.log" 2>&1 ||
  rc=$?
[ $rc -ne 77 ] || { cat "$out/testbed.log"; exit 77; }
[ $rc -eq 0 ] || { echo "soak: testbed up failed:" >&2; cat "$out/testbed.log" >&2; exit 1; }
fleet_pid=
cleanup() {
  [ -n "$fleet_pid" ] && kill -INT "$fleet_pid" 2>/dev/null && wait "$fleet_pid" 2>/dev/null
  "$testbed" down "$run" >/dev/null 2>&1 || true
}
trap cleanup EXIT
trap 'exit 130' INT TERM
cat "$out/testbed.log"

# Our processes, by their command lines (the domain tells this run's apart): "ROLE PID" lines.
processes() {
  local pid cmd
  for pid in $(pgrep -f -- "--domain $domain( |$)" || true); do
    cmd=$(tr '\0' ' ' 2>/dev/null <"/proc/$pid/cmdline") || continue
    case $cmd in
      *esfleet-fleet\ *) echo "fleet $pid" ;;
      *esfleet-leader\ *) echo "leader $pid" ;;
      *esfleet-sim\ *) echo "sim $pid" ;;
      *esfleet-follower\ *) echo "$(sed -E 's/.*--robot-id (robot-[0-9]+).*/\1/' <<<"$cmd") $pid" ;;
    esac
  done
}
# awk reads to the end: exiting at the first match could SIGPIPE processes, a failure under pipefail.
pid_of() { processes | awk -v r="$1" '$1 == r && !found {print $2; found = 1}'; }

"$testbed" exec "$run" 1 "$bin/esfleet-fleet" --netns "$run" --robots "$robots" \
  --duration "$duration" --domain "$domain" --profile deploy/fastdds/lan-udp.xml \
  --seed "$seed" --max-restarts 100000 --max-leader-restarts 100000 --out "$out/fleet" \
  --live false >"$out/fleet.log" 2>&1 &
fleet_pid=$!
start=$(date +%s)
echo "soak: $robots robots for $minutes min, $loss % loss, leader killed every $leader_kill s," \
  "a follower every $follower_kill s; fleet log $out/fleet.log"

next_leader=$leader_kill next_follower=$follower_kill next_sample=0 victim=$((seed % robots))
printf 't_s\trole\tpid\trss_kb\n' >"$out/rss.tsv"
printf 't_s\tvictim\tpid\n' >"$out/kills.tsv"
while kill -0 "$fleet_pid" 2>/dev/null; do
  t=$(($(date +%s) - start))
  if [ "$t" -ge "$next_sample" ]; then
    processes | while read -r role pid; do
      kb=$(awk '/^VmRSS/ {print $2}' "/proc/$pid/status" 2>/dev/null || true)
      # A process that ended since pgrep has no status: skip it (an if, not an && list, so that
      # the loop's status, and under set -e the script's fate, never hangs on the last one).
      if [ -n "$kb" ]; then printf '%s\t%s\t%s\t%s\n' "$t" "$role" "$pid" "$kb"; fi
    done >>"$out/rss.tsv"
    next_sample=$((next_sample + 10))
  fi
  if [ "$t" -lt $((duration - quiet)) ]; then
    if [ "$leader_kill" -gt 0 ] && [ "$t" -ge "$next_leader" ]; then
      pid=$(pid_of leader)
      [ -n "$pid" ] && kill -KILL "$pid" && printf '%s\tleader\t%s\n' "$t" "$pid" >>"$out/kills.tsv"
      next_leader=$((next_leader + leader_kill))
    fi
    if [ "$follower_kill" -gt 0 ] && [ "$t" -ge "$next_follower" ]; then
      name=robot-$((victim + 1))
      pid=$(pid_of "$name")
      [ -n "$pid" ] && kill -KILL "$pid" && printf '%s\t%s\t%s\n' "$t" "$name" "$pid" >>"$out/kills.tsv"
      victim=$(((victim + 1) % robots))
      next_follower=$((next_follower + follower_kill))
    fi
  fi
  sleep 1
done
rc=0
wait "$fleet_pid" || rc=$?
fleet_pid=
echo "soak: esfleet-fleet exited with $rc after $(($(date +%s) - start)) s"
tail -n "$((robots + 8))" "$out/fleet.log"

python3 "$here/soak_report.py" "$out" "$robots" "$duration" "${max_slope:--1}" "$rc"
