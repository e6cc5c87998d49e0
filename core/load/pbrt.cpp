// pbrt-v2 scene text, the subset that describes geometry (issue 18, docs/SCENE_FORMAT.md "pbrt"):
// Shape "trianglemesh" (point P, integer indices) as an ordinary mesh, Shape "loopsubdiv" as a
// Loop subdivision control mesh (Mesh::subdivision; its "nlevels" is ignored: the level is chosen
// every frame from the screen-space tolerance, core/surfaces/loop.cpp), the transform
// directives, Attribute/Transform blocks, Material's "color Kd" as the mesh colour, the
// perspective camera with the Film's resolution, and Include. Directives that do not change what
// we draw (Sampler, SurfaceIntegrator, LightSource, Texture, ...) are skipped; a light's own shape
// (a Shape inside an AreaLightSource block) is left out, since we draw surfaces, not lights; any
// other shape kind is an error, never a silently missing surface. Errors name file, line, column.
#include <algorithm>
#include <array>
#include <map>
#include <cmath>
#include <cstring>
#include <string>
#include <string_view>
#include <vector>

#include "core/load/internal.h"
#include "core/load/text_cursor.h"

namespace vismap::detail {
namespace {

using M4 = std::array<double, 16>;  // column-major, as core/camera.h

M4 identity() { return {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1}; }


// Gauss-Jordan with partial pivoting; false when singular.
bool invert(const M4& m, M4& out) {
  double a[4][8];
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) {
      a[r][c] = m[4 * c + r];
      a[r][4 + c] = r == c ? 1 : 0;
    }
  for (int c = 0; c < 4; ++c) {
    int p = c;
    for (int r = c + 1; r < 4; ++r)
      if (std::fabs(a[r][c]) > std::fabs(a[p][c])) p = r;
    if (!(std::fabs(a[p][c]) > 1e-300)) return false;
    for (int k = 0; k < 8; ++k) std::swap(a[c][k], a[p][k]);
    double d = a[c][c];
    for (int k = 0; k < 8; ++k) a[c][k] /= d;
    for (int r = 0; r < 4; ++r)
      if (r != c) {
        double f = a[r][c];
        for (int k = 0; k < 8; ++k) a[r][k] -= f * a[c][k];
      }
  }
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) out[4 * c + r] = a[r][4 + c];
  return true;
}

struct Token {
  enum Kind { End, Word, String, Open, Close } kind = End;
  std::string_view text;  // a string's contents without the quotes
  size_t at = 0;          // byte offset in the file
};

struct Param {
  std::string type, name;
  std::vector<double> nums;
  std::vector<size_t> num_at;  // byte offset of each number, for messages
  std::vector<std::string_view> strs;
  size_t at = 0;
};

struct State {
  M4 ctm = identity();
  std::array<float, 3> color{0.8f, 0.8f, 0.8f};
  bool area_light = false;
};

class PbrtReader {
 public:
  PbrtReader(const LoadOptions& opts, ByteBudget* budget, Scene& scene)
      : opts_(opts), budget_(budget), scene_(scene) {}

  void parse(const Source& src, std::string_view text, int depth) {
    File f{src, text, 0};
    while (true) {
      Token t = next(f);
      if (t.kind == Token::End) return;
      if (t.kind != Token::Word) fail_at(f, t.at, InputErrorKind::ParseError, "expected a directive");
      directive(f, t, depth);
    }
  }

  void finish() {
    if (camera_set_) scene_.camera = camera_;
  }

 private:
  struct File {
    Source src;
    std::string_view s;
    size_t pos;
  };

  [[noreturn]] void fail_at(const File& f, size_t at, InputErrorKind kind, const std::string& msg) {
    at = std::min(at, f.s.size());
    int64_t line = 1;
    size_t line_start = 0;
    for (size_t i = 0; i < at; ++i)
      if (f.s[i] == '\n') {
        ++line;
        line_start = i + 1;
      }
    throw InputError(kind, f.src.file, "", "line", line,
                     "column " + std::to_string(at - line_start + 1) + ": " + msg);
  }

