// Writes the dense penetrating soup of tests/support/soup.h as an OBJ, for bench/soup.sh:
//   make_soup N OUT.obj [--size S] [--seed K]
#include <cstdio>
#include <cstdlib>
#include <string>

#include "tests/support/soup.h"

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: make_soup N OUT.obj [--size S] [--seed K]\n");
    return 2;
  }
  const uint32_t n = uint32_t(std::stoul(argv[1]));
  double size = 0.2;
  uint64_t seed = 1;
  for (int i = 3; i + 1 < argc; i += 2) {
    const std::string f = argv[i];
    if (f == "--size")
      size = std::stod(argv[i + 1]);
    else if (f == "--seed")
      seed = std::stoull(argv[i + 1]);
    else
      return 2;
  }
  const vismap::Scene s = vismap::test_support::penetrating_soup(n, size, seed);
  FILE* f = std::fopen(argv[2], "w");
  if (!f) return 1;
  const vismap::Mesh& m = s.meshes[0];
  std::fprintf(f, "# %u random triangles of size %g in the unit cube, seed %llu\n", n, size,
               static_cast<unsigned long long>(seed));
  for (size_t v = 0; v < m.vertex_count(); ++v)
    std::fprintf(f, "v %.9g %.9g %.9g\n", m.positions[3 * v], m.positions[3 * v + 1],
                 m.positions[3 * v + 2]);
  for (size_t t = 0; t < m.triangle_count(); ++t)
    std::fprintf(f, "f %u %u %u\n", m.indices[3 * t] + 1, m.indices[3 * t + 1] + 1,
                 m.indices[3 * t + 2] + 1);
  return std::fclose(f) == 0 ? 0 : 1;
}
