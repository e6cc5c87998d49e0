// PLY reader (ascii, binary little and big endian): a "vertex" element with x, y, z and either a
// "face" element (list vertex_indices / vertex_index, polygons triangulated by add_polygon) or a
// "tristrips" element (lists with -1 restarting a strip). Other elements and properties are
// skipped. Our own reader rather than OpenMesh's: OpenMesh's PolyMesh drops or splits faces at
// non-manifold edges (happy_vrip_res3.ply), cannot read tristrips (igea.ply) and is slower on the
// ascii bunny (52 ms against about 15 ms here); the renderer must see every face in file order.
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>

#include "core/load/internal.h"
#include "core/load/text_cursor.h"

namespace vismap::detail {
namespace {

enum class PType { I8, U8, I16, U16, I32, U32, F32, F64 };

struct Prop {
  std::string name;
  PType type = PType::F32;
  bool list = false;
  PType count_type = PType::U8;
};

struct Element {
  std::string name;
  uint64_t count = 0;
  std::vector<Prop> props;
};

enum class Format { Ascii, BinaryLE, BinaryBE };

bool parse_type(std::string_view t, PType& out) {
  static const std::pair<const char*, PType> kTypes[] = {
      {"char", PType::I8},    {"int8", PType::I8},     {"uchar", PType::U8},
      {"uint8", PType::U8},   {"short", PType::I16},   {"int16", PType::I16},
      {"ushort", PType::U16}, {"uint16", PType::U16},  {"int", PType::I32},
      {"int32", PType::I32},  {"uint", PType::U32},    {"uint32", PType::U32},
      {"float", PType::F32},  {"float32", PType::F32}, {"double", PType::F64},
      {"float64", PType::F64}};
  for (auto& [n, ty] : kTypes)
    if (t == n) {
      out = ty;
      return true;
    }
  return false;
}

size_t type_size(PType t) {
  switch (t) {
    case PType::I8:
    case PType::U8:
      return 1;
    case PType::I16:
    case PType::U16:
      return 2;
    case PType::I32:
    case PType::U32:
    case PType::F32:
      return 4;
    case PType::F64:
      return 8;
  }
  return 0;
}

// Reads scalars from a binary body, refusing to run past its end.
class BinaryReader {
 public:
  BinaryReader(std::string_view b, size_t pos, bool big) : b_(b), pos_(pos), big_(big) {}
  bool has(size_t n) const { return b_.size() - pos_ >= n; }
  size_t remaining() const { return b_.size() - pos_; }
  void skip(size_t n) { pos_ += n; }
  // Caller checks has(type_size(t)).
  double number(PType t) {
    unsigned char raw[8];
    size_t n = type_size(t);
    std::memcpy(raw, b_.data() + pos_, n);
    pos_ += n;
    if (big_ != (std::endian::native == std::endian::big))
      for (size_t i = 0; i < n / 2; ++i) std::swap(raw[i], raw[n - 1 - i]);
    switch (t) {
      case PType::I8:
        return static_cast<int8_t>(raw[0]);
      case PType::U8:
        return raw[0];
      case PType::I16: {
        int16_t v;
        std::memcpy(&v, raw, 2);
        return v;
      }
      case PType::U16: {
        uint16_t v;
        std::memcpy(&v, raw, 2);
        return v;
      }
      case PType::I32: {
        int32_t v;
        std::memcpy(&v, raw, 4);
        return v;
      }
      case PType::U32: {
        uint32_t v;
        std::memcpy(&v, raw, 4);
        return v;
      }
      case PType::F32: {
        float v;
        std::memcpy(&v, raw, 4);
        return v;
      }
      case PType::F64: {
        double v;
        std::memcpy(&v, raw, 8);
        return v;
      }
    }
    return 0;
  }

