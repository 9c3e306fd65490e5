// The object's input surface coloured by σ. The input mesh may be coarse (the cube has 12
// triangles), so for display each triangle is subdivided until its edges are short enough to
// show a brush; σ is evaluated locally per display vertex (sigma.ts) and a brush stamp only
// recolours the vertices it reaches. Raycasts go to the (smaller) input mesh.
import * as THREE from "three";
import { mergeVertices, toCreasedNormals } from "three/addons/utils/BufferGeometryUtils.js";
import { finiteRange, resolveRange, VertexColorizer, type ColorScale } from "../../core/colormap";
import { floats, uints, type MeshFrame } from "../../core/meshframe";
import { simplifiedStandIn, type StandIn } from "../../core/stand_in";
import { applyBrushTo, stampTowards, type BrushSettings } from "./brush_stamp";
import { evaluateAll, type Brush, type SigmaBody, type Vec3 } from "./sigma";

const MAX_DISPLAY_TRIANGLES = 250_000;

export class SurfaceLayer {
  readonly mesh: THREE.Mesh<THREE.BufferGeometry, THREE.MeshStandardMaterial>;
  /** The input mesh as sent by the server (raycast target, never drawn). */
  readonly pickMesh: THREE.Mesh;
  readonly bounds: THREE.Box3;
  readonly inputVertices: number;
  private positions: Float32Array;
  private sigma: Float32Array;
  private colors: THREE.BufferAttribute;
  private scale: ColorScale = { map: "coolwarm", mode: "symmetric", min: -1, max: 1 };
  private colorizer = new VertexColorizer();
  /** σ's smallest and largest value on the surface, and the range its colours span. */
  dataRange: [number, number] = [NaN, NaN];
  colorRange: [number, number] = [-1, 1];
  private disposed = false;
  /** The coarse mesh drawn while orbiting, once made (null for small surfaces). */
  standIn: StandIn | null = null;

  constructor(frame: MeshFrame) {
    const input = new THREE.BufferGeometry();
    input.setAttribute("position", new THREE.BufferAttribute(floats(frame.positions).slice(), 3));
    input.setIndex(new THREE.BufferAttribute(uints(frame.indices).slice(), 1));
    input.computeBoundingBox();
    input.computeBoundingSphere();
    this.inputVertices = frame.n_vertices;
    this.bounds = input.boundingBox!.clone();
    this.pickMesh = new THREE.Mesh(input, new THREE.MeshBasicMaterial({ side: THREE.DoubleSide }));

    // Creased normals split vertices at sharp edges; merging re-shares the rest (a fine 200k-
    // triangle input drops from 600k to ~100k vertices: that is what a software renderer pays for).
    const display = mergeVertices(subdivide(toCreasedNormals(input.clone(), Math.PI / 6), this.bounds), 1e-7);
    this.positions = display.getAttribute("position").array as Float32Array;
    this.sigma = new Float32Array(this.positions.length / 3);
    this.colors = new THREE.BufferAttribute(new Float32Array(this.positions.length), 3);
    display.setAttribute("color", this.colors);
    this.mesh = new THREE.Mesh(
      display,
      new THREE.MeshStandardMaterial({ vertexColors: true, roughness: 0.75, metalness: 0.0, polygonOffset: true, polygonOffsetFactor: 1, polygonOffsetUnits: 1 }),
    );
    this.mesh.renderOrder = 0;
  }

  get displayTriangles(): number {
    const g = this.mesh.geometry;
    return (g.index ? g.index.count : this.positions.length / 3) / 3;
  }

  /** Makes the stand-in of at most `triangles` triangles for a surface with more than twice as
   *  many (off the page's thread); resolves to it, or null. */
  async makeStandIn(triangles: number): Promise<StandIn | null> {
    const s = triangles > 0 ? await simplifiedStandIn(this.mesh.geometry, triangles) : null;
    if (this.disposed) s?.geometry.dispose();
    else this.standIn = s;
    return this.standIn;
  }

  /** Recomputes σ everywhere (preset, reset, load). */
  setSigma(body: SigmaBody): void {
    evaluateAll(body, this.positions, this.sigma);
    this.recolor();
  }

  /** The brush's stamp at a point, judged by σ at the display vertices (null: it changes nothing). */
  stampAt(settings: BrushSettings, centre: Vec3): Brush | null {
    return stampTowards(settings, centre, this.positions, this.sigma);
  }

