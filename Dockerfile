# geoprox container image: the query daemon geoproxd serving the meshes of a config, plus the
# geoprox command-line tool.
#   docker build -t geoprox .
#   docker run --rm -p 7878:7878 -p 7879:7879 geoprox            # the sample meshes
#   docker run --rm -v $PWD/my-config:/srv/geoprox/configs:ro -v $PWD/my-data:/srv/geoprox/data:ro \
#              -v geoprox-graphs:/srv/geoprox/var geoprox
# Graphs are built at first start into /srv/geoprox/var/graphs (a volume: mount prebuilt ones
# there, or keep the volume so later starts only map them). The root filesystem can be read-only.

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
 && useradd --system --user-group --uid 10001 --home-dir /srv/geoprox --shell /usr/sbin/nologin geoprox \
 && mkdir -p /srv/geoprox/var/graphs && chown -R geoprox:geoprox /srv/geoprox/var
COPY --from=builder /src/build/server/geoproxd /usr/local/bin/geoproxd
COPY --from=builder /src/build/clients/cli/geoprox /usr/local/bin/geoprox
COPY data/meshes /srv/geoprox/data/meshes
COPY configs /srv/geoprox/configs
WORKDIR /srv/geoprox
USER geoprox
VOLUME ["/srv/geoprox/var"]
EXPOSE 7878 7879
HEALTHCHECK --interval=10s --timeout=3s --start-period=60s --retries=3 \
  CMD ["geoproxd", "--probe"]
STOPSIGNAL SIGTERM
ENTRYPOINT ["geoproxd", "--config", "/srv/geoprox/configs/default.json", "--bind", "0.0.0.0"]
