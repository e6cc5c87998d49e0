// The compact frame encoding (proto/COMPACT.md): the planar map as one watertight indexed
// triangle mesh on a fixed-point grid (1/16 pixel by default), connectivity and vertices coded
// with meshoptimizer's codecs, source ids sorted and delta-coded, the whole entropy-coded with
// zstd. Self-contained: a client needs no scene. Lossy only in positions (at most half a grid
// step per coordinate); the tiling stays exact on the grid (no crack, no overlap, no T-junction).
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "core/camera.h"
#include "core/planar_map.h"
#include "core/scene.h"
#include "core/stream/frame_io.h"

namespace vismap {

// The grid's steps per pixel (quantum): the one range that every reader of a quantum checks
// (the CLI's --quantum, vismapd's hello, vismap-client, the compact and delta decoders) and the
// docs state (issue 45, item 9: the CLI said 1..16384 for some values and 1 ... 256 for others).
// 256 keeps the grid within 2^22 steps a side at the largest viewport (kMaxViewport 2^14).
inline constexpr uint32_t kMinQuantum = 1;
inline constexpr uint32_t kMaxQuantum = 256;
// "1 ... 256 grid steps per pixel": the words every message about a bad quantum uses (inline:
// the protocol fuzzer links server/protocol.cpp without this module).
inline std::string quantum_range_text() {
  return std::to_string(kMinQuantum) + " ... " + std::to_string(kMaxQuantum) +
         " grid steps per pixel";
}

struct CompactOptions {
  uint32_t quantum = 16;  // grid steps per pixel, kMinQuantum ... kMaxQuantum (positions within
                          // 1/(2*quantum) px)
  bool shade = false;     // a shade byte per source triangle (the SVG writer's Lambert shade)
  Compression compression = Compression::Zstd;
  int level = 0;  // the coder's level: 0 its default (zstd 3, deflate 6); zstd 1 ... 19,
                  // deflate 1 ... 9
};

// What write_compact measured (the bench and --stats print it).
struct CompactStats {
  uint64_t vertices = 0, triangles = 0;  // after quantization
  uint64_t t_junctions = 0;              // vertices inserted into a neighbour's edge
  uint64_t dropped = 0;                  // triangles quantization made degenerate or inverted
  uint64_t vertex_bytes = 0, index_bytes = 0, id_bytes = 0, shade_bytes = 0;  // before zstd
};

std::string write_compact(const PlanarMap& map, const Scene& scene, const Camera& camera,
                          const CompactOptions& options, CompactStats* stats = nullptr);

// A decoded compact frame. Throws InputError (ParseError/Truncated) on malformed bytes.
struct CompactFrame {
  uint32_t version = 0, width = 0, height = 0, flags = 0, quantum = 0;
  Compression compression = Compression::Zstd;
  std::vector<int32_t> xy;          // 2 per vertex, grid steps (pixels * quantum), y down
  std::vector<uint32_t> indices;    // 3 per triangle, clockwise on screen (positive shoelace)
  std::vector<uint32_t> source;     // per triangle: global source triangle id (FORMAT.md)
  std::vector<uint32_t> mesh;       // per triangle: mesh index (from the frame's mesh table)
  std::vector<uint64_t> mesh_base;  // per mesh: its first global triangle id
  std::vector<std::array<float, 3>> mesh_color;  // per mesh: linear RGB in [0, 1]
  std::vector<uint8_t> shade;  // per triangle when flags & kCompactShade: 0 ... 255
  size_t triangle_count() const { return source.size(); }
  size_t vertex_count() const { return xy.size() / 2; }
};
constexpr uint32_t kCompactShade = 1;

CompactFrame read_compact(const std::string& bytes);

// The decoded triangles as a planar map of `scene` (one 3-vertex fragment per triangle, pixels
// as doubles), so write_svg and the checks take it. Throws InputError when the frame names a
// mesh or triangle the scene does not have.
PlanarMap to_planar_map(const CompactFrame& frame, const Scene& scene);

}  // namespace vismap
