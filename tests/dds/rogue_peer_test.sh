#!/usr/bin/env bash
# A rogue participant on the domain (tests/dds/rogue_peer.cpp) publishes malformed, oversized,
# out-of-range, old-protocol and stale tiles, bogus deltas and summaries for the leader's map
# during the whole run, in three attacks: 16 MB tiles every 2 s, 64 MB tiles every 2 s, and a
# flood of 30 000 new keys (15 000 tile and 15 000 delta keys). After each, the follower must end with exactly the leader's map
# (same digests), count the bad samples in stats.json, log them once per sender and kind (no
# flood), name the old protocol, and its peak memory (VmHWM) must stay within twice that of the
# same run without the rogue (issue 23: bounded types and resource limits, docs/fuzzing.md).
#
# usage: rogue_peer_test.sh BIN_DIR LOG PROFILE DOMAIN [MAX_SCANS] [RATE]
set -euo pipefail
bin=$1 log=$2 profile=$3 domain=$4 max_scans=${5:-300} rate=${6:-4}
source "$(dirname "$0")/../integration/common.sh" rogue-peer

common=(--domain "$domain" --profile "$profile")
slam=(--log "$log" --odometry on --max-scans "$max_scans" --seed 7 --rate "$rate")

# peak_rss PID FILE: records the follower's VmHWM (kB) every 0.1 s until it exits.
peak_rss() {
  while kill -0 "$1" 2>/dev/null; do
    # An exited, not yet reaped follower still has /proc/PID/status, without VmHWM.
    local kb
    kb=$(awk '/^VmHWM/ {print $2}' "/proc/$1/status" 2>/dev/null || true)
    [ -n "$kb" ] && echo "$kb" >"$2"
    sleep 0.1
  done
}

# run NAME: a follower, then the leader; waits for the follower's complete map.
run() {
  local name=$1
  "$bin/esfleet-follower" "${common[@]}" --save-map "$work/$name" --exit-when-complete \
    --timeout 120 >"$work/$name.log" 2>&1 &
  local pid_f=$!
  pids+=("$pid_f")
  peak_rss "$pid_f" "$work/$name.hwm" &
  local pid_rss=$!
  "$bin/esfleet-leader" "${slam[@]}" "${common[@]}" --out "$work/leader-$name" --linger 120 \
    >"$work/leader-$name.log" 2>&1 &
  local pid_l=$!
  pids+=("$pid_l")
  wait_for "$pid_f" 150 "follower $name"
  wait "$pid_rss" || true
  kill -INT "$pid_l"
  wait "$pid_l" || fail "leader ($name) exited with $? on SIGINT"
  cmp -s "$work/leader-$name/map.digest" "$work/$name/map.digest" ||
    fail "follower $name map differs from the leader's: $(diff "$work/leader-$name/map.digest" "$work/$name/map.digest" | head -5)"
}

# 1. Without the rogue: the reference peak memory.
run clean