 private:
  std::string_view b_;
  size_t pos_;
  bool big_;
};

struct Header {
  Format format = Format::Ascii;
  std::vector<Element> elements;
  size_t body = 0;        // byte offset of the data
  int64_t body_line = 0;  // line number where the data starts (ascii)
};

Header parse_header(const Source& src, std::string_view bytes) {
  Header h;
  TextCursor c(bytes);
  auto bad = [&](const std::string& msg) -> void {
    fail(InputErrorKind::ParseError, src, "", "header line", c.line(), msg);
  };
  if (bytes.substr(0, 3) != "ply") bad("not a PLY file (no 'ply' magic)");
  c.next_line();
  bool have_format = false;
  while (true) {
    if (c.pos() >= bytes.size())
      fail(InputErrorKind::Truncated, src, "", "header line", c.line(), "no 'end_header'");
    std::string_view kw = c.token_on_line();
    if (kw == "end_header") {
      c.next_line();
      break;
    }
    if (kw == "format") {
      std::string_view f = c.token_on_line();
      if (f == "ascii")
        h.format = Format::Ascii;
      else if (f == "binary_little_endian")
        h.format = Format::BinaryLE;
      else if (f == "binary_big_endian")
        h.format = Format::BinaryBE;
      else
        bad("unknown format " + quote(f));
      have_format = true;
    } else if (kw == "element") {
      Element e;
      e.name = c.token_on_line();
      int64_t n = -1;
      if (e.name.empty() || !parse_number(c.token_on_line(), n) || n < 0)
        bad("expected 'element NAME COUNT'");
      e.count = static_cast<uint64_t>(n);
      h.elements.push_back(std::move(e));
    } else if (kw == "property") {
      if (h.elements.empty()) bad("property before any element");
      Prop p;
      std::string_view t = c.token_on_line();
      if (t == "list") {
        p.list = true;
        if (!parse_type(c.token_on_line(), p.count_type) || !parse_type(c.token_on_line(), p.type))
          bad("expected 'property list COUNT_TYPE TYPE NAME'");
      } else if (!parse_type(t, p.type)) {
        bad("unknown property type " + quote(t));
      }
      p.name = c.token_on_line();
      if (p.name.empty()) bad("property without a name");
      h.elements.back().props.push_back(std::move(p));
    } else if (kw != "comment" && kw != "obj_info" && !kw.empty()) {
      bad("unknown header keyword " + quote(kw));
    }
    c.next_line();
  }
  if (!have_format)
    fail(InputErrorKind::ParseError, src, "", "", -1, "PLY header has no format line");
  h.body = c.pos();
  h.body_line = c.line();
  return h;
}

// What we take from each element, by role.
enum class Role { Vertex, Face, Strips, Skip };

struct Reader {
  const Source& src;
  const std::string& mesh;
  Mesh& m;
  uint64_t nv = 0;
  std::vector<uint32_t> poly;  // corners of the current face / strip

