// Scene files (.json, docs/SCENE_FORMAT.md): meshes from other files placed with transforms and
// colors, and a camera. A file named by several entries is loaded once and copied per instance.
// Every key is checked: an unknown key or a wrong type is BadScene naming the JSON path.
#include <cmath>
#include <map>
#include <nlohmann/json.hpp>

#include "core/load/internal.h"

namespace vismap::detail {
namespace {

using json = nlohmann::json;
using M4 = std::array<double, 16>;  // column-major

const M4 kIdentity = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};

// Rotation by `deg` degrees about unit axis (x,y,z), right-handed.
M4 rotation(double x, double y, double z, double deg) {
  double l = std::sqrt(x * x + y * y + z * z);
  x /= l, y /= l, z /= l;
  double a = deg * M_PI / 180.0, c = std::cos(a), s = std::sin(a), t = 1 - c;
  return {t * x * x + c,
          t * x * y + s * z,
          t * x * z - s * y,
          0,
          t * x * y - s * z,
          t * y * y + c,
          t * y * z + s * x,
          0,
          t * x * z + s * y,
          t * y * z - s * x,
          t * z * z + c,
          0,
          0,
          0,
          0,
          1};
}

struct Checker {
  const Source& src;
  [[noreturn]] void bad(const std::string& path, const std::string& msg) const {
    fail(InputErrorKind::BadScene, src, "", path, -1, msg);
  }
  void keys(const json& j, const std::string& path,
            std::initializer_list<const char*> allowed) const {
    if (!j.is_object()) bad(path.empty() ? "(top level)" : path, "expected an object");
    for (auto it = j.begin(); it != j.end(); ++it) {
      bool ok = it.key() == "comment";
      for (const char* a : allowed) ok = ok || it.key() == a;
      if (!ok) bad(path.empty() ? it.key() : path + "." + it.key(), "unknown key");
    }
  }
  double number(const json& j, const std::string& path) const {
    if (!j.is_number()) bad(path, "expected a number");
    double v = j.get<double>();
    if (!std::isfinite(v)) bad(path, "expected a finite number");
    return v;
  }
  std::vector<double> numbers(const json& j, const std::string& path, size_t n) const {
    if (!j.is_array() || j.size() != n)
      bad(path, "expected an array of " + std::to_string(n) + " numbers");
    std::vector<double> v;
    for (size_t i = 0; i < n; ++i) v.push_back(number(j[i], path + "[" + std::to_string(i) + "]"));
    return v;
  }
  Vec3 vec3(const json& j, const std::string& path) const {
    auto v = numbers(j, path, 3);
    return {v[0], v[1], v[2]};
  }
  uint32_t pixels(const json& j, const std::string& path) const {
    // The camera's own limit (issue 35: 65,536 passed here and was refused later as over 16,384).
    if (!j.is_number_integer() || j.get<int64_t>() < 1 || j.get<int64_t>() > kMaxViewport)
      bad(path, "expected an integer in 1.." + std::to_string(kMaxViewport));
    return uint32_t(j.get<int64_t>());
  }
};

M4 entry_transform(const Checker& ck, const json& e, const std::string& path) {
  if (e.contains("matrix")) {
    for (const char* k : {"translate", "rotate_deg", "rotate_axis_angle", "scale"})
      if (e.contains(k))
        ck.bad(path + ".matrix", std::string("'matrix' cannot be combined with '") + k + "'");
    auto v = ck.numbers(e["matrix"], path + ".matrix", 16);
    M4 m{};
    std::copy(v.begin(), v.end(), m.begin());
    return m;
  }
  M4 t = kIdentity, r = kIdentity, s = kIdentity;
  if (e.contains("translate")) {
    Vec3 v = ck.vec3(e["translate"], path + ".translate");
    t[12] = v[0], t[13] = v[1], t[14] = v[2];
  }
  if (e.contains("rotate_deg") && e.contains("rotate_axis_angle"))
    ck.bad(path + ".rotate_axis_angle", "give either 'rotate_deg' or 'rotate_axis_angle'");
  if (e.contains("rotate_deg")) {  // about x, then y, then z (world axes)
    Vec3 a = ck.vec3(e["rotate_deg"], path + ".rotate_deg");
    r = multiply(rotation(0, 0, 1, a[2]), multiply(rotation(0, 1, 0, a[1]), rotation(1, 0, 0, a[0])));
  }
  if (e.contains("rotate_axis_angle")) {
    auto a = ck.numbers(e["rotate_axis_angle"], path + ".rotate_axis_angle", 4);
    if (a[0] == 0 && a[1] == 0 && a[2] == 0) ck.bad(path + ".rotate_axis_angle", "axis is zero");
    r = rotation(a[0], a[1], a[2], a[3]);
  }
  if (e.contains("scale")) {
    const json& j = e["scale"];
    Vec3 v = j.is_number() ? Vec3{ck.number(j, path + ".scale"), j.get<double>(), j.get<double>()}
             : j.is_array()
                 ? ck.vec3(j, path + ".scale")
                 : (ck.bad(path + ".scale", "expected a number or an array of 3 numbers"), Vec3{});
    if (v[0] == 0 || v[1] == 0 || v[2] == 0) ck.bad(path + ".scale", "scale must not be zero");
    s[0] = v[0], s[5] = v[1], s[10] = v[2];
  }
  return multiply(t, multiply(r, s));
}

Camera read_camera(const Checker& ck, const json& j) {
  ck.keys(j, "camera",
          {"type", "eye", "target", "up", "fov_y_deg", "ortho_height", "near", "far", "width",
           "height"});
  Camera c;
  if (j.contains("type")) {
    const json& t = j["type"];
    if (t == "perspective")
      c.projection = Camera::Projection::Perspective;
    else if (t == "orthographic")
      c.projection = Camera::Projection::Orthographic;
    else
      ck.bad("camera.type", "expected \"perspective\" or \"orthographic\"");
  }
  if (j.contains("eye")) c.eye = ck.vec3(j["eye"], "camera.eye");
  if (j.contains("target")) c.target = ck.vec3(j["target"], "camera.target");
  if (j.contains("up")) c.up = ck.vec3(j["up"], "camera.up");
  if (j.contains("fov_y_deg")) c.fov_y_deg = ck.number(j["fov_y_deg"], "camera.fov_y_deg");
  if (j.contains("ortho_height"))
    c.ortho_height = ck.number(j["ortho_height"], "camera.ortho_height");
  if (j.contains("near")) c.near_plane = ck.number(j["near"], "camera.near");
  if (j.contains("far")) c.far_plane = ck.number(j["far"], "camera.far");
  if (j.contains("width")) c.width = ck.pixels(j["width"], "camera.width");
  if (j.contains("height")) c.height = ck.pixels(j["height"], "camera.height");
  if (c.eye == c.target)
    fail(InputErrorKind::BadCamera, ck.src, "", "camera", -1, "eye equals target");
  return c;
}

}  // namespace

