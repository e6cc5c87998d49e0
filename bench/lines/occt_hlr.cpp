// OpenCASCADE's polygonal hidden-line removal (HLRBRep_PolyAlgo) on a vismap scene, for the peer
// bench (bench/lines/run.sh, docs/LINES.md "Against other tools"): the same camera as `vismap
// render`, the visible lines written as SVG in our pixel frame, so `vismap check --lines
// --lines-from` scores them with the code that scores ours.
//
//   vismap_occt_hlr SCENE --eye X,Y,Z --target X,Y,Z --up X,Y,Z --fov-y DEG --width W --height H
//                   --form outline|faces [--crease-angle DEG] -o OUT.svg
//
// Perspective: HLRAlgo_Projector's perspective mode ("focus") only moves the front/back test; the
// hiding and the output stay orthographic (measured, issue 20: ~20 % of the bunny's contour came
// out falsely hidden). So every vertex is first warped into the camera's normalized device
// frame (view_projection, divided by w; a projective map keeps triangles flat and depth order
// along each ray), scaled to pixels, and drawn by an orthographic projector looking down -Z.
//
// Forms (issue 20 measured both):
//   outline  one face per mesh carrying a Poly_Triangulation, with UV nodes (the vertices' screen
//            x, y) and vertex normals, without which it draws nothing: silhouettes only, no
//            creases or boundaries (the face has no edges).
//   faces    one planar face per triangle sharing vertices and edges (so it knows adjacency),
//            edges under the crease angle marked G1 so smooth edges are not drawn: creases,
//            boundaries, and the silhouette along mesh edges. Slow; run.sh gives it a time limit.
// Kinds in the SVG: OutLine edges and the sharp edges lying on a mesh contour or boundary edge
// are class "contour", the other sharp edges "crease" (core/lines/svg_lines.h reads the classes).
#include <BRepBuilderAPI_MakeEdge.hxx>
#include <BRepBuilderAPI_MakeFace.hxx>
#include <BRepBuilderAPI_MakeWire.hxx>
#include <BRepLib.hxx>
#include <BRepMesh_IncrementalMesh.hxx>
#include <BRep_Builder.hxx>
#include <BRep_Tool.hxx>
#include <HLRAlgo_Projector.hxx>
#include <HLRBRep_PolyAlgo.hxx>
#include <HLRBRep_PolyHLRToShape.hxx>
#include <Poly_Triangulation.hxx>
#include <TopExp.hxx>
#include <TopExp_Explorer.hxx>
#include <TopoDS.hxx>
#include <TopoDS_Compound.hxx>
#include <TopoDS_Edge.hxx>
#include <TopoDS_Face.hxx>
#include <TopoDS_Vertex.hxx>
#include <gp_Ax2.hxx>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <vector>

#include "core/camera.h"
#include "core/scene.h"

