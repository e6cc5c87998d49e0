// Shared by the loaders (core/load*.cpp); not part of the public API.
// A reader parses one format into "raw" meshes: positions plus triangles in the source's face
// order (polygons fan-triangulated), with indices already range-checked against the face that
// named them. finish_mesh() then validates and cleans what every format shares.
#pragma once

#include <algorithm>
#include <array>
#include <chrono>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/error.h"
#include "core/scene.h"

namespace vismap::detail {

// Sizes computed from counts that a file states: the product, or UINT64_MAX when it does not fit.
// Saturating instead of wrapping means a lying count can only make a size too big for the bytes
// that remain (and so refused), never small (2^62 list entries of 4 bytes wrap to 0 otherwise).
constexpr uint64_t checked_mul(uint64_t a, uint64_t b) {
  uint64_t r = 0;
  return __builtin_mul_overflow(a, b, &r) ? UINT64_MAX : r;
}
constexpr uint64_t checked_add(uint64_t a, uint64_t b) {
  uint64_t r = 0;
  return __builtin_add_overflow(a, b, &r) ? UINT64_MAX : r;
}

// The absolute cap on the input bytes one load holds, whatever LoadOptions::max_bytes says
// (0 there means only this). 4 GiB: the largest load of shared/data holds 42 MB
// (dragon_vrip.ply.gz, 8.3 MB inflating to 33.8 MB), and a decompression bomb stops here.
inline constexpr uint64_t kMaxInputBytes = uint64_t(1) << 32;

// The input bytes one load holds, charged as they are read: each file opened (the scene, what a
// scene file, a .gltf or an .obj's mtllib references) by its size before reading it, a .gz
// file's inflated bytes as they grow, an implicit object's tape. Past the cap: TooLarge, before
// anything is allocated. It also keeps the load's time limit (LoadOptions::time_limit_s).
class ByteBudget {
 public:
  explicit ByteBudget(const LoadOptions& opts)
      : limit_(opts.max_bytes == 0 ? kMaxInputBytes : std::min(opts.max_bytes, kMaxInputBytes)),
        seconds_(opts.time_limit_s > 0 ? opts.time_limit_s : 0),
        until_(std::chrono::steady_clock::now() +
               std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                   std::chrono::duration<double>(seconds_))) {}
  uint64_t limit() const { return limit_; }
  uint64_t left() const { return limit_ - used_; }
  // Throws TooLarge naming `file` when `n` more bytes do not fit.
  void charge(uint64_t n, const std::string& file, const std::string& what);
  // Throws TimeLimit naming `file` once the load has run past its time limit; `doing` says in
  // what ("the bounds search").
  void check_time(const std::string& file, const char* doing) const;

 private:
  uint64_t limit_;
  uint64_t used_ = 0;
  double seconds_;  // 0: no time limit
  std::chrono::steady_clock::time_point until_;
};

// A load's warnings (Scene::warnings): the first kMaxLoadWarnings lines, and how many more.
inline constexpr size_t kMaxLoadWarnings = 20;
struct LoadWarnings {
  std::vector<std::string> lines;
  uint64_t more = 0;
  void add(std::string line) {
    if (lines.size() < kMaxLoadWarnings)
      lines.push_back(std::move(line));
    else
      ++more;
  }
  // Into the scene's, with the count of those left out.
  void move_to(std::vector<std::string>& out);
};

// Where a load happens: the name used in messages and the folder relative references resolve
// against (empty for bytes from memory: external references are then refused), and the budget
// every file of the load is charged against (one per load_scene / load_scene_from_memory call),
// and where its warnings go.
struct Source {
  std::string file;
  std::string base_dir;
  ByteBudget* budget = nullptr;
  LoadWarnings* warnings = nullptr;  // none: warnings are dropped
};

// Lower-cased extension, compound for ".ply.gz" (".ply.gz", ".obj", ... or "" if none).
// Why a placing transform (column-major 4x4) collapses what it places, or "" when it does not:
// a column of its linear part below float range (scale 1e-300) or not finite, or a determinant
// that vanishes against the columns' sizes (Scale 0 0 0, an all-zero matrix, two equal axes).
// Every vertex would land on a plane, a line or a point, and the frame would be empty without a
// word (issue 35, case 9). The bottom row is the caller's to check where it must be affine.
std::string degenerate_transform(const std::array<double, 16>& m);

std::string format_extension(const std::string& name);
std::string file_stem(const std::string& name);
std::string dir_of(const std::string& path);  // "" or ending in '/'

