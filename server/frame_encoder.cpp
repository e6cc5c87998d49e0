#include "server/frame_encoder.h"

#include "core/compact.h"
#include "core/output.h"

namespace vismap::server {

namespace {

class SvgEncoder : public FrameEncoder {
 public:
  explicit SvgEncoder(Fill fill) : fill_(fill) {}
  EncodedFrame encode(const PlanarMap& map, const Scene& scene, const Camera& camera) override {
    return {write_svg(map, scene, camera, fill_)};
  }

 private:
  Fill fill_;
};

class BinEncoder : public FrameEncoder {
 public:
  EncodedFrame encode(const PlanarMap& map, const Scene& scene, const Camera&) override {
    return {write_bin(map, scene)};
  }
};

class CompactEncoder : public FrameEncoder {
 public:
  explicit CompactEncoder(const CompactOptions& o) : options_(o) {}
  EncodedFrame encode(const PlanarMap& map, const Scene& scene, const Camera& camera) override {
    CompactStats st;
    EncodedFrame f{write_compact(map, scene, camera, options_, &st)};
    f.header = {{"vertices", st.vertices}, {"out_triangles", st.triangles}};
    return f;
  }

 private:
  CompactOptions options_;
};

}  // namespace

std::unique_ptr<FrameEncoder> make_encoder(const Hello& h) {
  switch (h.format) {
    case Format::Svg:
      return std::make_unique<SvgEncoder>(h.fill_id ? Fill::Id : Fill::Shade);
    case Format::Bin:
      return std::make_unique<BinEncoder>();
    case Format::Compact: {
      CompactOptions o;
      o.quantum = h.quantum;
      o.shade = !h.fill_id;
      o.compression = h.compression;
      return std::make_unique<CompactEncoder>(o);
    }
  }
  throw std::logic_error("make_encoder: a Format without an encoder");
}

}  // namespace vismap::server
