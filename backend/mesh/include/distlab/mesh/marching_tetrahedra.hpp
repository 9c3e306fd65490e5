#pragma once
// Marching tetrahedra: the piece of a level set inside one tetrahedron, from which of its corners
// lie inside the region. The one case split of the project: the Kelvin field's iso-surfaces
// (kelvin/isosurface.cpp) and the level sets of sampled grids (levelset/grid.cpp) both use it,
// each with its own crossing points and orientation.

namespace distlab::mesh {

// Emits the triangles of the level set in the tetrahedron with corners c[0..3] (the caller's ids),
// corner k inside the region when in[k]:
// - all inside or all outside: none;
// - one corner alone on its side: one triangle through the crossings of its three edges;
// - two and two: the quad of the four crossings as two triangles (a, b, e), (a, e, f).
// crossing(i, o): the output vertex on the edge from inside corner i to outside corner o, called
// in the order the vertices are listed above (corners in the order given); triangle(a, b, e): one
// triangle of output vertices (its orientation is the caller's to fix).
template <class Crossing, class Triangle>
void march_tetrahedron(const int (&c)[4], const bool (&in)[4], Crossing&& crossing, Triangle&& triangle) {
  int ins[4], outs[4], ni = 0, no = 0;
  for (int k = 0; k < 4; ++k) (in[k] ? ins[ni++] : outs[no++]) = c[k];
  if (ni == 0 || no == 0) return;
  if (ni == 1 || no == 1) {
    int v[3];
    for (int k = 0; k < 3; ++k) v[k] = ni == 1 ? crossing(ins[0], outs[k]) : crossing(ins[k], outs[0]);
    triangle(v[0], v[1], v[2]);
    return;
  }
  const int a = crossing(ins[0], outs[0]), b = crossing(ins[0], outs[1]);
  const int e = crossing(ins[1], outs[1]), f = crossing(ins[1], outs[0]);
  triangle(a, b, e);
  triangle(a, e, f);
}

}  // namespace distlab::mesh
