// Bicubic Bezier patches diced for the camera (issue 18, docs/SURFACES.md "Bezier patches").
// Device, every frame (kernels/patches.cl): patch_rates culls each patch against the view and
// bounds it (interior rates, each side's demand). Host: one read; each side gets the largest
// demand of the patches sharing it (keyed by its control points), the counts are summed; then
// patch_dice writes every patch's vertices and triangles into its slice. Host again: vertices
// with equal positions are welded (the corners and side points that two patches share come out
// bit-identical, being evaluated from the same canonical side data with the same rate), and
// triangles the weld collapses (at poles) dropped.
// Whole patches only: a patch whose tolerance needs more than the largest rate (128 per side)
// is diced at that rate and counted in TessellateStats::over_rate (splitting it would fix it).
#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>

#include "core/error.h"
#include "core/surfaces/internal.h"
#include "core/util/format.h"
#include "core/util/weld.h"

namespace vismap::surfaces {

namespace {

}  // namespace

Mesh dice_patches(ClRuntime& rt, const Mesh& mesh, const Camera& cam_in, const TessellateOptions& o,
                  TessellateStats& st, const TimeCheck& check_time) {
  // Long on purpose (~170 lines): two launches (patch_rates, patch_dice) and the host steps
  // between and after them (a side's rate shared by its patches, poles, offsets, the weld), each
  // a block over the same plan and offset arrays, in the order the data moves.
  const size_t np = mesh.patch_count();
  if (np == 0 || mesh.patches.size() != 48 * np)
    throw InputError(InputErrorKind::EmptyMesh, "", mesh.name, "", -1,
                     "a patch mesh needs 16 control points per patch");
  if (np > 0xFFFFFFFFull)
    throw InputError(InputErrorKind::TooLarge, "", mesh.name, "", -1, "more than 2^32 patches");
  const uint32_t n = uint32_t(np);

  const DiceView view = dice_view(cam_in, mesh.patches);
  const Camera& cam = view.cam;
  const cl_float16& m = view.m;
  const bool persp = view.persp;
  const float f_px = view.f_px;
  // Perspective: a displacement's image grows with its distance r from the image centre by
  // sqrt(1 + (r / f)^2) at most (the projection's largest singular value); r up to the half
  // diagonal.
  const double r_px = 0.5 * std::hypot(double(cam.width), double(cam.height));
  const float k_px = persp ? float(f_px * std::sqrt(1 + (r_px / f_px) * (r_px / f_px))) : f_px;
  cl_float4 prm;
  prm.s[0] = k_px;
  prm.s[1] = float(r_px);
  prm.s[2] = persp ? float(cam.near_plane) : 1.0f;
  prm.s[3] = o.tolerance_px;

  cl::Buffer d_ctrl = rt.upload(mesh.patches, "patch control points");
  cl::Buffer d_rates = rt.alloc(48 * size_t(n), "patch rates");
  rt.launch(Stage::Tessellate, "patch_rates", n, d_ctrl, cl_uint(n), m, prm, cl_uint(persp),
            d_rates);
  std::vector<uint32_t> plan(12 * size_t(n));
  rt.read(Stage::Tessellate, d_rates, 0, 48 * size_t(n), plan.data());
  st.launches += 1;
  check_time();
  st.host_syncs += 1;

  // Each side gets the largest demand of the patches that share it (its four control points, bit
  // for bit with -0 as +0, in either direction); a side collapsed to a point (a pole) gets its
  // grid's rate instead: all its points are that point, so any rate is crack-free, and this one
  // gives each triangle at the pole the (u, v) of its own sector.
  using SideKey = std::array<uint32_t, 12>;
  auto side_key = [&](uint32_t p, int e, bool& point) {
    SideKey fwd, rev;
    point = true;
    for (int k = 0; k < 4; ++k) {
      const int i = e == 0 ? 0 : e == 1 ? 3 : k, j = e == 2 ? 0 : e == 3 ? 3 : k;
      for (int d = 0; d < 3; ++d) {
        const float x = mesh.patches[48 * size_t(p) + 3 * (4 * i + j) + d] + 0.0f;
        std::memcpy(&fwd[3 * k + d], &x, 4);
        rev[3 * (3 - k) + d] = fwd[3 * k + d];
      }
      if (k > 0) point &= std::equal(&fwd[0], &fwd[3], &fwd[3 * k]);
    }
    return std::min(fwd, rev);
  };
  std::map<SideKey, uint32_t> demand;
  std::vector<uint8_t> pole(4 * size_t(n), 0);
  for (uint32_t p = 0; p < n; ++p) {
    if (plan[12 * p + 6]) continue;
    for (int e = 0; e < 4; ++e) {
      bool point = false;
      uint32_t& d = demand[side_key(p, e, point)];
      d = std::max(d, plan[12 * p + e]);
      pole[4 * p + e] = point;
    }
  }
  std::vector<uint32_t> voff(n), toff(n);
  uint64_t nv = 0, nt = 0;
  for (uint32_t p = 0; p < n; ++p) {
    uint32_t* r = &plan[12 * p];
    voff[p] = uint32_t(nv);
    toff[p] = uint32_t(nt);
    if (r[6]) {
      ++st.culled;
      continue;
    }
    ++st.pieces;
    st.over_rate += r[7];
    uint32_t ne[4];
    for (int e = 0; e < 4; ++e) {
      bool point = false;
      ne[e] = demand[side_key(p, e, point)];
    }
    const uint32_t nu_b = r[4], nv_b = r[5];
    auto grid = [&](uint32_t b, int e0, int e1) {
      uint32_t g = b;
      if (!pole[4 * p + e0]) g = std::max(g, ne[e0]);
      if (!pole[4 * p + e1]) g = std::max(g, ne[e1]);
      return g + 2;
    };
    const uint32_t Nu = grid(nu_b, 0, 1), Nv = grid(nv_b, 2, 3);
    for (int e = 0; e < 4; ++e)
      if (pole[4 * p + e]) ne[e] = (e < 2 ? Nu : Nv) - 2;
    const float du = 1.0f / float(nu_b + 2), dv = 1.0f / float(nv_b + 2);
    for (int e = 0; e < 4; ++e) r[e] = ne[e];
    r[4] = Nu;
    r[5] = Nv;
    std::memcpy(&r[8], &dv, 4);
    std::memcpy(&r[9], &dv, 4);
    std::memcpy(&r[10], &du, 4);
    std::memcpy(&r[11], &du, 4);
    const uint64_t sides = uint64_t(ne[0]) + ne[1] + ne[2] + ne[3];
    nv += sides + 4 + uint64_t(Nu - 1) * (Nv - 1);
    nt += 2 * uint64_t(Nu - 2) * (Nv - 2) + sides + 2 * uint64_t(Nu - 2) + 2 * uint64_t(Nv - 2);
    if (nt > kMaxDicedTriangles || nv > 0xFFFFFFFFull)
      throw InputError(InputErrorKind::TooLarge, "", mesh.name, "patch", int64_t(p),
                       "dicing needs more than 2^27 triangles at tolerance " +
                           std::to_string(o.tolerance_px) + " px; raise the tolerance");
    // What the dice will hold at its peak, counted before anything is allocated (issue 35, case
    // 4: 100,000 crumpled patches reached 9.2 GB before the triangle cap refused them): the
    // device's and the host's arrays and the weld's table, 84 bytes a vertex and 72 a triangle.
    if (o.memory_budget && 84 * nv + 72 * nt > o.memory_budget)
      throw InputError(InputErrorKind::TooLarge, "", mesh.name, "patch", int64_t(p),
                       "dicing needs " + mib(84 * nv + 72 * nt) + " by this patch (" +
                           std::to_string(nt) + " triangles) at tolerance " +
                           std::to_string(o.tolerance_px) + " px, over the memory budget of " +
                           mib(o.memory_budget) + "; raise the tolerance or the budget");
  }

  check_time();

  Mesh out;
  out.name = mesh.name;
  out.color = mesh.color;
  out.soup = false;
  out.source_triangles = mesh.source_triangles ? mesh.source_triangles : n;
  if (nt == 0) return out;  // every patch outside the view

  cl::Buffer d_plan = rt.upload(plan, "patch plan");
  cl::Buffer d_voff = rt.upload(voff, "patch vertex offsets");
  cl::Buffer d_toff = rt.upload(toff, "patch triangle offsets");
  cl::Buffer d_xyz = rt.alloc(12 * size_t(nv), "diced positions");
  cl::Buffer d_uv = rt.alloc(8 * size_t(nv), "diced uv");
  cl::Buffer d_tri = rt.alloc(12 * size_t(nt), "diced triangles");
  cl::Buffer d_face = rt.alloc(4 * size_t(nt), "diced patch ids");
  rt.launch(Stage::Tessellate, "patch_dice", n, d_ctrl, cl_uint(n), d_plan, d_voff, d_toff, d_xyz,
            d_uv, d_tri, d_face);
  std::vector<float> xyz(3 * nv), uv(2 * nv);
  std::vector<uint32_t> tri(3 * nt), face(nt);
  rt.read_async(Stage::Tessellate, d_xyz, 0, 12 * size_t(nv), xyz.data());
  rt.read_async(Stage::Tessellate, d_uv, 0, 8 * size_t(nv), uv.data());
  rt.read_async(Stage::Tessellate, d_tri, 0, 12 * size_t(nt), tri.data());
  rt.read(Stage::Tessellate, d_face, 0, 4 * size_t(nt), face.data());
  st.launches += 1;
  st.host_syncs += 1;

  // Weld equal positions, by their bits with -0 taken as +0 (a pole's control points may differ
  // in the sign of a zero from patch to patch).
  Weld<float, 3> ids{size_t(nv)};
  std::vector<uint32_t> remap(nv);
  out.positions.reserve(3 * nv);
  for (uint64_t v = 0; v < nv; ++v) {
    auto [id, fresh] = ids.add(&xyz[3 * v], uint32_t(out.positions.size() / 3));
    if (fresh) out.positions.insert(out.positions.end(), &xyz[3 * v], &xyz[3 * v] + 3);
    remap[v] = id;
  }
  out.indices.reserve(3 * nt);
  out.uv.reserve(6 * nt);
  out.face_ids.reserve(nt);
  for (uint64_t t = 0; t < nt; ++t) {
    const uint32_t a = tri[3 * t], b = tri[3 * t + 1], c = tri[3 * t + 2];
    const uint32_t ra = remap[a], rb = remap[b], rc = remap[c];
    if (ra == rb || rb == rc || rc == ra) continue;  // collapsed at a degenerate edge
    out.indices.insert(out.indices.end(), {ra, rb, rc});
    for (uint32_t v : {a, b, c}) out.uv.insert(out.uv.end(), {uv[2 * v], uv[2 * v + 1]});
    out.face_ids.push_back(face[t]);
  }
  st.triangles += out.indices.size() / 3;
  return out;
}

}  // namespace vismap::surfaces

namespace vismap {

std::array<double, 3> patch_point(const Mesh& mesh, size_t p, double u, double v) {
  const float* c = &mesh.patches.at(48 * p + 47) - 47;
  auto b3 = [](double t, double k[4]) {
    const double s = 1 - t;
    k[0] = s * s * s, k[1] = 3 * s * s * t, k[2] = 3 * s * t * t, k[3] = t * t * t;
  };
  double bu[4], bv[4];
  b3(u, bu);
  b3(v, bv);
  std::array<double, 3> r{0, 0, 0};
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j)
      for (int k = 0; k < 3; ++k) r[k] += bv[i] * bu[j] * c[3 * (4 * i + j) + k];
  return r;
}

}  // namespace vismap
