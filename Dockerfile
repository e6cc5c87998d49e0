# vismap: build with the same setup script CI uses, then a slim runtime with PoCL.
# On NVIDIA nodes the container runtime mounts the NVIDIA OpenCL ICD beside PoCL.
FROM debian:12 AS build
WORKDIR /src
COPY scripts/setup.sh scripts/setup.sh
RUN ./scripts/setup.sh
COPY . .
RUN cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DVISMAP_BUILD_TESTS=OFF \
 && cmake --build build -j"$(nproc)"

FROM debian:12-slim
RUN apt-get update -qq \
 && apt-get install -y -qq --no-install-recommends ocl-icd-libopencl1 pocl-opencl-icd libtinygltf2d libstb0 zlib1g \
 && rm -rf /var/lib/apt/lists/* \
 && useradd --create-home --uid 10001 vismap
COPY --from=build /src/build/vismap /usr/local/bin/vismap
COPY --from=build /src/data /usr/share/vismap/data
USER vismap
WORKDIR /home/vismap
ENTRYPOINT ["vismap"]
CMD ["render", "/usr/share/vismap/data/bunny.ply", "-o", "/tmp/bunny.svg", "--stats"]