  Token next(File& f) {
    const std::string_view s = f.s;
    while (f.pos < s.size()) {
      char c = s[f.pos];
      if (c == '#') {
        while (f.pos < s.size() && s[f.pos] != '\n') ++f.pos;
      } else if (c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\f' || c == '\v') {
        ++f.pos;
      } else {
        break;
      }
    }
    Token t;
    t.at = f.pos;
    if (f.pos >= s.size()) return t;
    char c = s[f.pos];
    if (c == '[' || c == ']') {
      t.kind = c == '[' ? Token::Open : Token::Close;
      t.text = s.substr(f.pos++, 1);
      return t;
    }
    if (c == '"') {
      size_t e = f.pos + 1;
      while (e < s.size() && s[e] != '"' && s[e] != '\n') ++e;
      if (e >= s.size() || s[e] != '"')
        fail_at(f, t.at, e >= s.size() ? InputErrorKind::Truncated : InputErrorKind::ParseError,
                "string not closed");
      t.kind = Token::String;
      t.text = s.substr(f.pos + 1, e - f.pos - 1);
      f.pos = e + 1;
      return t;
    }
    size_t e = f.pos;
    while (e < s.size()) {
      char d = s[e];
      if (d == ' ' || d == '\t' || d == '\n' || d == '\r' || d == '\f' || d == '\v' || d == '[' ||
          d == ']' || d == '"' || d == '#')
        break;
      ++e;
    }
    t.kind = Token::Word;
    t.text = s.substr(f.pos, e - f.pos);
    f.pos = e;
    return t;
  }

  Token peek(File& f) {
    size_t p = f.pos;
    Token t = next(f);
    f.pos = p;
    return t;
  }

  double number(File& f, const Token& t, const char* what) {
    double v;
    if (t.kind != Token::Word || !parse_number(t.text, v))
      fail_at(f, t.at, t.kind == Token::End ? InputErrorKind::Truncated : InputErrorKind::ParseError,
              std::string("expected a number (") + what + ")");
    if (!std::isfinite(v))
      fail_at(f, t.at, InputErrorKind::NonFiniteVertex, std::string(what) + " is not finite");
    return v;
  }

  // n numbers, bare or in one bracket.
  std::vector<double> numbers(File& f, size_t n, const char* what) {
    bool bracket = peek(f).kind == Token::Open;
    Token open;
    if (bracket) open = next(f);
    std::vector<double> v;
    for (size_t i = 0; i < n; ++i) v.push_back(number(f, next(f), what));
    if (bracket) {
      Token c = next(f);
      if (c.kind != Token::Close)
        fail_at(f, c.kind == Token::End ? open.at : c.at,
                c.kind == Token::End ? InputErrorKind::Truncated : InputErrorKind::ParseError,
                c.kind == Token::End ? "bracket not closed"
                                     : std::string("expected ']' after ") + std::to_string(n) +
                                           " numbers (" + what + ")");
    }
    return v;
  }

  std::string_view string_arg(File& f, const char* what) {
    Token t = next(f);
    if (t.kind != Token::String)
      fail_at(f, t.at, t.kind == Token::End ? InputErrorKind::Truncated : InputErrorKind::ParseError,
              std::string("expected a quoted ") + what);
    return t.text;
  }

  // "type name" value pairs until the next directive.
  std::vector<Param> params(File& f) {
    std::vector<Param> ps;
    while (peek(f).kind == Token::String) {
      Token decl = next(f);
      Param p;
      p.at = decl.at;
      std::string_view d = decl.text;
      size_t b = d.find_first_not_of(" \t"), sp = d.find_first_of(" \t", b);
      size_t nb = sp == std::string_view::npos ? sp : d.find_first_not_of(" \t", sp);
      if (b == std::string_view::npos || nb == std::string_view::npos)
        fail_at(f, decl.at, InputErrorKind::ParseError,
                "parameter " + quote(d) + " needs a type and a name (\"float fov\")");
      p.type = std::string(d.substr(b, sp - b));
      size_t ne = d.find_first_of(" \t", nb);
      p.name = std::string(d.substr(nb, ne == std::string_view::npos ? ne : ne - nb));
      bool is_str = p.type == "string" || p.type == "texture" || p.type == "bool";
      Token v = next(f);
      auto value = [&](const Token& t) {
        if (is_str) {
          if (t.kind != Token::String)
            fail_at(f, t.at, InputErrorKind::ParseError,
                    "parameter '" + p.name + "' expects quoted strings");
          p.strs.push_back(t.text);
        } else {
          double x;
          if (t.kind != Token::Word || !parse_number(t.text, x))
            fail_at(f, t.at, InputErrorKind::ParseError,
                    "parameter '" + p.name + "' expects numbers");
          p.nums.push_back(x);
          p.num_at.push_back(t.at);
        }
      };
      if (v.kind == Token::Open) {
        while (true) {
          Token t = next(f);
          if (t.kind == Token::Close) break;
          if (t.kind == Token::End)
            fail_at(f, v.at, InputErrorKind::Truncated, "bracket not closed");
          value(t);
        }
      } else if (v.kind == Token::End) {
        fail_at(f, v.at, InputErrorKind::Truncated, "parameter '" + p.name + "' has no value");
      } else {
        value(v);
      }
      ps.push_back(std::move(p));
    }
    return ps;
  }

