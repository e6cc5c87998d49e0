#include "core/frame/encoders.h"

#include <algorithm>
#include <stdexcept>

#include "core/stream/delta.h"
#include "core/write/cairo.h"

namespace vismap::frame {

namespace {

// The entropy coder's level: deflate's highest is 9 (the spec may give zstd's range).
int coder_level(const OutputSpec& o) {
  return o.compression == Compression::Deflate ? std::min(o.level, 9) : o.level;
}

constexpr std::array<const char*, 3> kStyleNames{"fill", "lines", "fill+lines"};

// The SVG writer's style for this frame: the spec's widths and colours, its fills, these lines.
SvgStyle frame_style(const OutputSpec& o, const LineSet* lines) {
  SvgStyle st = o.svg;
  st.fill = o.draws_fills();
  st.lines = lines;
  return st;
}

nlohmann::json line_header(const LineSet* lines) {
  return lines ? nlohmann::json{{"line_chains", lines->chain_count()}}
               : nlohmann::json::object();
}

class SvgEncoder : public FrameEncoder {
 public:
  explicit SvgEncoder(const OutputSpec& o) : o_(o) {}
  EncodedFrame encode(const FrameInput& in) override {
    return {write_svg(in.map, *in.scene, in.camera, o_.fill, frame_style(o_, in.lines)),
            line_header(in.lines)};
  }

 private:
  OutputSpec o_;
};

// PDF, EPS and PNG through cairo (core/write/cairo.h): the SVG's paths and lines.
class CairoEncoder : public FrameEncoder {
 public:
  CairoEncoder(const OutputSpec& o, CairoFormat f) : o_(o), format_(f) {}
  EncodedFrame encode(const FrameInput& in) override {
    return {write_cairo(in.map, *in.scene, in.camera, o_.fill, frame_style(o_, in.lines), format_),
            line_header(in.lines)};
  }

 private:
  OutputSpec o_;
  CairoFormat format_;
};

class BinEncoder : public FrameEncoder {
 public:
  explicit BinEncoder(const OutputSpec& o) : o_(o) {}
  EncodedFrame encode(const FrameInput& in) override {
    if (!in.lines) return {write_bin(in.map, *in.scene)};
    return {write_bin(in.map, *in.scene, in.lines, o_.draws_fills()), line_header(in.lines)};
  }

 private:
  OutputSpec o_;
};

class CompactEncoder : public FrameEncoder {
 public:
  explicit CompactEncoder(const OutputSpec& o) {
    options_.quantum = o.quantum;
    options_.shade = o.fill == Fill::Shade;
    options_.compression = o.compression;
    options_.level = coder_level(o);
  }
  EncodedFrame encode(const FrameInput& in) override {
    EncodedFrame f;
    f.bytes = write_compact(in.map, *in.scene, in.camera, options_, &f.compact);
    f.header = {{"vertices", f.compact.vertices}, {"out_triangles", f.compact.triangles}};
    return f;
  }

 private:
  CompactOptions options_;
};

// Delta frames (proto/DELTA.md): the client's state is mirrored in a DeltaEncoder, made anew
// (so the next frame is a keyframe) whenever the stream's scene changes. Its size is bounded
// by the scene: a byte per source triangle and vertex, and the previous frame's id sets.
class DeltaFrameEncoder : public FrameEncoder {
 public:
  explicit DeltaFrameEncoder(const OutputSpec& o) {
    options_.quantum = o.quantum;
    options_.compression = o.compression;
    options_.keyframe_every = o.keyframe_every;
    options_.version = o.delta_version;
    options_.client_holds_scene = o.client_holds_scene;
    options_.level = coder_level(o);
  }
  void request_keyframe() override { keyframe_requested_ = true; }
  uint64_t state_bytes() const override { return state_bytes_; }
  EncodedFrame encode(const FrameInput& in) override {
    if (!in.screen) throw std::logic_error("delta encoder: the render kept no screen triangles");
    if (!encoder_ || scene_.owner_before(in.scene) || in.scene.owner_before(scene_)) {
      encoder_ = std::make_unique<DeltaEncoder>(*in.scene, options_);
      scene_ = in.scene;
    }
    if (keyframe_requested_.exchange(false)) encoder_->request_keyframe();
    DeltaStats st;
    EncodedFrame f{encoder_->encode(in.map, *in.screen, in.camera, &st)};
    state_bytes_ = encoder_->state_bytes();
    f.header = {{"keyframe", st.keyframe},
                {"whole", st.whole},
                {"polygons", st.partial},
                {"points", st.points},
                {"new_triangles", st.new_triangles}};
    if (options_.version >= 2) {  // how it went out, and the compact size
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

const char* style_name(DrawStyle s) { return kStyleNames[static_cast<size_t>(s)]; }

std::optional<DrawStyle> style_named(std::string_view name) {
  for (size_t i = 0; i < kStyleNames.size(); ++i)
    if (name == kStyleNames[i]) return DrawStyle(i);
  return std::nullopt;
}

bool needs_screen(const OutputSpec& o) {
  return o.draws_lines() || o.format == OutputFormat::Delta;
}

std::unique_ptr<FrameEncoder> make_encoder(const OutputSpec& o) {
  switch (o.format) {
    case OutputFormat::Svg:
      return std::make_unique<SvgEncoder>(o);
    case OutputFormat::Pdf:
      return std::make_unique<CairoEncoder>(o, CairoFormat::Pdf);
    case OutputFormat::Eps:
      return std::make_unique<CairoEncoder>(o, CairoFormat::Eps);
    case OutputFormat::Png:
      return std::make_unique<CairoEncoder>(o, CairoFormat::Png);
    case OutputFormat::Bin:
      return std::make_unique<BinEncoder>(o);
    case OutputFormat::Compact:
      return std::make_unique<CompactEncoder>(o);
    case OutputFormat::Delta:
      return std::make_unique<DeltaFrameEncoder>(o);
  }
  throw std::logic_error("make_encoder: an OutputFormat without an encoder");
}

}  // namespace vismap::frame