# attack NAME ROGUE_ARGS...: the rogue publishes from before the leader starts until the
# follower is done; then the checks.
attack() {
  local name=$1
  shift
  "$bin/rogue_peer" "${common[@]}" --period-ms 100 "$@" >"$work/rogue-$name.out" \
    2>"$work/rogue-$name.log" &
  local pid_rogue=$!
  pids+=("$pid_rogue")
  run "$name"
  kill -INT "$pid_rogue"
  wait_for "$pid_rogue" 30 "rogue peer ($name)"
  cat "$work/rogue-$name.out"
  grep -q "rogue: sent" "$work/rogue-$name.out" || fail "the rogue ($name) did not report what it sent"
  local rounds
  rounds=$(sed -n 's/.* in \([0-9]*\) rounds/\1/p' "$work/rogue-$name.out")
  [ "${rounds:-0}" -ge 10 ] || fail "the rogue ($name) attacked for only ${rounds:-0} rounds"

  python3 - "$work/$name/stats.json" "$rounds" <<'PY' || fail "stats.json counters ($name)"
import json, sys
d = json.load(open(sys.argv[1]))
rounds = int(sys.argv[2])
def find(obj, key):
    if isinstance(obj, dict):
        if key in obj:
            return obj[key]
        for v in obj.values():
            r = find(v, key)
            if r is not None:
                return r
    return None
c = {k: find(d, k) for k in ("tiles_rejected", "tiles_stale", "deltas_rejected",
                             "deltas_needs_base", "meta_rejected", "complete")}
print("follower counters:", c)
# Per round the rogue sends 10 tiles + the flood keys that must be rejected (one more, the old
# protocol, is dropped by the reader), 3 deltas and 5 summaries: the follower sees most rounds
# (it starts with the leader).
assert c["complete"] is True, "map not complete"
assert c["tiles_rejected"] >= 10 * rounds // 2, c
assert c["deltas_rejected"] >= rounds, c
assert c["meta_rejected"] >= rounds, c
PY

  # Logged once per sending writer and kind, not per sample.
  local warnings
  warnings=$(grep -c "from writer" "$work/$name.log" || true)
  for what in "tile (" "tile delta (" "map summary dropped"; do
    grep -q "from writer .*$what" "$work/$name.log" || fail "$name: no log line names a rejected '$what'"
  done
  [ "$warnings" -le 8 ] || fail "$name: $warnings warnings logged: the rogue floods the log"
  # The old protocol is named once per writer (tiles: 2, summaries: 0), not per sample.
  grep -q "writer .* speaks esfleet protocol 2, this node protocol 3: .*upgrade that robot" \
    "$work/$name.log" || fail "$name: the protocol-2 tiles were not reported"
  local protocol_lines
  protocol_lines=$(grep -c "speaks esfleet protocol" "$work/$name.log" || true)
  [ "$protocol_lines" -le 2 ] || fail "$name: $protocol_lines protocol warnings: one per writer expected"

  local attacked_kb
  attacked_kb=$(cat "$work/$name.hwm" 2>/dev/null || true)
  [ -n "$attacked_kb" ] || fail "no VmHWM recorded for the follower ($name)"
  echo "follower peak RSS: clean ${clean_kb} kB, $name ${attacked_kb} kB"
  summary+=("$name ${attacked_kb} kB")
  # Issue 23: a hostile peer must not take a follower past twice its clean peak.
  [ "$attacked_kb" -le $((2 * clean_kb)) ] ||
    fail "$name: peak RSS under attack ${attacked_kb} kB is more than twice the clean run's ${clean_kb} kB"
}

clean_kb=$(cat "$work/clean.hwm" 2>/dev/null || true)
[ -n "$clean_kb" ] || fail "no VmHWM recorded for the clean follower"
grep -q "from writer\|speaks esfleet protocol" "$work/clean.log" &&
  fail "the clean run logged dropped samples"
summary=("clean ${clean_kb} kB")

# 2. Oversized samples: Fast DDS must refuse them before reassembly (the reader's payload pool
# holds the bounded type's maximum only), so they never reach the follower.
attack oversized16 --key-flood 10 --oversized-every 20 --oversized-mb 16
attack oversized64 --key-flood 10 --oversized-every 20 --oversized-mb 64
for name in oversized16 oversized64; do
  sent=$(sed -n 's/.*summaries, \([0-9]*\) oversized.*/\1/p' "$work/rogue-$name.out")
  [ "${sent:-0}" -ge 2 ] || fail "$name: the rogue sent only ${sent:-0} oversized tiles"
  grep -q "larger than the history payload size" "$work/$name.log" ||
    fail "$name: Fast DDS did not refuse the oversized tiles before reassembly"
done

# 3. Many keys: 200 new out-of-range keys per round on the tile and on the delta topic, 15 000
# on each (30 000 keys), below the readers' kMaxTileKeys (16 384, topics.hpp) so that the
# leader's tiles still get through. The leader replays at recorded speed here: under load, at
# 4x the rogue had sent only 4800 (200 per round) or 9000 keys (1000 per round, 9 rounds) when
# the leader was done.
slam=(--log "$log" --odometry on --max-scans "$max_scans" --seed 7 --rate 1)
attack flood --key-flood 200 --flood-max 15000 --oversized-every 0
flood_keys=$(sed -n 's/.* \([0-9]*\) flood keys.*/\1/p' "$work/rogue-flood.out")
[ "${flood_keys:-0}" -ge 10000 ] || fail "the flood sent only ${flood_keys:-0} keys per topic"

echo "OK: follower map == leader's under every attack; peak RSS: ${summary[*]}"
