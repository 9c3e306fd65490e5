// Which repair an upload needs, from its defects and what each server option actually does
// (backend/mesh repair.cpp, simplify.cpp; kelvin_objects.cpp reshape_surface):
// - "fix" merges duplicate vertices, removes degenerate and repeated faces, stitches borders and
//   fills holes of at most its hole size (≤ max_hole_edges). It removes no intersection: sheets
//   touching at a vertex stay touching once split, a fin (a face on an edge of a closed surface)
//   stays in — the fixed surface is then refused as self-intersecting.
// - components "largest" keeps one piece: defects between pieces or in the others go with them.
// - "simplify" runs first, before any repair, and takes only a closed manifold surface.
// - "wrap" makes a new closed surface around anything (its own face count, from α).
import { holeSizes } from "./upload_defects";
import type { Defects } from "./object_source";

export interface Advice {
  /** The options to prepare with (the Repair folder's fields). */
  repair: "none" | "fix" | "wrap";
  holeEdges: number;
  components: "all" | "largest";
  simplify: number;
  /** Why, in the panel's words. */
  text: string;
}

interface Limits {
  max_hole_edges?: number;
  max_object_triangles?: number;
}

const n = (x: number) => x.toLocaleString("en");

/** The advice for an upload: `indices` are its faces (the file's vertex numbers, 3 a face) and
 *  `positions` its vertices (for faces repeated under other vertex numbers). */
export function repairAdvice(d: Defects, indices: Uint32Array, positions: Float32Array, limits: Limits): Advice {
  const c = d.counts;
  const faces = indices.length / 3;
  const most = limits.max_object_triangles ?? Infinity;
  const tooBig = faces > most;
  const advice = (repair: Advice["repair"], text: string, extra: Partial<Advice> = {}): Advice => ({ repair, holeEdges: 0, components: "all", simplify: 0, text, ...extra });
  const shrink = tooBig ? `, and simplify to ${n(most)} faces (over this server's max_object_triangles)` : "";
  const clean = c.boundary_edges + c.non_manifold_edges + c.non_manifold_vertices + c.degenerate_faces + c.self_intersections === 0 && d.unchecked_faces === 0;
  if (clean) return tooBig ? advice("none", `advice: simplify to ${n(most)} faces (over this server's max_object_triangles)`, { simplify: most }) : advice("none", "");
  if (!d.truncated && c.components > 1 && largestPieceClean(d, indices, positions))
    return advice("none", `advice: components "largest" (every defect is in another piece or between pieces)${shrink}`, { components: "largest", simplify: tooBig ? most : 0 });
  // What fix cannot do, in order of how often it is the reason.
  const why: string[] = [];
  if (c.self_intersections > 0) why.push("it removes no self-intersection"); // unchecked faces are at the edges and vertices below
  if (c.non_manifold_vertices > 0) why.push("sheets touching at a vertex still touch once split");
  if (c.non_manifold_edges > 0 && (d.truncated || !onlyRepeatedFaces(d, indices, positions))) why.push("an edge in more than two faces that are not copies of one face stays");
  const holes = d.truncated ? [] : holeSizes(d.boundary_edges as Array<[number, number]>);
  const limit = limits.max_hole_edges ?? Infinity;
  if (c.boundary_edges > 0 && (d.truncated || holes[0] > limit)) why.push(`a hole of ${d.truncated ? "unknown size" : n(holes[0])} edges is over the ${n(limit)} it fills at most`);
  if (why.length) return advice("wrap", `advice: repair "wrap": fix cannot make this mesh closed (${why.join("; ")})`);
  if (tooBig) return advice("wrap", `advice: repair "wrap": the mesh is over max_object_triangles and simplify, which runs before any repair, needs a closed surface`);
  const holeEdges = holes[0] ?? 0;
  const does = [
    holeEdges ? `fills ${holes.length === 1 ? "the hole" : `the ${holes.length} holes`}` : "",
    c.non_manifold_edges ? "removes the repeated faces" : "",
    c.degenerate_faces ? "removes the degenerate faces" : "",
  ].filter(Boolean);
  return advice("fix", `advice: repair "fix"${holeEdges ? ` with holes up to ${n(holeEdges)} edges` : ""} (it ${does.join(", ")})`, { holeEdges });
}

/** Whether every edge in more than two faces is one because a face is listed again (by its corners'
 *  positions): the only such edge "fix" mends. */
function onlyRepeatedFaces(d: Defects, indices: Uint32Array, positions: Float32Array): boolean {
  const key = place(positions);
  const byEdge = new Map<string, Set<string>>();
  for (let f = 0; f < indices.length / 3; f++) {
    const corners = [key(indices[3 * f]), key(indices[3 * f + 1]), key(indices[3 * f + 2])];
    const face = [...corners].sort().join("|");
    for (let k = 0; k < 3; k++) {
      const edge = [corners[k], corners[(k + 1) % 3]].sort().join("|");
      if (!byEdge.has(edge)) byEdge.set(edge, new Set());
      byEdge.get(edge)!.add(face);
    }
  }
  return d.non_manifold_edges.every(([i, j]) => (byEdge.get([key(i), key(j)].sort().join("|"))?.size ?? 0) <= 2);
}

/** Whether the piece components "largest" keeps has no defect of its own (an intersection or a
 *  touching vertex with another piece goes with that piece). */
function largestPieceClean(d: Defects, indices: Uint32Array, positions: Float32Array): boolean {
  const pieceOf = new Int32Array(indices.length / 3).fill(-1);
  d.components.forEach((piece, k) => piece.runs.forEach(([first, count]) => pieceOf.fill(k, first, first + count)));
  const keep = d.largest_component;
  // Vertices by position: the server welds equal positions, and names a vertex by its first copy.
  const key = place(positions);
  const kept = new Set<string>(),
    other = new Set<string>();
  for (let f = 0; f < pieceOf.length; f++) for (let k = 0; k < 3; k++) (pieceOf[f] === keep ? kept : other).add(key(indices[3 * f + k]));
  if (d.self_intersections.some(([f, g]) => pieceOf[f] === keep && pieceOf[g] === keep)) return false;
  if (d.degenerate_faces.some((f) => pieceOf[f] === keep)) return false;
  if ([...d.boundary_edges, ...d.non_manifold_edges].some(([i, j]) => kept.has(key(i)) && kept.has(key(j)))) return false;
  return !d.non_manifold_vertices.some((v) => kept.has(key(v)) && !other.has(key(v)));
}

/** A vertex's position as a key (the file's float32 coordinates). */
function place(positions: Float32Array): (v: number) => string {
  return (v) => `${positions[3 * v]},${positions[3 * v + 1]},${positions[3 * v + 2]}`;
}
