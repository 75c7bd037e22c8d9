#!/usr/bin/env bash
# Deployment on separate hosts: the shipped systemd units, env-file format, wrapper and Fast DDS
# profiles, with a leader and two followers in three network namespaces joined by a bridge
# (deploy/netns/testbed.sh), talking UDP only. The units' ExecStart= line is run (as systemd
# would, with the variables of an env file in the shipped format, the unit's KillSignal= to
# stop) inside the namespaces.
#   lan   lan-udp.xml as shipped (multicast discovery over the bridge); follower B's link is cut
#         while the leader maps and healed after the log, so B joins late over the network.
#   wifi  wifi-initial-peers.xml edited as deploy/README.md says (sed on <initialPeersList>),
#         LOSS % (default 10) of the UDP datagrams dropped at random and 2 Mbit/s on every link.
#         The profile's 1400-byte messages with this loss aborted 2 of 3 followers when tiles
#         were fragmented (Fast DDS 2.9.1 GAP bug, docs/faults.md); tools/lossy-deploy-runs.sh
#         repeats this case and counts.
# Both followers must end with the leader's map (same map.digest), declare a first pose within
# 0.3 m of the leader's pose for the same scan, and use no shared memory.
#
# The leader maps at full speed (--rate 0); its mapping rate (scans per second of the SLAM
# loop, publishing included) and publishing figures are printed from its stats.json.
#
# usage: deploy_netns_test.sh BIN_DIR LOG DOMAIN lan|wifi [LOSS] [RATE] [ORDER]
#   RATE: tc rate of every link in wifi mode (default 2mbit), "none" for no cap.
#   ORDER: leader-first (default) or followers-first: the leader once both followers have joined
#          DDS, so that they are matched while it maps (its 600 scans take a few seconds).
# Exit 77 (skipped) without root, network namespaces, tc or nft.
set -euo pipefail
bin=$1 log=$2 domain=$3 mode=$4 loss=${5:-10} rate=${6:-2mbit} order=${7:-leader-first}
here=$(cd "$(dirname "$0")" && pwd)
deploy=$(cd "$here/../../deploy" && pwd)
testbed=$deploy/netns/testbed.sh

skip() { echo "SKIP: $*"; exit 77; }
[ "$(id -u)" -eq 0 ] || skip "needs root (network namespaces)"
command -v ip >/dev/null || skip "no 'ip' (package iproute2)"
if [ "$mode" = wifi ]; then
  command -v tc >/dev/null || skip "no 'tc' (package iproute2)"
  command -v nft >/dev/null || skip "no 'nft' (package nftables)"
fi

# Namespaces left by an earlier run of this case that was killed (CTest timeout): remove them.
for ns in $(ip netns list 2>/dev/null | awk '{print $1}' | grep "^esf-d${domain}_[0-9]*-br$"); do
  old=${ns#esf-}
  old=${old%-br}
  kill -0 "${old#d${domain}_}" 2>/dev/null || "$testbed" down "$old"
done
source "$here/common.sh" "deploy-$mode"
run=d${domain}_$$
trap 'cleanup; "$testbed" down "$run"' EXIT

# --- hosts: 1 = leader, 2 = follower A, 3 = follower B
case $mode in
  lan) netem=() ;;
  wifi)
    netem=(--loss "$loss")
    [ "$rate" = none ] || netem+=(--rate "$rate")
    ;;
  *) fail "mode must be lan or wifi" ;;
esac
rc=0
"$testbed" up "$run" 3 --subnet "$domain" "${netem[@]}" >"$work/testbed.log" 2>&1 || rc=$?
[ $rc -ne 77 ] || skip "$(cat "$work/testbed.log")"
[ $rc -eq 0 ] || fail "testbed up failed: $(cat "$work/testbed.log")"
cat "$work/testbed.log"
ip_of() { "$testbed" addr "$run" "$1"; }

# --- the profile, as deploy/README.md tells a user to make it
mkdir -p "$work/etc"
profile=$work/etc/fastdds.xml
if [ "$mode" = lan ]; then
  cp "$deploy/fastdds/lan-udp.xml" "$profile"
else
  cp "$deploy/fastdds/wifi-initial-peers.xml" "$profile"
  LEADER_IP=$(ip_of 1) FOLLOWER1_IP=$(ip_of 2) FOLLOWER2_IP=$(ip_of 3)
  sed -i -e "s/192\.168\.1\.10</$LEADER_IP</" -e "s/192\.168\.1\.11</$FOLLOWER1_IP</" \
    -e "s/192\.168\.1\.12</$FOLLOWER2_IP</" "$profile"
  grep -q 192.168.1 "$profile" && fail "example addresses left in the profile"
  grep -q ">$FOLLOWER2_IP<" "$profile" || fail "sed did not put the addresses in"
fi
grep -q "<type>SHM</type>" "$profile" && fail "the profile names shared memory"
grep -q "<useBuiltinTransports>false</useBuiltinTransports>" "$profile" ||
  fail "the profile keeps the builtin transports (shared memory)"

