// A rollout's Kelvin fields in its world (issue 33): each object's surface painted with σ (the
// Kelvin view's colour map and range), the iso-surfaces of h at 0 and δ (or the iso-levels chosen
// in the panel) as translucent shells (core/iso_layers, as the Kelvin view draws them), the
// control points as small spheres coloured by h (red below δ: outside the barrier's safe set),
// and per field a segment from the control point closest to the object to the closest surface
// point. Objects and shells are in each object's frame (the server's frames), placed by its pose;
// control points follow the links.
import * as THREE from "three";
import { finiteRange, resolveRange, VertexColorizer, type ColorScale } from "../../core/colormap";
import { IsoLayers } from "../../core/iso_layers";
import { floats, toGeometry } from "../../core/meshframe";
import type { FrameStore } from "./frames";
import { linkFrames, poseMatrix } from "./kinematics";
import type { CbfControlPoint, CbfFieldGeometry, CbfRobot } from "./types";

/** The colour of a control point with h < δ. */
export const BELOW_DELTA = "#ff3b30";
const POINT_RADIUS = 0.0018; // m: the pads' grid is 8 mm apart
const CLOSEST_COLOR = 0xffe066;

/** How h colours the control points: a sequential map over [lo, hi], red below δ. */
export interface HScale {
  map: ColorScale["map"];
  range: [number, number];
  delta: number;
}

/** One Kelvin object: its σ-painted surface and shells, in its own frame. */
class FieldObject {
  readonly group = new THREE.Group();
  readonly surface: THREE.Mesh<THREE.BufferGeometry, THREE.MeshStandardMaterial>;
  readonly shells = new IsoLayers();
  readonly sigma: Float32Array;
  readonly delta: number;
  readonly name: string;
  readonly levels: Array<{ level: number; empty: boolean; faces: number; hMin: number | null }> = [];
  private readonly colors: THREE.BufferAttribute;
  private readonly colorizer = new VertexColorizer();
  sigmaRange: [number, number] = [NaN, NaN];
  colorRange: [number, number] = [-1, 1];

  constructor(field: CbfFieldGeometry["fields"][number]) {
    this.name = field.name;
    this.delta = field.delta;
    this.group.name = `field:${field.name}`;
    this.group.matrixAutoUpdate = false;
    this.group.matrix.copy(poseMatrix(field.pose));
    const g = toGeometry(field.surface);
    this.sigma = floats(field.surface.scalars!).slice();
    this.colors = new THREE.BufferAttribute(new Float32Array(this.sigma.length * 3), 3);
    g.setAttribute("color", this.colors);
    this.surface = new THREE.Mesh(g, new THREE.MeshStandardMaterial({ vertexColors: true, roughness: 0.75, polygonOffset: true, polygonOffsetFactor: 1, polygonOffsetUnits: 1 }));
    this.surface.name = "surface";
    this.shells.setLevels(field.isosurfaces.map((f) => f.level));
    for (const f of field.isosurfaces) {
      this.levels.push({ level: f.level, empty: !!f.empty, faces: f.n_faces, hMin: f.h_min ?? null });
      if (!f.empty) this.shells.accept(f, f.level, 0);
    }
    this.group.add(this.surface, this.shells.group);
  }

  /** σ's colour map and range (the Kelvin view's scale). */
  setSigmaScale(scale: ColorScale): void {
    this.sigmaRange = finiteRange(this.sigma);
    this.colorRange = resolveRange(scale, ...this.sigmaRange);
    this.colorizer.set(scale.map, this.colorRange);
    this.colorizer.write(this.colors, this.sigma);
  }

  /** σ at a point of triangle `face` (barycentric weights of its corners). */
  sigmaAt(face: number, bary: THREE.Vector3): number {
    const idx = this.surface.geometry.index!;
    return bary.x * this.sigma[idx.getX(3 * face)] + bary.y * this.sigma[idx.getX(3 * face + 1)] + bary.z * this.sigma[idx.getX(3 * face + 2)];
  }

  dispose(): void {
    this.surface.geometry.dispose();
    this.surface.material.dispose();
    this.shells.clear();
  }
}

export class FieldLayer {
  readonly group = new THREE.Group();
  objects: FieldObject[] = [];
  /** The rollout whose control points and objects are shown (null: none). */
  owner: string | null = null;
  private points: THREE.InstancedMesh | null = null;
  private controlPoints: CbfControlPoint[] = [];
  /** h per control point at the step drawn (the smallest over the fields; NaN before frames). */
  pointH = new Float64Array(0);
  private readonly closest: THREE.LineSegments<THREE.BufferGeometry, THREE.LineBasicMaterial>;
  private readonly closestDots: THREE.Points<THREE.BufferGeometry, THREE.PointsMaterial>;
  private hScale: HScale = { map: "viridis", range: [0, 1], delta: 0 };
  private readonly colorizer = new VertexColorizer();
  private readonly below = new THREE.Color(BELOW_DELTA);
  /** The second rollout overlaid on the first: its shells tinted, its objects not drawn twice. */
  private overlaid = false;
  private tint: number | null = null;

