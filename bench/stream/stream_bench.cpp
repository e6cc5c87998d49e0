// vismap_stream_bench: what streaming a planar map costs per frame, against video (issue 16).
// Loads one scene, keeps one Renderer warm, renders an orbit of cameras and, per frame, encodes
// the map with every encoding in encodings() and decodes it again, timing both. Prints one JSON
// object per frame and a summary line; writes each frame's SVG (the exact frame: bench/stream/
// run.sh rasterizes it, feeds the rasters to the video encoders and measures their PSNR against
// it) and, for lossy encodings, the decoded frame as SVG beside it. Not a test (benchmarks
// measure, tests do not time things). docs/STREAMING.md has the methodology and results.
//
//   vismap_stream_bench SCENE --out DIR [--frames 60] [--width 1920] [--height 1080]
//                       [--step-deg 6] [--elevation-deg 20] [--distance 1.7] [--fov-y 35]
//                       [--device NAME]
//
// The orbit: frame i looks at the bounding-box centre from azimuth i*step around the +Y axis
// through it (azimuth 0 is on the +Z side, growing towards +X), at a fixed elevation above the
// horizontal plane through the centre, from `distance` bounding-box diagonals; perspective, up
// +Y, near/far fitted to the bounds (fit_near_far) for each frame. A scene file's own camera is
// ignored. Frame i's files: DIR/exact/frame_%04d.svg, DIR/<encoding>/frame_%04d.svg.
#include <sys/stat.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <memory>
#include <numbers>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "core/camera.h"
#include "core/error.h"
#include "core/pipeline.h"
#include "core/scene.h"
#include "core/util/clock.h"
#include "core/write/output.h"

// ---- compact plugs in here (issue 16; core/stream/compact.h on main, not yet on this branch) ----
// When the header is there the encoding below is compiled in and listed; nothing else changes.
#if __has_include("core/stream/compact.h")
#include "core/stream/compact.h"
#define VISMAP_STREAM_HAVE_COMPACT 1
#include "core/stream/delta.h"
#endif

namespace {

using namespace vismap;

// ---- encodings ----------------------------------------------------------------------------

// One rendered frame, as every encoding sees it. The map was rendered with attributes
// (barycentrics and 1/w); an encoding that does not want them uses WithoutAttributes.
struct Frame {
  PlanarMap& map;
  const Scene& scene;
  const Camera& camera;
  const ScreenTriangles& screen;  // the render's screen triangles (delta wants them)
};

// Extra figures an encoder reports for the frame's JSON line (compact: its CompactStats).
using Extras = std::vector<std::pair<std::string, double>>;

// One way of sending a frame. More plug in by adding an entry to encodings(); an encoding that
// keeps state from frame to frame (delta: the previous frame) holds it in its lambdas' captures.
struct Encoding {
  std::string name;
  // The bytes that go over the wire for this frame (timed: encode ms).
  std::function<std::string(const Frame&, Extras&)> encode;
  // Parses the bytes as a client would (timed: decode ms); returns the triangles decoded, which
  // the bench checks against the frame's fan count when `lossless_triangles`. Empty: the bench
  // has no in-process decoder (svg: the client's rasterizer is its decoder; run.sh times
  // rsvg-convert instead).
  std::function<size_t(const std::string&)> decode;
  bool lossless_triangles = false;
  // Lossy encodings: the decoded frame as a planar map (not timed), written as SVG to
  // DIR/<name>/ so run.sh rasterizes it and measures its PSNR against the exact raster.
  std::function<PlanarMap(const std::string&, const Scene&)> decoded_map;
  // The SVG encoding's bytes are the exact frame (written to DIR/exact/).
  bool is_exact_svg = false;
};

// Detaches the map's attributes for the scope (no copy of the geometry), so the binary writer
// writes the 24 + 32*T byte frame without barycentrics and 1/w.
class WithoutAttributes {
 public:
  explicit WithoutAttributes(PlanarMap& m) : m_(m) {
    bary_.swap(m_.bary);
    inv_w_.swap(m_.inv_w);
  }
  ~WithoutAttributes() {
    bary_.swap(m_.bary);
    inv_w_.swap(m_.inv_w);
  }
  WithoutAttributes(const WithoutAttributes&) = delete;
  WithoutAttributes& operator=(const WithoutAttributes&) = delete;

