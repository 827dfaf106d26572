#!/usr/bin/env bash
# The documented installs work offline (docs/python.md, "Installing"):
#  - scripts/install-python into a fresh virtual environment (made with Debian's python and
#    --system-site-packages for numpy), then `import geoprox.native` there, from another
#    directory and without PYTHONPATH, computes a distance;
#  - `pip install --no-build-isolation --no-index clients/python` (the pure-Python client) into
#    another fresh environment, from a copy of clients/python (pip writes build files beside
#    the sources).
# Usage: install_test.sh REPO_ROOT BUILD_DIR PYTHON. Exits 77 with one line when BUILD_DIR has
# no geoprox.native (sanitizer builds, no pybind11 or numpy).
set -euo pipefail
root=${1:?usage: install_test.sh REPO_ROOT BUILD_DIR PYTHON}
build=${2:?usage: install_test.sh REPO_ROOT BUILD_DIR PYTHON}
python=${3:?usage: install_test.sh REPO_ROOT BUILD_DIR PYTHON}
if ! compgen -G "$build/python/geoprox/native*.so" >/dev/null; then
  echo "SKIP: geoprox.native was not built in $build (sanitizer build, or no pybind11/numpy)"
  exit 77
fi
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fail() { echo "FAIL (install_test.sh): $*" >&2; exit 1; }

"$python" -m venv --system-site-packages "$tmp/venv" || fail "cannot make a venv (python3-venv)"
"$root/scripts/install-python" --python "$tmp/venv/bin/python" --build-dir "$build" \
  >"$tmp/install.log" 2>&1 || { cat "$tmp/install.log" >&2; fail "scripts/install-python failed"; }
site=$("$tmp/venv/bin/python" -c 'import sysconfig; print(sysconfig.get_path("platlib"))')
compgen -G "$site/geoprox/native*.so" >/dev/null || fail "no geoprox/native*.so in $site"
[ -f "$site/geoprox/__init__.py" ] || fail "the client's modules were not installed in $site"
(cd "$tmp" && env -u PYTHONPATH "$tmp/venv/bin/python" - "$root/data/meshes/spot.obj" \
  "$site") <<'PY' ||
import sys
import numpy as np
import geoprox
import geoprox.native as native
spot, site = sys.argv[1], sys.argv[2]
assert native.__file__.startswith(site), native.__file__
assert geoprox.__file__.startswith(site), geoprox.__file__
V, F = native.read_mesh(spot)
g = native.Graph.build(V, F, samples=60, neighbors=8)
d = g.distance(np.array([0, 0]), np.array([0, 1]))
edge = float(np.linalg.norm(V[1] - V[0]))
assert d[0] == 0 and edge * 0.999 <= d[1], (d, edge)
print("venv: geoprox.native from", native.__file__, "distance", d[1])
PY
  fail "import geoprox.native or its distance failed in the venv"

"$python" -m venv --system-site-packages "$tmp/client-venv" || fail "cannot make a venv"
cp -r "$root/clients/python" "$tmp/client-src"
rm -rf "$tmp/client-src/build" "$tmp/client-src/"*.egg-info
"$tmp/client-venv/bin/pip" install -q --no-build-isolation --no-index "$tmp/client-src" \
  >"$tmp/pip.log" 2>&1 || { cat "$tmp/pip.log" >&2; fail "pip install of clients/python failed"; }
(cd "$tmp" && env -u PYTHONPATH "$tmp/client-venv/bin/python" -c '
import geoprox, sys
assert "client-venv" in geoprox.__file__, geoprox.__file__
assert hasattr(geoprox, "Client")
print("client-venv: geoprox from", geoprox.__file__)') ||
  fail "the pip-installed client does not import"
echo "install_test.sh: passed"
