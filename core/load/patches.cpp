// Bicubic Bezier patch readers (issue 18, docs/SCENE_FORMAT.md "Bezier patches"): the .bpt text
// (a patch count, then per patch its degrees "3 3" and 16 lines "x y z") and Newell's .patches
// (a patch count, a line of 16 comma-separated 1-based point indices per patch, a point count,
// a line "x,y,z" per point). One patch mesh per file (Mesh::patches; positions and indices stay
// empty, diced per frame by core/surfaces/patches.cpp), so finish_mesh is not used.
//
// Orientation: both files list a patch's 16 points in four rows of four; point k is control
// point (i, j) = (k / 4, k % 4), the index inside a row runs along u. Stored as is, the
// Utah teapot's normals S_u x S_v point outward (its control nets, as triangles (i,j) (i,j+1)
// (i+1,j+1) and (i,j) (i+1,j+1) (i+1,j), enclose +32.1, a positive volume; tests/test_load_readers.cpp
// LoadPatches), and teapot.bpt and newell_teapot.patches hold the same 32 patches in the same
// order, point for point.
#include <cmath>
#include <string>
#include <string_view>
#include <vector>

#include "core/load/internal.h"
#include "core/load/text_cursor.h"

namespace vismap::detail {
namespace {

// The lines of a text file, one at a time, with their numbers; blank lines are skipped.
class Lines {
 public:
  explicit Lines(std::string_view s) : s_(s) {}
  // The next line with content (without its newline), false at the end of the text.
  bool next(std::string_view& out) {
    while (pos_ < s_.size()) {
      size_t end = s_.find('\n', pos_);
      if (end == std::string_view::npos) end = s_.size();
      std::string_view l = s_.substr(pos_, end - pos_);
      pos_ = end + 1;
      ++line_;
      if (l.find_first_not_of(" \t\r\f\v") != std::string_view::npos) {
        out = l;
        return true;
      }
    }
    ++line_;  // a message about the end of the file names the line after the last one
    pos_ = s_.size() + 1;
    return false;
  }
  int64_t line() const { return line_; }
  size_t left() const { return pos_ < s_.size() ? s_.size() - pos_ : 0; }

 private:
  std::string_view s_;
  size_t pos_ = 0;
  int64_t line_ = 0;
};

// Splits a line into fields: on whitespace (.bpt) or on commas with whitespace around them
// (.patches). An empty field between two commas is kept, so that "1,,2" is an error.
std::vector<std::string_view> fields(std::string_view l, bool commas) {
  std::vector<std::string_view> out;
  auto trim = [](std::string_view t) {
    size_t b = t.find_first_not_of(" \t\r\f\v");
    if (b == std::string_view::npos) return std::string_view();
    size_t e = t.find_last_not_of(" \t\r\f\v");
    return t.substr(b, e - b + 1);
  };
  if (commas) {
    size_t b = 0;
    while (true) {
      size_t e = l.find(',', b);
      out.push_back(
          trim(l.substr(b, e == std::string_view::npos ? std::string_view::npos : e - b)));
      if (e == std::string_view::npos) break;
      b = e + 1;
    }
  } else {
    TextCursor c(l);
    for (std::string_view t = c.token(); !t.empty(); t = c.token()) out.push_back(t);
  }
  return out;
}

// What both formats share: the messages ("line N: ..."), the counts, the points.
struct Reader {
  const Source& src;
  const LoadOptions& opts;
  std::string_view bytes;
  bool commas;
  Mesh m;
  Lines lines{bytes};

  Reader(const Source& s, std::string_view b, const LoadOptions& o, bool c)
      : src(s), opts(o), bytes(b), commas(c) {
    m.name = file_stem(src.file);
  }

