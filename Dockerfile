# vismap: build with the same setup script CI uses, then a slim runtime with PoCL.
# Ships the CLI (`vismap`), the streaming server (`vismapd`, the default command) and
# `vismap-client` (also the HEALTHCHECK probe, so the runtime needs no curl). See docs/DEPLOY.md.
#
# GPU nodes: the NVIDIA container runtime (nvidia-container-toolkit; on Kubernetes the NVIDIA
# device plugin) mounts the driver's libnvidia-opencl.so.1 into the container when
# NVIDIA_DRIVER_CAPABILITIES includes `compute`. The ICD loader (ocl-icd) finds it through
# /etc/OpenCL/vendors/nvidia.icd, written below; on CPU nodes that library is absent, the loader
# skips the entry and PoCL's CPU device is used. Pick the device with VISMAP_DEVICE or --device.
FROM debian:12 AS build
WORKDIR /src
COPY scripts/setup.sh scripts/setup.sh
RUN ./scripts/setup.sh
COPY . .
RUN cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DVISMAP_BUILD_TESTS=OFF -DVISMAP_BUILD_SERVER=ON \
 && cmake --build build -j"$(nproc)" --target vismap vismapd vismap-client

FROM debian:12-slim
# The shared libraries of vismap and vismapd (ldd: libOpenCL, libtinygltf, libstb, zlib, meshoptimizer
# and zstd (compact and delta frames), cairo (PDF, EPS and PNG output); vismap
# also GMP and MPFR for `vismap check`).
RUN apt-get update -qq \
 && apt-get install -y -qq --no-install-recommends ocl-icd-libopencl1 pocl-opencl-icd libtinygltf2d libstb0 zlib1g libgmpxx4ldbl libmpfr6 libgmp10 libmeshoptimizer2d libzstd1 libcairo2 \
 && rm -rf /var/lib/apt/lists/* \
 && mkdir -p /etc/OpenCL/vendors \
 && echo libnvidia-opencl.so.1 > /etc/OpenCL/vendors/nvidia.icd \
 && useradd --create-home --uid 10001 vismap
COPY --from=build /src/build/vismap /usr/local/bin/vismap
COPY --from=build /src/build/server/vismapd /usr/local/bin/vismapd
COPY --from=build /src/build/clients/vismap-client /usr/local/bin/vismap-client
COPY --from=build /src/server/www /usr/share/vismap/www
COPY --from=build /src/data /usr/share/vismap/data
# compute: the runtime mounts the NVIDIA OpenCL library; utility: nvidia-smi for debugging.
# Caches (vismap's compiled programs, PoCL's kernels) go to /tmp so the root filesystem may be
# read-only; mount a volume there to keep them across restarts.
ENV NVIDIA_DRIVER_CAPABILITIES=compute,utility \
    XDG_CACHE_HOME=/tmp/cache \
    POCL_CACHE_DIR=/tmp/cache/pocl
USER 10001:10001
WORKDIR /home/vismap
EXPOSE 8080
HEALTHCHECK --interval=10s --timeout=5s --start-period=30s --retries=3 \
  CMD ["vismap-client", "--health", "http://127.0.0.1:8080/health"]
# vismapd drains on SIGTERM (drain_timeout_s, 10 s by default): `docker stop -t 15`.
STOPSIGNAL SIGTERM
CMD ["vismapd", "--address", "0.0.0.0", "--port", "8080", "--library", "/usr/share/vismap/data", \
     "--www", "/usr/share/vismap/www"]