 private:
  PlanarMap& m_;
  std::vector<float> bary_, inv_w_;
};

std::vector<Encoding> encodings() {
  std::vector<Encoding> list;
  // svg: what `vismap render` writes (Fill::Shade); its bytes are the exact frame.
  Encoding svg;
  svg.name = "svg";
  svg.encode = [](const Frame& f, Extras&) {
    return write_svg(f.map, f.scene, f.camera, Fill::Shade);
  };
  svg.is_exact_svg = true;
  list.push_back(svg);
  // bin: proto/FORMAT.md without attributes (positions, mesh, source id; 24 + 32*T bytes). A
  // client shades from the source ids, so it holds the scene's normals and colours.
  Encoding bin;
  bin.name = "bin";
  bin.encode = [](const Frame& f, Extras&) {
    WithoutAttributes plain(f.map);
    return write_bin(f.map, f.scene);
  };
  bin.decode = [](const std::string& b) { return read_bin(b).triangle_count(); };
  bin.lossless_triangles = true;
  list.push_back(bin);
  // bin_attr: the same with barycentrics and 1/w per vertex (24 + 80*T), as `vismap render
  // --format bin` writes it, for clients that interpolate attributes (textures, normals).
  Encoding attr = bin;
  attr.name = "bin_attr";
  attr.encode = [](const Frame& f, Extras&) { return write_bin(f.map, f.scene); };
  list.push_back(attr);
#ifdef VISMAP_STREAM_HAVE_COMPACT
  // compact (proto/COMPACT.md): quantized to 1/16 px, a shade byte per triangle so the client
  // needs no scene (as a video client), zstd level 3. Lossy in positions: the decoded frame is
  // drawn as SVG and compared against the exact raster by run.sh.
  Encoding compact;
  compact.name = "compact";
  compact.encode = [](const Frame& f, Extras& x) {
    CompactOptions o;
    o.shade = true;
    CompactStats st;
    std::string b = write_compact(f.map, f.scene, f.camera, o, &st);
    x = {{"vertices", double(st.vertices)},         {"triangles", double(st.triangles)},
         {"t_junctions", double(st.t_junctions)},   {"dropped", double(st.dropped)},
         {"vertex_bytes", double(st.vertex_bytes)}, {"index_bytes", double(st.index_bytes)},
         {"id_bytes", double(st.id_bytes)},         {"shade_bytes", double(st.shade_bytes)}};
    return b;
  };
  compact.decode = [](const std::string& b) { return read_compact(b).triangle_count(); };
  compact.decoded_map = [](const std::string& b, const Scene& scene) {
    return to_planar_map(read_compact(b), scene);
  };
  list.push_back(compact);
#endif
#ifdef VISMAP_STREAM_HAVE_COMPACT
  // delta (proto/DELTA.md version 2, what protocol version 3 streams): each frame the smallest of
  // the frame against the client's state, a keyframe and the compact frame; decoded in order.
  // `delta`: a client that does not hold the scene (the sources go with the frames that need
  // them, when that is smaller than compact); `delta_held`: one that holds it (the sources
  // message once, not counted in the frames: `sources_bytes` in the summary line's extras of
  // frame 0). `delta_held_z19`: delta_held with its frames' zstd at level 19 (vismapd's
  // frame_level), not 3: fewer bytes for more encode time. All are decoded, drawn and compared
  // with the exact raster.
  for (const auto& [hold, level] : {std::pair{false, 0}, std::pair{true, 0}, std::pair{true, 19}}) {
    struct DeltaState {
      std::unique_ptr<DeltaEncoder> enc;
      DeltaDecoder dec;
      DeltaFrame last;
    };
    auto ds = std::make_shared<DeltaState>();
    Encoding delta;
    delta.name = level ? "delta_held_z19" : hold ? "delta_held" : "delta";
    delta.encode = [ds, hold = hold, level = level](const Frame& f, Extras& x) {
      double sources = 0;
      if (!ds->enc) {
        DeltaOptions o;
        o.client_holds_scene = hold;
        o.level = level;
        ds->enc = std::make_unique<DeltaEncoder>(f.scene, o);
        if (hold) {
          const std::string msg = encode_delta_sources(f.scene, o.compression);
          ds->dec.hold_scene(msg);
          sources = double(msg.size());
        }
      }
      DeltaStats st;
      std::string b = ds->enc->encode(f.map, f.screen, f.camera, &st);
      x = {{"coding", double(int(st.coding))},
           {"compact_bytes", double(st.compact_bytes)},
           {"delta_bytes", double(st.delta_bytes)},
           {"whole", double(st.whole)},
           {"flips", double(st.flips)},
           {"polygons", double(st.partial)},
           {"points", double(st.points)},
           {"edge_refs", double(st.edge_refs)},
           {"new_triangles", double(st.new_triangles)}};
      if (sources > 0) x.push_back({"sources_bytes", sources});
      return b;
    };
    delta.decode = [ds](const std::string& b) {
      ds->last = ds->dec.decode(b);
      return ds->last.triangle_count();
    };
    delta.decoded_map = [ds](const std::string&, const Scene& scene) {
      const DeltaFrame& d = ds->last;
      PlanarMap m;
      m.width = d.width, m.height = d.height;
      const std::vector<uint64_t> base = scene.triangle_id_base();
      for (size_t t = 0; t < d.triangle_count(); ++t) {
        for (int c = 0; c < 3; ++c) {
          const uint32_t v = d.indices[3 * t + c];
          m.xy.push_back(double(d.xy[2 * v]) / d.quantum);
          m.xy.push_back(double(d.xy[2 * v + 1]) / d.quantum);
        }
        m.offsets.push_back(uint32_t(m.xy.size() / 2));
        const uint32_t mesh = d.mesh[t];
        const std::vector<uint32_t>& ids = scene.meshes[mesh].face_ids;
        const auto it =
            std::lower_bound(ids.begin(), ids.end(), uint32_t(d.source[t] - base[mesh]));
        m.mesh.push_back(mesh);
        m.triangle.push_back(uint32_t(it - ids.begin()));
      }
      return m;
    };
    list.push_back(delta);
  }
  // delta_v1_held: version 1 (what protocol version 2 streams), as if the client held the scene:
  // bytes only, the figure the version 2 records are measured against.
  auto dh = std::make_shared<std::unique_ptr<DeltaEncoder>>();
  Encoding v1;
  v1.name = "delta_v1_held";
  v1.encode = [dh](const Frame& f, Extras&) {
    if (!*dh) {
      DeltaOptions o;
      o.version = 1;
      o.client_holds_scene = true;
      *dh = std::make_unique<DeltaEncoder>(f.scene, o);
    }
    return (*dh)->encode(f.map, f.screen, f.camera);
  };
  list.push_back(v1);
#endif
  return list;
}

// ---- the orbit ----------------------------------------------------------------------------

struct Orbit {
  uint32_t frames = 60, width = 1920, height = 1080;
  double step_deg = 6, elevation_deg = 20, distance_diag = 1.7, fov_y_deg = 35;
};

Camera orbit_camera(const Scene& scene, const Bounds& b, const Orbit& o, uint32_t i) {
  const Vec3 c{0.5 * (b.lo[0] + b.hi[0]), 0.5 * (b.lo[1] + b.hi[1]), 0.5 * (b.lo[2] + b.hi[2])};
  const double dx = b.hi[0] - b.lo[0], dy = b.hi[1] - b.lo[1], dz = b.hi[2] - b.lo[2];
  const double d = o.distance_diag * std::sqrt(dx * dx + dy * dy + dz * dz);
  const double deg = std::numbers::pi / 180;
  const double az = i * o.step_deg * deg, el = o.elevation_deg * deg;
  Camera cam;
  cam.projection = Camera::Projection::Perspective;
  cam.fov_y_deg = o.fov_y_deg;
  cam.target = c;
  cam.eye = {c[0] + d * std::cos(el) * std::sin(az), c[1] + d * std::sin(el),
             c[2] + d * std::cos(el) * std::cos(az)};
  cam.up = {0, 1, 0};
  cam.width = o.width;
  cam.height = o.height;
  cam.near_plane = cam.far_plane = 0;
  fit_near_far(cam, scene);
  cam.validate();
  return cam;
}

// ---- output -------------------------------------------------------------------------------

std::string fmt(double v) {
  if (!std::isfinite(v)) return "null";
  char b[64];
  std::snprintf(b, sizeof b, "%.10g", v);
  return b;
}

std::string json_string(const std::string& s) {
  std::string o = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') o += '\\';
    if (static_cast<unsigned char>(c) < 0x20) continue;
    o += c;
  }
  return o + "\"";
}

