// SVG line drawings read back into a LineSet (core/lines/svg_lines.h): a small tag scanner, not an
// XML library, since the files it reads (ours, Freestyle's, the OCCT driver's) are flat lists of
// groups and paths; what it does not understand is an error, never skipped.
#include "core/lines/svg_lines.h"

#include <array>
#include <cctype>
#include <cmath>
#include <cstring>
#include <fstream>
#include <map>
#include <sstream>
#include <vector>

#include "core/error.h"

namespace vismap {

namespace {

using Affine = std::array<double, 6>;  // x' = a x + c y + e, y' = b x + d y + f (SVG's matrix())

Affine compose(const Affine& m, const Affine& n) {  // m then applied after n: m * n
  return {m[0] * n[0] + m[2] * n[1], m[1] * n[0] + m[3] * n[1], m[0] * n[2] + m[2] * n[3],
          m[1] * n[2] + m[3] * n[3], m[0] * n[4] + m[2] * n[5] + m[4],
          m[1] * n[4] + m[3] * n[5] + m[5]};
}

struct Reader {
  const std::string& text;
  const std::string& file;
  size_t pos = 0;
  int64_t element = -1;  // index of the current element in the file (start tags counted)
  std::string element_name;

  [[noreturn]] void fail(const std::string& msg) const {
    throw InputError(InputErrorKind::ParseError, file, "", "element <" + element_name + ">",
                     element, msg);
  }
};

bool is_space(char c) {
  return c == ' ' || c == '\t' || c == '\n' || c == '\r';
}

// SVG number grammar: sign? (digits ("." digits?)? | "." digits) exponent?. "1.5.5" is two
// numbers, "1-2" too (our writer relies on both).
bool parse_number(const std::string& s, size_t& i, double& v) {
  while (i < s.size() && (is_space(s[i]) || s[i] == ',')) ++i;
  const size_t start = i;
  if (i < s.size() && (s[i] == '+' || s[i] == '-')) ++i;
  bool digits = false;
  while (i < s.size() && std::isdigit(static_cast<unsigned char>(s[i]))) ++i, digits = true;
  if (i < s.size() && s[i] == '.') {
    ++i;
    while (i < s.size() && std::isdigit(static_cast<unsigned char>(s[i]))) ++i, digits = true;
  }
  if (!digits) {
    i = start;
    return false;
  }
  if (i < s.size() && (s[i] == 'e' || s[i] == 'E')) {
    size_t j = i + 1;
    if (j < s.size() && (s[j] == '+' || s[j] == '-')) ++j;
    if (j < s.size() && std::isdigit(static_cast<unsigned char>(s[j]))) {
      while (j < s.size() && std::isdigit(static_cast<unsigned char>(s[j]))) ++j;
      i = j;
    }
  }
  v = std::strtod(s.substr(start, i - start).c_str(), nullptr);
  return std::isfinite(v);
}

std::vector<double> numbers(const Reader& r, const std::string& s, const char* what) {
  std::vector<double> out;
  size_t i = 0;
  double v;
  while (parse_number(s, i, v)) out.push_back(v);
  while (i < s.size() && (is_space(s[i]) || s[i] == ',')) ++i;
  if (i != s.size()) r.fail(std::string(what) + ": not a number at \"" + s.substr(i, 20) + "\"");
  return out;
}

double number_attr(const Reader& r, const std::map<std::string, std::string>& a,
                   const std::string& name) {
  auto it = a.find(name);
  if (it == a.end()) return 0;  // SVG's default for x1, y1, ...
  std::vector<double> v = numbers(r, it->second, name.c_str());
  if (v.size() != 1) r.fail(name + ": expected one number");
  return v[0];
}

Affine parse_transform(const Reader& r, const std::string& s) {
  Affine m{1, 0, 0, 1, 0, 0};
  size_t i = 0;
  while (true) {
    while (i < s.size() && (is_space(s[i]) || s[i] == ',')) ++i;
    if (i == s.size()) return m;
    const size_t open = s.find('(', i), close = s.find(')', i);
    if (open == std::string::npos || close == std::string::npos || close < open)
      r.fail("transform: cannot read \"" + s.substr(i) + "\"");
    std::string name = s.substr(i, open - i);
    while (!name.empty() && is_space(name.back())) name.pop_back();
    const std::vector<double> a = numbers(r, s.substr(open + 1, close - open - 1), "transform");
    Affine t{1, 0, 0, 1, 0, 0};
    if (name == "matrix" && a.size() == 6)
      t = {a[0], a[1], a[2], a[3], a[4], a[5]};
    else if (name == "translate" && (a.size() == 1 || a.size() == 2))
      t = {1, 0, 0, 1, a[0], a.size() == 2 ? a[1] : 0};
    else if (name == "scale" && (a.size() == 1 || a.size() == 2))
      t = {a[0], 0, 0, a.size() == 2 ? a[1] : a[0], 0, 0};
    else if (name == "rotate" && (a.size() == 1 || a.size() == 3)) {
      const double rad = a[0] * 3.14159265358979323846 / 180, c = std::cos(rad), sn = std::sin(rad);
      t = {c, sn, -sn, c, 0, 0};
      if (a.size() == 3)
        t = compose(compose(Affine{1, 0, 0, 1, a[1], a[2]}, t), Affine{1, 0, 0, 1, -a[1], -a[2]});
    } else
      r.fail("transform: " + name + " with " + std::to_string(a.size()) + " numbers is not read");
    m = compose(m, t);
    i = close + 1;
  }
}

// "0 0 1024 1024" or "1024" / "1024px".
bool same_size(const std::string& v, double want) {
  char* end = nullptr;
  const double d = std::strtod(v.c_str(), &end);
  if (end == v.c_str()) return false;
  const std::string rest(end);
  return (rest.empty() || rest == "px") && std::abs(d - want) < 1e-6;
}

// A kind's name, or a name ending in "_" and a kind's name (Freestyle's lineset groups are
// id="LAYER_LINESET", so a lineset named "crease" is read as creases).
int kind_of(const std::string& name) {
  for (size_t k = 0; k < kLineKinds; ++k) {
    const std::string kn = line_kind_name(LineKind(k));
    if (name == kn || (name.size() > kn.size() && name.compare(name.size() - kn.size() - 1,
                                                               std::string::npos, "_" + kn) == 0))
      return int(k);
  }
  return -1;
}

struct Open {
  std::string name;
  Affine m;
  int kind;  // -1: inherit Contour
  bool hidden;
  bool skip;  // inside title/desc/metadata/style/defs or a namespaced element
};

struct Builder {
  LineSet out;
  std::vector<double> pts;
  bool closed = false;
  int kind = 0;
  void flush() {
    // A closed chain does not repeat its first point (core/lines/lines.h).
    size_t n = pts.size() / 2;
    if (closed && n > 1 && pts[0] == pts[2 * n - 2] && pts[1] == pts[2 * n - 1]) --n;
    if (n >= 2) {
      out.xy.insert(out.xy.end(), pts.begin(), pts.begin() + 2 * n);
      out.off.push_back(uint32_t(out.xy.size() / 2));
      out.kind.push_back(LineKind(kind));
      out.closed.push_back(closed && n > 2);
      out.hidden.push_back(0);
      out.edges[kind] += closed && n > 2 ? n : n - 1;
    }
    pts.clear();
    closed = false;
  }
};

void read_path(const Reader& r, const std::string& d, const Affine& m, Builder& b) {
  auto emit = [&](double x, double y) {
    b.pts.push_back(m[0] * x + m[2] * y + m[4]);
    b.pts.push_back(m[1] * x + m[3] * y + m[5]);
  };
  double cx = 0, cy = 0, sx = 0, sy = 0;  // current point and subpath start, user units
  char cmd = 0;
  size_t i = 0;
  while (true) {
    while (i < d.size() && (is_space(d[i]) || d[i] == ',')) ++i;
    if (i == d.size()) break;
    if (std::isalpha(static_cast<unsigned char>(d[i]))) {
      cmd = d[i++];
      if (!std::strchr("MmLlHhVvZz", cmd))
        r.fail(std::string("path command '") + cmd + "' is not read (only M L H V Z)");
      if (cmd == 'Z' || cmd == 'z') {
        b.closed = true;
        b.flush();
        cx = sx, cy = sy;
        cmd = 0;  // numbers after Z need a command
        continue;
      }
    } else if (!cmd)
      r.fail("path data: a number with no command before it at \"" + d.substr(i, 20) + "\"");
    const bool rel = std::islower(static_cast<unsigned char>(cmd));
    double v[2];
    const int need = (cmd == 'H' || cmd == 'h' || cmd == 'V' || cmd == 'v') ? 1 : 2;
    for (int k = 0; k < need; ++k)
      if (!parse_number(d, i, v[k])) r.fail("path data: expected a number at \"" + d.substr(i, 20) + "\"");
    switch (cmd) {
      case 'M':
      case 'm':
        b.flush();
        cx = rel ? cx + v[0] : v[0], cy = rel ? cy + v[1] : v[1];
        sx = cx, sy = cy;
        emit(cx, cy);
        cmd = rel ? 'l' : 'L';  // further pairs are lines
        break;
      case 'L':
      case 'l':
        if (b.pts.empty()) emit(cx, cy);  // after a Z: the subpath starts at its start
        cx = rel ? cx + v[0] : v[0], cy = rel ? cy + v[1] : v[1];
        emit(cx, cy);
        break;
      case 'H':
      case 'h':
        if (b.pts.empty()) emit(cx, cy);
        cx = rel ? cx + v[0] : v[0];
        emit(cx, cy);
        break;
      default:  // V v
        if (b.pts.empty()) emit(cx, cy);
        cy = rel ? cy + v[0] : v[0];
        emit(cx, cy);
        break;
    }
  }
  b.flush();
}

}  // namespace

LineSet read_svg_lines(const std::string& text, const std::string& file, uint32_t width,
                       uint32_t height) {
  // Long on purpose (~135 lines): a tag scanner's loop; the open-element stack, the inherited
  // transforms and classes and the builder it feeds are one state that every tag changes.
  Reader r{text, file, 0, -1, ""};
  Builder b;
  std::vector<Open> stack;
  bool root_seen = false;
  const std::string& s = text;
  size_t& i = r.pos;
  while (true) {
    const size_t lt = s.find('<', i);
    if (lt == std::string::npos) break;
    i = lt;
    auto skip_to = [&](const char* end) {
      const size_t e = s.find(end, i);
      if (e == std::string::npos) {
        r.element_name = "?";
        r.fail(std::string("unterminated markup, no ") + end);
      }
      i = e + std::strlen(end);
    };
    if (s.compare(i, 4, "<!--") == 0) { skip_to("-->"); continue; }
    if (s.compare(i, 9, "<![CDATA[") == 0) { skip_to("]]>"); continue; }
    if (s.compare(i, 2, "<?") == 0) { skip_to("?>"); continue; }
    if (s.compare(i, 2, "<!") == 0) { skip_to(">"); continue; }
    if (s.compare(i, 2, "</") == 0) {
      const size_t gt = s.find('>', i);
      if (gt == std::string::npos) r.fail("unterminated end tag");
      std::string name = s.substr(i + 2, gt - i - 2);
      while (!name.empty() && is_space(name.back())) name.pop_back();
      if (stack.empty() || stack.back().name != name) {
        r.element_name = name;
        r.fail("end tag does not match the open element");
      }
      stack.pop_back();
      i = gt + 1;
      continue;
    }
    // A start tag: name, attributes, "/>" or ">".
    ++i;
    const size_t name_start = i;
    while (i < s.size() && !is_space(s[i]) && s[i] != '>' && s[i] != '/') ++i;
    const std::string name = s.substr(name_start, i - name_start);
    ++r.element;
    r.element_name = name;
    std::map<std::string, std::string> attrs;
    bool self_closing = false;
    while (true) {
      while (i < s.size() && is_space(s[i])) ++i;
      if (i >= s.size()) r.fail("unterminated start tag");
      if (s[i] == '>') { ++i; break; }
      if (s.compare(i, 2, "/>") == 0) { i += 2; self_closing = true; break; }
      const size_t a0 = i;
      while (i < s.size() && s[i] != '=' && !is_space(s[i]) && s[i] != '>') ++i;
      const std::string an = s.substr(a0, i - a0);
      while (i < s.size() && is_space(s[i])) ++i;
      if (i >= s.size() || s[i] != '=') r.fail("attribute " + an + " has no value");
      ++i;
      while (i < s.size() && is_space(s[i])) ++i;
      if (i >= s.size() || (s[i] != '"' && s[i] != '\'')) r.fail("attribute " + an + ": no quote");
      const char q = s[i++];
      const size_t e = s.find(q, i);
      if (e == std::string::npos) r.fail("attribute " + an + ": unterminated value");
      attrs[an] = s.substr(i, e - i);
      i = e + 1;
    }

    const Open parent = stack.empty() ? Open{"", {1, 0, 0, 1, 0, 0}, -1, false, false} : stack.back();
    Open o{name, parent.m, parent.kind, parent.hidden, parent.skip};
    static const char* const kIgnored[] = {"title", "desc", "metadata", "style", "defs"};
    for (const char* ig : kIgnored) o.skip |= name == ig;
    o.skip |= name.find(':') != std::string::npos;
    if (!o.skip) {
      if (!root_seen) {
        if (name != "svg") r.fail("the file's first element is not <svg>");
        root_seen = true;
        auto vb = attrs.find("viewBox");
        std::string got;
        bool ok;
        if (vb != attrs.end()) {
          const std::vector<double> v = numbers(r, vb->second, "viewBox");
          ok = v.size() == 4 && v[0] == 0 && v[1] == 0 && std::abs(v[2] - width) < 1e-6 &&
               std::abs(v[3] - height) < 1e-6;
          got = "viewBox \"" + vb->second + "\"";
        } else {
          ok = same_size(attrs["width"], width) && same_size(attrs["height"], height);
          got = "width \"" + attrs["width"] + "\", height \"" + attrs["height"] + "\"";
        }
        if (!ok)
          throw InputError(InputErrorKind::BadScene, file, "", "element <svg>", r.element,
                           got + " is not the camera's 0 0 " + std::to_string(width) + " " +
                               std::to_string(height));
      } else if (name == "svg")
        r.fail("nested <svg> is not read");
      for (const char* key : {"class", "id"}) {
        auto it = attrs.find(key);
        if (it == attrs.end()) continue;
        // class may list several names
        std::istringstream words(it->second);
        for (std::string w; words >> w;) {
          if (w == "hidden") o.hidden = true;
          if (kind_of(w) >= 0) o.kind = kind_of(w);
        }
      }
      if (auto it = attrs.find("transform"); it != attrs.end())
        o.m = compose(o.m, parse_transform(r, it->second));
      if (!o.hidden) {
        b.kind = o.kind >= 0 ? o.kind : 0;
        if (name == "path") {
          read_path(r, attrs["d"], o.m, b);
        } else if (name == "polyline" || name == "polygon") {
          const std::vector<double> v = numbers(r, attrs["points"], "points");
          if (v.size() % 2) r.fail("points: an odd count of numbers");
          for (size_t k = 0; k < v.size(); k += 2) {
            b.pts.push_back(o.m[0] * v[k] + o.m[2] * v[k + 1] + o.m[4]);
            b.pts.push_back(o.m[1] * v[k] + o.m[3] * v[k + 1] + o.m[5]);
          }
          b.closed = name == "polygon";
          b.flush();
        } else if (name == "line") {
          const double x1 = number_attr(r, attrs, "x1"), y1 = number_attr(r, attrs, "y1"),
                       x2 = number_attr(r, attrs, "x2"), y2 = number_attr(r, attrs, "y2");
          b.pts = {o.m[0] * x1 + o.m[2] * y1 + o.m[4], o.m[1] * x1 + o.m[3] * y1 + o.m[5],
                   o.m[0] * x2 + o.m[2] * y2 + o.m[4], o.m[1] * x2 + o.m[3] * y2 + o.m[5]};
          b.flush();
        } else if (name != "svg" && name != "g")
          r.fail("not a line element (read: path, polyline, polygon, line, g)");
      } else if (name != "svg" && name != "g" && name != "path" && name != "polyline" &&
                 name != "polygon" && name != "line")
        r.fail("not a line element (read: path, polyline, polygon, line, g)");
    }
    if (!self_closing) stack.push_back(o);
  }
  r.element_name = stack.empty() ? "svg" : stack.back().name;
  if (!root_seen) r.fail("no <svg> element");
  if (!stack.empty()) r.fail("not closed at the end of the file");
  return b.out;
}

LineSet read_svg_lines_file(const std::string& path, uint32_t width, uint32_t height) {
  std::ifstream in(path, std::ios::binary);
  if (!in)
    throw InputError(InputErrorKind::FileNotFound, path, "", "", -1, "cannot open the drawing");
  std::ostringstream ss;
  ss << in.rdbuf();
  return read_svg_lines(ss.str(), path, width, height);
}

}  // namespace vismap
