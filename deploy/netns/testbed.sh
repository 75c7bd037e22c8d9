#!/usr/bin/env bash
# A multi-host network on one machine, for trying esfleet's leader and followers as separate
# robots: K network namespaces ("hosts") esf-RUN-1 .. esf-RUN-K, each with one interface eth0
# (10.X.0.i/24, loopback up, a multicast route) on a veth link to a bridge in a namespace of its
# own (esf-RUN-br). Nothing is added to the root namespace, so `down` (deleting the namespaces)
# removes every link, bridge, nftables rule and qdisc. Needs root, iproute2, and nftables for
# --loss.
#
#   testbed.sh up RUN K [--subnet X] [--loss P] [--rate RATE]
#       creates the hosts. --subnet X: addresses 10.X.0.i (default 200). --loss P: every host
#       drops P % of the UDP datagrams it receives on eth0, at random and silently (nftables,
#       `numgen random mod 100 < P`; dropping on output would fail the sender's send() instead). --rate RATE: a token-bucket cap (tc tbf, e.g. 2mbit) on both directions of
#       every link. If anything fails, what was created is removed again. Exit 77 when network
#       namespaces cannot be created here (not root, no permission).
#   testbed.sh down RUN         stops the processes still running in the hosts (SIGINT, then
#                               SIGKILL after 3 s), removes the hosts and the bridge (safe to repeat).
#   testbed.sh cut RUN I        cuts host I off the network (the bridge stops forwarding its
#                               port; its interface stays up, as out of radio range) ...
#   testbed.sh heal RUN I       ... and reconnects it.
#   testbed.sh exec RUN I CMD...  runs CMD on host I (ip netns exec esf-RUN-I CMD...).
#   testbed.sh addr RUN I       prints host I's address.
#   testbed.sh stats RUN        per host: UDP datagrams dropped on arrival (--loss); bytes sent,
#                               packets dropped and delayed by the rate cap (--rate).
#
# RUN is a short name ([A-Za-z0-9_]); use a different one for each testbed running at the same
# time.
set -euo pipefail

usage() { sed -n '2,/^set -euo/p' "$0" | sed -e '$d' -e 's/^# \{0,1\}//' >&2; exit 2; }
die() { echo "testbed: $*" >&2; exit 1; }

[ $# -ge 2 ] || usage
cmd=$1 run=$2
shift 2
[[ $run =~ ^[A-Za-z0-9_]{1,40}$ ]] || die "RUN must be 1-40 letters, digits or _: '$run'"
bridge_ns=esf-$run-br
host_ns() { echo "esf-$run-$1"; }

down() {  # stops what still runs in the hosts (SIGINT, after 3 s SIGKILL), deletes them
  local ns namespaces=() pids=()
  for ns in $(ip netns list 2>/dev/null | awk '{print $1}'); do
    case $ns in "esf-$run-"*) namespaces+=("$ns") ;; esac
  done
  for ns in "${namespaces[@]}"; do pids+=($(ip netns pids "$ns" 2>/dev/null)); done
  if [ ${#pids[@]} -gt 0 ]; then
    kill -INT "${pids[@]}" 2>/dev/null || true
    for _ in $(seq 1 30); do
      kill -0 "${pids[@]}" 2>/dev/null || break
      sleep 0.1
    done
    kill -KILL "${pids[@]}" 2>/dev/null || true
  fi
  for ns in "${namespaces[@]}"; do ip netns del "$ns" 2>/dev/null || true; done
}

subnet_of() {  # the X of 10.X.0.i, read back from host 1
  ip -n "$(host_ns 1)" -4 -o addr show dev eth0 | awk '{split($4, a, "."); print a[2]}'
}

case $cmd in
up)
  [ $# -ge 1 ] || usage
  k=$1
  shift
  subnet=200 loss=0 rate=
  while [ $# -gt 0 ]; do
    case $1 in
      --subnet) subnet=$2; shift 2 ;;
      --loss) loss=$2; shift 2 ;;
      --rate) rate=$2; shift 2 ;;
      *) usage ;;
    esac
  done
  [[ $k =~ ^[0-9]+$ ]] && [ "$k" -ge 1 ] && [ "$k" -le 250 ] || die "K must be 1-250"
  [[ $subnet =~ ^[0-9]+$ ]] && [ "$subnet" -le 255 ] || die "--subnet must be 0-255"
  [[ $loss =~ ^[0-9]+$ ]] && [ "$loss" -le 100 ] || die "--loss must be a percentage 0-100"
  if [ "$(id -u)" -ne 0 ]; then
    echo "testbed: network namespaces need root" >&2
    exit 77
  fi
  if ip netns list | awk '{print $1}' | grep -q "^esf-$run-"; then
    die "namespaces esf-$run-* exist already (testbed.sh down $run)"
  fi
  if ! ip netns add "$bridge_ns" 2>/dev/null; then
    echo "testbed: cannot create a network namespace here ('ip netns add' failed)" >&2
    exit 77
  fi
  trap 'rc=$?; [ $rc -eq 0 ] || { echo "testbed: setup failed, removing it" >&2; down; }' EXIT
  ip -n "$bridge_ns" link set lo up
  ip -n "$bridge_ns" link add br0 type bridge mcast_snooping 0
  ip -n "$bridge_ns" link set br0 up
  for i in $(seq 1 "$k"); do
    ns=$(host_ns "$i")
    ip netns add "$ns"
    ip -n "$ns" link set lo up
    ip -n "$bridge_ns" link add "veth$i" type veth peer name eth0 netns "$ns"
    ip -n "$bridge_ns" link set "veth$i" master br0 up
    ip -n "$ns" addr add "10.$subnet.0.$i/24" dev eth0
    ip -n "$ns" link set eth0 up
    ip -n "$ns" route add 224.0.0.0/4 dev eth0
    if [ "$loss" -gt 0 ]; then
      ip netns exec "$ns" nft -f - <<NFT
