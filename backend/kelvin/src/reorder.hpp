#pragma once
#include "distlab/kelvin/tet_mesh.hpp"

namespace distlab::kelvin {

// Renumbers vertices and cells along a Morton curve (same mesh, same orientation and neighbour
// convention; deterministic).
void reorder_spatially(TetMesh& mesh);

}  // namespace distlab::kelvin
