#include "server/frame_encoder.h"

#include <algorithm>
#include <atomic>

#include "core/lines/lines.h"
#include "core/stream/compact.h"
#include "core/stream/delta.h"
#include "core/write/output.h"

namespace vismap::server {

namespace {

// What a hello's style asks for: lines (from the render's screen triangles) or not.
struct LineStyle {
  bool lines = false, fills = true;
  LineOptions options;
  explicit LineStyle(const Hello& h)
      : lines(h.style != "fill"), fills(h.style != "lines") {
    options.hidden = h.hidden;
    options.crease_angle_deg = h.crease_angle_deg;
  }
};

class SvgEncoder : public FrameEncoder {
 public:
  SvgEncoder(Fill fill, const LineStyle& style) : fill_(fill), style_(style) {}
  bool needs_screen() const override { return style_.lines; }
  EncodedFrame encode(const PlanarMap& map, const std::shared_ptr<const Scene>& scene,
                      const Camera& camera, const ScreenTriangles* screen) override {
    if (!style_.lines) return {write_svg(map, *scene, camera, fill_)};
    if (!screen) throw std::logic_error("svg encoder: the render kept no screen triangles");
    const LineSet lines = extract_lines(map, *screen, *scene, camera, style_.options);
    SvgStyle st;
    st.fill = style_.fills;
    st.lines = &lines;
    EncodedFrame f{write_svg(map, *scene, camera, fill_, st)};
    f.header = {{"line_chains", lines.chain_count()}};
    return f;
  }

 private:
  Fill fill_;
  LineStyle style_;
};

class BinEncoder : public FrameEncoder {
 public:
  explicit BinEncoder(const LineStyle& style) : style_(style) {}
  bool needs_screen() const override { return style_.lines; }
  EncodedFrame encode(const PlanarMap& map, const std::shared_ptr<const Scene>& scene,
                      const Camera& camera, const ScreenTriangles* screen) override {
    if (!style_.lines) return {write_bin(map, *scene)};
    if (!screen) throw std::logic_error("bin encoder: the render kept no screen triangles");
    const LineSet lines = extract_lines(map, *screen, *scene, camera, style_.options);
    EncodedFrame f{write_bin(map, *scene, &lines, style_.fills)};
    f.header = {{"line_chains", lines.chain_count()}};
    return f;
  }

 private:
  LineStyle style_;
};

class CompactEncoder : public FrameEncoder {
 public:
  explicit CompactEncoder(const CompactOptions& o) : options_(o) {}
  EncodedFrame encode(const PlanarMap& map, const std::shared_ptr<const Scene>& scene,
                      const Camera& camera, const ScreenTriangles*) override {
    CompactStats st;
    EncodedFrame f{write_compact(map, *scene, camera, options_, &st)};
    f.header = {{"vertices", st.vertices}, {"out_triangles", st.triangles}};
    return f;
  }

 private:
  CompactOptions options_;
};

// Delta frames (proto/DELTA.md): the client's state is mirrored in a DeltaEncoder, made anew
// (so the next frame is a keyframe) whenever the session's scene changes. Its size is bounded
// by the scene: a byte per source triangle and vertex, and the previous frame's id sets.
class DeltaFrameEncoder : public FrameEncoder {
 public:
  explicit DeltaFrameEncoder(const DeltaOptions& o) : options_(o) {}
  bool needs_screen() const override { return true; }
  void request_keyframe() override { keyframe_requested_ = true; }
  uint64_t state_bytes() const override { return state_bytes_; }
  EncodedFrame encode(const PlanarMap& map, const std::shared_ptr<const Scene>& scene,
                      const Camera& camera, const ScreenTriangles* screen) override {
    if (!screen) throw std::logic_error("delta encoder: the render kept no screen triangles");
    if (!encoder_ || scene_.owner_before(scene) || scene.owner_before(scene_)) {
      encoder_ = std::make_unique<DeltaEncoder>(*scene, options_);
      scene_ = scene;
    }
    if (keyframe_requested_.exchange(false)) encoder_->request_keyframe();
    DeltaStats st;
    EncodedFrame f{encoder_->encode(map, *screen, camera, &st)};
    state_bytes_ = encoder_->state_bytes();
    f.header = {{"keyframe", st.keyframe},
                {"whole", st.whole},
                {"polygons", st.partial},
                {"points", st.points},
                {"new_triangles", st.new_triangles}};
    if (options_.version >= 2) {  // protocol version 3: how it went out, and the compact size
      static constexpr const char* kCoding[] = {"delta", "keyframe", "compact"};
      f.header["coding"] = kCoding[int(st.coding)];
      f.header["compact_bytes"] = st.compact_bytes;
    }
    return f;
  }

 private:
  DeltaOptions options_;
  std::weak_ptr<const Scene> scene_;  // the scene encoder_ mirrors (weak: a new one replaces it)
  std::unique_ptr<DeltaEncoder> encoder_;
  std::atomic<bool> keyframe_requested_{false};
  std::atomic<uint64_t> state_bytes_{0};
};

}  // namespace

std::unique_ptr<FrameEncoder> make_encoder(const Hello& h, int level) {
  if (h.compression == Compression::Deflate) level = std::min(level, 9);  // deflate's highest
  switch (h.format) {
    case Format::Svg:
      return std::make_unique<SvgEncoder>(h.fill_id ? Fill::Id : Fill::Shade, LineStyle(h));
    case Format::Bin:
      return std::make_unique<BinEncoder>(LineStyle(h));
    case Format::Compact: {
      CompactOptions o;
      o.quantum = h.quantum;
      o.shade = !h.fill_id;
      o.compression = h.compression;
      o.level = level;
      return std::make_unique<CompactEncoder>(o);
    }
    case Format::Delta: {
      DeltaOptions o;
      o.quantum = h.quantum;
      o.compression = h.compression;
      o.keyframe_every = h.keyframe_every;
      o.version = h.version >= 3 ? 2 : 1;  // DELTA.md version 2 from protocol version 3
      o.client_holds_scene = h.hold_scene;
      o.level = level;
      return std::make_unique<DeltaFrameEncoder>(o);
    }
  }
  throw std::logic_error("make_encoder: a Format without an encoder");
}

}  // namespace vismap::server
