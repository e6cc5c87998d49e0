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
  // The parse, the tape and the bounds search are the load's to hold and within its time limit
  // (issue 35, case 1: a 4 MB upload's search grew past 14 GB, and 10^5 small spheres held a
  // load thread 160 s).
  const auto check_time = [&src](const char* doing) {
    return [&src, doing] { src.budget->check_time(src.file, doing); };
  };
  auto tape = std::make_shared<implicit::Tape>(
      implicit::parse(std::string(text), src.file, check_time("the parse")));
  src.budget->charge(
      tape->clauses.size() * sizeof(implicit::Clause), src.file,
      "the expression's tape of " + std::to_string(tape->clauses.size()) + " clauses");
  if (bounds) {
    for (int k = 0; k < 3; ++k)
      if (!((*bounds)[k] < (*bounds)[k + 3]))
        fail(InputErrorKind::BadScene, src, name, "bounds", -1,
             "each low bound must be below its high bound");
    m.implicit_box = *bounds;
  } else {
    // Without bounds the solid's box is searched for (f < 0 in [-1024, 1024]^3); an unbounded
    // solid is BadScene naming the file.
    implicit::SearchLimits limits;
    limits.max_bytes = src.budget->left();
    limits.check_time = check_time("the bounds search");
    m.implicit_box = implicit::find_bounds(*tape, src.file, 1024, limits);
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
