#!/usr/bin/env bash
# End-to-end test of `geoprox info`: the validation report of the shipped sample mesh and of
# small generated meshes.
# Usage: bash info_test.sh GEOPROX_BINARY REPO_ROOT
set -euo pipefail
# shellcheck source=lib.sh
source "$(dirname "$0")/lib.sh"
cli_test_setup "$@"

# report_has FILE WORD NUMBER: some line of the report names WORD and gives NUMBER.
report_has() {
  grep -Eiq "$2[^0-9]*[^0-9.]$3([^0-9.]|\$)" "$1" ||
    fail "report of $4 does not give $2 = $3:"$'\n'"$(cat "$1")"
  checks=$((checks + 1))
}

info() { expect_geoprox_ok "$tmp/report" info "$1"; }

require_spot
info "$spot"
report_has "$tmp/report" vertices 2930 spot.obj
report_has "$tmp/report" faces 5856 spot.obj
cp "$tmp/report" "$tmp/spot-report"
info "$spot"
cmp -s "$tmp/report" "$tmp/spot-report" || fail "two runs of geoprox info differ"

# Two separate triangles, one of them with an extra isolated vertex in the file.
printf 'v 0 0 0\nv 1 0 0\nv 0 1 0\nv 5 0 0\nv 6 0 0\nv 5 1 0\nv 9 9 9\nf 1 2 3\nf 4 5 6\n' >"$tmp/two.obj"
info "$tmp/two.obj"
report_has "$tmp/report" vertices 7 two.obj
report_has "$tmp/report" faces 2 two.obj
report_has "$tmp/report" components 2 two.obj

echo "info_test.sh: $checks checks passed"
