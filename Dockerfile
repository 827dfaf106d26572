# geoprox container image. For now it runs the `geoprox` command-line tool; the query daemon,
# its ports and a HEALTHCHECK come with the server (later issue).
#   docker build -t geoprox .
#   docker run --rm geoprox info data/meshes/spot.obj

# --- builder: toolchain and libraries, build, run the test suite --------------------------
FROM debian:12 AS builder
SHELL ["/bin/bash", "-o", "pipefail", "-c"]
WORKDIR /src
# Dependencies first, in their own layer, so source changes do not reinstall them.
COPY scripts/install-deps scripts/install-deps
RUN scripts/install-deps && rm -rf /var/lib/apt/lists/*
COPY . .
RUN cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DGEOPROX_BUILD_BENCH=OFF \
 && cmake --build build -j"$(nproc)" \
 && ctest --test-dir build --output-on-failure -j"$(nproc)" \
      -E 'MeshIo.DirtySharedMeshes'  # needs ../shared/meshes, which is not in the build context

# --- runtime: shared libraries only, non-root ---------------------------------------------
FROM debian:12-slim AS runtime
SHELL ["/bin/bash", "-o", "pipefail", "-c"]
COPY scripts/install-deps /tmp/install-deps
RUN /tmp/install-deps --runtime-only && rm -rf /var/lib/apt/lists/* /tmp/install-deps \
 && useradd --system --user-group --uid 10001 --home-dir /srv/geoprox --shell /usr/sbin/nologin geoprox
COPY --from=builder /src/build/clients/cli/geoprox /usr/local/bin/geoprox
COPY data/meshes /srv/geoprox/data/meshes
COPY configs /srv/geoprox/configs
WORKDIR /srv/geoprox
USER geoprox
ENTRYPOINT ["geoprox"]
CMD ["--help"]
