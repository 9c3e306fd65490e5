// An uploaded mesh drawn before it is prepared, with where it is not a closed 2-manifold marked as
// the server found it (GET /api/kelvin/uploads/{id}/defects): open edges, edges in more than two
// faces, vertices where sheets touch, self-intersecting and degenerate faces, and the pieces that
// components "largest" would drop. Edges and vertices are the file's, so the marks sit exactly on
// the file's own geometry.
import * as THREE from "three";
import { LineMaterial } from "three/addons/lines/LineMaterial.js";
import { LineSegments2 } from "three/addons/lines/LineSegments2.js";
import { LineSegmentsGeometry } from "three/addons/lines/LineSegmentsGeometry.js";
import { floats, uints, type MeshFrame } from "../../core/meshframe";
import type { Defects } from "./object_source";

/** The colours of the marks (also in the panel's summary, as its legend). */
export const defectColors = { open: "#e8590c", nonManifold: "#c2255c", vertex: "#f59f00", intersecting: "#7048e8", dropped: "#1c7ed6" } as const;

export interface MarkedEdge {
  kind: "open" | "non-manifold";
  vertices: [number, number];
  a: [number, number, number];
  b: [number, number, number];
}

/** The loops the open edges form (an edge graph's connected pieces), largest first: a hole's size
 *  in edges is what "fix" compares with its hole size. */
export function holeSizes(edges: Array<[number, number]>): number[] {
  const parent = new Map<number, number>();
  const find = (v: number): number => {
    let r = v;
    while (parent.get(r) !== r) r = parent.get(r)!;
    for (let x = v; x !== r;) {
      const next = parent.get(x)!;
      parent.set(x, r);
      x = next;
    }
    return r;
  };
  for (const [a, b] of edges) {
    if (!parent.has(a)) parent.set(a, a);
    if (!parent.has(b)) parent.set(b, b);
    parent.set(find(a), find(b));
  }
  const count = new Map<number, number>();
  for (const [a] of edges) count.set(find(a), (count.get(find(a)) ?? 0) + 1);
  return [...count.values()].sort((x, y) => y - x);
}

const plural = (n: number, one: string, many: string) => `${n.toLocaleString("en")} ${n === 1 ? one : many}`;

/** The counts as the panel lists them: one line per kind found, or that the mesh is closed. */
export function defectLines(d: Defects): string[] {
  const c = d.counts,
    out: string[] = [];
  if (c.boundary_edges > 0) {
    const holes = d.truncated ? [] : holeSizes(d.boundary_edges as Array<[number, number]>);
    const loops = holes.length ? ` (${plural(holes.length, "hole", "holes")}: ${holes.slice(0, 6).join(", ")}${holes.length > 6 ? ", …" : ""} edges)` : "";
    out.push(`${plural(c.boundary_edges, "open edge", "open edges")}${loops}`);
  }
  if (c.non_manifold_edges > 0) out.push(`${plural(c.non_manifold_edges, "edge in more than two faces", "edges in more than two faces")}`);
  if (c.non_manifold_vertices > 0) out.push(`${plural(c.non_manifold_vertices, "vertex where sheets touch", "vertices where sheets touch")}`);
  if (c.degenerate_faces > 0) out.push(`${plural(c.degenerate_faces, "degenerate face", "degenerate faces")}`);
  const untested = d.unchecked_faces > 0 ? ` (${plural(d.unchecked_faces, "face", "faces")} at those defects not tested)` : "";
  if (c.self_intersections > 0 || untested)
    out.push(`${d.self_intersections_complete ? "" : "at least "}${plural(c.self_intersections, "pair of intersecting faces", "pairs of intersecting faces")}${untested}`);
  if (c.components > 1) out.push(`${plural(c.components, "piece", "pieces")} (components "largest" keeps piece ${d.largest_component + 1})`);
  if (d.truncated) out.push(`only the first ${d.max_items.toLocaleString("en")} of each are marked (this server's max_defect_items)`);
  return out;
}

/** Whether the mesh can be prepared as it is (no defect the preparation refuses). */
export function isClosedManifold(d: Defects): boolean {
  const c = d.counts;
  return c.boundary_edges + c.non_manifold_edges + c.non_manifold_vertices + c.degenerate_faces + c.self_intersections === 0 && d.unchecked_faces === 0;
}

export class DefectsLayer {
  readonly group = new THREE.Group();
  readonly bounds: THREE.Box3;
  readonly defects: Defects;
  /** The upload's surface (shown until the prepared surface replaces it). */
  private readonly input: THREE.Mesh;
  private readonly marks = new THREE.Group();
  private readonly positions: Float32Array;
  private readonly edges: MarkedEdge[] = [];

