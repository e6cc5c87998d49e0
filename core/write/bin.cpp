// Binary triangle list, version 1 (proto/FORMAT.md): a 24-byte header, then struct-of-arrays
// sections, all little-endian 4-byte values. Fragments are fanned from their first vertex.
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <string>

#include "core/error.h"
#include "core/util/bytes.h"
#include "core/write/output.h"
#include "core/write/shared.h"

namespace vismap {

namespace {

constexpr char kMagic[4] = {'V', 'M', 'A', 'P'};
constexpr uint32_t kVersion = 1;
constexpr uint32_t kFlagAttributes = 1;
constexpr uint32_t kFlagLines = 2;
// A chain's info word: bits 0-7 its LineKind, bit 8 closed, bit 9 hidden.
constexpr uint32_t kInfoClosed = 1u << 8, kInfoHidden = 1u << 9;
constexpr size_t kHeaderBytes = 24;
// Bytes per triangle: positions 6 floats, mesh and id 2 uint32; attributes 9 + 3 floats.
constexpr uint64_t kTriangleBytes = 6 * 4 + 4 + 4;
constexpr uint64_t kAttributeBytes = 9 * 4 + 3 * 4;

static_assert(sizeof(float) == 4 && std::numeric_limits<float>::is_iec559, "IEEE float32 needed");

using le::get_f32;
using le::get_u32;
using le::put_f32;
using le::put_u32;

[[noreturn]] void malformed(InputErrorKind kind, const std::string& element, int64_t index,
                            const std::string& msg) {
  throw InputError(kind, "binary frame", "", element, index, msg);
}

}  // namespace

std::string write_bin(const PlanarMap& map, const Scene& scene) {
  return write_bin(map, scene, nullptr, true);
}

std::string write_bin(const PlanarMap& map, const Scene& scene, const LineSet* lines,
                      bool triangles) {
  detail::check_map(map, scene, "binary writer");
  const size_t nf = map.fragment_count();
  const bool attrs = !map.bary.empty();
  const std::vector<uint64_t> base = scene.triangle_id_base();

  uint64_t tris = 0;
  for (size_t f = 0; triangles && f < nf; ++f) {
    const uint32_t n = map.offsets[f + 1] - map.offsets[f];
    if (n >= 3) tris += n - 2;
  }
  if (tris > 0xFFFFFFFFull)
    throw InputError(InputErrorKind::TooLarge, "binary writer", "", "planar map", -1,
                     std::to_string(tris) + " triangles exceed the format's 32-bit count");
  const uint64_t t = tris;
  const uint64_t chains = lines ? lines->chain_count() : 0, points = lines ? lines->xy.size() / 2 : 0;
  if (chains > 0xFFFFFFFFull || points > 0xFFFFFFFFull)
    throw InputError(InputErrorKind::TooLarge, "binary writer", "", "lines", -1,
                     "more chains or points than the format's 32-bit counts");
  const uint64_t tri_end = kHeaderBytes + t * (kTriangleBytes + (attrs ? kAttributeBytes : 0));
  std::string out(tri_end + (lines ? 8 + 8 * chains + 8 * points : 0), '\0');
  char* p = out.data();
  std::memcpy(p, kMagic, 4);
  put_u32(p + 4, kVersion);
  put_u32(p + 8, map.width);
  put_u32(p + 12, map.height);
  put_u32(p + 16, (attrs ? kFlagAttributes : 0) | (lines ? kFlagLines : 0));
  put_u32(p + 20, uint32_t(t));
  char* pos = p + kHeaderBytes;
  char* mesh = pos + 24 * t;
  char* ids = mesh + 4 * t;
  char* bary = ids + 4 * t;
  char* inv_w = bary + 36 * t;

  if (lines) {
    char* q = p + tri_end;
    put_u32(q, uint32_t(chains));
    put_u32(q + 4, uint32_t(points));
    char* ends = q + 8;
    char* info = ends + 4 * chains;
    char* xy = info + 4 * chains;
    for (uint64_t c = 0; c < chains; ++c) {
      put_u32(ends + 4 * c, lines->off[c + 1]);
      put_u32(info + 4 * c, uint32_t(lines->kind[c]) | (lines->closed[c] ? kInfoClosed : 0) |
                                (lines->hidden[c] ? kInfoHidden : 0));
    }
    for (uint64_t i = 0; i < 2 * points; ++i) put_f32(xy + 4 * i, float(lines->xy[i]));
  }
  uint64_t k = 0;  // output triangle
  for (size_t f = 0; triangles && f < nf; ++f) {
    const uint32_t b = map.offsets[f], n = map.offsets[f + 1] - b;
    if (n < 3) continue;
    const uint64_t id = detail::global_triangle_id(map, scene, base, f);
    if (id > 0xFFFFFFFFull)
      throw InputError(InputErrorKind::TooLarge, "binary writer", scene.meshes[map.mesh[f]].name,
                       "fragment", int64_t(f),
                       "global triangle id " + std::to_string(id) + " exceeds 32 bits");
    for (uint32_t i = 1; i + 1 < n; ++i, ++k) {
      const uint32_t v[3] = {b, b + i, b + i + 1};
      for (int c = 0; c < 3; ++c) {
        put_f32(pos + 24 * k + 8 * c, float(map.xy[2 * size_t(v[c])]));
        put_f32(pos + 24 * k + 8 * c + 4, float(map.xy[2 * size_t(v[c]) + 1]));
        if (attrs) {
          for (int j = 0; j < 3; ++j)
            put_f32(bary + 36 * k + 12 * c + 4 * j, map.bary[3 * size_t(v[c]) + j]);
          put_f32(inv_w + 12 * k + 4 * c, map.inv_w[v[c]]);
        }
      }
      put_u32(mesh + 4 * k, map.mesh[f]);
      put_u32(ids + 4 * k, uint32_t(id));
    }
  }
  return out;
}

BinFrame read_bin(const std::string& bytes) {
  using K = InputErrorKind;
  const size_t size = bytes.size();
  if (size < kHeaderBytes)
    malformed(
        K::Truncated, "header", -1,
        std::to_string(size) + " bytes, the header alone needs " + std::to_string(kHeaderBytes));
  const char* p = bytes.data();
  if (std::memcmp(p, kMagic, 4) != 0) malformed(K::ParseError, "header", -1, "magic is not VMAP");
  BinFrame fr;
  fr.version = get_u32(p + 4);
  if (fr.version != kVersion)
    malformed(K::ParseError, "header", -1,
              "unsupported version " + std::to_string(fr.version) + " (this reader knows 1)");
  fr.width = get_u32(p + 8);
  fr.height = get_u32(p + 12);
  fr.flags = get_u32(p + 16);
  if (fr.flags & ~(kFlagAttributes | kFlagLines))
    malformed(K::ParseError, "header", -1, "unknown flags " + std::to_string(fr.flags));
  const uint64_t t = get_u32(p + 20);
  const bool attrs = fr.flags & kFlagAttributes;
  const uint64_t tri_end = kHeaderBytes + t * (kTriangleBytes + (attrs ? kAttributeBytes : 0));
  uint64_t need = tri_end;
  uint64_t chains = 0, points = 0;
  if ((fr.flags & kFlagLines) && size >= tri_end + 8) {
    chains = get_u32(p + tri_end);
    points = get_u32(p + tri_end + 4);
  }
  if (fr.flags & kFlagLines) need += 8 + 8 * chains + 8 * points;
  if (size < need && size >= tri_end)
    malformed(K::Truncated, "section", -1,
              "lines end at byte " + std::to_string(need) + " but the frame has " +
                  std::to_string(size) + " bytes");
  if (size < need) {
    // Name the section the bytes run out in.
    const char* names[] = {"positions", "mesh", "triangle_id", "bary", "inv_w"};
    const uint64_t ends[] = {kHeaderBytes + 24 * t, kHeaderBytes + 28 * t, kHeaderBytes + 32 * t,
                             kHeaderBytes + 68 * t, kHeaderBytes + 80 * t};
    int s = 0;
    while (ends[s] <= size) ++s;
    malformed(K::Truncated, "section", -1,
              std::string(names[s]) + " ends at byte " + std::to_string(ends[s]) +
                  " but the frame" + " has " + std::to_string(size) + " bytes (" +
                  std::to_string(t) + " triangles need " + std::to_string(need) + ")");
  }
  if (size > need)
    malformed(K::ParseError, "frame", -1,
              std::to_string(size - need) + " trailing bytes after " + std::to_string(t) +
                  " triangles" + (fr.flags & kFlagLines ? " and the lines" : "") + " (" +
                  std::to_string(need) + " bytes)");
  if (fr.flags & kFlagLines) {
    const char* ends = p + tri_end + 8;
    const char* info = ends + 4 * chains;
    const char* xy = info + 4 * chains;
    fr.has_lines = true;
    LineSet& L = fr.lines;
    for (uint64_t c = 0; c < chains; ++c) {
      const uint32_t end = get_u32(ends + 4 * c), w = get_u32(info + 4 * c);
      if (end <= L.off.back() || end > points)
        malformed(K::ParseError, "line chain", int64_t(c),
                  "chain end " + std::to_string(end) + " after " + std::to_string(L.off.back()) +
                      " (chains hold at least one point, " + std::to_string(points) + " in all)");
      if ((w & 0xFF) >= kLineKinds || (w & ~(0xFFu | kInfoClosed | kInfoHidden)))
        malformed(K::ParseError, "line chain", int64_t(c), "bad info word " + std::to_string(w));
      L.off.push_back(end);
      L.kind.push_back(LineKind(w & 0xFF));
      L.closed.push_back((w & kInfoClosed) != 0);
      L.hidden.push_back((w & kInfoHidden) != 0);
    }
    if (L.off.back() != points)
      malformed(K::ParseError, "lines", -1,
                "chains end at point " + std::to_string(L.off.back()) + " of " +
                    std::to_string(points));
    L.xy.resize(2 * points);
    for (uint64_t i = 0; i < 2 * points; ++i) {
      L.xy[i] = get_f32(xy + 4 * i);
      if (!std::isfinite(L.xy[i]))
        malformed(K::ParseError, "line point", int64_t(i / 2), "non-finite position");
    }
  }

  const char* pos = p + kHeaderBytes;
  const char* mesh = pos + 24 * t;
  const char* ids = mesh + 4 * t;
  const char* bary = ids + 4 * t;
  const char* inv_w = bary + 36 * t;
  fr.xy.resize(6 * t);
  fr.mesh.resize(t);
  fr.triangle_id.resize(t);
  for (uint64_t i = 0; i < 6 * t; ++i) {
    fr.xy[i] = get_f32(pos + 4 * i);
    if (!std::isfinite(fr.xy[i]))
      malformed(K::ParseError, "triangle", int64_t(i / 6), "non-finite position");
  }
  for (uint64_t i = 0; i < t; ++i) {
    fr.mesh[i] = get_u32(mesh + 4 * i);
    fr.triangle_id[i] = get_u32(ids + 4 * i);
  }
  if (attrs) {
    fr.bary.resize(9 * t);
    fr.inv_w.resize(3 * t);
    for (uint64_t i = 0; i < 9 * t; ++i) {
      fr.bary[i] = get_f32(bary + 4 * i);
      if (!std::isfinite(fr.bary[i]))
        malformed(K::ParseError, "triangle", int64_t(i / 9), "non-finite barycentric");
    }
    for (uint64_t i = 0; i < 3 * t; ++i) {
      fr.inv_w[i] = get_f32(inv_w + 4 * i);
      if (!(fr.inv_w[i] > 0) || !std::isfinite(fr.inv_w[i]))
        malformed(K::ParseError, "triangle", int64_t(i / 3), "1/w must be positive and finite");
    }
  }
  return fr;
}

}  // namespace vismap
