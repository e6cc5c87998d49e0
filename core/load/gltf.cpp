// glTF 2.0 (.gltf with external or data-URI buffers, .glb) through tinygltf. Every primitive of
// every mesh node in the scene becomes one Mesh, positions baked to world space with the node
// hierarchy (matrix or TRS); color from baseColorFactor. Modes TRIANGLES, TRIANGLE_STRIP and
// TRIANGLE_FAN are read (strips and fans converted as the spec orders them); points and lines are
// skipped. The first camera node in depth-first scene order becomes Scene::camera.
#include <sys/stat.h>
#include <tiny_gltf.h>

#include <cmath>
#include <cstring>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>

#include "core/load/internal.h"

namespace vismap::detail {
namespace {

using M4 = std::array<double, 16>;  // column-major

M4 identity() {
  return {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
}


M4 local_matrix(const tinygltf::Node& n) {
  if (n.matrix.size() == 16) {
    M4 m;
    std::copy(n.matrix.begin(), n.matrix.end(), m.begin());
    return m;
  }
  double t[3] = {0, 0, 0}, q[4] = {0, 0, 0, 1}, s[3] = {1, 1, 1};
  if (n.translation.size() == 3) std::copy(n.translation.begin(), n.translation.end(), t);
  if (n.rotation.size() == 4) std::copy(n.rotation.begin(), n.rotation.end(), q);
  if (n.scale.size() == 3) std::copy(n.scale.begin(), n.scale.end(), s);
  double x = q[0], y = q[1], z = q[2], w = q[3];
  double r[9] = {1 - 2 * (y * y + z * z), 2 * (x * y + z * w),     2 * (x * z - y * w),
                 2 * (x * y - z * w),     1 - 2 * (x * x + z * z), 2 * (y * z + x * w),
                 2 * (x * z + y * w),     2 * (y * z - x * w),     1 - 2 * (x * x + y * y)};
  M4 m = identity();
  for (int c = 0; c < 3; ++c)
    for (int row = 0; row < 3; ++row) m[c * 4 + row] = r[c * 3 + row] * s[c];
  m[12] = t[0], m[13] = t[1], m[14] = t[2];
  return m;
}

struct Loader {
  const Source& src;
  const LoadOptions& opts;
  const tinygltf::Model& model;
  Scene scene;
  std::set<int> visited;  // nodes seen: a cycle or a shared child is refused, not followed
  uint64_t triangles = 0;

  // Element size, count and a bounds-checked pointer for accessor `a`.
  const tinygltf::Accessor& accessor(int ai, const std::string& mesh) {
    if (ai < 0 || ai >= int(model.accessors.size()))
      fail(InputErrorKind::ParseError, src, mesh, "accessor", ai, "no such accessor");
    return model.accessors[ai];
  }

  const unsigned char* view(int ai, const std::string& mesh, size_t want_size, size_t& stride) {
    const tinygltf::Accessor& a = accessor(ai, mesh);
    if (a.sparse.isSparse)
      fail(InputErrorKind::ParseError, src, mesh, "accessor", ai,
           "sparse accessors are not supported");
    if (a.bufferView < 0 || a.bufferView >= int(model.bufferViews.size()))
      fail(InputErrorKind::ParseError, src, mesh, "accessor", ai, "accessor has no buffer view");
    const tinygltf::BufferView& bv = model.bufferViews[a.bufferView];
    if (bv.buffer < 0 || bv.buffer >= int(model.buffers.size()))
      fail(InputErrorKind::ParseError, src, mesh, "accessor", ai, "buffer view has no buffer");
    const std::vector<unsigned char>& data = model.buffers[bv.buffer].data;
    stride = bv.byteStride ? bv.byteStride : want_size;
    if (stride < want_size)  // the spec: a stride is at least the element size
      fail(InputErrorKind::ParseError, src, mesh, "accessor", ai,
           "byteStride " + std::to_string(stride) + " is smaller than the element (" +
               std::to_string(want_size) + " bytes)");
    // Counts and offsets come from the file: checked sums and products, so that a huge count
    // cannot wrap to a small size and pass the bounds check.
    uint64_t need = a.count == 0 ? 0 : checked_add(checked_mul(stride, a.count - 1), want_size);
    if (checked_add(a.byteOffset, need) > bv.byteLength ||
        checked_add(bv.byteOffset, bv.byteLength) > data.size())
      fail(InputErrorKind::Truncated, src, mesh, "accessor", ai,
           "accessor reads past the end of its buffer (" + std::to_string(data.size()) + " bytes)");
    return data.data() + bv.byteOffset + a.byteOffset;
  }

  void add_primitive(const tinygltf::Primitive& p, const std::string& name, const M4& w) {
    if (p.mode != TINYGLTF_MODE_TRIANGLES && p.mode != TINYGLTF_MODE_TRIANGLE_STRIP &&
        p.mode != TINYGLTF_MODE_TRIANGLE_FAN)
      return;
    auto pos = p.attributes.find("POSITION");
    if (pos == p.attributes.end())
      fail(InputErrorKind::ParseError, src, name, "", -1, "primitive has no POSITION");
    const tinygltf::Accessor& pa = accessor(pos->second, name);
    if (pa.type != TINYGLTF_TYPE_VEC3 || pa.componentType != TINYGLTF_COMPONENT_TYPE_FLOAT)
      fail(InputErrorKind::ParseError, src, name, "accessor", pos->second,
           "POSITION must be float VEC3");
    size_t stride;
    const unsigned char* pp = view(pos->second, name, 12, stride);
    Mesh m;
    m.name = name;
    m.positions.resize(pa.count * 3);
    for (size_t i = 0; i < pa.count; ++i) {
      float v[3];
      std::memcpy(v, pp + i * stride, 12);
      for (int r = 0; r < 3; ++r)
        m.positions[3 * i + r] = float(w[r] * v[0] + w[4 + r] * v[1] + w[8 + r] * v[2] + w[12 + r]);
    }
    std::vector<uint32_t> idx;
    if (p.indices >= 0) {
      const tinygltf::Accessor& ia = accessor(p.indices, name);
      size_t cs = tinygltf::GetComponentSizeInBytes(ia.componentType);
      if (ia.type != TINYGLTF_TYPE_SCALAR || (cs != 1 && cs != 2 && cs != 4) ||
          ia.componentType == TINYGLTF_COMPONENT_TYPE_FLOAT)
        fail(InputErrorKind::ParseError, src, name, "accessor", p.indices,
             "indices must be unsigned integer scalars");
      const unsigned char* ip = view(p.indices, name, cs, stride);
      idx.resize(ia.count);
      for (size_t i = 0; i < ia.count; ++i) {
        const unsigned char* e = ip + i * stride;
        idx[i] = cs == 1   ? e[0]
                 : cs == 2 ? uint32_t(e[0] | e[1] << 8)
                           : ((uint32_t)e[0] | (uint32_t)e[1] << 8 | (uint32_t)e[2] << 16 |
                              (uint32_t)e[3] << 24);
      }
    } else {
      idx.resize(pa.count);
      for (size_t i = 0; i < idx.size(); ++i) idx[i] = uint32_t(i);
    }
    for (size_t i = 0; i < idx.size(); ++i)
      if (idx[i] >= pa.count)
        fail(InputErrorKind::IndexOutOfRange, src, name, "index", int64_t(i),
             "vertex index " + std::to_string(idx[i]) + " out of range (" +
                 std::to_string(pa.count) + " vertices)");
    if (p.mode == TINYGLTF_MODE_TRIANGLES) {
      idx.resize(idx.size() / 3 * 3);
      m.indices = std::move(idx);
    } else {
      for (size_t i = 0; i + 2 < idx.size(); ++i) {
        if (p.mode == TINYGLTF_MODE_TRIANGLE_FAN)
          m.indices.insert(m.indices.end(), {idx[i + 1], idx[i + 2], idx[0]});
        else if (i % 2 == 0)
          m.indices.insert(m.indices.end(), {idx[i], idx[i + 1], idx[i + 2]});
        else
          m.indices.insert(m.indices.end(), {idx[i + 1], idx[i], idx[i + 2]});
      }
    }
    double det = w[0] * (w[5] * w[10] - w[9] * w[6]) - w[4] * (w[1] * w[10] - w[9] * w[2]) +
                 w[8] * (w[1] * w[6] - w[5] * w[2]);
    if (det < 0)  // the spec: a mirroring node transform reverses the winding
      for (size_t t = 0; t + 2 < m.indices.size(); t += 3)
        std::swap(m.indices[t + 1], m.indices[t + 2]);
    if (p.material >= 0 && p.material < int(model.materials.size())) {
      const auto& f = model.materials[p.material].pbrMetallicRoughness.baseColorFactor;
      if (f.size() >= 3) m.color = {float(f[0]), float(f[1]), float(f[2])};
    }
    if (m.indices.empty()) return;  // too few indices for a triangle: nothing to draw
    triangles += m.indices.size() / 3;
    check_size(triangles, opts, src, name);
    scene.dropped_degenerate += finish_mesh(m, src);
    scene.meshes.push_back(std::move(m));
  }

  void add_camera(const tinygltf::Camera& c, const M4& w) {
    Camera cam;
    auto xf = [&](double x, double y, double z, double h) {
      Vec3 r;
      for (int i = 0; i < 3; ++i) r[i] = w[i] * x + w[4 + i] * y + w[8 + i] * z + w[12 + i] * h;
      return r;
    };
    auto normalize = [](Vec3 v) {
      double l = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
      return l > 0 ? Vec3{v[0] / l, v[1] / l, v[2] / l} : v;
    };
    cam.eye = xf(0, 0, 0, 1);
    Vec3 fwd = normalize(xf(0, 0, -1, 0));
    cam.target = {cam.eye[0] + fwd[0], cam.eye[1] + fwd[1], cam.eye[2] + fwd[2]};
    cam.up = normalize(xf(0, 1, 0, 0));
    double aspect = 0;
    if (c.type == "orthographic") {
      cam.projection = Camera::Projection::Orthographic;
      cam.ortho_height = 2 * c.orthographic.ymag;
      cam.near_plane = c.orthographic.znear;
      cam.far_plane = c.orthographic.zfar;
      if (c.orthographic.ymag > 0) aspect = c.orthographic.xmag / c.orthographic.ymag;
    } else {
      cam.fov_y_deg = c.perspective.yfov * 180.0 / M_PI;
      cam.near_plane = c.perspective.znear;
      cam.far_plane = c.perspective.zfar;  // 0 (infinite in glTF): chosen from the scene
      aspect = c.perspective.aspectRatio;
    }
    if (aspect > 0 && aspect < 16) cam.width = uint32_t(std::lround(cam.height * aspect));
    scene.camera = cam;
  }

  // Depth first, children in order (scene order gives global triangle ids and picks the camera),
  // with an explicit stack: a chain of a million nodes overflowed the call stack. Each node is
  // visited once: the spec makes the hierarchy a forest, and a node listed as the child of two
  // nodes of the level above, 64 levels deep, was 2^64 visits (a cycle is the same refusal).
  void visit(int root) {
    std::vector<std::pair<int, M4>> stack{{root, identity()}};
    while (!stack.empty()) {
      auto [ni, parent] = stack.back();
      stack.pop_back();
      if (ni < 0 || ni >= int(model.nodes.size()))
        fail(InputErrorKind::ParseError, src, "", "node", ni, "no such node");
      if (!visited.insert(ni).second)
        fail(InputErrorKind::ParseError, src, "", "node", ni,
             "node reached twice (a cycle, or more than one parent: the node hierarchy must be "
             "a forest)");
      const tinygltf::Node& n = model.nodes[ni];
      M4 w = multiply(parent, local_matrix(n));
      if (n.camera >= 0 && !scene.camera && n.camera < int(model.cameras.size()))
        add_camera(model.cameras[n.camera], w);
      if (n.mesh >= 0) {
        if (n.mesh >= int(model.meshes.size()))
          fail(InputErrorKind::ParseError, src, "", "node", ni, "no such mesh");
        const tinygltf::Mesh& mesh = model.meshes[n.mesh];
        std::string base = !mesh.name.empty() ? mesh.name
                           : !n.name.empty()  ? n.name
                                              : "mesh " + std::to_string(n.mesh);
        for (size_t p = 0; p < mesh.primitives.size(); ++p)
          add_primitive(mesh.primitives[p],
                        mesh.primitives.size() > 1 ? base + "#" + std::to_string(p) : base, w);
      }
      for (auto c = n.children.rbegin(); c != n.children.rend(); ++c) stack.emplace_back(*c, w);
    }
  }
};

// tinygltf reports errors as text; a GLB container we check ourselves so that a cut-short file
// is "truncated", not a vague parse error.
// glTF 1.0 (2015: dictionaries where 2.0 has arrays, a different binary container) is a format of
// its own that tinygltf reads as an empty 2.0 scene: "no triangles" said nothing of why (issue
// 45, item 9).
constexpr const char* kGltf1 = "glTF 1.0 is not read, only glTF 2.0";

// Whether a .gltf's JSON is glTF 1.0: asset.version 1.x (a string, or a number as some 1.0
// exporters wrote it), or no version and 1.0's dictionaries of accessors or meshes. Looked at only
// where the file gave no triangles or did not parse, so a 2.0 file is never parsed twice.
bool is_gltf1(std::string_view text) {
  const nlohmann::json j = nlohmann::json::parse(text.begin(), text.end(), nullptr, false);
  if (j.is_discarded() || !j.is_object()) return false;
  const auto asset = j.find("asset");
  if (asset != j.end() && asset->is_object()) {
    const auto v = asset->find("version");
    if (v != asset->end()) {
      if (v->is_number()) return v->get<double>() < 2;
      if (v->is_string()) return v->get<std::string>().rfind('1', 0) == 0;
    }
  }
  for (const char* key : {"accessors", "meshes"}) {
    const auto a = j.find(key);
    if (a != j.end() && a->is_object() && !a->empty()) return true;
  }
  return false;
}

void check_glb(const Source& src, std::string_view b) {
  if (b.size() < 12) {
    bool prefix =
        std::string_view("glTF").substr(0, std::min<size_t>(4, b.size())) == b.substr(0, 4);
    fail(prefix ? InputErrorKind::Truncated : InputErrorKind::ParseError, src, "", "", -1,
         "GLB file shorter than its 12-byte header");
  }
  if (b.substr(0, 4) != "glTF")
    fail(InputErrorKind::ParseError, src, "", "", -1, "not a GLB file (no 'glTF' magic)");
  uint32_t version;
  std::memcpy(&version, b.data() + 4, 4);
  if (version == 1) fail(InputErrorKind::UnknownFormat, src, "", "", -1, kGltf1);
  uint32_t length;
  std::memcpy(&length, b.data() + 8, 4);
  if (length > b.size())
    fail(InputErrorKind::Truncated, src, "", "byte", int64_t(b.size()),
         "GLB header promises " + std::to_string(length) + " bytes, file has " +
             std::to_string(b.size()));
  size_t at = 12;
  for (int chunk = 0; at < length; ++chunk) {
    uint32_t clen;
    if (length - at < 8)
      fail(InputErrorKind::Truncated, src, "", "chunk", chunk, "chunk header cut short");
    std::memcpy(&clen, b.data() + at, 4);
    if (uint64_t(clen) + 8 > length - at)
      fail(InputErrorKind::Truncated, src, "", "chunk", chunk,
           "chunk runs past the end of the file");
    at += 8 + size_t(clen);
  }
}

bool no_image(tinygltf::Image*, const int, std::string*, std::string*, int, int,
              const unsigned char*, int, void*) {
  return true;  // images are not needed for visibility
}
bool no_file(const std::string&, void*) {
  return false;
}
std::string same_path(const std::string& p, void*) {
  return p;
}
bool no_read(std::vector<unsigned char>*, std::string* err, const std::string& p, void*) {
  if (err) *err += "File not found : " + p + " (external files are not read for uploads)\n";
  return false;
}
bool no_write(std::string*, const std::string&, const std::vector<unsigned char>&, void*) {
  return false;
}

// Files a .gltf / .glb on disk references (buffers, images) go through read_input_file like every
// other file of the load: confined, regular files only, charged to the load's budget. tinygltf's
// own reader would block on a FIFO and read outside LoadOptions::confine_to. Its callbacks cannot
// throw through the library, so the first refusal is kept here and thrown after it returns.
struct FileAccess {
  const LoadOptions& opts;
  ByteBudget& budget;
  std::optional<InputError> refused;
};
bool file_exists(const std::string& p, void*) {
  struct stat st;
  return ::stat(p.c_str(), &st) == 0;  // read_file says why a file that is there is refused
}
// Images are not needed for visibility: checked like any file, but not read (tinygltf then hands
// no_image one byte). An extension says which, as tinygltf gives the callback only the path.
bool is_image(const std::string& p) {
  std::string ext = format_extension(p);
  for (const char* e :
       {".png", ".jpg", ".jpeg", ".webp", ".ktx", ".ktx2", ".dds", ".gif", ".bmp", ".basis"})
    if (ext == e) return true;
  return false;
}
bool read_file(std::vector<unsigned char>* out, std::string* err, const std::string& p,
               void* user) {
  auto& fa = *static_cast<FileAccess*>(user);
  try {
    if (is_image(p)) {
      check_input_file(p, fa.opts);
      out->assign(1, 0);
      return true;
    }
    std::string bytes = read_input_file(p, fa.opts, fa.budget);
    out->assign(bytes.begin(), bytes.end());
    return true;
  } catch (const InputError& e) {
    if (!fa.refused) fa.refused = e;
    if (err) *err += e.detail();
    return false;
  }
}

}  // namespace

Scene read_gltf(const Source& src, std::string_view bytes, bool binary, const LoadOptions& opts) {
  if (binary) check_glb(src, bytes);
  if (bytes.size() > UINT32_MAX)  // tinygltf takes the length as unsigned int
    fail(InputErrorKind::TooLarge, src, "", "", -1, "glTF file larger than 4 GiB");
  tinygltf::TinyGLTF gltf;
  gltf.SetImageLoader(no_image, nullptr);
  FileAccess access{opts, *src.budget, std::nullopt};
  if (src.base_dir.empty())
    gltf.SetFsCallbacks({no_file, same_path, no_read, no_write, nullptr});
  else
    gltf.SetFsCallbacks({file_exists, same_path, read_file, no_write, &access});
  tinygltf::Model model;
  std::string err, warn;
  bool ok = binary ? gltf.LoadBinaryFromMemory(&model, &err, &warn,
                                               reinterpret_cast<const unsigned char*>(bytes.data()),
                                               unsigned(bytes.size()), src.base_dir)
                   : gltf.LoadASCIIFromString(&model, &err, &warn, bytes.data(),
                                              unsigned(bytes.size()), src.base_dir);
  if (access.refused) {  // a referenced file refused (even an image, which tinygltf only warns of)
    const InputError& e = *access.refused;
    throw InputError(e.kind(), e.file(), "", "", -1,
                     e.detail() + " (referenced by " + src.file + ")");
  }
  if (!ok && !binary && is_gltf1(bytes))
    fail(InputErrorKind::UnknownFormat, src, "", "", -1, kGltf1);
  if (!ok) {
    while (!err.empty() && (err.back() == '\n' || err.back() == '\r')) err.pop_back();
    for (char& ch : err)
      if (ch == '\n') ch = ';';
    InputErrorKind kind = err.find("File not found") != std::string::npos ||
                                  err.find("File open error") != std::string::npos
                              ? InputErrorKind::FileNotFound
                              : InputErrorKind::ParseError;
    fail(kind, src, "", "", -1, "glTF: " + (err.empty() ? std::string("cannot parse") : err));
  }
  Loader L{src, opts, model, {}, {}, 0};
  L.scene.source = src.file;
  std::vector<int> roots;
  int si = model.defaultScene >= 0 ? model.defaultScene : 0;
  if (si < int(model.scenes.size())) {
    roots = model.scenes[si].nodes;
  } else {  // no scene: every node that is nobody's child
    std::vector<bool> child(model.nodes.size());
    for (const auto& n : model.nodes)
      for (int c : n.children)
        if (c >= 0 && c < int(child.size())) child[c] = true;
    for (size_t i = 0; i < child.size(); ++i)
      if (!child[i]) roots.push_back(int(i));
  }
  for (int r : roots) L.visit(r);
  if (L.scene.triangle_count() == 0 && !binary && is_gltf1(bytes))
    fail(InputErrorKind::UnknownFormat, src, "", "", -1, kGltf1);
  if (L.scene.triangle_count() == 0)
    fail(InputErrorKind::EmptyMesh, src, "", "", -1,
         L.scene.meshes.empty() ? "no triangles in the scene"
                                : "every triangle is degenerate (zero area)");
  return std::move(L.scene);
}

}  // namespace vismap::detail
