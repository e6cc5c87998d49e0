#include "core/error.h"
#include "core/stages/tessellate.h"

namespace vismap::stages {

Mesh dice_patches(ClRuntime&, const Mesh& mesh, const Camera&, const TessellateOptions&,
                  TessellateStats&) {
  throw InputError(InputErrorKind::BadScene, "", mesh.name, "", -1,
                   "Bezier patches are not diced yet (issue 18)");
}

}  // namespace vismap::stages
