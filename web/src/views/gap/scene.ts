// Scene objects of the explorer: the two shapes (each a group posed like the shape, so
// iso-surfaces computed in the shape frame ride along as children) and the witness points and
// segments of GAP and of the Euclidean distance (or, on overlap, its penetration), drawn on top
// of everything.
import * as THREE from "three";
import { poseOf, shapeGeometry, type ShapeState } from "./shapes";

export const COLORS = {
  a: 0x5b8def,
  b: 0xc77dff,
  gap: 0xffb347, // = --gap in style.css
  euclid: 0x6ad1a3, // = --euclid
  pen: 0xff7eb6, // = .legend-pen in gap.css: penetration witness points
};

class Segment extends THREE.Group {
  private readonly p = [new THREE.Mesh(), new THREE.Mesh()];
  /** The points drawn (null when hidden), for tests. */
  ends: number[][] | null = null;
  private readonly line: THREE.Line<THREE.BufferGeometry, THREE.LineBasicMaterial>;

  constructor(color: number, radius: number) {
    super();
    const sphere = new THREE.SphereGeometry(radius, 16, 8);
    const mat = new THREE.MeshBasicMaterial({ color, depthTest: false, transparent: true });
    for (const m of this.p) {
      m.geometry = sphere;
      m.material = mat;
      m.renderOrder = 10;
      this.add(m);
    }
    const g = new THREE.BufferGeometry().setFromPoints([new THREE.Vector3(), new THREE.Vector3()]);
    this.line = new THREE.Line(g, new THREE.LineBasicMaterial({ color, depthTest: false, transparent: true }));
    this.line.renderOrder = 10;
    this.line.frustumCulled = false;
    this.add(this.line);
    this.visible = false;
  }

  set(a: number[] | null, b: number[] | null): void {
    if (!a || !b) {
      this.visible = false;
      this.ends = null;
      return;
    }
    this.visible = true;
    this.ends = [a.slice(0, 3), b.slice(0, 3)];
    this.p[0].position.set(a[0], a[1], a[2]);
    this.p[1].position.set(b[0], b[1], b[2]);
    const pos = this.line.geometry.getAttribute("position") as THREE.BufferAttribute;
    pos.setXYZ(0, a[0], a[1], a[2]);
    pos.setXYZ(1, b[0], b[1], b[2]);
    pos.needsUpdate = true;
    this.line.geometry.computeBoundingSphere();
  }
}

export class GapScene {
  readonly groups = { a: new THREE.Group(), b: new THREE.Group() };
  readonly meshes: { a: THREE.Mesh; b: THREE.Mesh };
  readonly gap = new Segment(COLORS.gap, 0.011);
  readonly euclid = new Segment(COLORS.euclid, 0.01);
  readonly pen = new Segment(COLORS.pen, 0.012);

  constructor(scene: THREE.Scene) {
    const make = (color: number) =>
      new THREE.Mesh(
        new THREE.BufferGeometry(),
        new THREE.MeshStandardMaterial({ color, roughness: 0.55, metalness: 0.05, transparent: true, opacity: 0.9, polygonOffset: true, polygonOffsetFactor: 1 }),
      );
    this.meshes = { a: make(COLORS.a), b: make(COLORS.b) };
    for (const k of ["a", "b"] as const) {
      this.groups[k].name = `shape-${k}`;
      this.meshes[k].userData.shape = k;
      this.groups[k].add(this.meshes[k]);
      scene.add(this.groups[k]);
    }
    scene.add(this.gap, this.euclid, this.pen);
  }

  /** Rebuilds a shape's geometry (type or size changed) and applies its pose. */
  setShape(which: "a" | "b", s: ShapeState): void {
    const m = this.meshes[which];
    m.geometry.dispose();
    m.geometry = shapeGeometry(s);
    this.setPose(which, s);
  }

  setPose(which: "a" | "b", s: ShapeState): void {
    const { position, quaternion } = poseOf(s);
    this.groups[which].position.copy(position);
    this.groups[which].quaternion.copy(quaternion);
    this.groups[which].updateMatrixWorld(true);
  }

  select(which: "a" | "b"): void {
    for (const k of ["a", "b"] as const) {
      const mat = this.meshes[k].material as THREE.MeshStandardMaterial;
      mat.emissive.setHex(k === which ? 0x222833 : 0x000000);
    }
  }
}
