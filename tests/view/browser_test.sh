#!/usr/bin/env sh
# Runs browser_test.mjs (its arguments) when Node >= 20, chromium and playwright-core are
# there; otherwise says what is missing and exits 77 (CTest: skipped).
# usage: browser_test.sh BIN_DIR PROJECT_DIR DOMAIN PORT NODE_PREFIX ARTEFACTS
major=$(node -p 'process.versions.node.split(".")[0]' 2>/dev/null || echo 0)
[ "$major" -ge 20 ] || { echo "Node >= 20 not found: skipped"; exit 77; }
chromium=${ESFLEET_CHROMIUM:-/usr/bin/chromium}
[ -x "$chromium" ] || { echo "$chromium not found (apt-get install chromium): skipped"; exit 77; }
[ -f "$5/node_modules/playwright-core/package.json" ] ||
  { echo "playwright-core not in $5 (the fixture view.browser_setup installs it): skipped"; exit 77; }
exec node "$(dirname "$0")/browser_test.mjs" "$@"