  static const Param* find(const std::vector<Param>& ps, const char* name) {
    for (const Param& p : ps)
      if (p.name == name) return &p;
    return nullptr;
  }

  void apply(const M4& m) { st_.ctm = multiply(st_.ctm, m); }

  void directive(File& f, const Token& t, int depth) {
    std::string_view d = t.text;
    if (d == "Translate") {
      auto v = numbers(f, 3, "Translate");
      M4 m = identity();
      m[12] = v[0], m[13] = v[1], m[14] = v[2];
      apply(m);
    } else if (d == "Scale") {
      auto v = numbers(f, 3, "Scale");
      M4 m = identity();
      m[0] = v[0], m[5] = v[1], m[10] = v[2];
      apply(m);
    } else if (d == "Rotate") {
      auto v = numbers(f, 4, "Rotate");
      double len = std::sqrt(v[1] * v[1] + v[2] * v[2] + v[3] * v[3]);
      if (!(len > 0)) fail_at(f, t.at, InputErrorKind::ParseError, "Rotate about a zero axis");
      double x = v[1] / len, y = v[2] / len, z = v[3] / len;
      double a = v[0] * M_PI / 180, s = std::sin(a), c = std::cos(a);
      M4 m = identity();  // pbrt's Rotate (Rodrigues), column-major
      m[0] = x * x + (1 - x * x) * c, m[4] = x * y * (1 - c) - z * s, m[8] = x * z * (1 - c) + y * s;
      m[1] = x * y * (1 - c) + z * s, m[5] = y * y + (1 - y * y) * c, m[9] = y * z * (1 - c) - x * s;
      m[2] = x * z * (1 - c) - y * s, m[6] = y * z * (1 - c) + x * s, m[10] = z * z + (1 - z * z) * c;
      apply(m);
    } else if (d == "LookAt") {
      auto v = numbers(f, 9, "LookAt");
      apply(look_at(f, t, v));
    } else if (d == "Transform" || d == "ConcatTransform") {
      auto v = numbers(f, 16, d == "Transform" ? "Transform" : "ConcatTransform");
      M4 m;
      for (int i = 0; i < 16; ++i) m[i] = v[i];  // pbrt-v2 reads the 16 numbers column-major
      if (d == "Transform")
        st_.ctm = m;
      else
        apply(m);
    } else if (d == "Identity") {
      st_.ctm = identity();
    } else if (d == "AttributeBegin" || d == "TransformBegin") {
      stack_.push_back({st_, d == "AttributeBegin"});
    } else if (d == "AttributeEnd" || d == "TransformEnd") {
      bool attr = d == "AttributeEnd";
      if (stack_.empty() || stack_.back().second != attr)
        fail_at(f, t.at, InputErrorKind::ParseError,
                std::string(d) + " without its " + (attr ? "AttributeBegin" : "TransformBegin"));
      if (attr)
        st_ = stack_.back().first;
      else
        st_.ctm = stack_.back().first.ctm;
      stack_.pop_back();
    } else if (d == "WorldBegin") {
      st_.ctm = identity();
    } else if (d == "WorldEnd") {
    } else if (d == "Camera") {
      std::string_view kind = string_arg(f, "camera kind");
      auto ps = params(f);
      camera(f, t, kind, ps);
    } else if (d == "Film") {
      string_arg(f, "film kind");
      auto ps = params(f);
      for (const char* n : {"xresolution", "yresolution"})
        if (const Param* p = find(ps, n)) {
          if (p->nums.size() != 1 || !(p->nums[0] >= 1 && p->nums[0] <= kMaxViewport) ||
              p->nums[0] != std::floor(p->nums[0]))
            fail_at(f, p->at, InputErrorKind::BadCamera,
                    std::string(n) + " must be one whole number of pixels in 1.." +
                        std::to_string(kMaxViewport));
          (n[0] == 'x' ? camera_.width : camera_.height) = uint32_t(p->nums[0]);
        }
      if (camera_set_) fit_fov();
    } else if (d == "Material" || d == "MakeNamedMaterial") {
      std::string_view name = string_arg(f, d == "Material" ? "material kind" : "material name");
      auto ps = params(f);
      std::array<float, 3> c = st_.color;
      if (const Param* p = find(ps, "Kd"); p && (p->type == "color" || p->type == "rgb")) {
        if (p->nums.size() != 3)
          fail_at(f, p->at, InputErrorKind::ParseError, "Kd needs 3 numbers");
        for (int k = 0; k < 3; ++k) {
          if (!std::isfinite(p->nums[k]))
            fail_at(f, p->num_at[k], InputErrorKind::ParseError, "Kd is not finite");
          c[k] = float(std::clamp(p->nums[k], 0.0, 1.0));
        }
      } else if (d == "Material") {
        c = {0.5f, 0.5f, 0.5f};  // pbrt's default Kd for matte and plastic
      }
      if (d == "Material")
        st_.color = c;
      else
        named_[std::string(name)] = c;
    } else if (d == "NamedMaterial") {
      std::string_view name = string_arg(f, "material name");
      auto it = named_.find(std::string(name));
      if (it == named_.end())
        fail_at(f, t.at, InputErrorKind::BadScene, "no material named " + quote(name));
      st_.color = it->second;
    } else if (d == "AreaLightSource") {
      string_arg(f, "light kind");
      params(f);
      st_.area_light = true;
    } else if (d == "Shape") {
      std::string_view kind = string_arg(f, "shape kind");
      auto ps = params(f);
      shape(f, t, kind, ps);
    } else if (d == "Include") {
      std::string_view name = string_arg(f, "file name");
      include(f, t, std::string(name), depth);
    } else if (d == "Sampler" || d == "SurfaceIntegrator" || d == "VolumeIntegrator" ||
               d == "Renderer" || d == "PixelFilter" || d == "Accelerator" || d == "LightSource" ||
               d == "Volume" || d == "Texture" || d == "MakeNamedMedium" || d == "MediumInterface" ||
               d == "Option") {
      // Not geometry: their arguments (strings, then a parameter list) are read and dropped.
      // Leading names ("lowdiscrepancy") hold no space; parameter declarations do.
      while (peek(f).kind == Token::String && peek(f).text.find(' ') == std::string_view::npos)
        next(f);
      params(f);
    } else if (d == "ObjectBegin" || d == "ObjectEnd" || d == "ObjectInstance" ||
               d == "CoordinateSystem" || d == "CoordSysTransform" || d == "ActiveTransform" ||
               d == "TransformTimes" || d == "ReverseOrientation") {
      fail_at(f, t.at, InputErrorKind::BadScene,
              "pbrt directive '" + std::string(d) + "' is not supported (docs/SCENE_FORMAT.md)");
    } else {
      // An included file's words are not echoed (issue 35: Include "/etc/passwd" printed its
      // first line); the message keeps to its file, line and column.
      fail_at(f, t.at, InputErrorKind::ParseError,
              depth > 0 ? std::string("not a pbrt directive (an included file's text is not "
                                      "shown)")
                        : "unknown directive " + quote(d));
    }
  }

