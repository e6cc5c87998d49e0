// Implicit objects (issue 19, docs/IMPLICIT.md): a .sexp file, or a scene file's "expression" or
// .sexp entry, becomes one Mesh holding the parsed tape and its box; Renderer::tessellate turns
// it into triangles for each camera (core/surfaces/implicit3d.cpp).
#include <memory>

#include "core/implicit/implicit.h"
#include "core/load/internal.h"

namespace vismap::detail {

Mesh implicit_object(const Source& src, std::string_view text, const std::string& name,
                     const std::optional<std::array<double, 6>>& bounds) {
  Mesh m;
  m.name = name;
  auto tape = std::make_shared<implicit::Tape>(implicit::parse(std::string(text), src.file));
  if (bounds) {
    for (int k = 0; k < 3; ++k)
      if (!((*bounds)[k] < (*bounds)[k + 3]))
        fail(InputErrorKind::BadScene, src, name, "bounds", -1,
             "each low bound must be below its high bound");
    m.implicit_box = *bounds;
  } else {
    // Without bounds the solid's box is searched for (f < 0 in [-1024, 1024]^3); an unbounded
    // solid is BadScene naming the file.
    m.implicit_box = implicit::find_bounds(*tape, src.file);
  }
  m.implicit = std::move(tape);
  m.source_triangles = 1;  // until diced: one object
  return m;
}

Scene read_sexp(const Source& src, std::string_view bytes, const LoadOptions&) {
  Scene s;
  s.source = src.file;
  s.meshes.push_back(implicit_object(src, bytes, file_stem(src.file), std::nullopt));
  return s;
}

}  // namespace vismap::detail
