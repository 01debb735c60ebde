# Multi-stage build on Debian bookworm: the build stage compiles and runs the test suite, the
# runtime stage carries only the binaries and their shared libraries' packages.
# (The gRPC server and its health probe arrive with the service issue; until then the image
# runs the offline assessment tool.)
FROM debian:bookworm AS build
WORKDIR /src
COPY scripts/install-deps.sh scripts/
RUN bash scripts/install-deps.sh && rm -rf /var/lib/apt/lists/*
COPY . .
RUN cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release \
    && cmake --build build \
    && ctest --test-dir build --output-on-failure -j "$(nproc)"

FROM debian:bookworm-slim AS runtime
RUN apt-get update \
    && DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends \
       libpcl-io1.13 libpcl-sample-consensus1.13 liboctomap1.9 libgomp1 \
    && rm -rf /var/lib/apt/lists/*
COPY --from=build /src/build/bench/strata-offline /usr/local/bin/strata-offline
RUN useradd --system --uid 10001 strata
USER strata
ENTRYPOINT ["strata-offline"]
CMD ["assess", "scene:two_level_ramp"]