// Reads a file that a load opens (the scene itself or a file it references), by `path` as given.
// Refuses, as FileNotFound naming `path`: a missing file; anything but a regular file (a FIFO,
// device or directory: checked before opening and again on the open descriptor, so a FIFO never
// blocks the load); with opts.confine_to, a file whose realpath lies outside that folder.
// Charges the file's size to `budget` before reading (TooLarge past the cap).
std::string read_input_file(const std::string& path, const LoadOptions& opts, ByteBudget& budget);
// The checks of read_input_file without the reading; returns the path to open.
std::string check_input_file(const std::string& path, const LoadOptions& opts);

// load_scene with the caller's budget: a scene file's references share the scene's budget.
Scene load_file(const std::string& path, const LoadOptions& opts, ByteBudget& budget);

// Throws Truncated when the stream is cut short, ParseError when it is not gzip, TooLarge when it
// inflates past what src.budget has left (checked before every growth of the output).
std::string gunzip(const Source& src, std::string_view bytes);

std::vector<Mesh> read_ply(const Source& src, std::string_view bytes, const LoadOptions& opts);
std::vector<Mesh> read_obj(const Source& src, std::string_view bytes, const LoadOptions& opts);
std::vector<Mesh> read_off(const Source& src, std::string_view bytes, const LoadOptions& opts);
std::vector<Mesh> read_stl(const Source& src, std::string_view bytes, const LoadOptions& opts);
Scene read_gltf(const Source& src, std::string_view bytes, bool binary, const LoadOptions& opts);
Scene read_scene_file(const Source& src, std::string_view bytes, const LoadOptions& opts);
// pbrt-v2 scene text (core/load/pbrt.cpp): trianglemesh and loopsubdiv shapes, the camera.
Scene read_pbrt(const Source& src, std::string_view bytes, const LoadOptions& opts);
// Bicubic Bezier patches (core/load/patches.cpp): .bpt text and Newell's .patches, one patch mesh
// (Mesh::patches, no triangles: finish_mesh does not apply).
Scene read_bpt(const Source& src, std::string_view bytes, const LoadOptions& opts);
Scene read_newell_patches(const Source& src, std::string_view bytes, const LoadOptions& opts);

// Implicit objects (core/load/sexp.cpp): an expression parsed (errors name src.file, line and
// column) into one Mesh with Mesh::implicit set, its box `bounds` (checked lo < hi) or, without
// them, found by implicit::find_bounds. read_sexp: a .sexp file as such an object.
Mesh implicit_object(const Source& src, std::string_view text, const std::string& name,
                     const std::optional<std::array<double, 6>>& bounds);
Scene read_sexp(const Source& src, std::string_view bytes, const LoadOptions& opts);

// Throws ParseError "UTF-16 text: save the file as UTF-8" when a text file's bytes are UTF-16 (a
// byte-order mark, or a NUL in every other one of its first bytes): every reader read it as no
// triangles before (issue 45, item 9).
void refuse_utf16(const Source& src, std::string_view bytes);

// Loads a mesh file (any format but .json) from bytes into a scene.
Scene load_mesh_bytes(const Source& src, std::string_view bytes, const LoadOptions& opts);

// Validates a raw mesh (finite vertices, indices in range), drops degenerate triangles (repeated
// index or exactly zero area, computed in double), fills face_ids / source_triangles / soup.
// Returns the number of triangles dropped. Throws EmptyMesh when the source has no triangles.
uint64_t finish_mesh(Mesh& m, const Source& src);

// Throws TooLarge when `triangles` exceeds opts.max_triangles (0 = no limit).
void check_size(uint64_t triangles, const LoadOptions& opts, const Source& src,
                const std::string& mesh);

// Appends polygon `corners`' k - 2 triangles (k >= 3) to `indices`, in the face's place (the
// global triangle id rule: a k-gon counts as k - 2 triangles in face order): the fan from its
// first corner where it is convex, as always; ear clipping in its plane where it is not
// (core/util/polygon.h: concave and self-touching faces). `positions` holds the vertices the
// corners index (every corner checked in range by the caller). A polygon whose edges cross, or
// one too large to cut, is fanned and warned of (src.warnings), naming the file, the mesh, the
// face and, where `line` >= 0, the line.
void add_polygon(std::vector<uint32_t>& indices, const std::vector<float>& positions,
                 const uint32_t* corners, size_t k, const Source& src, const std::string& mesh,
                 int64_t face, int64_t line);

[[noreturn]] inline void fail(InputErrorKind kind, const Source& src, const std::string& mesh,
                              const std::string& element, int64_t index, const std::string& msg) {
  throw InputError(kind, src.file, mesh, element, index, msg);
}

}  // namespace vismap::detail
