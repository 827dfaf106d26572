# geoprox container image: the query daemon geoproxd serving the meshes of a config, plus the
# geoprox command-line tool. docs/deployment.md is the manual (replicas, HAProxy, Kubernetes).
#   docker build -t geoprox .
#   docker run --rm --read-only -p 7878:7878 -p 7879:7879 -p 7880:7880 geoprox  # sample meshes
#   (the web viewer: http://127.0.0.1:7880/; the image carries its built files, no Node.js)
#   docker run --rm --read-only -v $PWD/my-config:/srv/geoprox/configs:ro \
#              -v $PWD/my-data:/srv/geoprox/data:ro -v geoprox-graphs:/srv/geoprox/var geoprox
# The config is /srv/geoprox/configs/geoproxd.json (deploy/geoproxd.json: binds 0.0.0.0, data in
# /srv/geoprox/data, graphs in /srv/geoprox/var/graphs). Graphs are built at first start into
# /srv/geoprox/var/graphs, the only directory written; mount prebuilt ones there (read-only is
# fine when every graph is present and valid), or keep the volume so later starts only map them.
# The root filesystem can be read-only. scripts/check-dockerfile checks this file (a ctest) and
# scripts/docker-build-check runs its steps in a fresh Debian 12 root.

# --- builder: toolchain and libraries, build, run the test suite --------------------------
FROM debian:12 AS builder
SHELL ["/bin/bash", "-o", "pipefail", "-c"]
WORKDIR /src
# Dependencies first, in their own layer, so source changes do not reinstall them.
COPY scripts/install-deps scripts/install-deps
RUN scripts/install-deps && rm -rf /var/lib/apt/lists/*
COPY . .
# The README's build and test commands (the tests that need the optional mesh corpus skip).
RUN cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DGEOPROX_BUILD_BENCH=OFF \
 && cmake --build build -j"$(nproc)" \
 && ctest --test-dir build --output-on-failure -j"$(nproc)"

# --- web: the viewer (clients/web) bundled by Vite; only its dist/ goes on ----------------
FROM node:20-bookworm-slim AS web
WORKDIR /web
# The lock file first, in its own layer, so source changes do not reinstall the packages.
COPY clients/web/package.json clients/web/package-lock.json ./
RUN npm ci --no-audit --no-fund --loglevel=error
COPY clients/web/index.html clients/web/vite.config.js ./
COPY clients/web/src src
RUN npm run build

# --- runtime: shared libraries only, non-root ---------------------------------------------
FROM debian:12-slim AS runtime
SHELL ["/bin/bash", "-o", "pipefail", "-c"]
COPY scripts/install-deps /tmp/install-deps
RUN /tmp/install-deps --runtime-only && rm -rf /var/lib/apt/lists/* /tmp/install-deps \
 && useradd --system --user-group --uid 10001 --home-dir /srv/geoprox --shell /usr/sbin/nologin geoprox \
 && mkdir -p /srv/geoprox/var/graphs && chown -R geoprox:geoprox /srv/geoprox/var
COPY --from=builder /src/build/server/geoproxd /usr/local/bin/geoproxd
COPY --from=builder /src/build/clients/cli/geoprox /usr/local/bin/geoprox
# Where geoproxd looks by default (../share/geoprox/web from its binary): served at "/".
COPY --from=web /web/dist /usr/local/share/geoprox/web
COPY data/meshes /srv/geoprox/data/meshes
COPY deploy/geoproxd.json /srv/geoprox/configs/geoproxd.json
WORKDIR /srv/geoprox
USER geoprox
VOLUME ["/srv/geoprox/configs", "/srv/geoprox/data", "/srv/geoprox/var"]
EXPOSE 7878 7879 7880
HEALTHCHECK --interval=10s --timeout=3s --start-period=60s --retries=3 \
  CMD ["geoproxd", "--probe"]
STOPSIGNAL SIGTERM
ENTRYPOINT ["geoproxd", "--config", "/srv/geoprox/configs/geoproxd.json"]
