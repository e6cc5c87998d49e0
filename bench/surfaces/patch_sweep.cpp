// Bezier patch tolerance sweep (issue 18, docs/SURFACES.md "Bezier patches"): for each tolerance,
// the dicing's time (tessellate, median of 5 warm calls), triangle count, the largest screen
// distance between triangles and surface (sampled: 15 points per triangle against the patch in
// double precision), the whole warm frame (tessellate + render, median of 3), and the pixel error
// against a dense reference: the z-buffer id raster at R x R (default 4096, the same view) of the
// patches diced at 0.02 px, against the raster of this tolerance's dicing, both mapped to patch
// ids; counted away from edges (pixels farther than one pixel of the swept frame, raster / size
// raster pixels, from any change of id in the reference),
// and hole pixels (the reference shows a patch, ours the background).
//   build/bench/vismap_patch_sweep FILE [--size 1024] [--raster 4096] [--csv OUT.csv]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "core/error.h"
#include "core/pipeline.h"

using namespace vismap;

namespace {

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

std::array<double, 3> project(const Mat4& m, double w_px, double h_px, const std::array<double, 3>& p) {
  double q[4];
  for (int r = 0; r < 4; ++r) q[r] = m[r] * p[0] + m[4 + r] * p[1] + m[8 + r] * p[2] + m[12 + r];
  return {(q[0] / q[3] + 1) * 0.5 * w_px, (1 - q[1] / q[3]) * 0.5 * h_px, q[3]};
}

double max_error(const Mesh& patches, const Mesh& d, const Camera& cam) {
  const Mat4 m = cam.view_projection();
  double worst = 0;
  const int k = 4;
  for (size_t t = 0; t < d.triangle_count(); ++t) {
    std::array<double, 3> p[3];
    bool front = true;
    for (int c = 0; c < 3; ++c) {
      for (int j = 0; j < 3; ++j) p[c][j] = d.positions[3 * d.indices[3 * t + c] + j];
      front &= project(m, cam.width, cam.height, p[c])[2] > cam.near_plane;
    }
    if (!front) continue;
    for (int i = 0; i <= k; ++i)
      for (int j = 0; i + j <= k; ++j) {
        const double b[3] = {double(i) / k, double(j) / k, double(k - i - j) / k};
        std::array<double, 3> q{0, 0, 0};
        double u = 0, v = 0;
        for (int c = 0; c < 3; ++c) {
          for (int x = 0; x < 3; ++x) q[x] += b[c] * p[c][x];
          u += b[c] * d.uv[6 * t + 2 * c];
          v += b[c] * d.uv[6 * t + 2 * c + 1];
        }
        auto a = project(m, cam.width, cam.height, q);
        if (a[0] < 0 || a[0] > cam.width || a[1] < 0 || a[1] > cam.height) continue;
        auto s = project(m, cam.width, cam.height, patch_point(patches, d.face_ids[t], u, v));
        worst = std::max(worst, std::hypot(s[0] - a[0], s[1] - a[1]));
      }
  }
  return worst;
}

// Patch id per pixel (~0u background) of a diced single-mesh scene.
std::vector<uint32_t> patch_raster(Renderer& r, const Scene& diced, const Camera& cam) {
  std::vector<uint32_t> ids;
  r.raster_ids(diced, cam, &ids);
  for (uint32_t& id : ids)
    if (id != ~0u) id = diced.meshes[0].face_ids[id];
  return ids;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: vismap_patch_sweep FILE [--size N] [--raster R] [--csv OUT]\n");
    return 2;
  }
  std::string file = argv[1], csv;
  uint32_t size = 1024, raster = 4096;
  for (int i = 2; i + 1 < argc; i += 2) {
    std::string f = argv[i];
    if (f == "--size") size = uint32_t(std::stoul(argv[i + 1]));
    else if (f == "--raster") raster = uint32_t(std::stoul(argv[i + 1]));
    else if (f == "--csv") csv = argv[i + 1];
  }
  try {
    Scene s = load_scene(file);
    Camera cam = frame_scene(s, size, size);
    Camera big = cam;
    big.width = big.height = raster;
    Renderer r;
    // The reference: diced for the big raster's own pixels at 0.02 of the sweep's pixel.
    Scene ref = r.tessellate(s, big, TessellateOptions{0.02f * float(raster) / float(size)});
    const std::vector<uint32_t> ref_ids = patch_raster(r, ref, big);
    // Away from edges: every pixel within one pixel of the sweep's frame (raster / size of the
    // raster's) shows the same id in the reference (rows first, then columns).
    const int rad = int(std::max<uint32_t>(1, raster / size));
    std::vector<uint8_t> row_same(ref_ids.size(), 0), interior(ref_ids.size(), 0);
    for (uint32_t y = 0; y < raster; ++y)
      for (int x = rad; x + rad < int(raster); ++x) {
        const uint32_t* line = &ref_ids[size_t(y) * raster];
        bool same = true;
        for (int dx = -rad; dx <= rad && same; ++dx) same = line[x + dx] == line[x];
        row_same[size_t(y) * raster + x] = same;
      }
    uint64_t covered = 0, inner = 0;
    for (int y = rad; y + rad < int(raster); ++y)
      for (int x = rad; x + rad < int(raster); ++x) {
        const size_t at = size_t(y) * raster + x;
        const uint32_t id = ref_ids[at];
        covered += id != ~0u;
        bool same = true;
        for (int dy = -rad; dy <= rad && same; ++dy)
          same = row_same[at + dy * int64_t(raster)] && ref_ids[at + dy * int64_t(raster)] == id;
        interior[at] = same;
        inner += same && id != ~0u;
      }
    std::printf("%s at %ux%u: reference %zu triangles, raster %ux%u (%llu object pixels, %llu "
                "away from edges)\n",
                file.c_str(), size, size, ref.meshes[0].triangle_count(), raster, raster,
                (unsigned long long)covered, (unsigned long long)inner);
    std::printf("| tolerance px | triangles | tessellate ms | frame ms | largest error px | "
                "pixel error | hole pixels |\n|---|---|---|---|---|---|---|\n");
    FILE* out = csv.empty() ? nullptr : std::fopen(csv.c_str(), "w");
    if (out)
      std::fprintf(out, "tolerance_px,triangles,tessellate_ms,frame_ms,max_error_px,pixel_error,"
                        "hole_pixels,over_rate\n");
    for (float tol : {4.0f, 2.0f, 1.0f, 0.5f, 0.2f, 0.1f}) {
      TessellateOptions o{tol};
      TessellateStats st;
      Scene d = r.tessellate(s, cam, o, &st);
      r.render(d, cam);  // first render of this size: buffers, kernels
      std::vector<double> tess, frame;
      for (int i = 0; i < 5; ++i) {
        d = r.tessellate(s, cam, o, &st);
        tess.push_back(st.ms);
      }
      for (int i = 0; i < 3; ++i) {
        auto t0 = std::chrono::steady_clock::now();
        Scene e = r.tessellate(s, cam, o);
        r.render(e, cam);
        frame.push_back(
            std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
      }
      const double err = max_error(s.meshes[0], d.meshes[0], cam);
      const std::vector<uint32_t> ids = patch_raster(r, d, big);
      uint64_t wrong = 0, holes = 0;
      for (size_t i = 0; i < ids.size(); ++i) {
        if (!interior[i]) continue;
        if (ids[i] != ref_ids[i] && (ref_ids[i] != ~0u || ids[i] != ~0u)) ++wrong;
        if (ref_ids[i] != ~0u && ids[i] == ~0u) ++holes;
      }
      const double pe = double(wrong) / double(std::max<uint64_t>(inner, 1));
      std::printf("| %.2f | %zu | %.2f | %.1f | %.3f | %.2e | %llu |%s\n", tol,
                  d.meshes[0].triangle_count(), median(tess), median(frame), err, pe,
                  (unsigned long long)holes, st.over_rate ? " (over rate)" : "");
      if (out)
        std::fprintf(out, "%g,%zu,%.3f,%.2f,%.4f,%.3e,%llu,%llu\n", tol,
                     d.meshes[0].triangle_count(), median(tess), median(frame), err, pe,
                     (unsigned long long)holes, (unsigned long long)st.over_rate);
      std::fflush(stdout);
    }
    if (out) std::fclose(out);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "vismap_patch_sweep: %s\n", e.what());
    return 1;
  }
}
