// The delta frame encoding (proto/DELTA.md): the client holds the scene's source triangles (sent
// to it once, the first time each is needed) and the previous frame; a frame carries the camera,
// the change of the set of source triangles that are visible whole (the client projects those
// itself), and the rest of the planar map as polygons whose corners are source vertices (by
// reference), or points on a 1/16 px grid. Watertight like the compact frame: the polygons
// conform, every shared point is referenced, never repeated.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/camera.h"
#include "core/error.h"
#include "core/planar_map.h"
#include "core/scene.h"
#include "core/stream/compact.h"

namespace vismap {

struct DeltaOptions {
  uint32_t quantum = 16;  // grid steps per pixel of the sent points, 1 ... 256
  Compression compression = Compression::Zstd;
  // The coder's level for delta frames and keyframes (0: its default); the compact frame a
  // version 2 stream may send instead stays at the default (coding it at a high level every
  // frame costs more than its few percent are worth), and is what "never larger" compares with.
  int level = 0;
  uint32_t keyframe_every = 0;  // 0: only the first frame and on request
  // The format version written (DELTA.md): 2 adds the records predicted from the frame before,
  // sends a frame as its compact frame (COMPACT.md) whenever that is smaller, and lets the client
  // hold the scene; 1 is what protocol version 2 sessions get.
  uint32_t version = 2;
  // The client holds every source triangle: version 2, it was given encode_delta_sources' message
  // (DeltaDecoder::hold_scene); version 1, bytes only (a measurement mode, not decodable).
  bool client_holds_scene = false;
};

// How a frame went out: coded against the client's state, as a keyframe (state afresh), or as
// the compact frame of the same view (smaller than either; the client's state is left alone).
enum class DeltaCoding : uint8_t { Delta, Keyframe, Compact };

struct DeltaStats {
  DeltaCoding coding = DeltaCoding::Delta;
  bool keyframe = false;                        // coding == Keyframe
  uint64_t delta_bytes = 0, compact_bytes = 0;  // the candidates' sizes (0: not made)
  uint64_t whole = 0, added = 0, removed = 0;   // whole triangles: drawn, entering, leaving
  uint64_t flips = 0;  // triangles whose facing changed since the base frame (version 2)
  uint64_t partial = 0, partial_corners = 0, points = 0;  // polygons, their corners, new points
  uint64_t edge_points = 0;  // of the points: those sent as a step along an own edge
  uint64_t edge_refs = 0;    // corners that name a point already on an own edge (version 2)
  uint64_t new_triangles = 0, new_vertices = 0;                 // sources sent with this frame
  uint64_t source_bytes = 0, set_bytes = 0, polygon_bytes = 0;  // before entropy coding
};

// What the encoder knows the client holds: the state after the last frame it coded as delta or
// keyframe (a compact frame leaves it alone).
struct DeltaClientState {
  bool valid = false;                            // false: the next delta frame is a keyframe
  uint32_t index = 0;                            // the frame this state is at
  std::vector<uint8_t> known_tri, known_vertex;  // per global id / vertex number
  std::vector<uint32_t> whole;                   // sorted global ids drawn whole in that frame
  std::vector<uint32_t> partial;                 // sorted global ids that owned polygons in it
  std::array<double, 12> rows{};  // its projection, and grid (version 2: facing flips)
  uint32_t width = 0, height = 0;
};

// The server's side, one per session: what the client holds. Its memory is bounded by the
// scene (a bit per source triangle and per vertex, the previous whole set).
class DeltaEncoder {
 public:
  DeltaEncoder(const Scene& scene, const DeltaOptions& options);
  // `screen` is the render's ScreenTriangles (RenderOptions::keep_screen_triangles); `camera`
  // the one the map was rendered with, near and far fitted.
  std::string encode(const PlanarMap& map, const ScreenTriangles& screen, const Camera& camera,
                     DeltaStats* stats = nullptr);
  void request_keyframe() { keyframe_ = true; }  // the client lost its state
  size_t state_bytes() const;

