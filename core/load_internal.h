// Shared by the loaders (core/load*.cpp); not part of the public API.
// A reader parses one format into "raw" meshes: positions plus triangles in the source's face
// order (polygons fan-triangulated), with indices already range-checked against the face that
// named them. finish_mesh() then validates and cleans what every format shares.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "core/error.h"
#include "core/scene.h"

namespace vismap::detail {

// Where a load happens: the name used in messages and the folder relative references resolve
// against (empty for bytes from memory: external references are then refused).
struct Source {
  std::string file;
  std::string base_dir;
};

// Lower-cased extension, compound for ".ply.gz" (".ply.gz", ".obj", ... or "" if none).
std::string format_extension(const std::string& name);
std::string file_stem(const std::string& name);
std::string read_whole_file(const std::string& path);  // throws FileNotFound
std::string dir_of(const std::string& path);           // "" or ending in '/'

// Throws Truncated when the stream is cut short, ParseError when it is not gzip.
std::string gunzip(const Source& src, std::string_view bytes);

std::vector<Mesh> read_ply(const Source& src, std::string_view bytes, const LoadOptions& opts);
std::vector<Mesh> read_obj(const Source& src, std::string_view bytes, const LoadOptions& opts);
std::vector<Mesh> read_off(const Source& src, std::string_view bytes, const LoadOptions& opts);
std::vector<Mesh> read_stl(const Source& src, std::string_view bytes, const LoadOptions& opts);
Scene read_gltf(const Source& src, std::string_view bytes, bool binary, const LoadOptions& opts);
Scene read_scene_file(const Source& src, std::string_view bytes, const LoadOptions& opts);

// Loads a mesh file (any format but .json) from bytes into a scene.
Scene load_mesh_bytes(const Source& src, std::string_view bytes, const LoadOptions& opts);

// Validates a raw mesh (finite vertices, indices in range), drops degenerate triangles (repeated
// index or exactly zero area, computed in double), fills face_ids / source_triangles / soup.
// Returns the number of triangles dropped. Throws EmptyMesh when the source has no triangles.
uint64_t finish_mesh(Mesh& m, const Source& src);

// Throws TooLarge when `triangles` exceeds opts.max_triangles (0 = no limit).
void check_size(uint64_t triangles, const LoadOptions& opts, const Source& src,
                const std::string& mesh);

// Appends the fan triangulation of polygon `corners` (k >= 3) to m.indices.
inline void add_fan(Mesh& m, const uint32_t* corners, size_t k) {
  for (size_t i = 2; i < k; ++i) {
    m.indices.push_back(corners[0]);
    m.indices.push_back(corners[i - 1]);
    m.indices.push_back(corners[i]);
  }
}

[[noreturn]] inline void fail(InputErrorKind kind, const Source& src, const std::string& mesh,
                              const std::string& element, int64_t index, const std::string& msg) {
  throw InputError(kind, src.file, mesh, element, index, msg);
}

}  // namespace vismap::detail