  /** Applies one brush: only the vertices it reaches change, unless σ's range (and with it an
   *  auto or symmetric colour range) grows. */
  addBrush(b: Brush): void {
    const touched = applyBrushTo(b, this.positions, this.sigma);
    if (!touched.length) return;
    if (this.rangeChanged()) this.colorizer.write(this.colors, this.sigma);
    else this.colorizer.write(this.colors, this.sigma, touched);
  }

  /** The colour map and range of σ. */
  setColor(scale: ColorScale): void {
    this.scale = { ...scale };
    this.recolor();
  }

  /** σ at the display vertices (tests compare it with the server's surface scalars). */
  sigmaValues(): Float32Array {
    return this.sigma;
  }

  private recolor(): void {
    this.rangeChanged();
    this.colorizer.write(this.colors, this.sigma);
  }

  /** Updates σ's range and the colour range; true when the colour range moved. */
  private rangeChanged(): boolean {
    this.dataRange = finiteRange(this.sigma);
    const [lo, hi] = resolveRange(this.scale, ...this.dataRange);
    const moved = lo !== this.colorRange[0] || hi !== this.colorRange[1] || this.colorizerMap !== this.scale.map;
    this.colorRange = [lo, hi];
    this.colorizerMap = this.scale.map;
    this.colorizer.set(this.scale.map, this.colorRange);
    return moved;
  }
  private colorizerMap = "";

  dispose(): void {
    this.disposed = true;
    this.standIn?.geometry.dispose();
    this.standIn = null;
    this.mesh.geometry.dispose();
    this.mesh.material.dispose();
    this.pickMesh.geometry.dispose();
    (this.pickMesh.material as THREE.Material).dispose();
  }
}

/** Splits every triangle of a non-indexed geometry into n² (n from its longest edge). */
function subdivide(g: THREE.BufferGeometry, bounds: THREE.Box3): THREE.BufferGeometry {
  const pos = g.getAttribute("position").array as Float32Array;
  const nor = g.getAttribute("normal").array as Float32Array;
  const nTri = pos.length / 9;
  let target = bounds.getSize(new THREE.Vector3()).length() / 120;
  const edge = (t: number) => {
    let m = 0;
    for (let k = 0; k < 3; k++) {
      const a = t * 9 + k * 3,
        b = t * 9 + ((k + 1) % 3) * 3;
      m = Math.max(m, Math.hypot(pos[a] - pos[b], pos[a + 1] - pos[b + 1], pos[a + 2] - pos[b + 2]));
    }
    return m;
  };
  const splits = new Uint16Array(nTri);
  for (;;) {
    let total = 0;
    for (let t = 0; t < nTri; t++) {
      splits[t] = Math.min(64, Math.max(1, Math.ceil(edge(t) / target)));
      total += splits[t] * splits[t];
    }
    if (total <= Math.max(MAX_DISPLAY_TRIANGLES, nTri)) break;
    target *= 1.3;
  }
  let nv = 0;
  for (let t = 0; t < nTri; t++) nv += splits[t] * splits[t] * 3;
  const P = new Float32Array(nv * 3),
    N = new Float32Array(nv * 3);
  let o = 0;
  const put = (t: number, u: number, v: number) => {
    const w = 1 - u - v,
      a = t * 9;
    for (let c = 0; c < 3; c++) {
      P[o + c] = w * pos[a + c] + u * pos[a + 3 + c] + v * pos[a + 6 + c];
      N[o + c] = w * nor[a + c] + u * nor[a + 3 + c] + v * nor[a + 6 + c];
    }
    o += 3;
  };
  for (let t = 0; t < nTri; t++) {
    const n = splits[t];
    for (let i = 0; i < n; i++)
      for (let j = 0; j < n - i; j++) {
        put(t, i / n, j / n);
        put(t, (i + 1) / n, j / n);
        put(t, i / n, (j + 1) / n);
        if (j < n - i - 1) {
          put(t, (i + 1) / n, j / n);
          put(t, (i + 1) / n, (j + 1) / n);
          put(t, i / n, (j + 1) / n);
        }
      }
  }
  const out = new THREE.BufferGeometry();
  out.setAttribute("position", new THREE.BufferAttribute(P, 3));
  out.setAttribute("normal", new THREE.BufferAttribute(N, 3)); // the shader renormalises
  out.computeBoundingBox();
  out.computeBoundingSphere();
  return out;
}