  uint32_t vertex_index(double v, const char* elem, uint64_t i) {
    if (!(v >= 0 && v < static_cast<double>(nv)))
      fail(InputErrorKind::IndexOutOfRange, src, mesh, elem, static_cast<int64_t>(i),
           "vertex index " +
               (std::fabs(v) < 9e18 ? std::to_string(static_cast<int64_t>(v)) : std::to_string(v)) +
               " out of range (" + std::to_string(nv) + " vertices)");
    return static_cast<uint32_t>(v);
  }
  // line: the face's in an ascii file, -1 in a binary one.
  void end_face(uint64_t face, int64_t line) {
    if (poly.size() >= 3)
      add_polygon(m.indices, m.positions, poly.data(), poly.size(), src, mesh, int64_t(face), line);
  }
  // Strips: -1 restarts; every other triangle flips so all keep the strip's orientation.
  void end_strip(const std::vector<double>& raw, uint64_t elem) {
    size_t start = 0;
    for (size_t j = 0; j <= raw.size(); ++j) {
      if (j < raw.size() && raw[j] != -1) continue;
      for (size_t k = start + 2; k < j; ++k) {
        uint32_t a = vertex_index(raw[k - 2], "tristrips", elem);
        uint32_t b = vertex_index(raw[k - 1], "tristrips", elem);
        uint32_t c = vertex_index(raw[k], "tristrips", elem);
        if ((k - start) % 2) std::swap(a, b);
        m.indices.insert(m.indices.end(), {a, b, c});
      }
      start = j + 1;
    }
  }
};

Role role_of(const Element& e, int& ix, int& iy, int& iz, int& ilist) {
  ix = iy = iz = ilist = -1;
  for (size_t p = 0; p < e.props.size(); ++p) {
    const Prop& pr = e.props[p];
    if (!pr.list && pr.name == "x") ix = int(p);
    if (!pr.list && pr.name == "y") iy = int(p);
    if (!pr.list && pr.name == "z") iz = int(p);
    if (pr.list && (pr.name == "vertex_indices" || pr.name == "vertex_index")) ilist = int(p);
  }
  if (e.name == "vertex") return Role::Vertex;
  if (e.name == "face" && ilist >= 0) return Role::Face;
  if (e.name == "tristrips" && ilist >= 0) return Role::Strips;
  return Role::Skip;
}

}  // namespace

std::vector<Mesh> read_ply(const Source& src, std::string_view bytes, const LoadOptions& opts) {
  // Long on purpose (~170 lines): the body's loops share the header's element table, the cursor
  // and the bound argued below (every loop consumes input per item); split, that argument would
  // have to be made again for each part.
  Header h = parse_header(src, bytes);
  Mesh m;
  m.name = file_stem(src.file);
  Reader r{src, m.name, m, 0, {}};
  bool have_vertices = false;
  for (const Element& e : h.elements) {
    int ix, iy, iz, il;
    Role role = role_of(e, ix, iy, iz, il);
    if (role == Role::Vertex) {
      if (ix < 0 || iy < 0 || iz < 0)
        fail(InputErrorKind::ParseError, src, m.name, "", -1, "vertex element lacks x, y or z");
      if (e.count > UINT32_MAX)
        fail(InputErrorKind::TooLarge, src, m.name, "", -1, "too many vertices");
      r.nv = e.count;
      have_vertices = true;
    } else if (role != Role::Skip) {
      if (!have_vertices)
        fail(InputErrorKind::ParseError, src, m.name, "", -1,
             "element '" + e.name + "' comes before the vertex element");
      if (role == Role::Face) check_size(e.count, opts, src, m.name);
    }
  }
  // Each loop below runs once per stated item and consumes at least a token or a byte per item
  // (or fails at the item where the file ends), so it is bounded by the bytes, except for an
  // element with no properties: "element junk 9223372036854775807" looped for ever, doing
  // nothing. Such an element still takes a line per item in ascii; in binary it takes no bytes,
  // and a count larger than the whole body is refused there as a lie all the same. No loop is
  // run for it.
  const uint64_t body = bytes.size() - h.body;
  for (const Element& e : h.elements)
    if (e.props.empty() && e.count > body)
      fail(InputErrorKind::Truncated, src, m.name, e.name, -1,
           "header states " + std::to_string(e.count) + " " + e.name +
               " items without properties, more than the " + std::to_string(body) +
               " bytes after the header");
  // Reserve no more than the body could hold, so a lying header cannot exhaust memory.
  m.positions.reserve(std::min<uint64_t>(checked_mul(r.nv, 3), bytes.size()));

  std::vector<double> vals, raw;
  if (h.format == Format::Ascii) {
    TextCursor c(bytes, h.body, h.body_line);
    for (const Element& e : h.elements) {
      int ix, iy, iz, il;
      Role role = role_of(e, ix, iy, iz, il);
      if (role == Role::Face)
        m.indices.reserve(std::min<uint64_t>(checked_mul(e.count, 3), bytes.size()));
      for (uint64_t i = 0; i < e.count && !e.props.empty(); ++i) {
        auto parse = [&](std::string_view t, double& out) {
          if (t.empty())
            fail(InputErrorKind::Truncated, src, m.name, e.name, int64_t(i),
                 "file ends before " + e.name + " " + std::to_string(i) + " of " +
                     std::to_string(e.count) + " is complete");
          if (!parse_number(t, out))
            fail(InputErrorKind::ParseError, src, m.name, e.name, int64_t(i),
                 "line " + std::to_string(c.line()) + ": expected a number, got " + quote(t));
        };
        auto number = [&](double& out) { parse(c.token(), out); };
        auto index = [&](double& out) {  // integers first: faster than a double parse
          std::string_view t = c.token();
          int64_t n;
          if (parse_number(t, n))
            out = double(n);
          else
            parse(t, out);
        };
        vals.assign(3, 0.0);
        for (size_t p = 0; p < e.props.size(); ++p) {
          const Prop& pr = e.props[p];
          double v;
          number(v);
          if (!pr.list) {
            if (int(p) == ix)
              vals[0] = v;
            else if (int(p) == iy)
              vals[1] = v;
            else if (int(p) == iz)
              vals[2] = v;
            continue;
          }
          if (!(v >= 0 && v <= 1e9))
            fail(InputErrorKind::ParseError, src, m.name, e.name, int64_t(i),
                 "line " + std::to_string(c.line()) + ": bad list length");
          size_t k = static_cast<size_t>(v);
          // Each entry is a token of a byte and a separator: raw.resize(k) is then bounded.
          if (k > (bytes.size() - c.pos() + 1) / 2)
            fail(InputErrorKind::Truncated, src, m.name, e.name, int64_t(i),
                 "line " + std::to_string(c.line()) + ": list of " + std::to_string(k) +
                     " entries runs past the end of the file");
          if (int(p) != il || role == Role::Vertex || role == Role::Skip) {
            for (size_t j = 0; j < k; ++j) number(v);
          } else if (role == Role::Face) {
            r.poly.clear();
            for (size_t j = 0; j < k; ++j) {
              index(v);
              r.poly.push_back(r.vertex_index(v, "face", i));
            }
            r.end_face(i, int64_t(c.line()));
          } else {
            raw.resize(k);
            for (size_t j = 0; j < k; ++j) number(raw[j]);
            r.end_strip(raw, i);
          }
        }
        if (role == Role::Vertex)
          m.positions.insert(m.positions.end(), {float(vals[0]), float(vals[1]), float(vals[2])});
      }
    }
  } else {
    BinaryReader b(bytes, h.body, h.format == Format::BinaryBE);
    for (const Element& e : h.elements) {
      int ix, iy, iz, il;
      Role role = role_of(e, ix, iy, iz, il);
      for (uint64_t i = 0; i < e.count && !e.props.empty(); ++i) {
        auto need = [&](size_t n) {
          if (!b.has(n))
            fail(InputErrorKind::Truncated, src, m.name, e.name, int64_t(i),
                 "file ends before " + e.name + " " + std::to_string(i) + " of " +
                     std::to_string(e.count) + " is complete");
        };
        float xyz[3] = {0, 0, 0};
        for (size_t p = 0; p < e.props.size(); ++p) {
          const Prop& pr = e.props[p];
          if (!pr.list) {
            need(type_size(pr.type));
            double v = b.number(pr.type);
            if (int(p) == ix)
              xyz[0] = float(v);
            else if (int(p) == iy)
              xyz[1] = float(v);
            else if (int(p) == iz)
              xyz[2] = float(v);
            continue;
          }
          need(type_size(pr.count_type));
          double kd = b.number(pr.count_type);
          if (!(kd >= 0))
            fail(InputErrorKind::ParseError, src, m.name, e.name, int64_t(i), "bad list length");
          // Held against the bytes left before any size is computed from it: a count of 2^62
          // times 4 bytes wrapped to 0, and the reader ran off the end of the buffer.
          if (kd > double(b.remaining()))
            fail(InputErrorKind::Truncated, src, m.name, e.name, int64_t(i),
                 "list of " +
                     (kd < 1e19 ? std::to_string(uint64_t(kd)) : std::string("more than 2^63")) +
                     " entries runs past the end of the file (" + std::to_string(b.remaining()) +
                     " bytes left)");
          size_t k = static_cast<size_t>(kd);
          need(checked_mul(k, type_size(pr.type)));
          if (int(p) != il || role == Role::Vertex || role == Role::Skip) {
            b.skip(k * type_size(pr.type));
          } else if (role == Role::Face) {
            r.poly.clear();
            for (size_t j = 0; j < k; ++j)
              r.poly.push_back(r.vertex_index(b.number(pr.type), "face", i));
            r.end_face(i, -1);
          } else {
            raw.resize(k);
            for (size_t j = 0; j < k; ++j) raw[j] = b.number(pr.type);
            r.end_strip(raw, i);
          }
        }
        if (role == Role::Vertex) m.positions.insert(m.positions.end(), xyz, xyz + 3);
      }
    }
  }
  check_size(m.indices.size() / 3, opts, src, m.name);
  std::vector<Mesh> out;
  out.push_back(std::move(m));
  return out;
}

}  // namespace vismap::detail
