// Implicit surface tolerance sweep (issue 19, docs/IMPLICIT.md "3D"): for a scene with one
// implicit object (its first mesh) and each tolerance, the dicing's time (tessellate, median of
// 3 warm calls) and its parts (queue, corners, meshing), cells per axis (the finest leaves'),
// leaf cells, triangles, back faces left out, regions left out as hidden behind full boxes, the whole warm frame (tessellate + render, median of 3), the largest
// |f| / |grad f| at output vertices (world units, and in pixels at the vertex's depth), and the
// pixel error against a dense reference: rays through sampled pixels of an R x R grid (default
// 4096, the same view) cast against f by interval bisection along the ray with tape shortening
// (no dicing involved), against the z-buffer id raster at R x R of this tolerance's triangles:
// object or background per pixel. A sample counts when the reference's rays at the sample and
// at 8 neighbours one sweep pixel (R / size) away agree (away from edges); a hole is a sample
// the reference shows covered and ours not. The leaves' shortened tape lengths (histogram) are
// printed for the default tolerance.
//   build/bench/vismap_implicit_sweep SCENE.json [--samples 4000] [--raster 4096]
//       [--tolerances 16,8,4,2] [--csv OUT.csv]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "core/error.h"
#include "core/implicit/implicit.h"
#include "core/pipeline.h"
#include "core/util/clock.h"

using namespace vismap;
using implicit::Interval;
using implicit::Tape;

namespace {

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}


struct Ray {
  double o[3], d[3];
};

// The ray through pixel centre (px, py) of an R x R view of `cam` (perspective, square).
Ray pixel_ray(const Camera& cam, uint32_t R, double px, double py) {
  double f[3], r[3], u[3];
  for (int k = 0; k < 3; ++k) f[k] = cam.target[k] - cam.eye[k];
  const double fl = std::sqrt(f[0] * f[0] + f[1] * f[1] + f[2] * f[2]);
  for (double& v : f) v /= fl;
  r[0] = f[1] * cam.up[2] - f[2] * cam.up[1];
  r[1] = f[2] * cam.up[0] - f[0] * cam.up[2];
  r[2] = f[0] * cam.up[1] - f[1] * cam.up[0];
  const double rl = std::sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2]);
  for (double& v : r) v /= rl;
  u[0] = r[1] * f[2] - r[2] * f[1];
  u[1] = r[2] * f[0] - r[0] * f[2];
  u[2] = r[0] * f[1] - r[1] * f[0];
  const double t = std::tan(cam.fov_y_deg * M_PI / 360);
  const double x = ((px + 0.5) / R * 2 - 1) * t * double(cam.width) / cam.height;
  const double y = (1 - (py + 0.5) / R * 2) * t;
  Ray ray;
  for (int k = 0; k < 3; ++k) {
    ray.o[k] = cam.eye[k];
    ray.d[k] = f[k] + x * r[k] + y * u[k];
  }
  return ray;
}

