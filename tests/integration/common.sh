# Shared harness of the integration test scripts (sourced, not run):
#   source "$(dirname "$0")/common.sh" NAME
# makes a scratch directory $work (esfleet-NAME.XXXXXX under $TMPDIR), keeps the background
# processes the script adds to $pids, and on exit stops them (SIGINT, up to 3 s, then SIGKILL)
# and removes $work. fail MESSAGE prints the message and the tail of every $work/*.log, then
# exits 1.
work=$(mktemp -d "${TMPDIR:-/tmp}/esfleet-$1.XXXXXX")
pids=()
cleanup() {
  for p in "${pids[@]}"; do kill -INT "$p" 2>/dev/null || true; done
  for _ in $(seq 1 30); do
    alive=0
    for p in "${pids[@]}"; do kill -0 "$p" 2>/dev/null && alive=1; done
    [ "$alive" = 0 ] && break
    sleep 0.1
  done
  for p in "${pids[@]}"; do kill -KILL "$p" 2>/dev/null || true; done
  rm -rf "$work"
}
trap cleanup EXIT
fail() {
  echo "FAIL: $*" >&2
  for f in "$work"/*.log; do
    [ -f "$f" ] || continue
    echo "--- $f" >&2
    tail -n 30 "$f" >&2
  done
  exit 1
}
# wait_for PID SECONDS WHAT: waits (bounded) for a child to exit; fails if it does not, or if it
# exits with a status other than 0.
wait_for() {
  local pid=$1 seconds=$2 what=$3 rc=0
  for _ in $(seq 1 $((seconds * 10))); do
    kill -0 "$pid" 2>/dev/null || break
    sleep 0.1
  done
  kill -0 "$pid" 2>/dev/null && fail "$what still running after $seconds s"
  wait "$pid" || rc=$?
  [ "$rc" = 0 ] || fail "$what exited with $rc"
}
