// Loop subdivision surfaces diced for the camera (issue 18, docs/SURFACES.md "Loop subdivision").
// Host, once per control mesh (LoopPlan): each level's topology (edges by sorted half-edge keys,
// one-ring by edge), its stencils as CSR tables (the next level's vertices as weighted sums of
// this level's; the limit positions of this level's vertices) and its faces with their control
// triangle and barycentrics, built lazily up to the level a frame needs. Device, every frame:
// the stencils applied level by level (kernels/loop.cl), and the flatness d_L of each level
// measured in pixels until (4/3) d_L <= tolerance. One uniform level per mesh: every face reads
// the one shared vertex array, so there is no crack by construction.
#include <algorithm>
#include <cmath>
#include <cstring>

#include "core/error.h"
#include "core/surfaces/internal.h"
#include "core/util/format.h"

namespace vismap::surfaces {

namespace {

struct Csr {
  std::vector<uint32_t> start{0}, col;
  std::vector<float> w;
  void add(uint32_t c, float x) {
    col.push_back(c);
    w.push_back(x);
  }
  void end_row() { start.push_back(uint32_t(col.size())); }
  uint64_t bytes() const { return 4 * (start.size() + col.size() + w.size()); }
};

// Loop's original vertex weight for valence n (Loop 1987).
double loop_beta(uint32_t n) {
  double c = 0.375 + 0.25 * std::cos(2 * M_PI / n);
  return (0.625 - c * c) / n;
}

}  // namespace

struct LoopLevel {
  uint32_t nv = 0;
  std::vector<uint32_t> faces;       // 3 per face
  std::vector<uint32_t> face_src;    // the source id of each face's control triangle
  std::vector<float> uv;             // 6 per face: barycentrics (b1, b2) of corners 0, 1, 2
  std::vector<uint32_t> edge_v;      // 2 per edge (a < b)
  std::vector<uint32_t> face_edges;  // 3 per face: edges (c0 c1), (c1 c2), (c2 c0)
  Csr refine;                        // rows: nv vertices, then one per edge (next level)
  Csr limit;                         // rows: nv limit positions
  cl::Buffer d_refine[3], d_limit[3], d_edges, d_pos, d_lim;
  bool on_device = false;
  void drop_device() {
    for (cl::Buffer* b : {&d_refine[0], &d_refine[1], &d_refine[2], &d_limit[0], &d_limit[1],
                          &d_limit[2], &d_edges, &d_pos, &d_lim})
      *b = cl::Buffer();
    on_device = false;
  }
  uint64_t bytes() const {
    return 4 * (faces.size() + face_src.size() + uv.size() + edge_v.size() + face_edges.size()) +
           refine.bytes() + limit.bytes();
  }
};

struct LoopPlan {
  std::vector<uint32_t> control_indices;  // the key: rebuilt when the topology changes
  std::vector<float> control_positions;   // re-uploaded when they change
  std::vector<LoopLevel> levels;
  uint64_t bytes = 0;
  uint64_t last_use = 0;  // LoopPlans::clock when it was last diced
  const ClRuntime* device = nullptr;  // whose context the device copies are in
  cl::Buffer d_control;
};

namespace {

// Edges, stencils of level l (faces already filled), and the faces of level l + 1.
void build_topology(LoopLevel& L) {
  const size_t nf = L.faces.size() / 3;
  std::vector<std::pair<uint64_t, uint32_t>> he(3 * nf);  // (edge key, half-edge)
  for (size_t h = 0; h < 3 * nf; ++h) {
    uint32_t a = L.faces[h], b = L.faces[h - h % 3 + (h % 3 + 1) % 3];
    he[h] = {(uint64_t(std::min(a, b)) << 32) | std::max(a, b), uint32_t(h)};
  }
  std::sort(he.begin(), he.end());
  L.face_edges.assign(3 * nf, 0);
  std::vector<uint32_t> opp;      // 2 per edge; UINT32_MAX when the edge is a crease/boundary
  std::vector<uint8_t> crease;    // edge used by other than two faces
  for (size_t i = 0; i < he.size();) {
    size_t j = i;
    while (j < he.size() && he[j].first == he[i].first) ++j;
    uint32_t e = uint32_t(L.edge_v.size() / 2);
    L.edge_v.push_back(uint32_t(he[i].first >> 32));
    L.edge_v.push_back(uint32_t(he[i].first));
    for (size_t k = i; k < j; ++k) L.face_edges[he[k].second] = e;
    bool two = j - i == 2;
    crease.push_back(!two);
    auto third = [&](uint32_t h) { return L.faces[h - h % 3 + (h % 3 + 2) % 3]; };
    opp.push_back(two ? third(he[i].second) : UINT32_MAX);
    opp.push_back(two ? third(he[i + 1].second) : UINT32_MAX);
    i = j;
  }
  const size_t ne = L.edge_v.size() / 2;
  // One-ring by edge: neighbours in CSR, crease neighbours counted.
  std::vector<uint32_t> deg(L.nv + 1, 0), ncrease(L.nv, 0), cn(2 * size_t(L.nv), 0);
  for (size_t e = 0; e < ne; ++e)
    for (int s = 0; s < 2; ++s) {
      uint32_t v = L.edge_v[2 * e + s];
      ++deg[v + 1];
      if (crease[e]) {
        if (ncrease[v] < 2) cn[2 * size_t(v) + ncrease[v]] = L.edge_v[2 * e + 1 - s];
        ++ncrease[v];
      }
    }
  for (uint32_t v = 0; v < L.nv; ++v) deg[v + 1] += deg[v];
  std::vector<uint32_t> ring(deg[L.nv]), fillp(deg.begin(), deg.end() - 1);
  for (size_t e = 0; e < ne; ++e) {
    ring[fillp[L.edge_v[2 * e]]++] = L.edge_v[2 * e + 1];
    ring[fillp[L.edge_v[2 * e + 1]]++] = L.edge_v[2 * e];
  }
  // Vertex rules (refine) and limit positions. Interior: Loop's masks; boundary (two crease
  // edges): (1/8, 3/4, 1/8), limit (1/6, 2/3, 1/6); corner or non-manifold (other crease counts)
  // and unused vertices: fixed.
  for (uint32_t v = 0; v < L.nv; ++v) {
    uint32_t n = deg[v + 1] - deg[v];
    if (n > 0 && ncrease[v] == 0) {
      double beta = loop_beta(n);
      double chi = 1.0 / (n + 3.0 / (8.0 * beta));
      L.refine.add(v, float(1 - n * beta));
      L.limit.add(v, float(1 - n * chi));
      for (uint32_t k = deg[v]; k < deg[v + 1]; ++k) {
        L.refine.add(ring[k], float(beta));
        L.limit.add(ring[k], float(chi));
      }
    } else if (ncrease[v] == 2) {
      L.refine.add(v, 0.75f);
      L.refine.add(cn[2 * size_t(v)], 0.125f);
      L.refine.add(cn[2 * size_t(v) + 1], 0.125f);
      L.limit.add(v, float(2.0 / 3.0));
      L.limit.add(cn[2 * size_t(v)], float(1.0 / 6.0));
      L.limit.add(cn[2 * size_t(v) + 1], float(1.0 / 6.0));
    } else {
      L.refine.add(v, 1.0f);
      L.limit.add(v, 1.0f);
    }
    L.refine.end_row();
    L.limit.end_row();
  }
  // Edge rules: interior 3/8, 3/8, 1/8, 1/8; crease or boundary: the midpoint.
  for (size_t e = 0; e < ne; ++e) {
    bool cr = crease[e];
    L.refine.add(L.edge_v[2 * e], cr ? 0.5f : 0.375f);
    L.refine.add(L.edge_v[2 * e + 1], cr ? 0.5f : 0.375f);
    if (!cr) {
      L.refine.add(opp[2 * e], 0.125f);
      L.refine.add(opp[2 * e + 1], 0.125f);
    }
    L.refine.end_row();
  }
}

// Level l + 1's faces from level l (whose topology is built): four per face, orientation kept.
LoopLevel refine_faces(const LoopLevel& P) {
  LoopLevel L;
  const size_t nf = P.faces.size() / 3;
  L.nv = P.nv + uint32_t(P.edge_v.size() / 2);
  L.faces.resize(12 * nf);
  L.face_src.resize(4 * nf);
  L.uv.resize(24 * nf);
  for (size_t f = 0; f < nf; ++f) {
    const uint32_t* c = &P.faces[3 * f];
    uint32_t m01 = P.nv + P.face_edges[3 * f], m12 = P.nv + P.face_edges[3 * f + 1],
             m20 = P.nv + P.face_edges[3 * f + 2];
    const uint32_t kids[12] = {c[0], m01, m20, m01, c[1], m12, m20, m12, c[2], m01, m12, m20};
    std::copy(kids, kids + 12, &L.faces[12 * f]);
    const float* u = &P.uv[6 * f];
    float U[6][2];  // corners 0 1 2, then midpoints 01 12 20
    for (int k = 0; k < 3; ++k) U[k][0] = u[2 * k], U[k][1] = u[2 * k + 1];
    for (int k = 0; k < 3; ++k)
      for (int s = 0; s < 2; ++s) U[3 + k][s] = 0.5f * (U[k][s] + U[(k + 1) % 3][s]);
    const int ku[12] = {0, 3, 5, 3, 1, 4, 5, 4, 2, 3, 4, 5};
    for (int k = 0; k < 12; ++k) {
      L.uv[24 * f + 2 * k] = U[ku[k]][0];
      L.uv[24 * f + 2 * k + 1] = U[ku[k]][1];
    }
    for (int k = 0; k < 4; ++k) L.face_src[4 * f + k] = P.face_src[f];
  }
  return L;
}

// Makes levels 0..l exist with topology (so level l's refine and limit stencils exist). Each
// level is counted before it is built (issue 35, case 6): against o.loop_plan_max_bytes, the host
// plan (the Killeroo, 8,316 control triangles, holds ~0.3 GB at level 4: 2.1M faces), and
// against o.memory_budget, what the frame holds for the dice: the plan's device copies (at most
// the plan's bytes), positions and limit positions per level (24 bytes a vertex) and the diced
// mesh on the host (40 bytes a face, 12 a vertex).
void ensure_level(LoopPlan& plan, const Mesh& mesh, uint32_t l, const TessellateOptions& o) {
  while (plan.levels.size() <= l) {
    if (!plan.levels.empty()) {
      const LoopLevel& P = plan.levels.back();
      uint64_t nf = 4 * (P.faces.size() / 3), ne = 2 * (P.edge_v.size() / 2) + 3 * (P.faces.size() / 3);
      uint64_t nv = P.nv + P.edge_v.size() / 2;
      // Sized from the counts before building: faces (indices, source, uv, edges), edges, and
      // the stencils (~7 entries per vertex row, 4 per edge row, 8 bytes each), both tables.
      uint64_t need = nf * 4 * (3 + 1 + 6 + 3) + ne * 4 * (2 + 4) + (nv * 7 * 2 + ne * 4) * 8;
      uint64_t vertices = nv;
      for (const LoopLevel& L : plan.levels) vertices += L.nv;
      const uint64_t frame = plan.bytes + need + 24 * vertices + 40 * nf + 12 * nv;
      const auto refuse = [&](const std::string& why) {
        throw InputError(InputErrorKind::TooLarge, "", mesh.name, "subdivision level",
                         int64_t(plan.levels.size()),
                         std::to_string(nf) + " faces would take " + why + "; raise the tolerance");
      };
      if (nf > UINT32_MAX || nv + ne > UINT32_MAX || plan.bytes + need > o.loop_plan_max_bytes)
        refuse("the plan past " + mib(o.loop_plan_max_bytes));
      if (o.memory_budget && frame > o.memory_budget)
        refuse("the dice to " + mib(frame) + ", over the memory budget of " + mib(o.memory_budget));
      plan.levels.push_back(refine_faces(P));
    } else {
      LoopLevel L;
      L.nv = uint32_t(mesh.vertex_count());
      L.faces = mesh.indices;
      size_t nf = mesh.triangle_count();
      L.face_src.resize(nf);
      L.uv.resize(6 * nf);
      for (size_t f = 0; f < nf; ++f) {
        L.face_src[f] = mesh.face_ids.size() == nf ? mesh.face_ids[f] : uint32_t(f);
        const float u[6] = {0, 0, 1, 0, 0, 1};
        std::copy(u, u + 6, &L.uv[6 * f]);
      }
      plan.levels.push_back(std::move(L));
    }
    build_topology(plan.levels.back());
    plan.bytes += plan.levels.back().bytes();
  }
}

// Drops the least recently used plans but `keep` until all hold at most `cap` bytes (or only
// `keep` is left); their device buffers go with them. Returns the bytes the plans hold.
uint64_t evict_plans(LoopPlans& plans, const LoopPlan* keep, uint64_t cap, TessellateStats& st) {
  uint64_t total = 0;
  for (const auto& [mesh, plan] : plans.by_mesh) total += plan ? plan->bytes : 0;
  while (total > cap) {
    auto oldest = plans.by_mesh.end();
    for (auto it = plans.by_mesh.begin(); it != plans.by_mesh.end(); ++it)
      if (it->second.get() != keep &&
          (oldest == plans.by_mesh.end() || !it->second ||
           (oldest->second && it->second->last_use < oldest->second->last_use)))
        oldest = it;
    if (oldest == plans.by_mesh.end()) break;
    total -= oldest->second ? oldest->second->bytes : 0;
    plans.by_mesh.erase(oldest);
    ++st.loop_plans_evicted;
  }
  return total;
}

void to_device(ClRuntime& rt, LoopLevel& L) {
  if (L.on_device) return;
  L.d_refine[0] = rt.upload(L.refine.start, "loop refine rows");
  L.d_refine[1] = rt.upload(L.refine.col, "loop refine cols");
  L.d_refine[2] = rt.upload(L.refine.w, "loop refine weights");
  L.d_limit[0] = rt.upload(L.limit.start, "loop limit rows");
  L.d_limit[1] = rt.upload(L.limit.col, "loop limit cols");
  L.d_limit[2] = rt.upload(L.limit.w, "loop limit weights");
  L.d_edges = rt.upload(L.edge_v, "loop edges");
  L.d_pos = rt.alloc(std::max<size_t>(12 * size_t(L.nv), 12), "loop positions");
  L.d_lim = rt.alloc(std::max<size_t>(12 * size_t(L.nv), 12), "loop limit positions");
  L.on_device = true;
}

}  // namespace

Mesh dice_subdivision(ClRuntime& rt, const Mesh& mesh, const Camera& cam_in,
                      const TessellateOptions& o, LoopPlans& plans, TessellateStats& st,
                      const TimeCheck& check_time) {
  if (mesh.triangle_count() == 0 || mesh.vertex_count() == 0)
    throw InputError(InputErrorKind::EmptyMesh, "", mesh.name, "", -1,
                     "a subdivision surface needs a control mesh");
  std::shared_ptr<LoopPlan>& slot = plans.by_mesh[&mesh];
  if (!slot || slot->control_indices != mesh.indices) {
    slot = std::make_shared<LoopPlan>();
    slot->control_indices = mesh.indices;
  }
  const std::shared_ptr<LoopPlan> held = slot;  // slot's map entry may move under eviction
  LoopPlan& plan = *held;
  plan.last_use = ++plans.clock;
  // Room for this plan first, then what it built (issue 35, case 6).
  evict_plans(plans, &plan, o.loop_plan_cache_bytes, st);
  if (plan.device != &rt) {  // another Renderer's context: its device copies are remade here
    for (LoopLevel& L : plan.levels) L.drop_device();
    plan.d_control = cl::Buffer();
    plan.device = &rt;
  }
  ensure_level(plan, mesh, 0, o);
  if (plan.control_positions != mesh.positions || !plan.d_control()) {
    plan.control_positions = mesh.positions;
    plan.d_control = rt.upload(mesh.positions, "loop control positions");
  }

  // The view: clip-space rows for culling, pixels per world unit at w = 1 for the distance.
  const DiceView view = dice_view(cam_in, mesh.positions);
  const Camera& cam = view.cam;
  const cl_float16& m = view.m;
  const bool persp = view.persp;
  const float f_px = view.f_px;
  float w_floor = persp ? float(cam.near_plane) : 1.0f;

  // Level l's limit positions are the first nv_l of level l + 1's (a vertex keeps its index and
  // its limit point): measuring d_l needs level l + 1, which then also gives the output.
  cl::Buffer dmax = rt.alloc(4, "loop flatness");
  uint32_t l = 0;
  for (;; ++l) {
    check_time();  // a level's topology and stencils take seconds on large control meshes
    ensure_level(plan, mesh, l + 1, o);
    LoopLevel& P = plan.levels[l];
    LoopLevel& N = plan.levels[l + 1];
    to_device(rt, P);
    to_device(rt, N);
    if (l == 0) rt.copy(Stage::Tessellate, plan.d_control, P.d_pos, 12 * size_t(P.nv));
    rt.launch(Stage::Tessellate, "loop_stencil", N.nv, P.d_refine[0], P.d_refine[1],
              P.d_refine[2], cl_uint(N.nv), P.d_pos, N.d_pos);
    rt.launch(Stage::Tessellate, "loop_stencil", N.nv, N.d_limit[0], N.d_limit[1], N.d_limit[2],
              cl_uint(N.nv), N.d_pos, N.d_lim);
    rt.fill_u32(dmax, 0, 1, Stage::Tessellate);
    const uint32_t per = 64, ne = uint32_t(P.edge_v.size() / 2);
    rt.launch(Stage::Tessellate, "loop_edge_error", (ne + per - 1) / per, P.d_edges, cl_uint(ne),
              cl_uint(P.nv), N.d_lim, m, f_px, w_floor, cl_uint(per), dmax);
    st.launches += 3;
    uint32_t bits = 0;
    rt.read(Stage::Tessellate, dmax, 0, 4, &bits);
    ++st.host_syncs;
    float d;
    std::memcpy(&d, &bits, 4);
    if (4.0f / 3.0f * d <= o.tolerance_px) break;
  }
  const LoopLevel& L = plan.levels[l];
  Mesh out;
  out.name = mesh.name;
  out.color = mesh.color;
  out.soup = false;
  out.positions.resize(3 * size_t(L.nv));
  rt.read(Stage::Tessellate, plan.levels[l + 1].d_lim, 0, 12 * size_t(L.nv),
          out.positions.data());
  ++st.host_syncs;
  out.indices = L.faces;
  out.face_ids = L.face_src;
  out.uv = L.uv;
  out.source_triangles = mesh.source_triangles ? mesh.source_triangles
                                               : uint32_t(mesh.triangle_count());
  st.subdivision_level = std::max(st.subdivision_level, l);
  st.pieces += mesh.triangle_count();
  st.triangles += L.faces.size() / 3;
  st.loop_plan_bytes = evict_plans(plans, &plan, o.loop_plan_cache_bytes, st);
  return out;
}

}  // namespace vismap::surfaces
