// STL reader (binary and ascii). Every facet keeps its own three vertices (soup = true), so facet
// i is triangle i. Own reader, not OpenMesh's: OpenMesh merges vertices and silently skips
// facets whose corners merge, which would shift the face ids.
#include <cstring>

#include "core/load/internal.h"
#include "core/load/text_cursor.h"

namespace vismap::detail {
namespace {

bool looks_ascii(std::string_view b) {
  TextCursor c(b);
  if (c.token() != "solid") return false;
  c.next_line();
  std::string_view t = c.token();
  return t == "facet" || t == "endsolid";
}

}  // namespace

std::vector<Mesh> read_stl(const Source& src, std::string_view bytes, const LoadOptions& opts) {
  Mesh m;
  m.name = file_stem(src.file);
  m.soup = true;
  if (!looks_ascii(bytes)) {
    if (bytes.size() < 84)
      fail(InputErrorKind::Truncated, src, m.name, "", -1,
           "binary STL shorter than its 84-byte header");
    uint32_t n;
    std::memcpy(&n, bytes.data() + 80, 4);  // little endian on every platform we build for
    check_size(n, opts, src, m.name);
    if (bytes.size() < 84 + 50 * uint64_t(n))
      fail(InputErrorKind::Truncated, src, m.name, "facet", int64_t((bytes.size() - 84) / 50),
           "file ends before facet " + std::to_string((bytes.size() - 84) / 50) + " of " +
               std::to_string(n));
    m.positions.resize(size_t(n) * 9);
    m.indices.resize(size_t(n) * 3);
    for (uint32_t i = 0; i < n; ++i) {
      std::memcpy(&m.positions[size_t(i) * 9], bytes.data() + 84 + 50 * size_t(i) + 12, 36);
      for (uint32_t k = 0; k < 3; ++k) m.indices[3 * size_t(i) + k] = 3 * i + k;
    }
  } else {
    TextCursor c(bytes);
    c.token();  // solid
    c.next_line();
    auto bad = [&](int64_t i, const std::string& msg) {
      fail(InputErrorKind::ParseError, src, m.name, "facet", i,
           "line " + std::to_string(c.line()) + ": " + msg);
    };
    auto expect = [&](int64_t i, std::string_view want) {
      std::string_view t = c.token();
      if (t.empty())
        fail(InputErrorKind::Truncated, src, m.name, "facet", i,
             "file ends inside facet " + std::to_string(i));
      if (t != want) bad(i, "expected '" + std::string(want) + "', got " + quote(t));
    };
    auto number = [&](int64_t i, float& out) {
      std::string_view t = c.token();
      if (t.empty())
        fail(InputErrorKind::Truncated, src, m.name, "facet", i,
             "file ends inside facet " + std::to_string(i));
      if (!parse_number(t, out)) bad(i, "expected a number, got " + quote(t));
    };
    for (int64_t i = 0;; ++i) {
      std::string_view t = c.token();
      if (t == "endsolid") break;
      if (t.empty()) fail(InputErrorKind::Truncated, src, m.name, "facet", i, "no 'endsolid'");
      if (t != "facet") bad(i, "expected 'facet', got " + quote(t));
      expect(i, "normal");
      float v;
      for (int k = 0; k < 3; ++k) number(i, v);
      expect(i, "outer");
      expect(i, "loop");
      uint32_t first = uint32_t(m.vertex_count()), corners = 0;
      while (true) {
        t = c.token();
        if (t == "endloop") break;
        if (t.empty())
          fail(InputErrorKind::Truncated, src, m.name, "facet", i,
               "file ends inside facet " + std::to_string(i));
        if (t != "vertex") bad(i, "expected 'vertex' or 'endloop', got " + quote(t));
        for (int k = 0; k < 3; ++k) number(i, v), m.positions.push_back(v);
        ++corners;
      }
      if (corners != 3) bad(i, "facet has " + std::to_string(corners) + " vertices, expected 3");
      m.indices.insert(m.indices.end(), {first, first + 1, first + 2});
      expect(i, "endfacet");
      check_size(m.indices.size() / 3, opts, src, m.name);
    }
  }
  std::vector<Mesh> out;
  out.push_back(std::move(m));
  return out;
}

}  // namespace vismap::detail