  constructor() {
    const pos = new THREE.BufferAttribute(new Float32Array(6 * 8), 3);
    pos.setUsage(THREE.DynamicDrawUsage);
    const g = new THREE.BufferGeometry();
    g.setAttribute("position", pos);
    g.setDrawRange(0, 0);
    this.closest = new THREE.LineSegments(g, new THREE.LineBasicMaterial({ color: CLOSEST_COLOR, depthTest: false, transparent: true }));
    this.closestDots = new THREE.Points(g, new THREE.PointsMaterial({ color: CLOSEST_COLOR, size: 7, sizeAttenuation: false, depthTest: false, transparent: true }));
    for (const o of [this.closest, this.closestDots]) {
      o.renderOrder = 11;
      o.frustumCulled = false;
      this.group.add(o);
    }
    this.group.name = "fields";
  }

  get hasPoints(): boolean {
    return this.controlPoints.length > 0;
  }

  /** The control points (from the rollout's status): small spheres, grey until h is known. */
  setControlPoints(points: CbfControlPoint[]): void {
    if (this.points) {
      this.group.remove(this.points);
      this.points.geometry.dispose();
      (this.points.material as THREE.Material).dispose();
      this.points = null;
    }
    this.controlPoints = points;
    this.pointH = new Float64Array(points.length).fill(NaN);
    if (!points.length) return;
    const mesh = new THREE.InstancedMesh(new THREE.SphereGeometry(POINT_RADIUS, 10, 8), new THREE.MeshStandardMaterial({ roughness: 0.4 }), points.length);
    mesh.name = "control points";
    mesh.instanceMatrix.setUsage(THREE.DynamicDrawUsage);
    mesh.frustumCulled = false;
    mesh.renderOrder = 12;
    for (let i = 0; i < points.length; i++) mesh.setColorAt(i, new THREE.Color(0x9aa4ae));
    this.points = mesh;
    this.group.add(mesh);
  }

  /** The objects and shells of GET .../fields (replacing any before). */
  setGeometry(g: CbfFieldGeometry, sigma: ColorScale): void {
    this.objects.forEach((o) => {
      this.group.remove(o.group);
      o.dispose();
    });
    this.objects = g.fields.map((f) => new FieldObject(f));
    for (const o of this.objects) {
      o.setSigmaScale(sigma);
      this.group.add(o.group);
    }
    this.restyle();
  }

  /** Nothing drawn (a new run). */
  clear(): void {
    this.setControlPoints([]);
    this.objects.forEach((o) => {
      this.group.remove(o.group);
      o.dispose();
    });
    this.objects = [];
    this.closest.geometry.setDrawRange(0, 0);
    this.owner = null;
  }

  /** A second rollout over the first: its shells in its colour, its objects hidden (the same mesh). */
  setOverlaid(overlaid: boolean, tint: number): void {
    this.overlaid = overlaid;
    this.tint = tint;
    this.restyle();
  }

  setVisible(parts: { object: boolean; shells: boolean; points: boolean }): void {
    for (const o of this.objects) {
      o.surface.visible = parts.object && !this.overlaid;
      o.shells.setVisible(parts.shells);
    }
    if (this.points) this.points.visible = parts.points;
    this.closest.visible = this.closestDots.visible = parts.points;
  }

  setSigmaScale(scale: ColorScale): void {
    for (const o of this.objects) o.setSigmaScale(scale);
  }

  setHScale(scale: HScale): void {
    this.hScale = scale;
    this.colorizer.set(scale.map, scale.range);
    this.recolorPoints();
  }