# --- env files in the shipped format: the example with the values replaced
set_var() {  # set_var FILE KEY VALUE: replaces the line KEY=... (which must exist)
  grep -q "^$2=" "$1" || fail "$(basename "$1") has no $2="
  local v=${3//\\/\\\\}
  v=${v//|/\\|}
  v=${v//&/\\&}
  sed -i "s|^$2=.*|$2=$v|" "$1"
}
make_env() {  # make_env ROLE NAME KEY=VALUE...
  local f=$work/etc/$2.env kv
  cp "$deploy/systemd/$1.env" "$f"
  shift 2
  for kv in "$@"; do set_var "$f" "${kv%%=*}" "${kv#*=}"; done
}
make_env leader leader ESFLEET_ROBOT_ID=leader ESFLEET_DOMAIN="$domain" \
  ESFLEET_PROFILE="$profile" ESFLEET_LOG="$log" ESFLEET_OUT="$work/leader" ESFLEET_BIN_DIR="$bin" \
  ESFLEET_ARGS='"--max-scans 600 --odometry on --rate 0 --seed 7"'
seed=1
for f in a b; do
  make_env follower "follower-$f" ESFLEET_ROBOT_ID="follower-$f" ESFLEET_DOMAIN="$domain" \
    ESFLEET_PROFILE="$profile" ESFLEET_LOG="$log" ESFLEET_OUT="$work/$f" ESFLEET_BIN_DIR="$bin" \
    ESFLEET_ARGS="\"--first-scan 300 --max-scans 600 --odometry on --rate 0 --wait-complete --seed $seed --timeout 100\""
  seed=$((seed + 1))
done

# --- the units: ExecStart=, EnvironmentFile=, KillSignal=
unit_key() { sed -n "s/^$2=//p" "$deploy/systemd/esfleet-$1.service" | tail -n 1; }
for role in leader follower; do
  [ "$(unit_key "$role" EnvironmentFile)" = "/etc/esfleet/$role.env" ] ||
    fail "esfleet-$role.service: EnvironmentFile is not /etc/esfleet/$role.env"
  exec_start=$(unit_key "$role" ExecStart)
  read -r -a cmd <<<"$exec_start"
  [ "$(basename "${cmd[0]}")" = esfleet-run ] || fail "esfleet-$role.service does not run esfleet-run"
  [ "${cmd[*]:1}" = "$role" ] || fail "esfleet-$role.service: ExecStart=$exec_start"
done
if command -v systemd-analyze >/dev/null; then
  # Installed paths rewritten to this tree (verify checks that the command exists).
  mkdir -p "$work/units"
  for role in leader follower; do
    sed -e "s|^ExecStart=[^ ]*esfleet-run|ExecStart=$deploy/bin/esfleet-run|" \
      -e "s|^EnvironmentFile=.*|EnvironmentFile=$work/etc/$role.env|" \
      "$deploy/systemd/esfleet-$role.service" >"$work/units/esfleet-$role.service"
  done
  cp "$work/etc/follower-a.env" "$work/etc/follower.env"
  systemd-analyze verify "$work/units/esfleet-leader.service" "$work/units/esfleet-follower.service" \
    >"$work/verify.log" 2>&1 || fail "systemd-analyze verify: $(cat "$work/verify.log")"
fi

# start HOST ROLE NAME: runs the unit's ExecStart (esfleet-run from this tree) on host HOST with
# only the variables of $work/etc/NAME.env (read like systemd's EnvironmentFile=).
start() {
  local host=$1 role=$2 name=$3 env=(PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin)
  local line key value
  while IFS= read -r line || [ -n "$line" ]; do
    [[ $line =~ ^[[:space:]]*(#|$) ]] && continue
    key=${line%%=*} value=${line#*=}
    [[ $value =~ ^\"(.*)\"$ ]] && value=${BASH_REMATCH[1]}
    env+=("$key=$value")
  done <"$work/etc/$name.env"
  read -r -a cmd <<<"$(unit_key "$role" ExecStart)"
  "$testbed" exec "$run" "$host" env -i "${env[@]}" "$deploy/bin/esfleet-run" "${cmd[@]:1}" \
    >"$work/$name.log" 2>&1 &
  pids+=($!)
}
kill_signal=$(unit_key leader KillSignal)
kill_signal=${kill_signal:-SIGTERM}

# No shared memory: no process of ours maps or opens anything in /dev/shm.
shm_check() {
  local p
  for p in "$@"; do
    if grep -q /dev/shm "/proc/$p/maps" 2>/dev/null ||
      ls -l "/proc/$p/fd" 2>/dev/null | grep -q /dev/shm; then
      fail "process $p ($(tr '\0' ' ' <"/proc/$p/cmdline" | cut -c1-60)) uses /dev/shm"
    fi
  done
}

# leader_figures: the leader's mapping rate and publishing figures, from its stats.json.
leader_figures() {
  python3 - "$work" <<'PY'
import json, sys
work = sys.argv[1]
s = json.load(open(f"{work}/leader/stats.json"))
p = s["dds"]["publisher"]
print(f"leader: {s['scans']} scans in {s['wall_s']:.2f} s of mapping, "
      f"{s['scans'] / s['wall_s']:.1f} scans/s; published {s['dds']['bytes_total'] / 1e3:.0f} kB "
      f"({s['dds']['tiles_published']} tiles, {s['dds']['deltas_published']} deltas) in "
      f"{p['rounds']} rounds, {p['coalesced']} of {p['tiles_handed_over']} tile copies "
      f"coalesced, hand-over {p['handover_s']:.3f} s, encoding {p['encode_s']:.3f} s, "
      f"waiting for acknowledgments {p['ack_wait_s']:.1f} s, longest wait {p['max_wait_s']:.2f} s")
PY
}
t0=$(date +%s%N)
elapsed() { echo "$((($(date +%s%N) - t0) / 10000000))" | sed -E 's/(..)$/.\1/'; }
[ "$mode" = lan ] && "$testbed" cut "$run" 3
start_leader() {
  start 1 leader leader
  pid_leader=${pids[-1]}
}
[ "$order" = followers-first ] || start_leader
start 2 follower follower-a
pid_a=${pids[-1]}
start 3 follower follower-b
pid_b=${pids[-1]}
if [ "$order" = followers-first ]; then
  for _ in $(seq 1 300); do  # both followers have joined DDS
    grep -q "following map" "$work/follower-a.log" && grep -q "following map" "$work/follower-b.log" && break
    sleep 0.1
  done
  start_leader
fi

ended=0
for _ in $(seq 1 1000); do
  kill -0 "$pid_leader" 2>/dev/null || fail "leader exited early"
  shm_check "$pid_leader" "$pid_a" "$pid_b"
  if [ $ended = 0 ] && grep -q "log ended" "$work/leader.log"; then
    ended=1
    echo "leader: log ended after $(elapsed) s"
    leader_figures || fail "no leader figures"
    echo "leader map digest: $(sha256sum <"$work/leader/map.digest" | cut -c1-16)"
    if [ "$mode" = lan ]; then "$testbed" heal "$run" 3; fi
  fi
  kill -0 "$pid_a" 2>/dev/null || kill -0 "$pid_b" 2>/dev/null || break
  sleep 0.1
done
for f in a b; do
  eval "pid=\$pid_$f"
  kill -0 "$pid" 2>/dev/null && fail "follower $f still running after 100 s"
  wait "$pid" || fail "follower $f exited with $?"
done
shm_check "$pid_leader"
# The leader's sockets are UDP in its own namespace.
"$testbed" exec "$run" 1 ss -uanp 2>/dev/null | grep -q "pid=$pid_leader," ||
  fail "the leader has no UDP socket in its namespace"
kill -s "${kill_signal#SIG}" "$pid_leader"
wait "$pid_leader" || fail "leader exited with $? on $kill_signal"
echo "all done after $(elapsed) s"
[ "$mode" = lan ] || "$testbed" stats "$run"

for f in a b; do
  [ -s "$work/$f/map.digest" ] || fail "follower $f saved no map digest"
  cmp -s "$work/leader/map.digest" "$work/$f/map.digest" ||
    fail "follower $f's map differs from the leader's: $(diff "$work/leader/map.digest" "$work/$f/map.digest" | head -5)"
done
python3 - "$work" "$mode" <<'PY' || fail "follower check"
import json, math, sys
work, mode = sys.argv[1:]
ref = {}
for line in open(f"{work}/leader/trajectory.txt"):
    t, x, y, th = map(float, line.split())
    ref[round(t, 6)] = (x, y, th)
ok = True
for f in "ab":
    s = json.load(open(f"{work}/{f}/stats.json"))
    loc = s["localisation"]
    line = (f"{mode}: follower {f}: map complete after {s['time_to_complete_s']:.1f} s, "
            f"{s['bytes_received'] / 1e6:.2f} MB received, {s['tiles']} tiles "
            f"(rejected {s['tiles_rejected']}); ")
    if not s["complete"]:
        print(line + "map NOT complete"); ok = False; continue
    if "first_pose" not in loc:
        print(line + f"no pose declared after {loc['scans']} scans"); ok = False; continue
    p = loc["first_pose"]
    r = ref[round(p["stamp"], 6)]
    d = math.hypot(p["x"] - r[0], p["y"] - r[1])
    a = math.degrees(abs((p["theta"] - r[2] + math.pi) % (2 * math.pi) - math.pi))
    print(line + f"first pose after {loc['scans_to_first_pose']} scans, error {d:.3f} m {a:.2f} deg")
    ok = ok and d <= 0.3
sys.exit(0 if ok else 1)
PY
echo "OK: $mode: leader and 2 followers in 3 namespaces over UDP, $(wc -l <"$work/leader/map.digest") tiles, maps identical"
