// make_subdivided: generates the benchmark's synthetic inputs (bench/run.sh calls it; the
// outputs go to bench/scenes/ and are not committed).
//
//   make_subdivided IN OUT.ply --levels L [--weld]
//       Loop subdivision (OpenMesh LoopT) of every mesh of IN (any format load_scene reads),
//       merged into one mesh, L times (x4 triangles per level), written as binary PLY.
//       --weld first merges vertices with bit-identical positions (files that repeat vertices
//       along seams, like the Utah teapot OBJ, would otherwise subdivide into separate patches).
//       Faces OpenMesh refuses (non-manifold) are left out and counted on stderr.
//   make_subdivided --stadium OUT.obj
//       A big low-poly stadium: ground, field and an elliptical bowl of stepped stands around the
//       origin (about 400 x 400 units, ~3k triangles), for the "teapot in a stadium" scene.
#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>
#include <OpenMesh/Tools/Subdivider/Uniform/LoopT.hh>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include "core/scene.h"

namespace {

using TriMesh = OpenMesh::TriMesh_ArrayKernelT<>;

void write_ply(const std::string& path, const TriMesh& m) {
  std::ofstream out(path, std::ios::binary);
  if (!out) throw std::runtime_error(path + ": cannot open for writing");
  out << "ply\nformat binary_little_endian 1.0\ncomment Loop-subdivided by bench/make_subdivided\n"
      << "element vertex " << m.n_vertices()
      << "\nproperty float x\nproperty float y\nproperty float z\n"
      << "element face " << m.n_faces() << "\nproperty list uchar int vertex_indices\nend_header\n";
  for (auto v : m.vertices()) {
    const auto& p = m.point(v);
    float xyz[3] = {p[0], p[1], p[2]};
    out.write(reinterpret_cast<const char*>(xyz), sizeof xyz);
  }
  for (auto f : m.faces()) {
    unsigned char n = 3;
    out.write(reinterpret_cast<const char*>(&n), 1);
    for (auto v : m.fv_range(f)) {
      int32_t i = v.idx();
      out.write(reinterpret_cast<const char*>(&i), 4);
    }
  }
  if (!out) throw std::runtime_error(path + ": write failed");
}

int subdivide(const std::string& in, const std::string& out, int levels, bool weld) {
  vismap::Scene scene = vismap::load_scene(in);
  TriMesh m;
  size_t refused = 0;
  std::map<std::array<float, 3>, TriMesh::VertexHandle> welded;
  for (const vismap::Mesh& mesh : scene.meshes) {
    std::vector<TriMesh::VertexHandle> vh(mesh.vertex_count());
    for (size_t v = 0; v < mesh.vertex_count(); ++v) {
      std::array<float, 3> p{mesh.positions[3 * v], mesh.positions[3 * v + 1],
                             mesh.positions[3 * v + 2]};
      if (weld) {
        auto [it, fresh] = welded.try_emplace(p);
        if (fresh) it->second = m.add_vertex(TriMesh::Point(p[0], p[1], p[2]));
        vh[v] = it->second;
      } else {
        vh[v] = m.add_vertex(TriMesh::Point(p[0], p[1], p[2]));
      }
    }
    for (size_t t = 0; t < mesh.triangle_count(); ++t) {
      auto a = vh[mesh.indices[3 * t]], b = vh[mesh.indices[3 * t + 1]],
           c = vh[mesh.indices[3 * t + 2]];
      if (a == b || b == c || a == c || !m.add_face(a, b, c).is_valid()) ++refused;
    }
  }
  m.request_vertex_status();
  m.request_edge_status();
  m.request_face_status();
  m.delete_isolated_vertices();
  m.garbage_collection();
  m.release_face_status();
  m.release_edge_status();
  m.release_vertex_status();
  const size_t f0 = m.n_faces();
  OpenMesh::Subdivider::Uniform::LoopT<TriMesh> loop;
  loop.attach(m);
  loop(static_cast<size_t>(levels));
  loop.detach();
  write_ply(out, m);
  std::fprintf(stderr,
               "make_subdivided: %s: %zu faces (%zu refused as non-manifold) -> %d Loop level(s) "
               "-> %zu faces, %zu vertices: %s\n",
               in.c_str(), f0, refused, levels, m.n_faces(), m.n_vertices(), out.c_str());
  return 0;
}

// Ground + field + stands. Units: the field is 140 x 90, the bowl reaches radius ~200.
int stadium(const std::string& out_path) {
  std::vector<std::array<double, 3>> v;
  std::vector<std::array<int, 4>> quads;  // 1-based OBJ indices
  auto vert = [&](double x, double y, double z) {
    v.push_back({x, y, z});
    return static_cast<int>(v.size());
  };
  // Ground: 10 x 10 quads, 440 x 440.
  const int G = 10;
  const double half = 220;
  std::vector<int> g((G + 1) * (G + 1));
  for (int j = 0; j <= G; ++j)
    for (int i = 0; i <= G; ++i)
      g[j * (G + 1) + i] = vert(-half + 2 * half * i / G, 0, -half + 2 * half * j / G);
  for (int j = 0; j < G; ++j)
    for (int i = 0; i < G; ++i)
      quads.push_back({g[j * (G + 1) + i], g[(j + 1) * (G + 1) + i], g[(j + 1) * (G + 1) + i + 1],
                       g[j * (G + 1) + i + 1]});
  // Field: a slightly raised 140 x 90 slab top.
  {
    int a = vert(-70, 0.05, -45), b = vert(-70, 0.05, 45), c = vert(70, 0.05, 45),
        d = vert(70, 0.05, -45);
    quads.push_back({a, b, c, d});
  }
  // Stands: an elliptical bowl of T steps (riser + tread), S segments around.
  const int S = 72, T = 10;
  const double pi = std::acos(-1.0);
  auto ring = [&](double ra, double rb, double y) {
    std::vector<int> r(S);
    for (int s = 0; s < S; ++s) {
      double t = 2 * pi * s / S;
      r[s] = vert(ra * std::cos(t), y, rb * std::sin(t));
    }
    return r;
  };
  auto band = [&](const std::vector<int>& inner, const std::vector<int>& outer) {
    for (int s = 0; s < S; ++s) {
      int n = (s + 1) % S;
      quads.push_back({inner[s], inner[n], outer[n], outer[s]});
    }
  };
  double ra = 110, rb = 75, y = 0;
  std::vector<int> prev = ring(ra, rb, y);
  for (int t = 0; t < T; ++t) {
    std::vector<int> up = ring(ra, rb, y + 4);  // riser
    band(prev, up);
    ra += 8, rb += 8, y += 4;
    std::vector<int> tread = ring(ra, rb, y);  // tread
    band(up, tread);
    prev = tread;
  }
  std::vector<int> top = ring(ra, rb, y + 12);  // back wall
  band(prev, top);
  std::ofstream out(out_path);
  if (!out) throw std::runtime_error(out_path + ": cannot open for writing");
  out << "# Low-poly stadium generated by bench/make_subdivided --stadium\no stadium\n";
  char line[128];
  for (const auto& p : v) {
    std::snprintf(line, sizeof line, "v %.6f %.6f %.6f\n", p[0], p[1], p[2]);
    out << line;
  }
  for (const auto& q : quads)
    out << "f " << q[0] << ' ' << q[1] << ' ' << q[2] << ' ' << q[3] << '\n';
  std::fprintf(stderr, "make_subdivided: stadium: %zu quads (%zu triangles): %s\n", quads.size(),
               2 * quads.size(), out_path.c_str());
  return out ? 0 : 1;
}

int usage() {
  std::fputs(
      "usage: make_subdivided IN OUT.ply --levels L [--weld]\n"
      "       make_subdivided --stadium OUT.obj\n",
      stderr);
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    if (argc == 3 && !std::strcmp(argv[1], "--stadium")) return stadium(argv[2]);
    std::string in, out;
    int levels = -1;
    bool weld = false;
    for (int i = 1; i < argc; ++i) {
      if (!std::strcmp(argv[i], "--levels") && i + 1 < argc)
        levels = std::atoi(argv[++i]);
      else if (!std::strcmp(argv[i], "--weld"))
        weld = true;
      else if (argv[i][0] == '-')
        return usage();
      else if (in.empty())
        in = argv[i];
      else if (out.empty())
        out = argv[i];
      else
        return usage();
    }
    if (in.empty() || out.empty() || levels < 0 || levels > 6) return usage();
    return subdivide(in, out, levels, weld);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "make_subdivided: %s\n", e.what());
    return 1;
  }
}
