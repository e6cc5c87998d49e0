// `vismap decode`: a bin, compact or delta frame back to triangles, as a summary, JSON or SVG.
#include "cli/decode.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "cli/args.h"
#include "core/error.h"
#include "core/stream/compact.h"
#include "core/stream/delta.h"
#include "core/util/clock.h"
#include "core/write/output.h"

namespace vismap::cli {

namespace {

// The decoded triangles, whatever the encoding: pixels, and a fill per triangle.
struct Triangles {
  std::string format;
  uint32_t version = 0, width = 0, height = 0, quantum = 0;
  size_t vertices = 0;
  std::vector<double> xy;        // 6 per triangle, pixels
  std::vector<uint32_t> source;  // global source triangle id
  std::vector<uint32_t> rgb;     // fill, 0xRRGGBB
  bool shaded = false;
  int64_t line_chains = -1, line_points = 0;  // bin frames with a line section
};

uint8_t srgb8(double linear) {
  const double c = std::clamp(linear, 0.0, 1.0);
  const double s = c <= 0.0031308 ? 12.92 * c : 1.055 * std::pow(c, 1.0 / 2.4) - 0.055;
  return static_cast<uint8_t>(std::lround(s * 255.0));
}

std::string number(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.4f", v);
  std::string s = b;
  while (s.back() == '0') s.pop_back();
  if (s.back() == '.') s.pop_back();
  return s == "-0" ? "0" : s;
}

// A compact or delta frame's triangles (grid steps) in pixels, filled with the shade colour
// (mesh colour x shade/255) when t.shaded, else the id colour.
template <class F>
void add_grid_triangles(Triangles& t, const F& f) {
  for (size_t k = 0; k < f.triangle_count(); ++k) {
    for (int j = 0; j < 3; ++j) {
      const uint32_t v = f.indices[3 * k + j];
      t.xy.push_back(double(f.xy[2 * v]) / f.quantum);
      t.xy.push_back(double(f.xy[2 * v + 1]) / f.quantum);
    }
    t.source.push_back(f.source[k]);
    uint32_t rgb = (f.source[k] + 1) & 0xFFFFFF;
    if (t.shaded) {
      rgb = 0;
      for (int j = 0; j < 3; ++j)
        rgb = rgb << 8 | srgb8(f.mesh_color[f.mesh[k]][j] * (f.shade[k] / 255.0));
    }
    t.rgb.push_back(rgb);
  }
}

template <class V>
void json_array(std::string& out, const char* key, const V& v, bool last = false) {
  out += std::string("  \"") + key + "\": [";
  for (size_t i = 0; i < v.size(); ++i) out += (i ? ", " : "") + std::to_string(v[i]);
  out += last ? "]\n" : "],\n";
}

// Float32 values that read back exactly (%.9g), for the line points.
void json_floats(std::string& out, const char* key, const std::vector<double>& v, bool last = false) {
  out += std::string("  \"") + key + "\": [";
  char buf[32];
  for (size_t i = 0; i < v.size(); ++i) {
    std::snprintf(buf, sizeof buf, "%.9g", v[i]);
    out += (i ? ", " : "") + std::string(buf);
  }
  out += last ? "]\n" : "],\n";
}

}  // namespace

namespace {

struct DecodeArgs {
  std::string out, sources;
  std::vector<std::string> paths;
  bool json = false;
};

DecodeArgs parse_decode(int argc, char** argv) {
  DecodeArgs a;
  for (int i = 2; i < argc; ++i) {
    const std::string f = argv[i];
    if (f == "-o" || f == "--output") {
      if (i + 1 >= argc) throw UsageError(f + " needs a value");
      a.out = argv[++i];
    } else if (f == "--json") {
      a.json = true;
    } else if (f == "--sources") {
      if (i + 1 >= argc) throw UsageError(f + " needs a value");
      a.sources = argv[++i];
    } else if (!f.empty() && f[0] == '-') {
      throw UsageError("unknown option " + f);
    } else {
      a.paths.push_back(f);
    }
  }
  if (a.paths.empty()) throw UsageError("decode: missing FRAME");
  return a;
}

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(InputErrorKind::FileNotFound, path, "", "", -1, "cannot open");
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// A delta sequence: each frame applies to the one before; the last is drawn. `bytes` and `path`
// end as the last frame's (the summary's and an error's).
void decode_delta(const DecodeArgs& a, std::string& bytes, std::string& path, Triangles& t,
                  std::string& detail) {
  DeltaDecoder decoder;
  if (!a.sources.empty()) decoder.hold_scene(read_file(a.sources));
  DeltaFrame d;
  for (size_t i = 0; i < a.paths.size(); ++i) {
    path = a.paths[i];
    if (i > 0) bytes = read_file(path);
    d = decoder.decode(bytes);
    if (i + 1 < a.paths.size())
      std::printf(
          "{\"format\": \"delta\", \"frame\": %u, \"keyframe\": %s, \"triangles\": "
          "%zu, \"bytes\": %zu}\n",
          d.index, d.keyframe ? "true" : "false", d.triangle_count(), bytes.size());
  }
  t.format = "delta";
  t.version = d.version, t.width = d.width, t.height = d.height, t.quantum = d.quantum;
  t.vertices = d.xy.size() / 2;
  t.shaded = true;
  add_grid_triangles(t, d);
  if (a.json) {
    json_array(detail, "xy", d.xy);
    json_array(detail, "indices", d.indices);
    json_array(detail, "source", d.source);
    json_array(detail, "mesh", d.mesh);
    json_array(detail, "shade", d.shade, true);
  }
}

void decode_compact(const std::string& bytes, bool json, Triangles& t, std::string& detail) {
  const CompactFrame c = read_compact(bytes);
  t.format = "compact";
  t.version = c.version, t.width = c.width, t.height = c.height, t.quantum = c.quantum;
  t.vertices = c.vertex_count();
  t.shaded = !c.shade.empty();
  add_grid_triangles(t, c);
  if (json) {
    json_array(detail, "xy", c.xy);
    json_array(detail, "indices", c.indices);
    json_array(detail, "source", c.source);
    json_array(detail, "mesh", c.mesh);
    json_array(detail, "mesh_base", c.mesh_base);
    json_array(detail, "shade", c.shade, true);
  }
}

void decode_bin(const std::string& bytes, bool json, Triangles& t, std::string& detail) {
  const BinFrame b = read_bin(bytes);
  t.format = "bin";
  t.version = b.version, t.width = b.width, t.height = b.height;
  t.vertices = 3 * b.triangle_count();
  t.xy.assign(b.xy.begin(), b.xy.end());
  t.source = b.triangle_id;
  for (uint32_t id : b.triangle_id) t.rgb.push_back((id + 1) & 0xFFFFFF);
  if (b.has_lines) {
    t.line_chains = b.lines.chain_count();
    t.line_points = b.lines.xy.size() / 2;
  }
  if (!json) return;
  json_array(detail, "xy", b.xy);
  json_array(detail, "mesh", b.mesh);
  json_array(detail, "triangle_id", b.triangle_id, !b.has_lines);
  if (b.has_lines) {  // FORMAT.md "Lines": chain_end, chain_info words, the points
    const LineSet& L = b.lines;
    std::vector<uint32_t> info(L.chain_count());
    for (size_t c = 0; c < info.size(); ++c)
      info[c] = uint32_t(L.kind[c]) | uint32_t(L.closed[c]) << 8 | uint32_t(L.hidden[c]) << 9;
    json_array(detail, "chain_end", std::vector<uint32_t>(L.off.begin() + 1, L.off.end()));
    json_array(detail, "chain_info", info);
    json_floats(detail, "line_xy", L.xy, true);
  }
}

// The decoded triangles as SVG: one path per fill colour (a path is filled as one shape: no
// seams between its triangles).
std::string decoded_svg(const Triangles& t) {
  std::map<uint32_t, std::string> paths;
  for (size_t k = 0; k < t.source.size(); ++k) {
    std::string& d = paths[t.rgb[k]];
    const double* p = &t.xy[6 * k];
    d += "M" + number(p[0]) + " " + number(p[1]) + "L" + number(p[2]) + " " + number(p[3]) + " " +
         number(p[4]) + " " + number(p[5]) + "Z";
  }
  std::string svg =
      "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<svg xmlns=\"http://www.w3.org/2000/svg\" "
      "width=\"" +
      std::to_string(t.width) + "\" height=\"" + std::to_string(t.height) + "\" viewBox=\"0 0 " +
      std::to_string(t.width) + " " + std::to_string(t.height) + "\"" +
      (t.shaded ? "" : " shape-rendering=\"crispEdges\"") + ">\n";
  char col[8];
  for (const auto& [rgb, d] : paths) {
    std::snprintf(col, sizeof col, "#%06x", rgb);
    // Shaded: a hairline stroke in the fill colour hides the seams antialiasing leaves
    // between paths of neighbouring colours (the outline grows by 0.2 px).
    svg += std::string("<path fill=\"") + col + "\" " +
           (t.shaded ? std::string("stroke=\"") + col + "\" stroke-width=\".4\" " : "") + "d=\"" +
           d + "\"/>\n";
  }
  return svg + "</svg>\n";
}

}  // namespace

// Per frame file its format by magic, its reader, then the SVG and the summary line (with every
// array under --json).
int cmd_decode(int argc, char** argv) {
  const DecodeArgs a = parse_decode(argc, argv);
  std::string bytes = read_file(a.paths[0]);
  std::string path = a.paths[0];
  // A delta sequence (version 2's may hold compact frames, and start from the held scene).
  const bool delta = (bytes.size() >= 4 && std::memcmp(bytes.data(), "VMDF", 4) == 0) ||
                     a.paths.size() > 1 || !a.sources.empty();
  const Clock::time_point t0 = Clock::now();
  Triangles t;
  std::string detail;
  try {
    if (delta)
      decode_delta(a, bytes, path, t, detail);
    else if (bytes.size() >= 4 && std::memcmp(bytes.data(), "VMCF", 4) == 0)
      decode_compact(bytes, a.json, t, detail);
    else
      decode_bin(bytes, a.json, t, detail);
  } catch (const InputError& e) {  // name the file, keep the frame's own words
    throw InputError(e.kind(), path, "", e.element(), e.index(), e.detail());
  }
  const double ms = ms_since(t0);
  if (!a.out.empty()) write_atomically(a.out, decoded_svg(t));
  std::printf(
      "{\"format\": \"%s\", \"version\": %u, \"width\": %u, \"height\": %u, "
      "\"quantum\": %u, \"vertices\": %zu, \"triangles\": %zu, \"bytes\": %zu",
      t.format.c_str(), t.version, t.width, t.height, t.quantum, t.vertices, t.source.size(),
      bytes.size());
  if (t.line_chains >= 0)
    std::printf(", \"line_chains\": %lld, \"line_points\": %lld", (long long)t.line_chains,
                (long long)t.line_points);
  if (a.json)  // every array, one per line (the test vectors' expected values; no timing)
    std::printf(",\n%s}\n", detail.c_str());
  else
    std::printf(", \"decode_ms\": %.3f}\n", ms);
  return 0;
}

}  // namespace vismap::cli