  // pbrt's LookAt: world to camera, the camera at `eye` looking down +z with +y up.
  M4 look_at(File& f, const Token& t, const std::vector<double>& v) {
    double e[3] = {v[0], v[1], v[2]}, dir[3] = {v[3] - v[0], v[4] - v[1], v[5] - v[2]};
    double up[3] = {v[6], v[7], v[8]};
    auto norm = [](double* a) {
      double l = std::sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
      if (!(l > 0)) return false;
      for (int k = 0; k < 3; ++k) a[k] /= l;
      return true;
    };
    auto cross = [](const double* a, const double* b, double* r) {
      r[0] = a[1] * b[2] - a[2] * b[1], r[1] = a[2] * b[0] - a[0] * b[2],
      r[2] = a[0] * b[1] - a[1] * b[0];
    };
    double right[3], nup[3];
    bool ok = norm(dir) && norm(up);
    if (ok) {
      cross(up, dir, right);
      ok = norm(right);
    }
    if (!ok)
      fail_at(f, t.at, InputErrorKind::BadCamera,
              "LookAt needs eye != target and up not along the view direction");
    cross(dir, right, nup);
    M4 c2w = {right[0], right[1], right[2], 0, nup[0], nup[1], nup[2], 0,
              dir[0],   dir[1],   dir[2],   0, e[0],   e[1],   e[2],   1};
    M4 w2c;
    invert(c2w, w2c);
    return w2c;
  }

