// Wavefront OBJ reader: v and f (polygons triangulated by add_polygon: fanned where convex; "i",
// "i/t", "i//n", "i/t/n", negative = relative), split into one Mesh per material (or per group /
// object where no material is used) in order of first use, each colored by its material's Kd from
// the mtllib. Other statements are ignored. Own reader, not OpenMesh's: OpenMesh does not split by
// group, drops faces at non-manifold edges and does not say which line is bad.
#include <sys/stat.h>

#include <cmath>
#include <map>

#include "core/load/internal.h"
#include "core/load/text_cursor.h"

namespace vismap::detail {
namespace {

using Materials = std::map<std::string, std::array<float, 3>, std::less<>>;

// Reads Kd of each newmtl; a missing or unreadable library only loses colors. A library that is
// there but refused (outside LoadOptions::confine_to, not a regular file, past max_bytes) fails
// the load like any other file it opens.
void read_mtl(const Source& src, std::string_view name, const LoadOptions& opts, Materials& out) {
  if (src.base_dir.empty()) return;  // bytes from memory never reach the file system
  std::string rel(name), file;
  for (const std::string& cand :
       {src.base_dir + rel, src.base_dir + rel.substr(rel.find_last_of('/') + 1)}) {
    struct stat st;
    if (::stat(cand.c_str(), &st) != 0) continue;  // not there: try the next place, or no colors
    file = read_input_file(cand, opts, *src.budget);
    break;
  }
  TextCursor c(file);
  c.hash_comments = true;
  std::string current;
  while (!c.at_end()) {
    std::string_view kw = c.token_on_line();
    if (kw == "newmtl") {
      current = c.token_on_line();
      out[current] = {0.8f, 0.8f, 0.8f};
    } else if (kw == "Kd" && !current.empty()) {
      std::array<float, 3> kd;
      bool ok = true;
      for (float& v : kd) ok = ok && parse_number(c.token_on_line(), v);
      if (ok) out[current] = kd;
    }
    c.next_line();
  }
}

struct Part {
  std::string group, material;
  std::vector<uint32_t> indices;  // into the file's vertex list
};

}  // namespace

std::vector<Mesh> read_obj(const Source& src, std::string_view bytes, const LoadOptions& opts) {
  std::string stem = file_stem(src.file);
  TextCursor c(bytes);
  c.hash_comments = true;
  std::vector<float> positions;
  std::vector<Part> parts;
  std::map<std::pair<std::string, std::string>, size_t> part_of;
  Materials materials;
  std::string group, material;
  Part* part = nullptr;
  std::vector<uint32_t> poly;
  int64_t face = 0;
  uint64_t triangles = 0;
  auto bad = [&](InputErrorKind kind, const std::string& element, int64_t i,
                 const std::string& msg) {
    fail(kind, src, group.empty() ? stem : group, element, i,
         "line " + std::to_string(c.line()) + ": " + msg);
  };
  while (!c.at_end()) {
    std::string_view kw = c.token_on_line();
    if (kw == "v") {
      int64_t vi = int64_t(positions.size() / 3);
      for (int k = 0; k < 3; ++k) {
        std::string_view t = c.token_on_line();
        float v;
        if (t.empty()) bad(InputErrorKind::ParseError, "vertex", vi, "expected 3 coordinates");
        if (!parse_number(t, v))
          bad(InputErrorKind::ParseError, "vertex", vi, "expected a number, got " + quote(t));
        if (!std::isfinite(v))
          bad(InputErrorKind::NonFiniteVertex, "vertex", vi,
              "coordinate " + std::string(1, "xyz"[k]) + " is not finite");
        positions.push_back(v);
      }
    } else if (kw == "f" || kw == "fo") {
      if (!part) {
        // One part per material (the Cornell box's "g" lines trail their faces, its usemtl lines
        // mark the objects); files without materials split by group / object.
        auto key = material.empty() ? std::make_pair(group, std::string())
                                    : std::make_pair(std::string(), material);
        auto [it, fresh] = part_of.try_emplace(key, parts.size());
        if (fresh) parts.push_back(Part{group, material, {}});
        part = &parts[it->second];
      }
      poly.clear();
      int64_t nv = int64_t(positions.size() / 3);
      while (!c.at_line_end()) {
        std::string_view t = c.token_on_line();
        std::string_view head = t.substr(0, t.find('/'));
        int64_t i = 0;
        if (!parse_number(head, i) || i == 0)
          bad(InputErrorKind::ParseError, "face", face, "bad vertex reference " + quote(t));
        int64_t v = i < 0 ? nv + i : i - 1;
        if (v < 0 || v >= nv)
          bad(InputErrorKind::IndexOutOfRange, "face", face,
              "vertex index " + std::to_string(i) + " out of range (" + std::to_string(nv) +
                  " vertices so far)");
        poly.push_back(uint32_t(v));
      }
      if (poly.size() >= 3)
        add_polygon(part->indices, positions, poly.data(), poly.size(), src,
                    group.empty() ? stem : group, face, int64_t(c.line()));
      triangles += poly.size() >= 3 ? poly.size() - 2 : 0;
      check_size(triangles, opts, src, group.empty() ? stem : group);
      ++face;
    } else if (kw == "g" || kw == "o") {
      std::string_view t = c.token_on_line();
      group = std::string(t);
      part = nullptr;
    } else if (kw == "usemtl") {
      material = std::string(c.token_on_line());
      part = nullptr;
    } else if (kw == "mtllib") {
      while (!c.at_line_end()) read_mtl(src, c.token_on_line(), opts, materials);
    }
    while (!c.at_line_end()) c.token_on_line();
    c.next_line();
  }

  std::vector<Mesh> out;
  if (parts.empty()) {  // no faces: one empty mesh, which finish_mesh reports as EmptyMesh
    Mesh m;
    m.name = stem;
    m.positions = std::move(positions);
    out.push_back(std::move(m));
    return out;
  }
  std::vector<uint32_t> local(positions.size() / 3, UINT32_MAX);
  for (Part& p : parts) {
    Mesh m;
    m.name = !p.material.empty() ? p.material : !p.group.empty() ? p.group : stem;
    for (const Mesh& o : out)
      if (o.name == m.name) m.name += "/" + p.material;
    if (auto it = materials.find(p.material); it != materials.end()) m.color = it->second;
    if (parts.size() == 1) {
      m.positions = std::move(positions);  // one part: keep the file's vertex numbering
      m.indices = std::move(p.indices);
    } else {
      std::vector<uint32_t> touched;
      for (uint32_t& v : p.indices) {
        if (local[v] == UINT32_MAX) {
          touched.push_back(v);
          local[v] = uint32_t(m.positions.size() / 3);
          m.positions.insert(m.positions.end(), &positions[3 * size_t(v)],
                             &positions[3 * size_t(v)] + 3);
        }
        v = local[v];
      }
      m.indices = std::move(p.indices);
      for (uint32_t v : touched) local[v] = UINT32_MAX;  // ready for the next part
    }
    out.push_back(std::move(m));
  }
  return out;
}

}  // namespace vismap::detail
