#!/usr/bin/env bash
# Lints docs/openapi.yaml with the pinned Redocly CLI of tests/openapi/node_modules and the rules
# of tests/openapi/redocly.yaml: passes only with zero errors and zero warnings.
#   openapi_lint_test.sh SOURCE_DIR
# Exits 77 (ctest SKIP_RETURN_CODE) when node or node_modules is missing: scripts/install-deps
# runs `npm ci` in tests/openapi.
set -euo pipefail
source_dir=$(cd "${1:?usage: openapi_lint_test.sh SOURCE_DIR}" && pwd)
tools="$source_dir/tests/openapi"
cli="$tools/node_modules/@redocly/cli/bin/cli.js"
if ! command -v node >/dev/null; then
  echo "SKIP: node is not installed (Node.js >= 20.19 runs the Redocly CLI)"
  exit 77
fi
if [ ! -f "$cli" ]; then
  echo "SKIP: tests/openapi/node_modules is missing: run scripts/install-deps (npm ci there)"
  exit 77
fi
export REDOCLY_TELEMETRY=off REDOCLY_SUPPRESS_UPDATE_NOTICE=true NO_COLOR=1
cd "$tools"
report=$(mktemp) stderr=$(mktemp)
trap 'rm -f "$report" "$stderr"' EXIT
set +e
node "$cli" lint "$source_dir/docs/openapi.yaml" --config redocly.yaml --format json \
  >"$report" 2>"$stderr"
rc=$?
set -e
totals=$(python3 -c 'import json,sys; t=json.load(open(sys.argv[1]))["totals"]
print(t["errors"], t["warnings"], t["ignored"])' "$report") || totals="? ? ?"
read -r errors warnings ignored <<<"$totals"
echo "redocly $(node "$cli" --version 2>/dev/null) lint docs/openapi.yaml: exit $rc," \
  "$errors errors, $warnings warnings, $ignored ignored (tests/openapi/.redocly.lint-ignore.yaml)"
if [ "$rc" -ne 0 ] || [ "$errors" != 0 ] || [ "$warnings" != 0 ]; then
  cat "$stderr" >&2
  node "$cli" lint "$source_dir/docs/openapi.yaml" --config redocly.yaml --format stylish >&2 ||
    true
  echo "0 passed, 1 failed"
  exit 1
fi
echo "1 passed, 0 failed"