 private:
  const Scene& scene_;
  DeltaOptions options_;
  std::vector<uint64_t> base_;         // per mesh: first global id
  std::vector<uint64_t> vertex_base_;  // per mesh: first global vertex number
  DeltaClientState client_;
  std::vector<uint8_t> held_tri_;  // the scene's faces when the client holds it, else zeros
  uint32_t frame_ = 0;
  bool keyframe_ = true;
};

// The message that gives a client the whole scene (DELTA.md, "Sources message"): every source
// vertex and triangle, so that DeltaDecoder::hold_scene can keep it and delta frames coded with
// client_holds_scene send none.
std::string encode_delta_sources(const Scene& scene, Compression compression, int level = 0);

// The decoded frame: triangles on the grid, as the compact frame's.
struct DeltaFrame {
  uint32_t width = 0, height = 0, quantum = 0, index = 0;
  uint32_t version = 0;           // DELTA.md version (2 for a compact frame: only 2 has them)
  bool keyframe = false;
  bool compact = false;           // a compact frame in the stream (no camera, state untouched)
  Camera camera;                  // projection, eye and target (the light of the shade)
  std::array<double, 12> rows{};  // clip_rows of the view-projection the frame was rendered with
  std::vector<int32_t> xy;        // 2 per vertex, grid steps
  std::vector<uint32_t> indices;  // 3 per triangle, positive orientation
  std::vector<uint32_t> source;   // per triangle: global source triangle id
  std::vector<uint32_t> mesh;     // per triangle
  std::vector<uint8_t> shade;     // per triangle: the Lambert factor of --fill shade, 0 ... 255
  std::vector<std::array<float, 3>> mesh_color;  // per mesh: linear RGB
  size_t triangle_count() const { return source.size(); }
};

// Thrown when a frame's base is not the frame this decoder decoded last (a frame was lost or
// reordered): ask the server for a keyframe (protocol: `keyframe` message).
struct DeltaOutOfSync : InputError {
  using InputError::InputError;
};

// The client's side: the sources it was sent and the previous whole set.
class DeltaDecoder {
 public:
  // A delta frame (VMDF) or, in a version 2 stream, a compact frame (VMCF).
  DeltaFrame decode(const std::string& bytes);  // throws InputError / DeltaOutOfSync
  bool has_state() const { return have_state_; }
  // Keeps the scene of encode_delta_sources' message: keyframes flagged `held` start from it.
  void hold_scene(const std::string& sources);  // throws InputError
  bool holds_scene() const { return held_ != nullptr; }

  // What a client holds between frames; a keyframe starts it afresh from its mesh table.
  struct State {
    std::vector<uint64_t> base, vertex_base;      // per mesh: first global id, first vertex number
    std::vector<float> vertex;                    // 3 per global vertex (NaN: not sent)
    std::vector<uint32_t> tri;                    // 3 per global triangle (~0: not sent)
    std::vector<uint32_t> whole;                  // sorted
    std::vector<uint32_t> partial;                // sorted: the previous frame's polygon sources
    std::vector<std::array<float, 3>> colors;     // per mesh: linear RGB
    std::array<double, 12> rows{};                // the last frame's projection and grid
    uint32_t width = 0, height = 0, quantum = 0;  // (0: none yet; version 2 facing flips)
    size_t triangles() const { return tri.size() / 3; }
    size_t vertices() const { return vertex.size() / 3; }
    uint32_t mesh_of(uint32_t id) const;  // the mesh of a global triangle id
  };

 private:
  bool have_state_ = false;
  uint32_t last_ = 0;
  State state_;
  std::shared_ptr<const State> held_;  // the scene of hold_scene: its store, no frame yet
};

// The rows x, y and w of a view-projection matrix (column-major Mat4), 4 each: what a delta frame
// sends, so that both sides project with the same numbers (no trigonometry on the client).
std::array<double, 12> clip_rows(const Mat4& view_projection);

// Projects a world point to the grid, as both sides must, operation by operation (DELTA.md):
// c = r[0..3]·(x, y, z, 1) left to right for each row, x = (cx/cw + 1) * 0.5 * width * quantum,
// y = (1 - cy/cw) * 0.5 * height * quantum, rounded to the nearest (ties away from zero). False
// when the point is not in front of the camera (cw <= 0) or far outside.
bool project_to_grid(const std::array<double, 12>& rows, uint32_t width, uint32_t height,
                     uint32_t quantum, const float* p, int32_t* out);

}  // namespace vismap