  void camera(File& f, const Token& t, std::string_view kind, const std::vector<Param>& ps) {
    M4 c2w;
    if (!invert(st_.ctm, c2w))
      fail_at(f, t.at, InputErrorKind::BadCamera, "the camera transform is singular");
    auto point = [&](double x, double y, double z, double w, int k) {
      return c2w[k] * x + c2w[4 + k] * y + c2w[8 + k] * z + c2w[12 + k] * w;
    };
    for (int k = 0; k < 3; ++k) {
      camera_.eye[k] = point(0, 0, 0, 1, k);
      camera_.target[k] = camera_.eye[k] + point(0, 0, 1, 0, k);
      camera_.up[k] = point(0, 1, 0, 0, k);
    }
    if (kind == "perspective") {
      camera_.projection = Camera::Projection::Perspective;
      fov_ = 90;  // pbrt's default
      if (const Param* p = find(ps, "fov")) {
        if (p->nums.size() != 1 || !(p->nums[0] > 0 && p->nums[0] < 180))
          fail_at(f, p->at, InputErrorKind::BadCamera, "fov must be one number in (0, 180)");
        fov_ = p->nums[0];
      }
    } else if (kind == "orthographic") {
      camera_.projection = Camera::Projection::Orthographic;
    } else {
      fail_at(f, t.at, InputErrorKind::BadCamera,
              "camera " + quote(kind) + " is not supported (perspective, orthographic)");
    }
    camera_set_ = true;
    fit_fov();
  }

  // pbrt's fov and screen window [-1, 1] span the shorter image axis; ours are vertical.
  void fit_fov() {
    double aspect = double(camera_.height) / double(camera_.width);
    double s = std::max(1.0, aspect);
    camera_.fov_y_deg = 2 * std::atan(std::tan(fov_ * M_PI / 360) * s) * 180 / M_PI;
    camera_.ortho_height = 2 * s;
  }

  void shape(File& f, const Token& t, std::string_view kind, const std::vector<Param>& ps) {
    if (st_.area_light) return;  // a light's emitter: not drawn (see the header)
    bool loop = kind == "loopsubdiv";
    if (kind != "trianglemesh" && !loop)
      fail_at(f, t.at, InputErrorKind::BadScene,
              "Shape " + quote(kind) +
                  " is not supported (trianglemesh, loopsubdiv; docs/SCENE_FORMAT.md)");
    const Param* P = find(ps, "P");
    const Param* ix = find(ps, "indices");
    if (!P || P->type != "point")
      fail_at(f, t.at, InputErrorKind::ParseError, std::string(kind) + " needs \"point P\"");
    if (!ix || ix->type != "integer")
      fail_at(f, t.at, InputErrorKind::ParseError,
              std::string(kind) + " needs \"integer indices\"");
    if (P->nums.size() % 3 != 0 || P->nums.empty())
      fail_at(f, P->at, InputErrorKind::ParseError, "P needs 3 numbers per point");
    if (ix->nums.size() % 3 != 0 || ix->nums.empty())
      fail_at(f, ix->at, InputErrorKind::ParseError, "indices need 3 per triangle");
    // Issue 35, case 9: "Scale 0 0 0" before a shape gave an empty frame and exit 0.
    if (const std::string why = degenerate_transform(st_.ctm); !why.empty())
      fail_at(f, t.at, InputErrorKind::BadScene, why + " (the current transform at this Shape)");
    Mesh m;
    int64_t line = 1;
    for (size_t i = 0; i < t.at; ++i) line += f.s[i] == '\n';
    m.name = file_stem(f.src.file) + ":" + std::to_string(line) + " " + std::string(kind);
    m.subdivision = loop;
    m.color = st_.color;
    size_t nv = P->nums.size() / 3;
    m.positions.resize(P->nums.size());
    const M4& c = st_.ctm;
    for (size_t v = 0; v < nv; ++v) {
      double x = P->nums[3 * v], y = P->nums[3 * v + 1], z = P->nums[3 * v + 2];
      for (int k = 0; k < 3; ++k)
        if (!std::isfinite(P->nums[3 * v + k]))
          fail_at(f, P->num_at[3 * v + k], InputErrorKind::NonFiniteVertex,
                  "point " + std::to_string(v) + " is not finite");
      double w = c[3] * x + c[7] * y + c[11] * z + c[15];
      for (int k = 0; k < 3; ++k) {
        double r = (c[k] * x + c[4 + k] * y + c[8 + k] * z + c[12 + k]) / w;
        if (!std::isfinite(float(r)))
          fail_at(f, P->num_at[3 * v], InputErrorKind::NonFiniteVertex,
                  "point " + std::to_string(v) + " is not finite after the transform");
        m.positions[3 * v + k] = float(r);
      }
    }
    m.indices.resize(ix->nums.size());
    for (size_t i = 0; i < ix->nums.size(); ++i) {
      double x = ix->nums[i];
      if (!(x >= 0 && x < double(nv)) || x != std::floor(x))
        fail_at(f, ix->num_at[i], InputErrorKind::IndexOutOfRange,
                "index " + std::string(f.s.substr(ix->num_at[i], 20).substr(
                               0, f.s.substr(ix->num_at[i], 20).find_first_of(" \t\n]"))) +
                    " is not a point of P (" + std::to_string(nv) + " points)");
      m.indices[i] = uint32_t(x);
    }
    double det = c[0] * (c[5] * c[10] - c[9] * c[6]) - c[4] * (c[1] * c[10] - c[9] * c[2]) +
                 c[8] * (c[1] * c[6] - c[5] * c[2]);
    if (det < 0)  // a mirroring transform keeps outward normals by reversing the winding
      for (size_t i = 0; i < m.indices.size(); i += 3) std::swap(m.indices[i + 1], m.indices[i + 2]);
    triangles_ += m.indices.size() / 3;
    check_size(triangles_, opts_, f.src, m.name);
    scene_.dropped_degenerate += finish_mesh(m, f.src);
    scene_.meshes.push_back(std::move(m));
  }