  /** Control points where the links are at step k, coloured by h there, and the closest points. */
  showStep(store: FrameStore, k: number, robot: CbfRobot): void {
    const n = store.dof;
    this.place(robot, Array.from(store.q.data.subarray(k * n, k * n + n)));
    const F = store.fieldCount,
      P = store.pointCount;
    if (P === this.controlPoints.length) {
      for (let p = 0; p < P; p++) {
        let m = Infinity;
        for (let f = 0; f < F; f++) m = Math.min(m, store.h.data[(k * F + f) * P + p]);
        this.pointH[p] = Number.isFinite(m) ? m : NaN;
      }
    }
    this.recolorPoints();
    // Per field: from the control point nearest the object to the closest surface point.
    const pos = this.closest.geometry.getAttribute("position") as THREE.BufferAttribute;
    const a = pos.array as Float32Array;
    const world = new THREE.Vector3();
    let shown = 0;
    for (let f = 0; f < Math.min(F, 8); f++) {
      const which = store.closestPoint.data[k * F + f];
      if (!(which >= 0) || !this.points) continue;
      this.pointAt(which, world);
      a.set([world.x, world.y, world.z], shown * 6);
      a.set(store.closest.data.subarray((k * F + f) * 3, (k * F + f) * 3 + 3), shown * 6 + 3);
      shown++;
    }
    pos.needsUpdate = true;
    this.closest.geometry.setDrawRange(0, shown * 2);
  }

  /** Control points at configuration q (before any frame), h unknown. */
  showQ(robot: CbfRobot, q: number[]): void {
    this.place(robot, q);
    this.pointH.fill(NaN);
    this.recolorPoints();
    this.closest.geometry.setDrawRange(0, 0);
  }

  /** The world position of control point i as drawn. */
  pointAt(i: number, out: THREE.Vector3): THREE.Vector3 {
    const m = new THREE.Matrix4();
    this.points!.getMatrixAt(i, m);
    return out.setFromMatrixPosition(m);
  }

  /** The hex colour each control point is drawn in (tests, hover). */
  pointColors(): number[] {
    const c = new THREE.Color();
    return this.controlPoints.map((_, i) => (this.points!.getColorAt(i, c), c.getHex()));
  }

  controlPoint(i: number): CbfControlPoint | undefined {
    return this.controlPoints[i];
  }

  /** What is under a ray: a control point (name, h) or an object's surface (σ there). */
  pick(ray: THREE.Raycaster): { kind: "point"; index: number; distance: number } | { kind: "surface"; object: string; sigma: number; distance: number } | null {
    this.group.updateMatrixWorld(true);
    const hits: Array<{ kind: "point"; index: number; distance: number } | { kind: "surface"; object: string; sigma: number; distance: number }> = [];
    if (this.points?.visible)
      for (const h of ray.intersectObject(this.points)) if (h.instanceId !== undefined) hits.push({ kind: "point", index: h.instanceId, distance: h.distance });
    for (const o of this.objects) {
      if (!o.surface.visible || !o.group.visible) continue;
      const h = ray.intersectObject(o.surface)[0];
      if (h && h.faceIndex !== undefined && h.faceIndex !== null && h.barycoord)
        hits.push({ kind: "surface", object: o.name, sigma: o.sigmaAt(h.faceIndex, h.barycoord), distance: h.distance });
    }
    hits.sort((x, y) => x.distance - y.distance);
    return hits[0] ?? null;
  }

  dispose(): void {
    this.setControlPoints([]);
    this.objects.forEach((o) => o.dispose());
    this.objects = [];
    this.closest.geometry.dispose();
    this.closest.material.dispose();
    this.closestDots.material.dispose();
  }

  private place(robot: CbfRobot, q: number[]): void {
    if (!this.points) return;
    const frames = linkFrames(robot, q);
    const m = new THREE.Matrix4();
    const v = new THREE.Vector3();
    this.controlPoints.forEach((c, i) => {
      const frame = frames[c.link];
      if (!frame) return;
      v.set(c.point[0], c.point[1], c.point[2]).applyMatrix4(frame);
      this.points!.setMatrixAt(i, m.makeTranslation(v.x, v.y, v.z));
    });
    this.points.instanceMatrix.needsUpdate = true;
  }

  private recolorPoints(): void {
    if (!this.points) return;
    const lut = new Float32Array(this.controlPoints.length * 3);
    const attr = new THREE.BufferAttribute(lut, 3);
    this.colorizer.write(attr, this.pointH);
    const c = new THREE.Color();
    for (let i = 0; i < this.controlPoints.length; i++) {
      const h = this.pointH[i];
      if (!Number.isFinite(h)) c.setHex(0x9aa4ae);
      else if (h < this.hScale.delta) c.copy(this.below);
      else c.setRGB(lut[3 * i], lut[3 * i + 1], lut[3 * i + 2]);
      this.points.setColorAt(i, c);
    }
    this.points.instanceColor!.needsUpdate = true;
  }

  private restyle(): void {
    for (const o of this.objects) {
      o.shells.setTint(this.overlaid ? this.tint : null);
      o.surface.visible = o.surface.visible && !this.overlaid;
    }
  }
}
