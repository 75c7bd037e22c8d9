#!/usr/bin/env sh
# The browser test's fixture: playwright-core VERSION from the npm registry into PREFIX (once).
# Skipped (77) without npm or with a Node older than 20 (playwright-core's minimum; Debian
# bookworm's nodejs is 18: the test then needs a newer Node, e.g. from nodesource).
# usage: browser_setup.sh PREFIX VERSION
prefix=$1 version=$2
if [ -f "$prefix/node_modules/playwright-core/package.json" ] &&
   grep -q "\"version\": \"$version\"" "$prefix/node_modules/playwright-core/package.json"; then
  exit 0
fi
command -v npm >/dev/null 2>&1 || { echo "npm not found: the browser test is skipped"; exit 77; }
major=$(node -p 'process.versions.node.split(".")[0]' 2>/dev/null || echo 0)
[ "$major" -ge 20 ] || { echo "Node $major < 20 (playwright-core needs 20): skipped"; exit 77; }
exec npm install --no-audit --no-fund --prefix "$prefix" "playwright-core@$version"