Scene read_scene_file(const Source& src, std::string_view bytes, const LoadOptions& opts) {
  // Long on purpose (~150 lines): the document's keys in order (meshes: each file loaded once,
  // placed and coloured; implicit objects; the camera), every check naming its element through
  // the one Checker.
  json doc;
  try {
    doc = json::parse(bytes.begin(), bytes.end());
  } catch (const json::parse_error& e) {
    size_t at = std::min<size_t>(e.byte, bytes.size());
    int64_t line = 1 + std::count(bytes.begin(), bytes.begin() + (at ? at - 1 : 0), '\n');
    fail(at >= bytes.size() ? InputErrorKind::Truncated : InputErrorKind::ParseError, src, "",
         "line", line, std::string("JSON: ") + e.what());
  } catch (const json::exception& e) {  // e.g. a number too large for any JSON number type
    fail(InputErrorKind::ParseError, src, "", "", -1, std::string("JSON: ") + e.what());
  }
  Checker ck{src};
  ck.keys(doc, "", {"meshes", "camera"});
  if (!doc.contains("meshes") || !doc["meshes"].is_array())
    ck.bad("meshes", "expected an array of mesh entries");
  Scene scene;
  scene.source = src.file;
  std::map<std::string, Scene> loaded;  // file -> untransformed scene, loaded once
  uint64_t triangles = 0;
  const json& meshes = doc["meshes"];
  // How many entries name each file (issue 35, case 7: a 1 MB scene naming the bunny 10,000
  // times copied it until bad_alloc at 7.6 GB). A file's copies are counted when it is first
  // loaded, before any copy is made, against the triangle limit and what one load may hold.
  std::map<std::string, uint64_t> references;
  for (const json& e : meshes)
    if (e.is_object() && !e.contains("expression") && e.contains("file") &&
        e["file"].is_string() && !e["file"].get<std::string>().empty()) {
      const std::string f = e["file"].get<std::string>();
      ++references[f[0] == '/' ? f : src.base_dir + f];
    }
  uint64_t projected_triangles = 0, projected_bytes = 0;
  for (size_t i = 0; i < meshes.size(); ++i) {
    std::string path = "meshes[" + std::to_string(i) + "]";
    const json& e = meshes[i];
    ck.keys(e, path,
            {"file", "expression", "bounds", "name", "translate", "rotate_deg",
             "rotate_axis_angle", "scale", "matrix", "color", "subdivision"});
    const bool inline_expr = e.contains("expression");
    if (inline_expr && e.contains("file"))
      ck.bad(path + ".expression", "give either 'file' or 'expression'");
    if (inline_expr && (!e["expression"].is_string() || e["expression"].get<std::string>().empty()))
      ck.bad(path + ".expression", "expected an expression string");
    if (!inline_expr &&
        (!e.contains("file") || !e["file"].is_string() || e["file"].get<std::string>().empty()))
      ck.bad(path + ".file", "expected a file name");
    std::string file = inline_expr ? std::string() : e["file"].get<std::string>();
    if (!inline_expr && src.base_dir.empty())
      ck.bad(path + ".file", "a scene sent as bytes cannot reference files");
    if (format_extension(file) == ".json") ck.bad(path + ".file", "scene files do not nest");
    const bool is_implicit = inline_expr || format_extension(file) == ".sexp";
    std::optional<std::array<double, 6>> bounds;
    if (e.contains("bounds")) {
      if (!is_implicit) ck.bad(path + ".bounds", "only an implicit object has bounds");
      auto b = ck.numbers(e["bounds"], path + ".bounds", 6);
      for (int k = 0; k < 3; ++k)
        if (!(b[k] < b[k + 3]))
          ck.bad(path + ".bounds", "expected [xlo, ylo, zlo, xhi, yhi, zhi] with each lo < hi");
      // The device dices the box in float: one thinner than a float step there, or beyond float
      // range, holds nothing (issue 35, case 9: 1e-300 wide gave an empty frame, exit 0).
      for (int k = 0; k < 3; ++k)
        if (!(std::isfinite(float(b[k])) && std::isfinite(float(b[k + 3])) &&
              float(b[k]) < float(b[k + 3]) && std::isfinite(float(b[k + 3]) - float(b[k]))))
          ck.bad(path + ".bounds", "each lo < hi also as floats, the device's numbers (a box "
                                   "thinner than a float step, or beyond float range, is empty)");
      bounds = std::array<double, 6>{b[0], b[1], b[2], b[3], b[4], b[5]};
    }
    M4 m = entry_transform(ck, e, path);
    // Issue 35, case 9: a transform that is projective or collapses the entry was applied as
    // given and the frame came out empty, exit 0.
    const std::string placed = path + (e.contains("matrix") ? ".matrix" : ".scale");
    if (m[3] != 0 || m[7] != 0 || m[11] != 0 || m[15] != 1)
      ck.bad(placed,
             "the bottom row must be 0, 0, 0, 1 (a placement must be affine and invertible)");
    if (const std::string why = degenerate_transform(m); !why.empty())
      ck.bad(placed, why + " (a placement must be affine and invertible)");
    std::optional<std::array<float, 3>> color;
    if (e.contains("color")) {
      auto c = ck.numbers(e["color"], path + ".color", 3);
      color = std::array<float, 3>{float(c[0]), float(c[1]), float(c[2])};
    }
    if (e.contains("name") && !e["name"].is_string()) ck.bad(path + ".name", "expected a string");
    if (e.contains("subdivision") && !e["subdivision"].is_boolean())
      ck.bad(path + ".subdivision", "expected true or false");
    if (is_implicit && e.contains("subdivision"))
      ck.bad(path + ".subdivision", "an implicit object has no control mesh");
    std::string full = inline_expr ? path : file[0] == '/' ? file : src.base_dir + file;
    // An implicit entry is its own object (its bounds are the entry's); a mesh file is loaded
    // once and copied per entry.
    auto it = is_implicit ? loaded.end() : loaded.find(full);
    Scene own;
    if (is_implicit) {
      try {
        std::string text = inline_expr ? e["expression"].get<std::string>()
                                       : read_input_file(full, opts, *src.budget);
        Source isrc{inline_expr ? src.file + " " + path + ".expression" : full, src.base_dir,
                    src.budget};
        own.meshes.push_back(implicit_object(isrc, text, file_stem(inline_expr ? "implicit" : full),
                                             bounds));
      } catch (const InputError& ie) {
        if (inline_expr) throw;
        throw InputError(ie.kind(), ie.file(), ie.mesh(), ie.element(), ie.index(),
                         ie.detail() + " (referenced by " + src.file + " " + path + ")");
      }
    } else if (it == loaded.end()) {
      try {
        // The scene's budget: its referenced files together are held against one cap.
        it = loaded.emplace(full, load_file(full, opts, *src.budget)).first;
      } catch (const InputError& e) {  // the referenced file's error, saying who referenced it
        throw InputError(e.kind(), e.file(), e.mesh(), e.element(), e.index(),
                         e.detail() + " (referenced by " + src.file + " " + path + ")");
      }
      // Its warnings once, however many entries name it.
      scene.warnings.insert(scene.warnings.end(), it->second.warnings.begin(),
                            it->second.warnings.end());
      const uint64_t copies = std::max<uint64_t>(references[full], 1);
      uint64_t tris = 0, bytes = 0;
      for (const Mesh& pm : it->second.meshes) {
        tris += pm.source_triangles;
        bytes += sizeof(Mesh) + pm.name.size() +
                 4 * (pm.positions.size() + pm.indices.size() + pm.face_ids.size() +
                      pm.patches.size() + pm.uv.size() + pm.normals.size());
      }
      projected_triangles = checked_add(projected_triangles, checked_mul(copies, tris));
      projected_bytes = checked_add(projected_bytes, checked_mul(copies, bytes));
      const std::string named = std::to_string(copies) + " entries name " + file + " (" +
                                std::to_string(tris) + " triangles)";
      if (opts.max_triangles != 0 && projected_triangles > opts.max_triangles)
        fail(InputErrorKind::TooLarge, src, "", path + ".file", -1,
             named + ": the scene would hold " + std::to_string(projected_triangles) +
                 " triangles, limit is " + std::to_string(opts.max_triangles));
      if (projected_bytes > kMaxInputBytes)
        fail(InputErrorKind::TooLarge, src, "", path + ".file", -1,
             named + ": their copies would hold " + std::to_string(projected_bytes >> 20) +
                 " MiB, more than one load may (" + std::to_string(kMaxInputBytes >> 20) +
                 " MiB)");
    }
    double det = m[0] * (m[5] * m[10] - m[9] * m[6]) - m[4] * (m[1] * m[10] - m[9] * m[2]) +
                 m[8] * (m[1] * m[6] - m[5] * m[2]);
    const Scene& part = is_implicit ? own : it->second;
    for (const Mesh& pm : part.meshes) {
      Mesh mesh = pm;
      if (e.contains("name"))
        mesh.name = e["name"].get<std::string>() + (part.meshes.size() > 1 ? "/" + pm.name : "");
      if (color) mesh.color = *color;
      // The mesh is a Loop control mesh (docs/SURFACES.md); false makes a loopsubdiv plain.
      if (e.contains("subdivision")) {
        if (!pm.patches.empty()) ck.bad(path + ".subdivision", "a patch mesh has no control mesh");
        mesh.subdivision = e["subdivision"].get<bool>();
      }
      for (size_t v = 0; v < mesh.positions.size(); v += 3) {
        double x = mesh.positions[v], y = mesh.positions[v + 1], z = mesh.positions[v + 2];
        for (int r = 0; r < 3; ++r) {
          float w = float(m[r] * x + m[4 + r] * y + m[8 + r] * z + m[12 + r]);
          if (!std::isfinite(w))
            fail(InputErrorKind::NonFiniteVertex, src, mesh.name, "vertex", int64_t(v / 3),
                 "not finite after the transform of " + path);
          mesh.positions[v + r] = w;
        }
      }
      // An implicit object is placed by its matrix: f is evaluated in its own space.
      if (mesh.implicit) mesh.implicit_xform = multiply(m, mesh.implicit_xform);
      // Bezier control points move with the surface: a patch is affine-invariant.
      for (size_t v = 0; v < mesh.patches.size(); v += 3) {
        double x = mesh.patches[v], y = mesh.patches[v + 1], z = mesh.patches[v + 2];
        for (int r = 0; r < 3; ++r) {
          float w = float(m[r] * x + m[4 + r] * y + m[8 + r] * z + m[12 + r]);
          if (!std::isfinite(w))
            fail(InputErrorKind::NonFiniteVertex, src, mesh.name, "patch", int64_t(v / 48),
                 "control point " + std::to_string(v % 48 / 3) +
                     " not finite after the transform of " + path);
          mesh.patches[v + r] = w;
        }
      }
      if (det < 0) {  // a mirroring transform keeps outward normals by reversing the winding
        for (size_t t = 0; t < mesh.indices.size(); t += 3)
          std::swap(mesh.indices[t + 1], mesh.indices[t + 2]);
        // and a patch by swapping u and v (S_v x S_u = -S_u x S_v): P_ij <-> P_ji.
        for (size_t p = 0; p + 48 <= mesh.patches.size(); p += 48)
          for (int i = 0; i < 4; ++i)
            for (int j = i + 1; j < 4; ++j)
              for (int c = 0; c < 3; ++c)
                std::swap(mesh.patches[p + 3 * (4 * i + j) + c],
                          mesh.patches[p + 3 * (4 * j + i) + c]);
      }
      triangles += mesh.source_triangles;
      check_size(triangles, opts, src, mesh.name);
      scene.meshes.push_back(std::move(mesh));
    }
    scene.dropped_degenerate += part.dropped_degenerate;
  }
  if (scene.meshes.empty())
    fail(InputErrorKind::EmptyMesh, src, "", "meshes", -1, "the scene has no meshes");
  if (doc.contains("camera")) scene.camera = read_camera(ck, doc["camera"]);
  return scene;
}

}  // namespace vismap::detail