// A JSON object built key by key.
class Json {
 public:
  Json& raw(const std::string& k, const std::string& v) {
    if (s_.size() > 1) s_ += ',';
    s_ += json_string(k);
    s_ += ':';
    s_ += v;
    return *this;
  }
  Json& num(const std::string& k, double v) { return raw(k, fmt(v)); }
  Json& str(const std::string& k, const std::string& v) { return raw(k, json_string(v)); }
  std::string done() const { return s_ + "}"; }

 private:
  std::string s_ = "{";
};

double median(std::vector<double> v) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

double mean(const std::vector<double>& v) {
  if (v.empty()) return NAN;
  double s = 0;
  for (double x : v) s += x;
  return s / v.size();
}

void make_dir(const std::string& p) {
  if (mkdir(p.c_str(), 0777) != 0 && errno != EEXIST)
    throw std::runtime_error("cannot create directory " + p);
}

void write_file(const std::string& path, const std::string& bytes) {
  std::ofstream f(path, std::ios::binary | std::ios::trunc);
  f.write(bytes.data(), std::streamsize(bytes.size()));
  if (!f) throw std::runtime_error("cannot write " + path);
}

std::string frame_file(const std::string& dir, uint32_t i) {
  char b[32];
  std::snprintf(b, sizeof b, "/frame_%04u.svg", i);
  return dir + b;
}