  constructor(frame: MeshFrame, defects: Defects) {
    this.defects = defects;
    this.positions = floats(frame.positions).slice();
    const index = uints(frame.indices).slice();
    const g = new THREE.BufferGeometry();
    g.setAttribute("position", new THREE.BufferAttribute(this.positions, 3));
    g.setIndex(new THREE.BufferAttribute(index, 1));
    g.computeVertexNormals();
    g.computeBoundingBox();
    this.bounds = g.boundingBox!.clone();
    this.input = new THREE.Mesh(
      g,
      new THREE.MeshStandardMaterial({ color: 0xb8bcc2, roughness: 0.8, side: THREE.DoubleSide, polygonOffset: true, polygonOffsetFactor: 1, polygonOffsetUnits: 1 }),
    );
    this.group.add(this.input, this.marks);
    this.marks.renderOrder = 10;

    const at = (v: number): [number, number, number] => [this.positions[3 * v], this.positions[3 * v + 1], this.positions[3 * v + 2]];
    const lines = (kind: MarkedEdge["kind"], list: number[][], color: string) => {
      if (!list.length) return;
      const xyz: number[] = [];
      for (const [i, j] of list) {
        const e: MarkedEdge = { kind, vertices: [i, j], a: at(i), b: at(j) };
        this.edges.push(e);
        xyz.push(...e.a, ...e.b);
      }
      const geometry = new LineSegmentsGeometry().setPositions(xyz);
      // Drawn through the surface: a defect behind the object is still seen.
      const line = new LineSegments2(geometry, new LineMaterial({ color: new THREE.Color(color).getHex(), linewidth: 3, depthTest: false, transparent: true }));
      line.renderOrder = 10;
      this.marks.add(line);
    };
    lines("open", defects.boundary_edges, defectColors.open);
    lines("non-manifold", defects.non_manifold_edges, defectColors.nonManifold);
    if (defects.non_manifold_vertices.length) {
      const p = new THREE.BufferGeometry();
      p.setAttribute(
        "position",
        new THREE.Float32BufferAttribute(
          defects.non_manifold_vertices.flatMap((v) => at(v)),
          3,
        ),
      );
      const points = new THREE.Points(p, new THREE.PointsMaterial({ color: defectColors.vertex, size: 9, sizeAttenuation: false, depthTest: false }));
      points.renderOrder = 11;
      this.marks.add(points);
    }
    const faces = (list: number[], color: string, opacity: number) => {
      if (!list.length) return;
      const sub = new THREE.BufferGeometry();
      sub.setAttribute("position", g.getAttribute("position"));
      sub.setIndex(list.flatMap((f) => [index[3 * f], index[3 * f + 1], index[3 * f + 2]]));
      const mesh = new THREE.Mesh(sub, new THREE.MeshBasicMaterial({ color, transparent: true, opacity, side: THREE.DoubleSide, depthTest: false }));
      mesh.renderOrder = 9;
      this.marks.add(mesh);
    };
    faces([...new Set(defects.self_intersections.flat())], defectColors.intersecting, 0.6);
    faces(defects.degenerate_faces, defectColors.intersecting, 0.6);
    // The pieces "components": "largest" would drop.
    const dropped: number[] = [];
    defects.components.forEach((piece, k) => {
      if (k === defects.largest_component || defects.components.length < 2) return;
      for (const [first, n] of piece.runs) for (let f = first; f < first + n; f++) dropped.push(f);
    });
    faces(dropped, defectColors.dropped, 0.35);
  }

  /** The input surface is drawn until the prepared one replaces it; the marks stay on request. */
  setInputVisible(on: boolean): void {
    this.input.visible = on;
  }
  setMarksVisible(on: boolean): void {
    this.marks.visible = on;
  }
  get inputVisible(): boolean {
    return this.input.visible;
  }
  get marksVisible(): boolean {
    return this.marks.visible;
  }

  /** Every marked edge with its file vertices and their positions (for the tests). */
  markedEdges(): MarkedEdge[] {
    return this.edges;
  }

  get vertexCount(): number {
    return this.positions.length / 3;
  }

  dispose(): void {
    this.group.traverse((o) => {
      const m = o as THREE.Mesh;
      m.geometry?.dispose();
      (Array.isArray(m.material) ? m.material : m.material ? [m.material] : []).forEach((x) => x.dispose());
    });
  }
}