  [[noreturn]] void bad(InputErrorKind kind, const std::string& element, int64_t i,
                        const std::string& msg) {
    fail(kind, src, m.name, element, i, "line " + std::to_string(lines.line()) + ": " + msg);
  }
  // The next line's fields; `what` says what was expected, for the message at the end of the file.
  std::vector<std::string_view> line(const std::string& element, int64_t i,
                                     const std::string& what) {
    std::string_view l;
    if (!lines.next(l)) bad(InputErrorKind::Truncated, element, i, "file ends before " + what);
    return fields(l, commas);
  }
  void expect_fields(const std::vector<std::string_view>& f, size_t n, const char* what,
                     const std::string& element, int64_t i) {
    if (f.size() != n)
      bad(InputErrorKind::ParseError, element, i,
          "expected " + std::to_string(n) + " " + what + ", got " + std::to_string(f.size()));
  }
  int64_t integer(std::string_view t, const std::string& element, int64_t i) {
    int64_t v = 0;
    if (!parse_number(t, v))
      bad(InputErrorKind::ParseError, element, i, "expected an integer, got " + quote(t));
    return v;
  }
  // A count on a line of its own. A count larger than the file holds is not refused here: the
  // reading stops at the end of the file with the line it reached, and nothing is reserved for
  // more items than the bytes can hold (reserve()).
  int64_t count(const char* what, const char* plural) {
    auto f = line("", -1, std::string("the ") + what + " count");
    expect_fields(f, 1, (std::string(what) + " count").c_str(), "", -1);
    int64_t n = integer(f[0], "", -1);
    if (n < 0)
      bad(InputErrorKind::ParseError, "", -1, std::string("bad ") + what + " count " + quote(f[0]));
    if (n > int64_t(UINT32_MAX))
      bad(InputErrorKind::TooLarge, "", -1,
          std::to_string(n) + " " + plural + ", limit is 2^32 - 1");
    return n;
  }
  // Room for `n` items of `size` values that take at least `min_bytes` each in the file: no more
  // than the bytes left could hold, so a lying count cannot exhaust memory.
  template <class T>
  void reserve(std::vector<T>& v, int64_t n, uint64_t size, uint64_t min_bytes) {
    v.reserve(size_t(
        std::min(checked_mul(uint64_t(n), size), checked_mul(lines.left() / min_bytes + 1, size))));
  }
  // Three finite coordinates from a line's fields.
  void point(const std::vector<std::string_view>& f, const std::string& element, int64_t i,
             float* xyz) {
    expect_fields(f, 3, "numbers", element, i);
    for (int k = 0; k < 3; ++k) {
      if (!parse_number(f[k], xyz[k]))
        bad(InputErrorKind::ParseError, element, i, "expected a number, got " + quote(f[k]));
      if (!std::isfinite(xyz[k]))
        bad(InputErrorKind::NonFiniteVertex, element, i,
            std::string("coordinate ") + "xyz"[k] + " is not finite");
    }
  }
  void no_more(const std::string& what) {
    std::string_view l;
    if (lines.next(l)) bad(InputErrorKind::ParseError, "", -1, "content after the " + what);
  }
  Scene scene(int64_t n) {
    m.source_triangles = uint32_t(n);
    Scene s;
    s.source = src.file;
    s.meshes.push_back(std::move(m));
    return s;
  }
};

}  // namespace

Scene read_bpt(const Source& src, std::string_view bytes, const LoadOptions& opts) {
  Reader r(src, bytes, opts, false);
  int64_t n = r.count("patch", "patches");
  if (n == 0) r.bad(InputErrorKind::EmptyMesh, "", -1, "no patches");
  check_size(uint64_t(n), opts, src, r.m.name);
  // A patch takes at least "3 3\n" and 16 lines "x y z\n", 4 + 16 * 6 bytes (one less for the
  // last, without its newline).
  r.reserve(r.m.patches, n, 48, 99);
  for (int64_t p = 0; p < n; ++p) {
    auto d = r.line("patch", p, "patch " + std::to_string(p) + " of " + std::to_string(n));
    r.expect_fields(d, 2, "degrees (u v)", "patch", p);
    int64_t du = r.integer(d[0], "patch", p), dv = r.integer(d[1], "patch", p);
    if (du != 3 || dv != 3)
      r.bad(InputErrorKind::ParseError, "patch", p,
            "degrees " + std::to_string(du) + " " + std::to_string(dv) +
                ": only bicubic patches (3 3) are supported");
    for (int k = 0; k < 16; ++k) {
      auto f = r.line("patch", p, "point " + std::to_string(k) + " of patch " + std::to_string(p));
      float xyz[3];
      r.point(f, "patch", p, xyz);
      r.m.patches.insert(r.m.patches.end(), xyz, xyz + 3);  // (k / 4, k % 4): rows along u
    }
  }
  r.no_more(std::to_string(n) + " patches the first line announces");
  return r.scene(n);
}

Scene read_newell_patches(const Source& src, std::string_view bytes, const LoadOptions& opts) {
  Reader r(src, bytes, opts, true);
  int64_t n = r.count("patch", "patches");
  if (n == 0) r.bad(InputErrorKind::EmptyMesh, "", -1, "no patches");
  check_size(uint64_t(n), opts, src, r.m.name);
  std::vector<uint32_t> idx;
  std::vector<int64_t> line_of;  // each patch's line, for an index found out of range later
  // A patch line takes at least 16 one-digit indices, 15 commas and a newline: 32 bytes.
  r.reserve(idx, n, 16, 32);
  r.reserve(line_of, n, 1, 32);
  for (int64_t p = 0; p < n; ++p) {
    auto f = r.line("patch", p, "patch " + std::to_string(p) + " of " + std::to_string(n));
    r.expect_fields(f, 16, "point indices", "patch", p);
    for (std::string_view t : f) {
      int64_t v = r.integer(t, "patch", p);
      if (v < 1 || v > int64_t(UINT32_MAX))
        r.bad(InputErrorKind::IndexOutOfRange, "patch", p,
              "point index " + std::to_string(v) + " out of range (points are numbered from 1)");
      idx.push_back(uint32_t(v - 1));
    }
    line_of.push_back(r.lines.line());
  }
  int64_t m = r.count("point", "points");
  std::vector<float> pts;
  r.reserve(pts, m, 3, 5);  // a point line takes at least "0,0,0" and its newline
  for (int64_t q = 0; q < m; ++q) {
    auto f = r.line("point", q, "point " + std::to_string(q + 1) + " of " + std::to_string(m));
    float xyz[3];
    r.point(f, "point", q, xyz);
    pts.insert(pts.end(), xyz, xyz + 3);
  }
  r.no_more(std::to_string(m) + " points the point count announces");
  r.m.patches.resize(size_t(n) * 48);  // n patch lines were read: at most 6 floats per byte
  for (int64_t p = 0; p < n; ++p)
    for (int k = 0; k < 16; ++k) {
      uint32_t v = idx[16 * size_t(p) + k];
      if (v >= uint64_t(m))
        fail(InputErrorKind::IndexOutOfRange, src, r.m.name, "patch", p,
             "line " + std::to_string(line_of[p]) + ": point index " + std::to_string(v + 1) +
                 " out of range (" + std::to_string(m) + " points, numbered from 1)");
      for (int c = 0; c < 3; ++c) r.m.patches[48 * size_t(p) + 3 * k + c] = pts[3 * size_t(v) + c];
    }
  return r.scene(n);
}

}  // namespace vismap::detail
