#!/usr/bin/env bash
# The installed CMake package, end to end:
#   find_package_test.sh BUILD_DIR SOURCE_DIR
# 1. `cmake --install BUILD_DIR` into a temporary prefix; checks the files a user gets (binaries,
#    headers, package config) and that the server library is not among them.
# 2. Configures and builds tests/package/consumer (a separate project) with
#    -DCMAKE_PREFIX_PATH=<prefix>: find_package(geoprox) with version and component checks,
#    geoprox::client and geoprox::core. The client program must not load the server's libraries.
# 3. Starts the installed geoproxd (located through geoprox::geoproxd) on spot.obj and runs the
#    client program against it; its exact distance must equal the one geoprox::core computes
#    offline, and its other checks must hold (client_consumer.cpp).
set -euo pipefail
build_dir=$(cd "$1" && pwd)
source_dir=$(cd "$2" && pwd)
work=$(mktemp -d "${TMPDIR:-/tmp}/geoprox-package.XXXXXX")
daemon=""
cleanup() {
  if [ -n "$daemon" ]; then kill -TERM "$daemon" 2>/dev/null || true; wait "$daemon" 2>/dev/null || true; fi
  rm -rf "$work"
}
trap cleanup EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

prefix="$work/prefix"
cmake --install "$build_dir" --prefix "$prefix" > "$work/install.log" || { cat "$work/install.log"; fail "cmake --install failed"; }
for f in bin/geoproxd bin/geoprox include/geoprox/geoprox_client.h include/geoprox/core/mesh/mesh.h \
         include/geoprox/protocol/json_rpc.h lib/libgeoprox_client.a lib/libgeoprox_protocol.a \
         lib/libgeoprox_core.a lib/cmake/geoprox/geoproxConfig.cmake \
         lib/cmake/geoprox/geoproxConfigVersion.cmake; do
  [ -e "$prefix/$f" ] || fail "cmake --install did not install $f (installed: $(cd "$prefix" && find . -type f | sort | tr '\n' ' '))"
done
if find "$prefix" -name '*geoprox_server*' | grep . >/dev/null; then
  fail "the server library was installed: $(find "$prefix" -name '*geoprox_server*')"
fi
if find "$prefix/include" -path '*server*' | grep . >/dev/null; then
  fail "server headers were installed: $(find "$prefix/include" -path '*server*')"
fi
for private in window_propagation.h query_engine.h mesh_reader_support.h graph_file_format.h \
               graph_file_internal.h tuning.h; do
  if find "$prefix/include" -name "$private" | grep . >/dev/null; then
    fail "a private header was installed: $(find "$prefix/include" -name "$private")"
  fi
done
# Every installed header compiles on its own: no public header includes a private one.
for h in $(cd "$prefix/include" && find geoprox/core -name '*.h'); do
  echo "#include <$h>" > "$work/header_check.cpp"
  c++ -std=c++20 -fsyntax-only -I"$prefix/include" -I"$prefix/include/geoprox" \
      "$work/header_check.cpp" 2> "$work/header_check.log" ||
    { cat "$work/header_check.log"; fail "installed header $h does not compile on its own"; }
done
echo "installed $(find "$prefix" -type f | wc -l) files into $prefix"

cache() { sed -n "s/^$1:[A-Z]*=//p" "$build_dir/CMakeCache.txt"; }
# The same compiler, and the sanitizer runtimes a sanitized build's static libraries need (the
# package does not carry them: users of a sanitized install add them the same way).
sanitize=""
if [ "$(cache GEOPROX_SANITIZE)" = "ON" ] || [ "$(cache GEOPROX_FUZZ)" = "ON" ]; then
  sanitize="-fsanitize=address,undefined"
elif [ "$(cache GEOPROX_TSAN)" = "ON" ]; then
  sanitize="-fsanitize=thread"
fi
build_type=$(cache CMAKE_BUILD_TYPE)
cmake -S "$source_dir/tests/package/consumer" -B "$work/consumer" -DCMAKE_PREFIX_PATH="$prefix" \
      -DCMAKE_CXX_COMPILER="$(cache CMAKE_CXX_COMPILER)" -DCMAKE_BUILD_TYPE="${build_type:-RelWithDebInfo}" \
      -DCMAKE_CXX_FLAGS="$sanitize" -DCMAKE_EXE_LINKER_FLAGS="$sanitize" > "$work/configure.log" 2>&1 \
  || { cat "$work/configure.log"; fail "configuring the consumer project failed"; }
grep -- "-- geoprox " "$work/configure.log"
cmake --build "$work/consumer" -j2 > "$work/build.log" 2>&1 \
  || { cat "$work/build.log"; fail "building the consumer project failed"; }

# Linking geoprox::client brings neither the server's nor the core's libraries.
libs=$(ldd "$work/consumer/client_consumer")
if echo "$libs" | grep -E -i 'openmesh|spdlog|boost|gomp|fmt'; then
  fail "client_consumer loads libraries of the server or core (above)"
fi

geoproxd=$(cat "$work/consumer/geoproxd_path.txt")
[ "$geoproxd" = "$prefix/bin/geoproxd" ] || fail "geoprox::geoproxd is $geoproxd, expected $prefix/bin/geoproxd"

exact=$("$work/consumer/core_consumer" "$source_dir/data/meshes/spot.obj")
echo "geoprox::core offline: exact distance v:0 -> f:100:0.2:0.3:0.5 on spot = $exact"

mkdir -p "$work/data/meshes"
cp "$source_dir/data/meshes/spot.obj" "$work/data/meshes/"
cat > "$work/geoproxd.json" <<JSON
{"bind": "127.0.0.1", "port": 0, "admin_port": 0, "http_port": 0, "compute_threads": 2, "build_threads": 2,
 "data_dir": "data", "graph_dir": "graphs", "log_level": "warn",
 "meshes": [{"id": "spot", "mesh": "meshes/spot.obj", "samples": 400, "neighbors": 12}]}
JSON
"$geoproxd" --config "$work/geoproxd.json" --port-file "$work/port.json" > "$work/geoproxd.log" 2>&1 &
daemon=$!
for _ in $(seq 600); do
  [ -s "$work/port.json" ] && break
  kill -0 "$daemon" 2>/dev/null || { cat "$work/geoproxd.log"; fail "the installed geoproxd exited"; }
  sleep 0.1
done
[ -s "$work/port.json" ] || { cat "$work/geoproxd.log"; fail "the installed geoproxd wrote no port file in 60 s"; }
port=$(python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))["port"])' "$work/port.json")

"$work/consumer/client_consumer" "$port" "$exact" || { cat "$work/geoproxd.log"; fail "client_consumer failed"; }
echo "package: 1 passed, 0 failed"