  void include(File& f, const Token& t, const std::string& name, int depth) {
    if (depth >= 16)
      fail_at(f, t.at, InputErrorKind::BadScene, "Include nested more than 16 deep (a cycle?)");
    if (f.src.base_dir.empty())
      fail_at(f, t.at, InputErrorKind::BadScene, "a scene sent as bytes cannot include files");
    std::string path = name[0] == '/' ? name : f.src.base_dir + name;
    // pbrt-v2's scenes name their geometry as "geometry/x.pbrt" beside the scene; a copy that
    // keeps both in one folder (../shared/data/killeroo) is found by the file name alone.
    if (!file_exists(path) && name[0] != '/') {
      std::string alt = f.src.base_dir + name.substr(name.find_last_of('/') + 1);
      if (file_exists(alt)) path = alt;
    }
    std::string bytes;
    try {
      bytes = read_input_file(path, opts_, *budget_);
    } catch (const InputError& e) {
      fail_at(f, t.at, e.kind(), "Include " + quote(name) + ": " + e.what());
    }
    Source src{path, dir_of(path), budget_};
    try {
      parse(src, bytes, depth + 1);
    } catch (const InputError& e) {  // the included file's error, saying who included it
      int64_t line = 1;
      for (size_t i = 0; i < t.at; ++i) line += f.s[i] == '\n';
      throw InputError(e.kind(), e.file(), e.mesh(), e.element(), e.index(),
                       e.detail() + " (included by " + f.src.file + " line " +
                           std::to_string(line) + ")");
    }
  }

  bool file_exists(const std::string& p) {
    try {
      check_input_file(p, opts_);
      return true;
    } catch (const InputError&) {
      return false;
    }
  }

  const LoadOptions& opts_;
  ByteBudget* budget_;
  Scene& scene_;
  State st_;
  std::vector<std::pair<State, bool>> stack_;  // saved state, true for an Attribute block
  std::map<std::string, std::array<float, 3>> named_;
  Camera camera_{.eye = {0, 0, 0}, .target = {0, 0, 1}, .width = 640, .height = 480};
  double fov_ = 90;
  bool camera_set_ = false;
  uint64_t triangles_ = 0;
};

}  // namespace

Scene read_pbrt(const Source& src, std::string_view bytes, const LoadOptions& opts) {
  Scene scene;
  scene.source = src.file;
  PbrtReader r(opts, src.budget, scene);
  r.parse(src, bytes, 0);
  r.finish();
  if (scene.meshes.empty())
    fail(InputErrorKind::EmptyMesh, src, "", "", -1, "the scene has no trianglemesh or loopsubdiv");
  if (scene.camera) {
    try {
      Camera c = *scene.camera;  // near and far are chosen later, from the scene bounds
      c.near_plane = 1, c.far_plane = 2;
      c.validate();
    } catch (const InputError& e) {
      fail(InputErrorKind::BadCamera, src, "", "Camera", -1, e.detail());
    }
  }
  return scene;
}

}  // namespace vismap::detail
