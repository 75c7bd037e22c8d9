#!/usr/bin/env bash
# Publishing never blocks mapping (docs/faults.md): the Wi-Fi deployment (deploy_netns_test.sh
# wifi: a leader mapping 600 CSAIL scans at full speed and two followers in three network
# namespaces, no loss; the followers start first so that they are matched while the leader
# maps) run twice, with no rate cap and with 256 kbit/s on every link. Each run
# must end with both followers holding the leader's exact map (the deployment test checks the
# digests); the two leaders must make the same map (the SLAM does not depend on the network);
# and with the cap publishing must take under 10 % of the leader's mapping time (the mapping
# thread only hands copies over; before the publisher thread it waited for the link, ~90 %).
# Prints both mapping rates (scans per second) and the followers' convergence times; the rates
# are not compared by a bound: on this shared 2-core machine two uncapped runs differed 1.85x.
#
# usage: capped_publish_test.sh BIN_DIR LOG DOMAIN
# Exit 77 (skipped) where the deployment test skips (no root, namespaces, tc or nft).
set -uo pipefail
bin=$1 log=$2 domain=$3
here=$(cd "$(dirname "$0")" && pwd)
declare -A rate digest coalesced share
for cap in none 256kbit; do
  out=$("$here/deploy_netns_test.sh" "$bin" "$log" "$domain" wifi 0 "$cap" followers-first 2>&1)
  rc=$?
  [ $rc -ne 77 ] || { echo "$out" | tail -1; exit 77; }
  if [ $rc -ne 0 ]; then
    echo "$out" | tail -60
    echo "FAIL: the deployment with rate cap '$cap' failed ($rc)"
    exit 1
  fi
  echo "--- rate cap: $cap"
  echo "$out" | grep -E "^leader: [0-9]|^wifi: follower|^OK"
  rate[$cap]=$(echo "$out" | sed -n 's/^leader: .* \([0-9.]*\) scans\/s.*/\1/p')
  digest[$cap]=$(echo "$out" | sed -n 's/^leader map digest: //p')
  coalesced[$cap]=$(echo "$out" | sed -n 's/^leader: .* \([0-9]*\) of [0-9]* tile copies coalesced.*/\1/p')
  share[$cap]=$(echo "$out" | sed -n 's/^leader: .* in \([0-9.]*\) s of mapping.*hand-over \([0-9.]*\) s.*/\2 \1/p')
done
# Discovery over 256 kbit/s may finish only after the few seconds of mapping: then nothing
# pushed back while it mapped, and the run shows less.
[ "${coalesced[256kbit]:-0}" -gt 0 ] ||
  echo "NOTE: with the cap no tile copy was coalesced: the followers matched only after the mapping"
[ -n "${digest[none]}" ] && [ "${digest[none]}" = "${digest[256kbit]}" ] ||
  { echo "FAIL: the leader's map differs with the cap (${digest[none]} vs ${digest[256kbit]})"; exit 1; }
python3 - "${rate[none]}" "${rate[256kbit]}" ${share[256kbit]} <<'PY'
import sys
free, capped, handover, mapping = map(float, sys.argv[1:])
print(f"leader mapping rate: {free:.1f} scans/s without a cap, {capped:.1f} with 256 kbit/s "
      f"({capped / free:.2f}x); with the cap publishing took {handover:.3f} s of its "
      f"{mapping:.2f} s of mapping ({100 * handover / mapping:.1f} %)")
sys.exit(0 if handover < 0.1 * mapping else 1)
PY
[ $? -eq 0 ] || { echo "FAIL: with the cap publishing took 10 % or more of the mapping time"; exit 1; }
echo "OK: same map with and without the cap, followers identical, mapping not slowed by the cap"
