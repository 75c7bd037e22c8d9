#!/usr/bin/env bash
# esfleet-sim with a bad --world: missing file, malformed YAML, missing image, a world without
# drivable space. Each must exit with code 2 (not crash) and name the file in its message.
#
# usage: bad_world_test.sh BIN_DIR
set -uo pipefail
bin=$1
work=$(mktemp -d "${TMPDIR:-/tmp}/esfleet-sim-bad-world.XXXXXX")
trap 'rm -rf "$work"' EXIT
failed=0

# expect_error FILE PATTERN: esfleet-sim --world FILE exits 2 with PATTERN and FILE in stderr.
expect_error() {
  local file=$1 pattern=$2 rc=0
  timeout 30 "$bin/esfleet-sim" --world "$file" --offline --out-log "$work/out" --duration 1 \
    >"$work/stdout" 2>"$work/stderr" || rc=$?
  if [ "$rc" != 2 ]; then
    echo "FAIL: $file: exit code $rc, expected 2"; cat "$work/stderr"; failed=1; return
  fi
  if ! grep -q -- "$file" "$work/stderr" || ! grep -q -- "$pattern" "$work/stderr"; then
    echo "FAIL: $file: message lacks the file or '$pattern':"; cat "$work/stderr"; failed=1; return
  fi
  echo "ok: $(head -n 1 "$work/stderr")"
}

expect_error "$work/missing.yaml" "missing.yaml"

printf 'image: map.pgm\nresolution: [oops\n' >"$work/malformed.yaml"
expect_error "$work/malformed.yaml" "yaml"

printf 'image: nothere.pgm\nresolution: 0.05\norigin: [0, 0, 0]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n' \
  >"$work/noimage.yaml"
expect_error "$work/noimage.yaml" "nothere.pgm"

# A 20 x 20 image, all free but far too small for 0.35 m clearance at 5 cm.
{ printf 'P5\n20 20\n255\n'; head -c 400 /dev/zero | tr '\0' '\376'; } >"$work/tiny.pgm"
printf 'image: tiny.pgm\nresolution: 0.05\norigin: [0, 0, 0]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n' \
  >"$work/tiny.yaml"
expect_error "$work/tiny.yaml" "no drivable space"

# A bad flag names itself.
rc=0
"$bin/esfleet-sim" --world "$work/tiny.yaml" --beams 1 2>"$work/stderr" || rc=$?
if [ "$rc" != 2 ] || ! grep -q -- "--beams" "$work/stderr"; then
  echo "FAIL: --beams 1: exit $rc"; cat "$work/stderr"; failed=1
fi
exit $failed