table inet esfleet_testbed {
  chain input {
    type filter hook input priority 0; policy accept;
    iifname "eth0" meta l4proto udp numgen random mod 100 < $loss counter drop
  }
}
NFT
    fi
    if [ -n "$rate" ]; then
      tc -n "$ns" qdisc add dev eth0 root tbf rate "$rate" burst 32kbit latency 400ms
      tc -n "$bridge_ns" qdisc add dev "veth$i" root tbf rate "$rate" burst 32kbit latency 400ms
    fi
  done
  trap - EXIT
  echo "testbed $run: hosts $(host_ns 1) .. $(host_ns "$k"), addresses 10.$subnet.0.1 .. 10.$subnet.0.$k" \
    "(loss ${loss} %, rate ${rate:-unlimited})"
  ;;
down)
  down
  ;;
cut|heal)
  [ $# -eq 1 ] || usage
  # The bridge stops forwarding to and from the port (state 0 = disabled, 3 = forwarding); both
  # ends of the link stay up, as for a robot out of radio range.
  ip -n "$bridge_ns" link show "veth$1" >/dev/null
  bridge -n "$bridge_ns" link set dev "veth$1" state "$([ "$cmd" = cut ] && echo 0 || echo 3)"
  ;;
exec)
  [ $# -ge 2 ] || usage
  i=$1
  shift
  exec ip netns exec "$(host_ns "$i")" "$@"
  ;;
addr)
  [ $# -eq 1 ] || usage
  echo "10.$(subnet_of).0.$1"
  ;;
stats)
  for ns in $(ip netns list | awk '{print $1}' | grep "^esf-$run-[0-9]" | sort -t- -k3n); do
    dropped=$(ip netns exec "$ns" nft list table inet esfleet_testbed 2>/dev/null |
      sed -n 's/.*counter packets \([0-9]*\).*/\1/p' || true)  # no table without --loss
    tbf=$(tc -s -n "$ns" qdisc show dev eth0 | awk '/^qdisc tbf/{t=1} t&&/Sent/&&!done{print $2" bytes sent, "$7" dropped, "$9" delayed"; done=1}' | tr -d ',')
    echo "$ns: ${dropped:-0} UDP datagrams dropped; rate cap: ${tbf:-none}"
  done
  ;;
*)
  usage
  ;;
esac
