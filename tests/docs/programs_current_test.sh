#!/usr/bin/env bash
# docs.programs_current: docs/programs.md must be what tools/programs-doc.sh makes of the
# programs' --help now. Fails with the difference and the command that regenerates the file.
#
# usage: programs_current_test.sh BIN_DIR SOURCE_DIR
set -euo pipefail
bin=$1
src=$2
fresh=$(mktemp)
trap 'rm -f "$fresh"' EXIT

"$src/tools/programs-doc.sh" "$bin" "$fresh"
if ! diff -u "$src/docs/programs.md" "$fresh"; then
  echo
  echo "docs/programs.md is stale: a program's flags or help text changed (diff above:" \
    "--- committed, +++ what the programs print now). Regenerate it:"
  echo "  cmake --build build --target programs-doc     (builds the programs, rewrites the file)"
  echo "  or, from the source directory: tools/programs-doc.sh $bin docs/programs.md"
  exit 1
fi
echo "docs/programs.md matches the --help of every program"