namespace {

using vismap::Camera;
using vismap::Vec3;

Vec3 parse_vec3(const std::string& flag, const std::string& s) {
  Vec3 v;
  if (std::sscanf(s.c_str(), "%lf,%lf,%lf", &v[0], &v[1], &v[2]) != 3)
    throw std::runtime_error(flag + ": expected X,Y,Z");
  return v;
}

struct Args {
  std::string scene, out, form = "outline";
  Camera cam;
  double crease_deg = 45;
};

// Pixel-frame point with depth: x right, y up (the projector's), z toward the eye.
struct P3 {
  double x, y, z;
};

std::vector<P3> warp(const vismap::Mesh& m, const Camera& c) {
  const vismap::Mat4 vp = c.view_projection();
  std::vector<P3> out(m.vertex_count());
  for (size_t i = 0; i < out.size(); ++i) {
    const double x = m.positions[3 * i], y = m.positions[3 * i + 1], z = m.positions[3 * i + 2];
    double r[4];
    for (int k = 0; k < 4; ++k) r[k] = vp[k] * x + vp[4 + k] * y + vp[8 + k] * z + vp[12 + k];
    if (!(r[3] > 0)) throw std::runtime_error("mesh '" + m.name + "': a vertex behind the eye");
    // NDC to pixels, centred: X = x_ndc W/2, Y = y_ndc H/2 (up); Z = -z_ndc W/2 (toward the eye,
    // so x, y, z stay right-handed and triangles keep their orientation).
    out[i] = {r[0] / r[3] * c.width / 2, r[1] / r[3] * c.height / 2, -r[2] / r[3] * c.width / 2};
  }
  return out;
}

TopoDS_Face triangulated_face(const vismap::Mesh& m, const std::vector<P3>& p) {
  const int nv = int(p.size()), nt = int(m.triangle_count());
  Handle(Poly_Triangulation) tri = new Poly_Triangulation(nv, nt, true, true);
  std::vector<double> nrm(3 * nv, 0.0);
  for (int t = 0; t < nt; ++t) {
    const uint32_t a = m.indices[3 * t], b = m.indices[3 * t + 1], c = m.indices[3 * t + 2];
    tri->SetTriangle(t + 1, Poly_Triangle(a + 1, b + 1, c + 1));
    const double ux = p[b].x - p[a].x, uy = p[b].y - p[a].y, uz = p[b].z - p[a].z;
    const double vx = p[c].x - p[a].x, vy = p[c].y - p[a].y, vz = p[c].z - p[a].z;
    const double n[3] = {uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx};  // area-weighted
    for (uint32_t v : {a, b, c})
      for (int k = 0; k < 3; ++k) nrm[3 * v + k] += n[k];
  }
  for (int i = 0; i < nv; ++i) {
    tri->SetNode(i + 1, gp_Pnt(p[i].x, p[i].y, p[i].z));
    tri->SetUVNode(i + 1, gp_Pnt2d(p[i].x, p[i].y));
    const double l = std::sqrt(nrm[3 * i] * nrm[3 * i] + nrm[3 * i + 1] * nrm[3 * i + 1] +
                               nrm[3 * i + 2] * nrm[3 * i + 2]);
    tri->SetNormal(i + 1, l > 0 ? gp_Dir(nrm[3 * i] / l, nrm[3 * i + 1] / l, nrm[3 * i + 2] / l)
                                : gp_Dir(0, 0, 1));
  }
  TopoDS_Face f;
  BRep_Builder().MakeFace(f, tri);
  return f;
}

// Vertices matched by position (soup meshes), edges shared between the faces that use them.
// Edges whose faces' normals differ by less than crease_deg get continuity G1 (set directly
// from the mesh: BRepLib::EncodeRegularity left every edge of these faces C0, so every mesh edge
// came out "sharp"), the rest stay C0: HLR draws those as sharp edges.
void planar_faces(const vismap::Mesh& m, const std::vector<P3>& p, BRep_Builder& bb,
                  TopoDS_Compound& comp, double crease_deg) {
  std::map<std::array<float, 3>, int> weld;
  std::vector<int> id(p.size());
  std::vector<TopoDS_Vertex> verts;
  for (size_t i = 0; i < p.size(); ++i) {
    const std::array<float, 3> key{m.positions[3 * i], m.positions[3 * i + 1], m.positions[3 * i + 2]};
    auto [it, fresh] = weld.emplace(key, int(verts.size()));
    if (fresh) {
      TopoDS_Vertex v;
      bb.MakeVertex(v, gp_Pnt(p[i].x, p[i].y, p[i].z), 1e-7);
      verts.push_back(v);
    }
    id[i] = it->second;
  }
  std::unordered_map<uint64_t, TopoDS_Edge> edges;
  auto edge = [&](int a, int b) {
    const uint64_t key = a < b ? (uint64_t(a) << 32 | uint32_t(b)) : (uint64_t(b) << 32 | uint32_t(a));
    auto it = edges.find(key);
    if (it == edges.end()) {
      const int lo = a < b ? a : b, hi = a < b ? b : a;
      it = edges.emplace(key, BRepBuilderAPI_MakeEdge(verts[lo], verts[hi]).Edge()).first;
    }
    return a < b ? it->second : TopoDS::Edge(it->second.Reversed());
  };
  struct Side { TopoDS_Face f; gp_Dir n; };
  std::unordered_map<uint64_t, std::vector<Side>> sides;
  for (size_t t = 0; t < m.triangle_count(); ++t) {
    const int a = id[m.indices[3 * t]], b = id[m.indices[3 * t + 1]], c = id[m.indices[3 * t + 2]];
    if (a == b || b == c || a == c) continue;
    BRepBuilderAPI_MakeWire w(edge(a, b), edge(b, c), edge(c, a));
    if (!w.IsDone()) continue;
    BRepBuilderAPI_MakeFace f(w.Wire(), true);
    if (!f.IsDone()) continue;
    bb.Add(comp, f.Face());
    const P3 &pa = p[m.indices[3 * t]], &pb = p[m.indices[3 * t + 1]], &pc = p[m.indices[3 * t + 2]];
    const gp_Vec n = gp_Vec(pb.x - pa.x, pb.y - pa.y, pb.z - pa.z)
                         .Crossed(gp_Vec(pc.x - pa.x, pc.y - pa.y, pc.z - pa.z));
    if (n.Magnitude() <= 0) continue;
    for (auto [u, v] : {std::pair{a, b}, std::pair{b, c}, std::pair{c, a}})
      sides[u < v ? (uint64_t(u) << 32 | uint32_t(v)) : (uint64_t(v) << 32 | uint32_t(u))]
          .push_back({f.Face(), gp_Dir(n)});
  }
  const double cos_crease = std::cos(crease_deg * M_PI / 180);
  for (const auto& [key, s] : sides)
    if (s.size() == 2 && s[0].n.Dot(s[1].n) > cos_crease)
      bb.Continuity(edges.at(key), s[0].f, s[1].f, GeomAbs_G1);
}

// Contour and boundary edges of the meshes, in the pixel frame (x right, y up), for telling a
// sharp output edge on the silhouette from a crease.
struct ContourIndex {
  std::vector<std::array<double, 4>> seg;
  std::unordered_map<uint64_t, std::vector<uint32_t>> grid;  // 8 px cells
  static uint64_t cell(long x, long y) { return uint64_t(uint32_t(x)) << 32 | uint32_t(y); }
  void add(const P3& a, const P3& b) {
    const uint32_t s = uint32_t(seg.size());
    seg.push_back({a.x, a.y, b.x, b.y});
    for (long x = long(std::floor(std::min(a.x, b.x) / 8)); x <= long(std::floor(std::max(a.x, b.x) / 8)); ++x)
      for (long y = long(std::floor(std::min(a.y, b.y) / 8)); y <= long(std::floor(std::max(a.y, b.y) / 8)); ++y)
        grid[cell(x, y)].push_back(s);
  }
  bool near(double x, double y) const {
    auto it = grid.find(cell(long(std::floor(x / 8)), long(std::floor(y / 8))));
    if (it == grid.end()) return false;
    for (uint32_t s : it->second) {
      const auto& q = seg[s];
      const double dx = q[2] - q[0], dy = q[3] - q[1], l2 = dx * dx + dy * dy;
      double t = l2 > 0 ? ((x - q[0]) * dx + (y - q[1]) * dy) / l2 : 0;
      t = std::max(0.0, std::min(1.0, t));
      if (std::hypot(x - q[0] - t * dx, y - q[1] - t * dy) < 0.05) return true;
    }
    return false;
  }
};

void index_contours(const vismap::Mesh& m, const std::vector<P3>& p, ContourIndex& ci) {
  std::map<std::array<float, 3>, uint32_t> weld;
  std::vector<uint32_t> id(p.size());
  for (size_t i = 0; i < p.size(); ++i)
    id[i] = weld.emplace(std::array<float, 3>{m.positions[3 * i], m.positions[3 * i + 1], m.positions[3 * i + 2]},
                         uint32_t(weld.size())).first->second;
  struct Use { uint32_t va, vb; int front_count, n; };
  std::unordered_map<uint64_t, Use> e;
  for (size_t t = 0; t < m.triangle_count(); ++t) {
    const uint32_t* ix = &m.indices[3 * t];
    const P3 &a = p[ix[0]], &b = p[ix[1]], &c = p[ix[2]];
    const bool front = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x) > 0;
    for (int k = 0; k < 3; ++k) {
      uint32_t u = id[ix[k]], v = id[ix[(k + 1) % 3]];
      const uint64_t key = u < v ? (uint64_t(u) << 32 | v) : (uint64_t(v) << 32 | u);
      Use& s = e.emplace(key, Use{ix[k], ix[(k + 1) % 3], 0, 0}).first->second;
      s.front_count += front;
      ++s.n;
    }
  }
  for (const auto& [key, s] : e)
    if (s.n == 1 || (s.front_count > 0 && s.front_count < s.n)) ci.add(p[s.va], p[s.vb]);
}

