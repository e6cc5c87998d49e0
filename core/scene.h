// The scene: triangle meshes in world space, their colors, and an optional camera.
// Loaders (core/load_*.cpp) fill it; the pipeline (core/pipeline.h) reads it.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/camera.h"

namespace vismap {

namespace implicit {
struct Tape;
}

struct Mesh {
  std::string name;              // for messages: the file's mesh/node/group name or the file stem
  std::vector<float> positions;  // x,y,z per vertex, world space (node/instance transforms applied)
  std::vector<uint32_t> indices;  // 3 per triangle, into positions
  // For each kept triangle, its place in the source's face order (a polygon with k corners counts
  // as k-2 fan triangles). Degenerate triangles are dropped, so ids can skip; --fill id uses these.
  std::vector<uint32_t> face_ids;
  uint32_t source_triangles = 0;  // triangles in the source before dropping (ids run 0..this-1)
  std::array<float, 3> color{0.8f, 0.8f, 0.8f};  // linear RGB base color in [0,1]
  bool soup = false;  // true when vertices are not shared (match edges by position)

  // Curved surfaces (issue 18, docs/SURFACES.md), diced per frame by Renderer::tessellate into an
  // ordinary triangle mesh in the same slot (core/surfaces/tessellate.h); render() refuses them
  // undiced. Bicubic Bezier patches: 16 control points per patch, 48 floats, world space;
  // point (i, j) of patch p at patches[48 p + 3 (4 i + j) + c], i along v and j along u, so that
  // S(u, v) = sum_ij B_i(v) B_j(u) P_ij. positions/indices stay empty; source_triangles = patches.
  std::vector<float> patches;
  // positions/indices are the control mesh of a Loop subdivision surface (triangles).
  bool subdivision = false;
  // A diced mesh: (u, v) per triangle corner (6 floats per triangle, in the order of indices)
  // in its source patch, or in its control triangle (the barycentrics of corners 1 and 2) for a
  // subdivision surface; per corner because a vertex on a shared edge has a (u, v) in each of
  // its sources. face_ids name the patch or the control triangle. Empty for ordinary meshes.
  std::vector<float> uv;

  // An implicit surface (issue 19, docs/IMPLICIT.md): the boundary of the solid f < 0 of this
  // tape in its own space, clipped to implicit_box (lo xyz, hi xyz, in that space), placed in
  // the world by implicit_xform (column-major 4x4 affine, as the scene file's matrix).
  // positions/indices stay empty until diced (source_triangles = 1: the object is one source).
  std::shared_ptr<const implicit::Tape> implicit;
  std::array<double, 6> implicit_box{};
  std::array<double, 16> implicit_xform{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  // A diced implicit: a unit normal per vertex (the world gradient of f, normalized; 3 floats),
  // which shading uses in place of the triangle's own. Empty otherwise.
  std::vector<float> normals;

  // The 8 corners of implicit_box placed by implicit_xform (corner c: bit k picks hi on axis k).
  std::array<std::array<double, 3>, 8> implicit_corners() const;

  size_t patch_count() const { return patches.size() / 48; }
  bool is_surface() const { return !patches.empty() || subdivision || implicit != nullptr; }

  size_t vertex_count() const { return positions.size() / 3; }
  size_t triangle_count() const { return indices.size() / 3; }
};

struct Scene {
  std::vector<Mesh> meshes;         // scene order; global triangle ids follow this order
  std::optional<Camera> camera;     // from the file (glTF camera or scene file), if any
  uint64_t dropped_degenerate = 0;  // zero-area triangles dropped while loading
  // What the load read but could not take as it is, one line each naming the file and the
  // element (a polygon whose edges cross, core/load/internal.h add_polygon); the CLI prints them
  // on stderr, vismapd logs them. At most kMaxLoadWarnings, then one line saying how many more.
  std::vector<std::string> warnings;
  std::string source;               // path it was loaded from

  size_t triangle_count() const;
  bool has_surfaces() const;  // any mesh is_surface(): Renderer::tessellate before render
  // Global id of mesh m's first source triangle: sum of source_triangles of meshes before it.
  std::vector<uint64_t> triangle_id_base() const;
};

// The box of the vertices that triangles use (stray unused vertices do not move the framing).
Bounds scene_bounds(const Scene& s);
// frame_bounds and fit_near_far (core/camera.h) over scene_bounds(s).
Camera frame_scene(const Scene& s, uint32_t width, uint32_t height);
void fit_near_far(Camera& c, const Scene& s);

struct LoadOptions {
  uint64_t max_triangles = 0;  // 0: no limit; otherwise a larger scene is InputError TooLarge
  // 0: no limit; otherwise the bytes a load may hold as input (a .gz file's inflated bytes, a
  // scene file's referenced files together) are capped here: past it, InputError TooLarge.
  // Charged: every file the load opens, by its size, before it is read; the inflated bytes of a
  // .ply.gz as they grow (checked before each growth, so a bomb is refused at the cap). Bytes
  // handed to load_scene_from_memory are the caller's and not charged. Whatever this says, one
  // load holds at most 4 GiB (detail::kMaxInputBytes).
  uint64_t max_bytes = 0;
  // Empty: any path. Otherwise every file the load opens (the scene itself and what a scene file
  // references) must resolve (realpath, symlinks followed) inside this directory, else
  // InputError FileNotFound naming the path as given. Non-regular files (FIFOs, devices,
  // directories) are refused in every case.
  std::string confine_to;
  // Seconds of wall time the load may take; 0: no limit. Checked in the parts of a load whose
  // work does not follow from its bytes (an implicit object's bounds search, per box): past it,
  // InputError TimeLimit naming the file. vismapd passes limits.render_time_limit_s.
  double time_limit_s = 0;
};

// Loads any supported file by extension: .gltf .glb (tinygltf), .ply .obj .off .stl (OpenMesh),
// .ply.gz, .pbrt, Bezier patches .bpt .patches (docs/SCENE_FORMAT.md), and .json scene files
// (which reference other files relative to themselves).
// Throws InputError naming the file and element on bad input; never returns a half scene.
Scene load_scene(const std::string& path, const LoadOptions& opts = {});

// The same from bytes in memory (for the server's uploads). `name` is used in messages and its
// extension picks the format.
Scene load_scene_from_memory(const std::string& name, const std::string& bytes,
                             const LoadOptions& opts = {});

}  // namespace vismap
