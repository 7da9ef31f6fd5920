# lensim's container image for cluster renders (docs/cluster.md): Debian 12, the Debian packages
# lensim builds with, a Release build of the renderer alone (no tests or benchmarks), and a
# slim runtime stage with lensim at /usr/local/bin/lensim and the repository's lenses.
#   docker build -t lensim:latest .
FROM debian:12 AS build
RUN apt-get update \
 && apt-get install -y --no-install-recommends \
      build-essential cmake ninja-build pkg-config \
      libembree-dev libtbb-dev libopenexr-dev libtiff-dev libpng-dev zlib1g-dev \
      libfmt-dev libcli11-dev nlohmann-json3-dev libnanovdb-dev \
 && rm -rf /var/lib/apt/lists/*
WORKDIR /src
COPY CMakeLists.txt ./
COPY src ./src
RUN cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release \
      -DLENSIM_BUILD_TESTS=OFF -DLENSIM_BUILD_BENCH=OFF \
 && cmake --build build --target lensim

FROM debian:12-slim
# The shared libraries lensim links (the runtime halves of the -dev packages above).
RUN apt-get update \
 && apt-get install -y --no-install-recommends \
      libembree3-3 libtbb12 libopenexr-3-1-30 libimath-3-1-29 libtiff6 libpng16-16 zlib1g \
      libfmt9 \
 && rm -rf /var/lib/apt/lists/*
COPY --from=build /src/build/lensim /usr/local/bin/lensim
COPY lenses /usr/local/share/lensim/lenses
RUN lensim --version
WORKDIR /data
ENTRYPOINT []
CMD ["lensim", "--help"]