// Does the ray meet f < 0 inside the box, between the near plane and the box's far side?
// Bisection of the ray's parameter: each piece's bounding box in intervals (with the piece's
// tape shortened), near pieces first; full: a hit; empty: skipped; down to a piece of length
// `eps`, where f at the piece's ends and middle decides.
bool ray_hits(const Tape& t, const std::array<double, 6>& box, const Ray& ray, double t_near,
              double eps) {
  double t0 = t_near, t1 = 1e30;
  for (int k = 0; k < 3; ++k) {  // slab clip to the box
    if (ray.d[k] == 0) {
      if (ray.o[k] < box[k] || ray.o[k] > box[k + 3]) return false;
      continue;
    }
    double a = (box[k] - ray.o[k]) / ray.d[k], b = (box[k + 3] - ray.o[k]) / ray.d[k];
    if (a > b) std::swap(a, b);
    t0 = std::max(t0, a);
    t1 = std::min(t1, b);
  }
  if (!(t0 < t1)) return false;
  struct Piece {
    double a, b;
    std::shared_ptr<const Tape> tape;
  };
  std::vector<Piece> stack{{t0, t1, std::make_shared<const Tape>(t)}};
  std::vector<uint8_t> choices;
  const double dl = std::sqrt(ray.d[0] * ray.d[0] + ray.d[1] * ray.d[1] + ray.d[2] * ray.d[2]);
  while (!stack.empty()) {
    Piece p = stack.back();
    stack.pop_back();
    Interval iv[3];
    for (int k = 0; k < 3; ++k) {
      const double u = ray.o[k] + p.a * ray.d[k], v = ray.o[k] + p.b * ray.d[k];
      iv[k] = {std::min(u, v), std::max(u, v)};
    }
    const Interval f = implicit::eval_interval(*p.tape, iv[0], iv[1], iv[2], &choices);
    if (f.lo >= 0) continue;
    if (f.hi < 0) return true;
    if ((p.b - p.a) * dl < eps) {
      for (double s : {p.a, 0.5 * (p.a + p.b), p.b})
        if (implicit::eval(*p.tape, ray.o[0] + s * ray.d[0], ray.o[1] + s * ray.d[1],
                           ray.o[2] + s * ray.d[2]) < 0)
          return true;
      continue;
    }
    auto shorter = std::make_shared<const Tape>(implicit::shorten(*p.tape, choices));
    const double m = 0.5 * (p.a + p.b);
    stack.push_back({m, p.b, shorter});
    stack.push_back({p.a, m, shorter});
  }
  return false;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr,
                 "usage: vismap_implicit_sweep SCENE [--samples N] [--raster R] "
                 "[--tolerances A,B,..] [--csv OUT]\n");
    return 2;
  }
  std::string file = argv[1], csv, tol_list = "16,8,4,2";
  uint32_t raster = 4096, samples = 4000;
  for (int i = 2; i + 1 < argc; i += 2) {
    std::string f = argv[i];
    if (f == "--samples") samples = uint32_t(std::stoul(argv[i + 1]));
    else if (f == "--raster") raster = uint32_t(std::stoul(argv[i + 1]));
    else if (f == "--tolerances") tol_list = argv[i + 1];
    else if (f == "--csv") csv = argv[i + 1];
  }
  std::vector<float> tols;
  for (size_t at = 0; at < tol_list.size();) {
    size_t comma = tol_list.find(',', at);
    tols.push_back(std::stof(tol_list.substr(at, comma - at)));
    at = comma == std::string::npos ? tol_list.size() : comma + 1;
  }
  try {
    const auto t_load = Clock::now();
    Scene s = load_scene(file);
    const double load_ms = ms_since(t_load);
    if (s.meshes.empty() || !s.meshes[0].implicit)
      throw std::runtime_error("the scene's first mesh must be an implicit object");
    const Mesh& obj = s.meshes[0];
    for (int k = 0; k < 16; ++k)
      if (obj.implicit_xform[k] != (k % 5 == 0 ? 1.0 : 0.0))
        throw std::runtime_error("the implicit object must have no transform (the reference "
                                 "casts rays in its own space)");
    Camera cam = s.camera ? *s.camera : frame_scene(s, 1024, 1024);
    if (cam.projection != Camera::Projection::Perspective || cam.width != cam.height)
      throw std::runtime_error("the bench needs a square perspective camera");
    if (cam.near_plane <= 0 || cam.far_plane <= 0) fit_near_far(cam, scene_bounds(s));
    const uint32_t size = cam.width;
    Camera big = cam;
    big.width = big.height = raster;
    const Tape clipped = implicit::clipped_to_box(*obj.implicit, obj.implicit_box.data(),
                                                  obj.implicit_box.data() + 3, 3);
    Scene only = s;
    only.meshes.resize(1);  // the reference and the raster see the implicit object alone

    // The reference: sampled pixels, each with its 8 neighbours a sweep pixel away.
    const double step = double(raster) / size;
    std::mt19937 rng(1);
    std::uniform_real_distribution<double> u(2 * step, raster - 2 * step);
    struct Sample {
      uint32_t x, y;
      bool hit, interior;
    };
    std::vector<Sample> ref;
    const auto t_ref = Clock::now();
    const double f_px = raster / (2 * std::tan(cam.fov_y_deg * M_PI / 360));
    double far_dist = 0;
    for (int c = 0; c < 8; ++c) {
      double d2 = 0;
      for (int k = 0; k < 3; ++k) {
        const double x = obj.implicit_box[(c >> k & 1) ? k + 3 : k];
        d2 += (x - cam.eye[k]) * (x - cam.eye[k]);
      }
      far_dist = std::max(far_dist, std::sqrt(d2));
    }
    for (uint32_t i = 0; i < samples; ++i) {
      Sample smp{uint32_t(u(rng)), uint32_t(u(rng)), false, true};
      bool first = true;
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const Ray ray = pixel_ray(big, raster, smp.x + dx * step, smp.y + dy * step);
          // Bisection down to a tenth of a reference pixel at the box's farthest corner.
          const double eps = 0.1 * far_dist / f_px;
          const double dl = std::sqrt(ray.d[0] * ray.d[0] + ray.d[1] * ray.d[1] + ray.d[2] * ray.d[2]);
          const bool h = ray_hits(clipped, obj.implicit_box, ray, cam.near_plane / dl, eps);
          if (first) smp.hit = h, first = false;
          else smp.interior = smp.interior && h == smp.hit;
        }
      ref.push_back(smp);
    }
    uint64_t inner = 0, inner_hit = 0;
    for (const Sample& smp : ref) inner += smp.interior, inner_hit += smp.interior && smp.hit;
    std::printf("%s at %ux%u: load %.0f ms (bounds search included); reference: %u sampled "
                "pixels of %ux%u, 9 rays each, %.1f s; %llu away from edges (%llu on the object)\n",
                file.c_str(), size, size, load_ms, samples, raster, raster,
                ms_since(t_ref) / 1000, (unsigned long long)inner, (unsigned long long)inner_hit);
    std::printf("| tolerance px | cells/axis | leaf cells | triangles | back faces out | hidden "
                "regions | tessellate ms (queue, corners, mesh) | frame ms | largest "
                "abs(f)/abs(grad f) px | pixel error | hole pixels |\n"
                "|---|---|---|---|---|---|---|---|---|---|---|\n");
    FILE* out = csv.empty() ? nullptr : std::fopen(csv.c_str(), "w");
    if (out)
      std::fprintf(out, "tolerance_px,cells,leaves,triangles,back_faces,hidden_regions,"
                        "tessellate_ms,queue_ms,corners_ms,mesh_ms,frame_ms,max_error_world,"
                        "max_error_px,pixel_error,hole_pixels\n");
    Renderer r;
    const Mat4 view = cam.view();
    const double fpx = cam.height / (2 * std::tan(cam.fov_y_deg * M_PI / 360));
    const implicit::SlotTape code = implicit::allocate_slots(clipped);
    for (float tol : tols) {
      TessellateOptions o;
      o.implicit_tolerance_px = tol;
      TessellateStats st;
      Scene d = r.tessellate(s, cam, o, &st);
      r.render(d, cam);  // first render of this size: buffers, kernels
      std::vector<double> tess, queue, corners, mesh, frame;
      for (int i = 0; i < 3; ++i) {
        d = r.tessellate(s, cam, o, &st);
        tess.push_back(st.ms);
        queue.push_back(st.implicit_queue_ms);
        corners.push_back(st.implicit_points_ms);
        mesh.push_back(st.implicit_mesh_ms);
      }
      for (int i = 0; i < 3; ++i) {
        auto t0 = Clock::now();
        Scene e = r.tessellate(s, cam, o);
        r.render(e, cam);
        frame.push_back(ms_since(t0));
      }
      // |f| / |grad f| at the vertices (f 1-Lipschitz or not, the first-order distance).
      const Mesh& m = d.meshes[0];
      double worst = 0, worst_px = 0;
      for (size_t v = 0; v < m.vertex_count(); ++v) {
        double g[3];
        const double x = m.positions[3 * v], y = m.positions[3 * v + 1], z = m.positions[3 * v + 2];
        const double f = implicit::eval_code_grad(code.code.data(), code.size(), code.slots,
                                                  code.root_slot, x, y, z, g);
        const double gl = std::sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]);
        if (!(gl > 0)) continue;
        const double dist = std::abs(f) / gl;
        const double depth = -(view[2] * x + view[6] * y + view[10] * z + view[14]);
        worst = std::max(worst, dist);
        if (depth > cam.near_plane) worst_px = std::max(worst_px, dist * fpx / depth);
      }
      Scene mine = d;
      mine.meshes.resize(1);
      std::vector<uint32_t> ids;
      r.raster_ids(mine, big, &ids);
      uint64_t wrong = 0, holes = 0;
      for (const Sample& smp : ref) {
        if (!smp.interior) continue;
        const bool ours = ids[size_t(smp.y) * raster + smp.x] != ~0u;
        wrong += ours != smp.hit;
        holes += smp.hit && !ours;
      }
      const double pe = double(wrong) / double(std::max<uint64_t>(inner, 1));
      std::printf("| %.2f | %llu | %llu | %zu | %llu | %llu | %.0f (%.0f, %.0f, %.0f) | %.0f | "
                  "%.4f (%.2f px) | %.2e | %llu |\n",
                  tol, (unsigned long long)st.implicit_cells,
                  (unsigned long long)st.implicit_leaves, m.triangle_count(),
                  (unsigned long long)st.implicit_back_faces,
                  (unsigned long long)st.implicit_occluded, median(tess), median(queue),
                  median(corners), median(mesh), median(frame), worst, worst_px, pe,
                  (unsigned long long)holes);
      if (tol == TessellateOptions{}.implicit_tolerance_px) {
        std::printf("  clauses per leaf at %.1f px (full tape %llu):", tol,
                    (unsigned long long)st.implicit_clauses_full);
        for (size_t b = 0; b < st.implicit_clause_hist.size(); ++b)
          if (st.implicit_clause_hist[b])
            std::printf(" [%u,%u): %llu", 1u << b, 2u << b,
                        (unsigned long long)st.implicit_clause_hist[b]);
        std::printf("; mean %.1f\n", double(st.implicit_leaf_clauses) / double(st.implicit_leaves));
      }
      if (out)
        std::fprintf(out, "%g,%llu,%llu,%zu,%llu,%llu,%.1f,%.1f,%.1f,%.1f,%.1f,%.5f,%.3f,%.3e,%llu\n",
                     tol, (unsigned long long)st.implicit_cells,
                     (unsigned long long)st.implicit_leaves, m.triangle_count(),
                     (unsigned long long)st.implicit_back_faces,
                     (unsigned long long)st.implicit_occluded, median(tess), median(queue),
                     median(corners), median(mesh), median(frame), worst, worst_px, pe,
                     (unsigned long long)holes);
      std::fflush(stdout);
    }
    if (out) std::fclose(out);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "vismap_implicit_sweep: %s\n", e.what());
    return 1;
  }
}
