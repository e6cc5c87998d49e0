#include "core/error.h"
#include "core/stages/tessellate.h"

namespace vismap::stages {

struct LoopPlan {};

Mesh dice_subdivision(ClRuntime&, const Mesh& mesh, const Camera&, const TessellateOptions&,
                      LoopPlans&, TessellateStats&) {
  throw InputError(InputErrorKind::BadScene, "", mesh.name, "", -1,
                   "Loop subdivision surfaces are not diced yet (issue 18)");
}

}  // namespace vismap::stages
