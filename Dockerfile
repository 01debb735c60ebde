# Strata: multi-stage build on Debian bookworm.
#   build    installs the build dependencies (scripts/install-deps.sh), builds the programs
#            and runs the whole test suite (tests that need ../shared/maps skip themselves;
#            --build-arg STRATA_RUN_TESTS=0 skips them for a commit CI has tested);
#   runtime  bookworm-slim with only the shared-library packages of the binaries, non-root,
#            strata-server as entrypoint and strata-health-probe as HEALTHCHECK.
# Build and run: deploy/README.md (podman needs `--format docker` to keep the HEALTHCHECK).
FROM debian:bookworm AS build
WORKDIR /src
COPY scripts/install-deps.sh scripts/
RUN bash scripts/install-deps.sh && rm -rf /var/lib/apt/lists/*
# The integration tests use ../shared/maps as strata-server's map root, skip the tests of
# the map files they do not find, and preload its README.md as a file that is no map; the
# context has no shared/, so give them a directory with only such a README.
RUN mkdir -p /shared/maps \
    && echo "Placeholder: the shared maps are not part of the image build." > /shared/maps/README.md
COPY . .
# STRATA_RUN_TESTS=0 builds an image of a commit that CI has tested already: no tests are built
# or run (about 21 minutes saved on two cores). The default builds and runs them all.
ARG STRATA_RUN_TESTS=1
# The commit the image is of, for strata_build_info (the context has no .git):
# --build-arg STRATA_COMMIT=$(git rev-parse --short=12 HEAD).
ARG STRATA_COMMIT=unknown
RUN tests=$([ "$STRATA_RUN_TESTS" = 1 ] && echo ON || echo OFF) \
    && cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release -DSTRATA_BUILD_TESTS=$tests \
       -DSTRATA_COMMIT=$STRATA_COMMIT \
       -DSTRATA_BUILD_BENCH=$tests \
    && cmake --build build \
    && if [ "$tests" = ON ]; then ctest --test-dir build --output-on-failure -j "$(nproc)"; fi
# The binaries the image ships; the `strata` CLI only when this tree builds it.
RUN mkdir -p /out \
    && cp build/server/strata-server build/server/strata-map-worker \
          build/deploy/health_probe/strata-health-probe \
          build/tools/offline/strata-offline /out/ \
    && if [ -x build/client/strata ]; then cp build/client/strata /out/; fi \
    && strip --strip-unneeded /out/*

FROM debian:bookworm-slim AS runtime
# Runtime libraries only (their dependencies come along): gRPC and protobuf, prometheus-cpp's
# core (metrics), libmicrohttpd (the web viewer and /metrics), PCL common/io/kdtree/sample_consensus (io pulls
# VTK), OctoMap and OpenMP. The viewer's page is compiled into strata-server.
RUN apt-get update \
    && DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends \
       libgrpc++1.51 libprotobuf32 libprometheus-cpp-core1.0 libmicrohttpd12 \
       libpcl-common1.13 libpcl-io1.13 libpcl-kdtree1.13 libpcl-sample-consensus1.13 \
       liboctomap1.9 libgomp1 \
    && rm -rf /var/lib/apt/lists/*
COPY --from=build /out/ /usr/local/bin/
# Fails the build when a binary needs a library the list above does not bring.
RUN if ldd /usr/local/bin/* | grep 'not found'; then exit 1; fi \
    && groupadd --system --gid 10001 strata \
    && useradd --system --uid 10001 --gid 10001 --no-create-home --home-dir /nonexistent \
       --shell /usr/sbin/nologin strata \
    && mkdir -p /maps
# Configuration through strata-server's environment variables (server/README.md); a flag
# given as a command argument overrides its variable. Change the port through STRATA_LISTEN,
# not --listen: the health probe reads STRATA_LISTEN to find the server.
ENV STRATA_LISTEN=0.0.0.0:50051 \
    STRATA_METRICS_PORT=9090 \
    STRATA_METRICS_ADDRESS=0.0.0.0 \
    STRATA_HTTP_PORT=8080 \
    STRATA_MAP_ROOT=/maps
# Map files (PCD, PLY, OctoMap) under the map root; the server only reads them.
VOLUME ["/maps"]
# gRPC, Prometheus /metrics, the web viewer.
EXPOSE 50051 9090 8080
USER 10001:10001
# SERVING once every preloaded map is ACTIVE; the start period covers a map's assessment.
HEALTHCHECK --interval=15s --timeout=5s --start-period=120s --retries=3 \
    CMD ["strata-health-probe", "--timeout-s", "3"]
STOPSIGNAL SIGTERM
ENTRYPOINT ["strata-server"]
# No arguments: serves the built-in demo scene as map "demo".
CMD []
