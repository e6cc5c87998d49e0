// Per-mesh facts the pipeline needs once per scene: is the mesh a closed, consistently oriented
// surface (so back faces can be culled when the camera is outside it), and which way it faces.
#pragma once

#include <cstdint>

#include "core/scene.h"

namespace vismap {

// +1: closed, consistently oriented, and every closed component (triangles joined through
// shared edges) of positive signed volume (faces point outward); -1: all of negative volume
// (faces point inward); 0: not closed, or components facing opposite ways (or flat).
// Vertices are matched by position, so soup and split-vertex meshes are judged by their shape.
int8_t closed_orientation(const Mesh& m);

}  // namespace vismap