// Output triangles as a client draws them: each convex fragment fanned, (vertices - 2) each.
uint64_t fan_triangles(const PlanarMap& m) {
  uint64_t t = 0;
  for (size_t f = 0; f < m.fragment_count(); ++f) t += m.offsets[f + 1] - m.offsets[f] - 2;
  return t;
}

struct Args {
  std::string scene, out, device;
  Orbit orbit;
};

int usage() {
  std::fputs(
      "usage: vismap_stream_bench SCENE --out DIR [--frames N] [--width W] [--height H]\n"
      "                           [--step-deg D] [--elevation-deg E] [--distance DIAGONALS]\n"
      "                           [--fov-y DEG] [--device NAME]\n",
      stderr);
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  keep_freed_memory_for_reuse();
  Args a;
  for (int i = 1; i < argc; ++i) {
    const std::string f = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw std::invalid_argument(f + " needs a value");
      return argv[++i];
    };
    try {
      if (f == "--out")
        a.out = value();
      else if (f == "--frames")
        a.orbit.frames = std::stoul(value());
      else if (f == "--width")
        a.orbit.width = std::stoul(value());
      else if (f == "--height")
        a.orbit.height = std::stoul(value());
      else if (f == "--step-deg")
        a.orbit.step_deg = std::stod(value());
      else if (f == "--elevation-deg")
        a.orbit.elevation_deg = std::stod(value());
      else if (f == "--distance")
        a.orbit.distance_diag = std::stod(value());
      else if (f == "--fov-y")
        a.orbit.fov_y_deg = std::stod(value());
      else if (f == "--device")
        a.device = value();
      else if (!f.empty() && f[0] == '-')
        return usage();
      else
        a.scene = f;
    } catch (const std::exception& e) {
      std::fprintf(stderr, "vismap_stream_bench: %s\n", e.what());
      return usage();
    }
  }
  if (a.scene.empty() || a.out.empty() || a.orbit.frames == 0) return usage();

  try {
    const auto t0 = Clock::now();
    const Scene scene = load_scene(a.scene);
    const double load_ms = ms_since(t0);
    const auto t1 = Clock::now();
    Renderer renderer(a.device);
    const double init_ms = ms_since(t1);
    const Bounds bounds = scene_bounds(scene);
    std::vector<Encoding> encs = encodings();

    make_dir(a.out);
    make_dir(a.out + "/exact");
    for (const Encoding& e : encs)
      if (e.decoded_map) make_dir(a.out + "/" + e.name);

    RenderOptions opts;
    opts.attributes = true;             // bin_attr wants them; the others detach or ignore them
    opts.keep_screen_triangles = true;  // delta wants them (the map is the same)
    // Warm-up: frame 0 once, untimed in the per-frame figures (scene upload, PoCL's kernel JIT).
    const auto t2 = Clock::now();
    RenderStats first;
    (void)renderer.render(scene, orbit_camera(scene, bounds, a.orbit, 0), opts, &first);
    const double first_ms = ms_since(t2);

    std::vector<double> render_ms, tris, frags;
    std::vector<std::vector<double>> bytes(encs.size()), enc_ms(encs.size()), dec_ms(encs.size());
    for (uint32_t i = 0; i < a.orbit.frames; ++i) {
      const Camera cam = orbit_camera(scene, bounds, a.orbit, i);
      RenderStats st;
      ScreenTriangles screen;
      PlanarMap map = renderer.render(scene, cam, opts, &st, &screen);
      const uint64_t fan = fan_triangles(map);
      render_ms.push_back(st.pipeline_ms);
      tris.push_back(double(fan));
      frags.push_back(double(map.fragment_count()));
      const Frame frame{map, scene, cam, screen};

      Json line;
      line.str("scene", a.scene)
          .num("frame", i)
          .num("azimuth_deg", i * a.orbit.step_deg)
          .num("render_ms", st.pipeline_ms)
          .num("fragments", double(map.fragment_count()))
          .num("visible_triangles", double(fan));
      Json per_enc;
      for (size_t e = 0; e < encs.size(); ++e) {
        const Encoding& enc = encs[e];
        Extras extras;
        const auto s0 = Clock::now();
        const std::string b = enc.encode(frame, extras);
        const double ems = ms_since(s0);
        Json j;
        j.num("bytes", double(b.size())).num("encode_ms", ems);
        bytes[e].push_back(double(b.size()));
        enc_ms[e].push_back(ems);
        if (enc.decode) {
          const auto d0 = Clock::now();
          const size_t n = enc.decode(b);
          const double dms = ms_since(d0);
          if (enc.lossless_triangles && n != fan)
            throw std::runtime_error(enc.name + " decoded " + std::to_string(n) +
                                     " triangles, the frame has " + std::to_string(fan));
          j.num("decode_ms", dms).num("decoded_triangles", double(n));
          dec_ms[e].push_back(dms);
        }
        for (const auto& [k, v] : extras) j.num(k, v);
        per_enc.raw(enc.name, j.done());
        if (enc.is_exact_svg) write_file(frame_file(a.out + "/exact", i), b);
        if (enc.decoded_map)
          write_file(frame_file(a.out + "/" + enc.name, i),
                     write_svg(enc.decoded_map(b, scene), scene, cam, Fill::Shade));
      }
      line.raw("encodings", per_enc.done());
      std::printf("%s\n", line.done().c_str());
      std::fflush(stdout);
    }

    Json sum, per_enc;
    sum.raw("summary", "true")
        .str("scene", a.scene)
        .str("device", renderer.device().platform + " / " + renderer.device().name)
        .num("input_triangles", double(first.input_triangles))
        .num("frames", a.orbit.frames)
        .num("width", a.orbit.width)
        .num("height", a.orbit.height)
        .num("step_deg", a.orbit.step_deg)
        .num("elevation_deg", a.orbit.elevation_deg)
        .num("distance_diag", a.orbit.distance_diag)
        .num("fov_y_deg", a.orbit.fov_y_deg)
        .num("load_ms", load_ms)
        .num("init_ms", init_ms)
        .num("first_render_ms", first_ms)
        .num("render_ms_median", median(render_ms))
        .num("render_ms_mean", mean(render_ms))
        .num("visible_triangles_mean", mean(tris))
        .num("visible_triangles_min", *std::min_element(tris.begin(), tris.end()))
        .num("visible_triangles_max", *std::max_element(tris.begin(), tris.end()))
        .num("fragments_mean", mean(frags));
    for (size_t e = 0; e < encs.size(); ++e) {
      Json j;
      j.num("bytes_mean", mean(bytes[e]))
          .num("bytes_min", *std::min_element(bytes[e].begin(), bytes[e].end()))
          .num("bytes_max", *std::max_element(bytes[e].begin(), bytes[e].end()))
          .num("encode_ms_mean", mean(enc_ms[e]))
          .num("encode_ms_median", median(enc_ms[e]))
          .num("decode_ms_mean", mean(dec_ms[e]))
          .num("decode_ms_median", median(dec_ms[e]));
      if (encs[e].decoded_map) j.str("decoded_svg_dir", a.out + "/" + encs[e].name);
      per_enc.raw(encs[e].name, j.done());
    }
    sum.raw("encodings", per_enc.done()).str("exact_svg_dir", a.out + "/exact");
    std::printf("%s\n", sum.done().c_str());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "vismap_stream_bench: %s\n", e.what());
    return 1;
  }
  return 0;
}