void write_edges(std::string& out, const TopoDS_Shape& shape, const Camera& c,
                 const ContourIndex* ci, std::string* creases, size_t& count) {
  if (shape.IsNull()) return;
  char buf[96];
  for (TopExp_Explorer ex(shape, TopAbs_EDGE); ex.More(); ex.Next()) {
    TopoDS_Vertex v1, v2;
    TopExp::Vertices(TopoDS::Edge(ex.Current()), v1, v2);
    if (v1.IsNull() || v2.IsNull()) continue;
    const gp_Pnt a = BRep_Tool::Pnt(v1), b = BRep_Tool::Pnt(v2);
    std::string* to = &out;
    if (ci && creases && !ci->near((a.X() + b.X()) / 2, (a.Y() + b.Y()) / 2)) to = creases;
    std::snprintf(buf, sizeof buf, "M%.3f %.3fL%.3f %.3f", a.X() + c.width / 2.0,
                  c.height / 2.0 - a.Y(), b.X() + c.width / 2.0, c.height / 2.0 - b.Y());
    *to += buf;
    ++count;
  }
}

}  // namespace

int main(int argc, char** argv) {
  try {
    Args a;
    bool eye = false, target = false, up = false, fov = false;
    for (int i = 1; i < argc; ++i) {
      const std::string f = argv[i];
      auto value = [&]() -> std::string {
        if (i + 1 >= argc) throw std::runtime_error(f + " needs a value");
        return argv[++i];
      };
      if (f == "--eye") a.cam.eye = parse_vec3(f, value()), eye = true;
      else if (f == "--target") a.cam.target = parse_vec3(f, value()), target = true;
      else if (f == "--up") a.cam.up = parse_vec3(f, value()), up = true;
      else if (f == "--fov-y") a.cam.fov_y_deg = std::stod(value()), fov = true;
      else if (f == "--width") a.cam.width = uint32_t(std::stoul(value()));
      else if (f == "--height") a.cam.height = uint32_t(std::stoul(value()));
      else if (f == "--form") a.form = value();
      else if (f == "--crease-angle") a.crease_deg = std::stod(value());
      else if (f == "-o") a.out = value();
      else if (a.scene.empty() && f[0] != '-') a.scene = f;
      else throw std::runtime_error("unknown argument " + f);
    }
    if (a.scene.empty() || a.out.empty() || !eye || !target || !up || !fov)
      throw std::runtime_error("usage: vismap_occt_hlr SCENE --eye --target --up --fov-y --width "
                               "--height --form outline|faces -o OUT.svg");
    if (a.form != "outline" && a.form != "faces") throw std::runtime_error("--form: outline or faces");
    const auto t0 = std::chrono::steady_clock::now();
    const vismap::Scene scene = vismap::load_scene(a.scene);
    vismap::fit_near_far(a.cam, scene);  // as vismap does for a camera without near/far
    a.cam.validate();

    BRep_Builder bb;
    TopoDS_Compound comp;
    bb.MakeCompound(comp);
    ContourIndex ci;
    for (const vismap::Mesh& m : scene.meshes) {
      const std::vector<P3> p = warp(m, a.cam);
      if (a.form == "outline")
        bb.Add(comp, triangulated_face(m, p));
      else {
        planar_faces(m, p, bb, comp, a.crease_deg);
        index_contours(m, p, ci);
      }
    }
    if (a.form == "faces") {
      BRepMesh_IncrementalMesh(comp, 1.0);  // planar triangles: one triangle each
    }
    const auto t1 = std::chrono::steady_clock::now();

    Handle(HLRBRep_PolyAlgo) algo = new HLRBRep_PolyAlgo();
    algo->Load(comp);
    // Looking down -Z from +Z, x right, y up: the warped frame's own axes.
    algo->Projector(HLRAlgo_Projector(gp_Ax2(gp_Pnt(0, 0, 0), gp_Dir(0, 0, 1), gp_Dir(1, 0, 0))));
    algo->Update();
    HLRBRep_PolyHLRToShape hlr;
    hlr.Update(algo);
    std::string contour, crease;
    size_t n_out = 0, n_sharp = 0;
    write_edges(contour, hlr.OutLineVCompound(), a.cam, nullptr, nullptr, n_out);
    write_edges(contour, hlr.VCompound(), a.cam, a.form == "faces" ? &ci : nullptr, &crease, n_sharp);
    const auto t2 = std::chrono::steady_clock::now();

    const std::string w = std::to_string(a.cam.width), h = std::to_string(a.cam.height);
    std::string svg = "<svg xmlns=\"http://www.w3.org/2000/svg\" viewBox=\"0 0 " + w + " " + h +
                      "\" width=\"" + w + "\" height=\"" + h + "\">\n<g fill=\"none\" stroke=\"black\" "
                      "stroke-width=\"1\" stroke-linecap=\"round\">\n";
    if (!contour.empty()) svg += "<path class=\"contour\" d=\"" + contour + "\"/>\n";
    if (!crease.empty()) svg += "<path class=\"crease\" stroke=\"#404040\" d=\"" + crease + "\"/>\n";
    svg += "</g>\n</svg>\n";
    std::ofstream(a.out, std::ios::binary) << svg;
    std::fprintf(stderr, "occt_hlr %s: %zu outline + %zu sharp edges; build %.2f s, hlr %.2f s\n",
                 a.form.c_str(), n_out, n_sharp, std::chrono::duration<double>(t1 - t0).count(),
                 std::chrono::duration<double>(t2 - t1).count());
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "occt_hlr: %s\n", e.what());
    return 1;
  }
}
