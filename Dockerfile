# syntax=docker/dockerfile:1
# Multi-stage build: compile in the Rust image, run on a slim Debian as a non-root user.

FROM rust:1.95-slim-bookworm AS build
WORKDIR /src
# Build dependencies first so that source edits do not rebuild them.
COPY Cargo.toml Cargo.lock ./
RUN mkdir src benches && echo 'fn main() {}' > src/main.rs && echo '' > src/lib.rs \
 && echo 'fn main() {}' | tee benches/pipeline.rs > benches/parameterize.rs \
 && cargo build --release --locked \
 && rm -rf src benches
COPY src ./src
# Not built here, but Cargo.toml names them ([[bench]]), so they must exist.
COPY benches ./benches
COPY proto ./proto
RUN touch src/main.rs src/lib.rs && cargo build --release --locked \
 && cp target/release/texatlas /usr/local/bin/texatlas

FROM debian:bookworm-slim AS runtime
# No curl in the slim image: the health check speaks HTTP/1.0 over bash's /dev/tcp.
RUN useradd --system --uid 10001 --home-dir /data --shell /usr/sbin/nologin texatlas \
 && mkdir -p /data && chown texatlas /data
COPY --from=build /usr/local/bin/texatlas /usr/local/bin/texatlas
USER texatlas
WORKDIR /data
VOLUME ["/data"]
# `texatlas serve` reads these; override with -e or flags.
ENV TEXATLAS_BIND=0.0.0.0:8080 \
    TEXATLAS_DATA_DIR=/data \
    TEXATLAS_LOG_FORMAT=json
EXPOSE 8080
HEALTHCHECK --interval=15s --timeout=3s --start-period=5s --retries=3 \
  CMD ["bash", "-c", "exec 3<>/dev/tcp/127.0.0.1/8080 && printf 'GET /healthz HTTP/1.0\\r\\n\\r\\n' >&3 && head -n1 <&3 | grep -q ' 200 '"]
# SIGTERM (docker stop) shuts down gracefully: running jobs finish or go back to the queue.
STOPSIGNAL SIGTERM
ENTRYPOINT ["texatlas"]
CMD ["serve"]
