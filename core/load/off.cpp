// OFF reader (OFF, COFF, NOFF, CNOFF, STOFF...: ascii, 3D). Extra per-vertex and per-face values
// (colors, normals, texture coordinates) are skipped. Own reader, not OpenMesh's: it reports the
// line and element of a bad value and keeps every face in file order (OpenMesh's PolyMesh refuses
// faces at non-manifold edges).
#include "core/load/internal.h"
#include "core/load/text_cursor.h"

namespace vismap::detail {

std::vector<Mesh> read_off(const Source& src, std::string_view bytes, const LoadOptions& opts) {
  Mesh m;
  m.name = file_stem(src.file);
  TextCursor c(bytes);
  c.hash_comments = true;
  auto bad = [&](const std::string& element, int64_t i, const std::string& msg) {
    fail(InputErrorKind::ParseError, src, m.name, element, i,
         "line " + std::to_string(c.line()) + ": " + msg);
  };
  std::string_view magic = c.token();
  bool ok_magic = magic.size() >= 3 && magic.substr(magic.size() - 3) == "OFF";
  for (char ch : magic.substr(0, magic.size() >= 3 ? magic.size() - 3 : 0))
    ok_magic = ok_magic && (ch == 'S' || ch == 'T' || ch == 'C' || ch == 'N');
  if (!ok_magic) bad("", -1, "not an OFF file (expected 'OFF', got " + quote(magic) + ")");
  if (!c.at_line_end() && c.token_on_line() == "BINARY") bad("", -1, "binary OFF is not supported");

  auto skip_rest_of_line = [&] {
    while (!c.at_line_end()) c.token_on_line();
    c.next_line();
  };
  auto count = [&](const char* what) {
    std::string_view t = c.token();
    int64_t n = -1;
    if (t.empty()) fail(InputErrorKind::Truncated, src, m.name, "", -1, "file ends in the header");
    if (!parse_number(t, n) || n < 0)
      bad("", -1, std::string("bad ") + what + " count " + quote(t));
    return n;
  };
  int64_t nv = count("vertex"), nf = count("face");
  count("edge");
  skip_rest_of_line();
  if (nv > int64_t(UINT32_MAX))
    fail(InputErrorKind::TooLarge, src, m.name, "", -1, "too many vertices");
  check_size(uint64_t(nf), opts, src, m.name);

  auto number = [&](const char* element, int64_t i, auto& out) {
    std::string_view t = c.token();
    if (t.empty())
      fail(InputErrorKind::Truncated, src, m.name, element, i,
           "file ends before " + std::string(element) + " " + std::to_string(i));
    if (!parse_number(t, out)) bad(element, i, "expected a number, got " + quote(t));
  };
  m.positions.reserve(std::min<uint64_t>(checked_mul(uint64_t(nv), 3), bytes.size()));
  for (int64_t i = 0; i < nv; ++i) {
    float xyz[3];
    for (float& v : xyz) number("vertex", i, v);
    m.positions.insert(m.positions.end(), xyz, xyz + 3);
    skip_rest_of_line();
  }
  m.indices.reserve(std::min<uint64_t>(checked_mul(uint64_t(nf), 3), bytes.size()));
  std::vector<uint32_t> poly;
  for (int64_t f = 0; f < nf; ++f) {
    int64_t k = 0;
    number("face", f, k);
    if (k < 0 || k > (int64_t(1) << 24)) bad("face", f, "bad corner count " + std::to_string(k));
    poly.clear();
    for (int64_t j = 0; j < k; ++j) {
      int64_t v = 0;
      number("face", f, v);
      if (v < 0 || v >= nv)
        fail(InputErrorKind::IndexOutOfRange, src, m.name, "face", f,
             "vertex index " + std::to_string(v) + " out of range (" + std::to_string(nv) +
                 " vertices)");
      poly.push_back(uint32_t(v));
    }
    if (poly.size() >= 3)
      add_polygon(m.indices, m.positions, poly.data(), poly.size(), src, m.name, f,
                  int64_t(c.line()));
    skip_rest_of_line();
  }
  std::vector<Mesh> out;
  out.push_back(std::move(m));
  return out;
}

}  // namespace vismap::detail
