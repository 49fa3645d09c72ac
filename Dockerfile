# syntax=docker/dockerfile:1
# Multi-stage build: compile in the Rust image, run on a slim Debian as a non-root user.

FROM rust:1.95-slim-bookworm AS build
WORKDIR /src
# Build dependencies first so that source edits do not rebuild them.
COPY Cargo.toml Cargo.lock ./
RUN mkdir src && echo 'fn main() {}' > src/main.rs && echo '' > src/lib.rs \
 && cargo build --release --locked \
 && rm -rf src
COPY src ./src
COPY proto ./proto
RUN touch src/main.rs src/lib.rs && cargo build --release --locked \
 && cp target/release/texatlas /usr/local/bin/texatlas

FROM debian:bookworm-slim AS runtime
RUN useradd --system --uid 10001 --home-dir /data --shell /usr/sbin/nologin texatlas \
 && mkdir -p /data && chown texatlas /data
COPY --from=build /usr/local/bin/texatlas /usr/local/bin/texatlas
USER texatlas
WORKDIR /data
VOLUME ["/data"]
ENTRYPOINT ["texatlas"]
CMD ["--help"]
