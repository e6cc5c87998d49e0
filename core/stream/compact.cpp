// The compact frame encoding, version 1 (proto/COMPACT.md): write_compact and read_compact.
#include "core/stream/compact.h"

#include <meshoptimizer.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>

#include "core/error.h"
#include "core/stream/frame_io.h"
#include "core/util/conform.h"
#include "core/util/flat_map.h"
#include "core/write/shared.h"

namespace vismap {

namespace {

using frame_io::get_u32;
using frame_io::put_u32;
using frame_io::put_varint;
using frame_io::zigzag;

constexpr char kMagic[4] = {'V', 'M', 'C', 'F'};
constexpr uint32_t kVersion = 1;
constexpr size_t kHeaderBytes = 44;
constexpr size_t kMeshBytes = 16;  // u32 first global id, 3 x f32 linear RGB
constexpr uint32_t kMaxTriangles = 1u << 28;
// A payload may be at most this many times its compressed size: zstd over meshoptimizer's
// output gains 1-3x, so this only stops a small message from asking for gigabytes.
constexpr uint64_t kMaxRatio = 256;

[[noreturn]] void malformed(InputErrorKind kind, const std::string& element, int64_t index,
                            const std::string& msg) {
  throw InputError(kind, "compact frame", "", element, index, msg);
}

// Reads the payload's sections in order; every read is bounds-checked.
struct Reader {
  const char* p;
  size_t n, at = 0;
  const char* take(size_t k, const char* section) {
    if (k > n - at) malformed(InputErrorKind::Truncated, section, -1, "payload ends inside it");
    const char* r = p + at;
    at += k;
    return r;
  }
  uint32_t u32(const char* section) { return get_u32(take(4, section)); }
};

uint64_t get_varint(const unsigned char*& p, const unsigned char* end, const char* section) {
  uint64_t v = 0;
  for (int shift = 0; shift < 64; shift += 7) {
    if (p == end) malformed(InputErrorKind::Truncated, section, -1, "ends inside a number");
    const unsigned char b = *p++;
    v |= uint64_t(b & 0x7F) << shift;
    if (!(b & 0x80)) return v;
  }
  malformed(InputErrorKind::ParseError, section, -1, "a number longer than 64 bits");
}

// The walk both sides make over the decoded triangles (proto/COMPACT.md, "Prediction"): in
// triangle order, each vertex at its first appearance gets a predicted position from vertices
// placed before it (parallelogram across an earlier triangle's edge, else an edge's midpoint,
// else a neighbour, else the last placed vertex), and each triangle a predicting earlier
// triangle (the first that shares one of its edges, else the one before it). `place(v, px, py)`
// must leave pos[2v], pos[2v+1] set; `triangle(t, pred)` gets pred = -1 for none.
template <class Place, class Triangle>
void walk_mesh(const uint32_t* idx, size_t nt, std::vector<int32_t>& pos,
               std::vector<uint8_t>& placed, Place&& place, Triangle&& triangle) {
  // Directed edge (a, b) -> 3 * triangle + its corner at a (the opposite corner follows b).
  FlatMap edges(3 * nt);
  auto key = [](uint32_t a, uint32_t b) { return uint64_t(a) << 32 | b; };
  int64_t last = -1;  // last placed vertex
  for (size_t t = 0; t < nt; ++t) {
    const uint32_t* c = idx + 3 * t;
    for (int k = 0; k < 3; ++k) {
      const uint32_t v = c[k];
      if (placed[v]) continue;
      const uint32_t p = c[(k + 1) % 3], q = c[(k + 2) % 3];
      int64_t px = 0, py = 0;
      if (placed[p] && placed[q]) {
        const uint32_t* e = edges.find(key(q, p));
        const uint32_t o = e ? idx[*e - *e % 3 + (*e + 2) % 3] : 0;
        if (e && placed[o]) {
          px = int64_t(pos[2 * p]) + pos[2 * q] - pos[2 * o];
          py = int64_t(pos[2 * p + 1]) + pos[2 * q + 1] - pos[2 * o + 1];
        } else {
          px = (int64_t(pos[2 * p]) + pos[2 * q]) >> 1;
          py = (int64_t(pos[2 * p + 1]) + pos[2 * q + 1]) >> 1;
        }
      } else if (placed[p] || placed[q]) {
        const uint32_t n = placed[p] ? p : q;
        px = pos[2 * n], py = pos[2 * n + 1];
      } else if (last >= 0) {
        px = pos[2 * last], py = pos[2 * last + 1];
      }
      place(v, px, py);
      placed[v] = 1;
      last = v;
    }
    int64_t pred = t > 0 ? int64_t(t) - 1 : -1;
    for (int k = 0; k < 3; ++k) {
      if (const uint32_t* e = edges.find(key(c[(k + 1) % 3], c[k]))) {
        pred = *e / 3;
        break;
      }
    }
    triangle(t, pred);
    for (int k = 0; k < 3; ++k) edges.emplace(key(c[k], c[(k + 1) % 3]), uint32_t(3 * t + k));
  }
}

// A residual a reader adds to a prediction: at most 2^40 in size, so no sum overflows.
int64_t small(uint64_t z, const char* what) {
  if (z > (uint64_t(1) << 41))
    throw InputError(InputErrorKind::ParseError, "compact frame", "", what, -1,
                     "a number out of range");
  return z & 1 ? ~int64_t(z >> 1) : int64_t(z >> 1);
}

}  // namespace

std::string write_compact(const PlanarMap& map, const Scene& scene, const Camera& camera,
                          const CompactOptions& options, CompactStats* stats) {
  // Long on purpose (~120 lines): the conforming mesh, the codec's order, then COMPACT.md's
  // sections in order, a few lines each.
  detail::check_map(map, scene, "compact writer");
  const bool zstd = options.compression == Compression::Zstd;
  if (!zstd && options.compression != Compression::Deflate)
    throw InputError(InputErrorKind::BadCamera, "compact writer", "", "compression", -1,
                     "must be zstd or deflate");
  const int level = options.level ? options.level : zstd ? 3 : 6;
  if (level < 1 || level > (zstd ? 19 : 9))
    throw InputError(
        InputErrorKind::BadCamera, "compact writer", "", "level", -1,
        "must be 1 ... " + std::to_string(zstd ? 19 : 9) + ", got " + std::to_string(level));
  const GridMesh g = conform_to_grid(map, options.quantum);
  const size_t nt = g.triangle_count(), nv = g.vertex_count();
  if (nt > kMaxTriangles)
    throw InputError(InputErrorKind::TooLarge, "compact writer", "", "planar map", -1,
                     std::to_string(nt) + " triangles exceed the format's 2^28");
  const std::vector<uint64_t> base = scene.triangle_id_base();

  // Triangles in vertex-cache order, vertices numbered by first use: what the index codec codes
  // in the fewest bytes. (Source ids sorted would cost ~6 KB for the bunny instead of ~40, but
  // connectivity in that order costs ~130 KB instead of ~35: docs/STREAMING.md.)
  std::vector<uint32_t> idx(3 * nt);
  meshopt_optimizeVertexCache(idx.data(), g.tri.data(), idx.size(), nv);
  std::vector<uint32_t> remap(nv);
  const size_t used = meshopt_optimizeVertexFetchRemap(remap.data(), idx.data(), idx.size(), nv);
  for (uint32_t& i : idx) i = remap[i];
  std::vector<int32_t> pos(2 * used);
  for (size_t v = 0; v < nv; ++v)
    if (remap[v] != ~0u) {
      pos[2 * remap[v]] = g.xy[2 * v];
      pos[2 * remap[v] + 1] = g.xy[2 * v + 1];
    }
  meshopt_encodeIndexVersion(1);
  std::string isec(meshopt_encodeIndexBufferBound(idx.size(), used), '\0');
  isec.resize(meshopt_encodeIndexBuffer(reinterpret_cast<unsigned char*>(isec.data()), isec.size(),
                                        idx.data(), idx.size()));
  // The codec may rotate a triangle's corners: predictions follow the order the decoder sees.
  std::vector<uint32_t> dec(idx.size());
  if (meshopt_decodeIndexBuffer(dec.data(), dec.size(), 4,
                                reinterpret_cast<const unsigned char*>(isec.data()), isec.size()))
    throw std::runtime_error("compact writer: the index codec did not decode its own output");

  // Each triangle's source: find its fragment through the codec's reordering. The triangle set
  // is unchanged, so a triangle is found by its corners (rotated so the smallest is first).
  // Both lists sorted by their corners (rotated so the smallest is first) pair them up.
  struct Corners {
    uint32_t a, b, c, t;
    bool operator<(const Corners& o) const {
      return a != o.a ? a < o.a : b != o.b ? b < o.b : c != o.c ? c < o.c : t < o.t;
    }
  };
  auto corners = [](const uint32_t* c, uint32_t t) {
    const int r = c[0] < c[1] ? (c[0] < c[2] ? 0 : 2) : (c[1] < c[2] ? 1 : 2);
    return Corners{c[r], c[(r + 1) % 3], c[(r + 2) % 3], t};
  };
  std::vector<Corners> from(nt), to(nt);
  for (uint32_t t = 0; t < nt; ++t) {
    const uint32_t r[3] = {remap[g.tri[3 * t]], remap[g.tri[3 * t + 1]], remap[g.tri[3 * t + 2]]};
    from[t] = corners(r, t);
    to[t] = corners(&dec[3 * t], t);
  }
  std::sort(from.begin(), from.end());
  std::sort(to.begin(), to.end());
  std::vector<uint32_t> source(nt), fragment(nt);
  for (size_t k = 0; k < nt; ++k) {
    if (from[k].a != to[k].a || from[k].b != to[k].b || from[k].c != to[k].c)
      throw std::runtime_error("compact writer: the index codec changed a triangle");
    fragment[to[k].t] = g.fragment[from[k].t];
  }
  for (size_t t = 0; t < nt; ++t)
    source[t] = uint32_t(detail::global_triangle_id(map, scene, base, fragment[t]));
  std::vector<uint8_t> shade_of(options.shade ? nt : 0);
  for (size_t t = 0; t < shade_of.size(); ++t) {
    const uint32_t f = fragment[t];
    const double k = detail::lambert_shade(scene, camera, map.mesh[f], map.triangle[f]);
    shade_of[t] = uint8_t(std::clamp<long>(std::lround(k * 255.0), 0, 255));
  }

  std::string vsec, ids, shades;
  std::vector<uint8_t> placed(used, 0);
  walk_mesh(
      dec.data(), nt, pos, placed,
      [&](uint32_t v, int64_t px, int64_t py) {
        put_varint(vsec, zigzag(pos[2 * v] - px));
        put_varint(vsec, zigzag(pos[2 * v + 1] - py));
      },
      [&](size_t t, int64_t pred) {
        put_varint(ids, zigzag(int64_t(source[t]) - (pred >= 0 ? int64_t(source[pred]) : 0)));
        if (options.shade) shades += char(uint8_t(shade_of[t] - (pred >= 0 ? shade_of[pred] : 0)));
      });
  const bool shade = options.shade;

  std::string payload;
  for (size_t m = 0; m < scene.meshes.size(); ++m) {
    put_u32(payload, uint32_t(base[m]));
    for (int c = 0; c < 3; ++c) put_u32(payload, std::bit_cast<uint32_t>(scene.meshes[m].color[c]));
  }
  for (const std::string* s : {&vsec, &isec, &ids, &shades}) put_u32(payload, uint32_t(s->size()));
  payload += vsec;
  payload += isec;
  payload += ids;
  payload += shades;

  std::string out;
  out.append(kMagic, 4);
  for (uint32_t v : {kVersion, map.width, map.height, shade ? kCompactShade : 0u, options.quantum,
                     uint32_t(used), uint32_t(nt), uint32_t(scene.meshes.size()),
                     uint32_t(options.compression), uint32_t(payload.size())})
    put_u32(out, v);
  out += frame_io::compress(payload, options.compression, level, "compact writer");
  if (stats) {
    stats->vertices = used;
    stats->triangles = nt;
    stats->t_junctions = g.t_junctions;
    stats->dropped = g.dropped;
    stats->vertex_bytes = vsec.size();
    stats->index_bytes = isec.size();
    stats->id_bytes = ids.size();
    stats->shade_bytes = shades.size();
  }
  return out;
}

CompactFrame read_compact(const std::string& bytes) {
  // Long on purpose (~125 lines): the header and then COMPACT.md's sections in order, a few lines
  // each, every check naming its section.
  if (bytes.size() < kHeaderBytes)
    malformed(InputErrorKind::Truncated, "header", -1,
              std::to_string(bytes.size()) + " bytes, the header alone is 44");
  if (std::memcmp(bytes.data(), kMagic, 4) != 0)
    malformed(InputErrorKind::ParseError, "header", -1, "magic is not VMCF");
  CompactFrame f;
  const char* h = bytes.data();
  f.version = get_u32(h + 4);
  if (f.version != kVersion)
    malformed(InputErrorKind::ParseError, "header", -1,
              "version " + std::to_string(f.version) + " (this reader knows 1)");
  f.width = get_u32(h + 8);
  f.height = get_u32(h + 12);
  f.flags = get_u32(h + 16);
  f.quantum = get_u32(h + 20);
  const uint32_t nv = get_u32(h + 24), nt = get_u32(h + 28), nm = get_u32(h + 32);
  const uint32_t codec = get_u32(h + 36);
  const uint64_t payload_bytes = get_u32(h + 40);
  if (codec != uint32_t(Compression::Zstd) && codec != uint32_t(Compression::Deflate))
    malformed(InputErrorKind::ParseError, "header", -1,
              "unknown compression " + std::to_string(codec));
  f.compression = Compression(codec);
  if (f.flags & ~kCompactShade)
    malformed(InputErrorKind::ParseError, "header", -1, "unknown flag bits");
  if (f.width < 1 || f.height < 1 || f.width > 65536 || f.height > 65536)
    malformed(InputErrorKind::ParseError, "header", -1, "viewport out of range");
  if (f.quantum < kMinQuantum || f.quantum > kMaxQuantum)
    malformed(InputErrorKind::ParseError, "header", -1, "quantum out of " + quantum_range_text());
  if (uint64_t(f.width) * f.quantum >= (1u << 31) || uint64_t(f.height) * f.quantum >= (1u << 31))
    malformed(InputErrorKind::ParseError, "header", -1, "viewport times quantum over 2^31");
  if (nt > kMaxTriangles || nv > 3ull * nt || (nt > 0 && nv < 3) || nm == 0 || nm > (1u << 24))
    malformed(InputErrorKind::ParseError, "header", -1, "counts out of range");
  const size_t zbytes = bytes.size() - kHeaderBytes;
  if (payload_bytes > kMaxRatio * zbytes + 4096)
    malformed(InputErrorKind::ParseError, "header", -1, "payload size out of proportion");
  std::string payload(payload_bytes, '\0');
  if (const std::string why =
          frame_io::decompress(h + kHeaderBytes, zbytes, f.compression, payload);
      !why.empty())
    malformed(InputErrorKind::ParseError, "payload", -1, why);

  // Every count is checked against the bytes that must hold it before anything is sized from it:
  // a 2 KB frame claiming 2^28 triangles had allocated 3 GB (issue 35, case 8).
  if (uint64_t(nm) * 16 > payload.size())
    malformed(InputErrorKind::Truncated, "mesh table", -1,
              std::to_string(nm) + " meshes need " + std::to_string(uint64_t(nm) * 16) +
                  " bytes, the payload has " + std::to_string(payload.size()));
  Reader r{payload.data(), payload.size()};
  f.mesh_base.resize(nm);
  f.mesh_color.resize(nm);
  for (uint32_t m = 0; m < nm; ++m) {
    f.mesh_base[m] = r.u32("mesh table");
    if (m > 0 && f.mesh_base[m] < f.mesh_base[m - 1])
      malformed(InputErrorKind::ParseError, "mesh", m, "first ids not ascending");
    for (int c = 0; c < 3; ++c) {
      const float v = std::bit_cast<float>(r.u32("mesh table"));
      if (!(v >= 0 && v <= 1))
        malformed(InputErrorKind::ParseError, "mesh", m, "color not in [0,1]");
      f.mesh_color[m][c] = v;
    }
  }
  uint32_t size[4];
  for (uint32_t& s : size) s = r.u32("section sizes");
  const char* vsec = r.take(size[0], "positions");
  const char* isec = r.take(size[1], "indices");
  const char* idsec = r.take(size[2], "ids");
  const char* ssec = r.take(size[3], "shades");
  if (r.at != r.n) malformed(InputErrorKind::ParseError, "payload", -1, "trailing bytes");
  // The index codec takes at least a byte per triangle, the ids a varint per triangle, the
  // positions two varints per vertex.
  if (size[1] < nt || size[2] < nt)
    malformed(InputErrorKind::ParseError, size[1] < nt ? "indices" : "ids", -1,
              "fewer bytes than the header's " + std::to_string(nt) + " triangles need");
  if (size[0] < 2ull * nv)
    malformed(InputErrorKind::ParseError, "positions", -1,
              "fewer bytes than the header's " + std::to_string(nv) + " vertices need");
  const bool shade = f.flags & kCompactShade;
  if (size[3] != (shade ? nt : 0))
    malformed(InputErrorKind::ParseError, "shades", -1,
              shade ? "one byte per triangle expected" : "present without the shade flag");

  f.indices.resize(3 * size_t(nt));
  if (meshopt_decodeIndexBuffer(f.indices.data(), f.indices.size(), 4,
                                reinterpret_cast<const unsigned char*>(isec), size[1]) != 0)
    malformed(InputErrorKind::ParseError, "indices", -1, "meshoptimizer's index codec refused");
  for (size_t t = 0; t < nt; ++t)
    for (int c = 0; c < 3; ++c)
      if (f.indices[3 * t + c] >= nv)
        malformed(InputErrorKind::IndexOutOfRange, "triangle", int64_t(t), "vertex index");

  f.xy.assign(2 * size_t(nv), 0);
  f.source.resize(nt);
  f.mesh.resize(nt);
  if (shade) f.shade.resize(nt);
  std::vector<uint8_t> placed(nv, 0);
  const auto* vp = reinterpret_cast<const unsigned char*>(vsec);
  const auto* vend = vp + size[0];
  const auto* ip = reinterpret_cast<const unsigned char*>(idsec);
  const auto* iend = ip + size[2];
  const int64_t xmax = int64_t(f.width) * f.quantum, ymax = int64_t(f.height) * f.quantum;
  size_t placed_count = 0;
  uint32_t m = 0;
  walk_mesh(
      f.indices.data(), nt, f.xy, placed,
      [&](uint32_t v, int64_t px, int64_t py) {
        const int64_t x = px + small(get_varint(vp, vend, "positions"), "positions");
        const int64_t y = py + small(get_varint(vp, vend, "positions"), "positions");
        if (x < 0 || y < 0 || x > xmax || y > ymax)
          malformed(InputErrorKind::ParseError, "vertex", int64_t(v), "outside the viewport");
        f.xy[2 * v] = int32_t(x), f.xy[2 * v + 1] = int32_t(y);
        ++placed_count;
      },
      [&](size_t t, int64_t pred) {
        const int64_t id =
            (pred >= 0 ? int64_t(f.source[pred]) : 0) + small(get_varint(ip, iend, "ids"), "ids");
        if (id < int64_t(f.mesh_base[0]) || id > int64_t(UINT32_MAX))
          malformed(InputErrorKind::ParseError, "triangle", int64_t(t), "source id out of range");
        f.source[t] = uint32_t(id);
        // The mesh holding the id: the last whose first id is at most it.
        if (!(m < nm && f.mesh_base[m] <= uint64_t(id) &&
              (m + 1 == nm || f.mesh_base[m + 1] > uint64_t(id))))
          m = uint32_t(std::upper_bound(f.mesh_base.begin(), f.mesh_base.end(), uint64_t(id)) -
                       f.mesh_base.begin() - 1);
        f.mesh[t] = m;
        if (shade) f.shade[t] = uint8_t((pred >= 0 ? f.shade[pred] : 0) + uint8_t(ssec[t]));
      });
  if (placed_count != nv)
    malformed(InputErrorKind::ParseError, "indices", -1, "a vertex no triangle uses");
  if (vp != vend) malformed(InputErrorKind::ParseError, "positions", -1, "trailing bytes");
  if (ip != iend) malformed(InputErrorKind::ParseError, "ids", -1, "trailing bytes");
  for (size_t t = 0; t < nt; ++t) {
    const uint32_t* i = &f.indices[3 * t];
    if (orient2(&f.xy[2 * i[0]], &f.xy[2 * i[1]], &f.xy[2 * i[2]]) <= 0)
      malformed(InputErrorKind::ParseError, "triangle", int64_t(t), "not clockwise on screen");
  }
  return f;
}

PlanarMap to_planar_map(const CompactFrame& frame, const Scene& scene) {
  PlanarMap map;
  map.width = frame.width;
  map.height = frame.height;
  const std::vector<uint64_t> base = scene.triangle_id_base();
  if (frame.mesh_base.size() != scene.meshes.size() ||
      !std::equal(base.begin(), base.end(), frame.mesh_base.begin()))
    throw InputError(InputErrorKind::BadScene, "compact frame", "", "mesh table", -1,
                     "does not match the scene's meshes");
  const double s = 1.0 / frame.quantum;
  for (size_t t = 0; t < frame.triangle_count(); ++t) {
    for (int c = 0; c < 3; ++c) {
      const uint32_t v = frame.indices[3 * t + c];
      map.xy.push_back(frame.xy[2 * v] * s);
      map.xy.push_back(frame.xy[2 * v + 1] * s);
    }
    map.offsets.push_back(uint32_t(map.xy.size() / 2));
    const uint32_t m = frame.mesh[t];
    const std::vector<uint32_t>& ids = scene.meshes[m].face_ids;
    const uint64_t face = frame.source[t] - frame.mesh_base[m];
    const auto it = std::lower_bound(ids.begin(), ids.end(), face);
    if (it == ids.end() || *it != face)
      throw InputError(
          InputErrorKind::BadScene, "compact frame", scene.meshes[m].name, "triangle", int64_t(t),
          "source id " + std::to_string(frame.source[t]) + " is not a triangle of the scene");
    map.mesh.push_back(m);
    map.triangle.push_back(uint32_t(it - ids.begin()));
  }
  return map;
}

}  // namespace vismap
