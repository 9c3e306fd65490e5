// The 3D scene, z up: per rollout of the run a "world" group holding the robot's collision
// primitives, the scenario's obstacles (transparent), the target frame (axes), the witness
// segments of the pairs and the rollout's Kelvin fields (fields.ts). Overlay puts both robots in one corridor; side by side moves the second
// world along y.
import * as THREE from "three";
import { FieldLayer } from "./fields";
import type { FrameStore } from "./frames";
import { shapeGeometry } from "../../core/shapes";
import { poseMatrix } from "./kinematics";
import { textLabel } from "../../core/label";
import type { RolloutSpec } from "./specs";
import type { CbfRobot, CbfScenario } from "./types";

export const SIDE_OFFSET = 1.4; // m along y between the worlds in "side by side"

export type Layout = "overlay" | "side";

/** Segments between the witness points of chosen pairs, with dots at both ends. */
class Witnesses extends THREE.Group {
  private readonly lines: THREE.LineSegments<THREE.BufferGeometry, THREE.LineBasicMaterial>;
  private readonly dots: THREE.Points<THREE.BufferGeometry, THREE.PointsMaterial>;
  shown: number[] = [];

  constructor(color: number, pairs: number) {
    super();
    const pos = new THREE.BufferAttribute(new Float32Array(Math.max(1, pairs) * 6), 3);
    pos.setUsage(THREE.DynamicDrawUsage);
    const g = new THREE.BufferGeometry();
    g.setAttribute("position", pos);
    this.lines = new THREE.LineSegments(g, new THREE.LineBasicMaterial({ color, depthTest: false, transparent: true }));
    this.dots = new THREE.Points(g, new THREE.PointsMaterial({ color, size: 7, sizeAttenuation: false, depthTest: false, transparent: true }));
    for (const o of [this.lines, this.dots]) {
      o.renderOrder = 10;
      o.frustumCulled = false;
      this.add(o);
    }
  }

  set(indices: number[], wa: Float32Array, wb: Float32Array, base: number): void {
    const pos = this.lines.geometry.getAttribute("position") as THREE.BufferAttribute;
    const a = pos.array as Float32Array;
    indices.forEach((k, n) => {
      const o = (base + k) * 3;
      a.set(wa.subarray(o, o + 3), n * 6);
      a.set(wb.subarray(o, o + 3), n * 6 + 3);
    });
    pos.needsUpdate = true;
    this.lines.geometry.setDrawRange(0, indices.length * 2);
    this.shown = indices;
  }
}

export class World {
  readonly group = new THREE.Group();
  readonly robot = new THREE.Group();
  readonly obstacles = new THREE.Group();
  readonly target = new THREE.AxesHelper(0.12);
  readonly name: THREE.Sprite;
  readonly fields = new FieldLayer();
  private readonly links: THREE.Mesh[] = [];
  witnesses: Witnesses;
  private pairCapacity = 0;
  /** The pose currently drawn (step index, or -1 for q0). */
  step = -1;

  constructor(
    readonly spec: RolloutSpec,
    readonly robotModel: CbfRobot,
  ) {
    const robot = robotModel;
    const mat = new THREE.MeshStandardMaterial({ color: spec.robotColor, roughness: 0.5, metalness: 0.1, transparent: true, opacity: 1 });
    for (const p of robot.primitives) {
      const m = new THREE.Mesh(shapeGeometry(p.shape), mat);
      m.name = p.name;
      m.matrixAutoUpdate = false;
      this.links.push(m);
      this.robot.add(m);
    }
    this.witnesses = new Witnesses(spec.color, 0);
    this.name = textLabel(spec.short, spec.color);
    this.name.position.set(0, 0, 1.25);
    this.group.add(this.robot, this.obstacles, this.target, this.witnesses, this.name, this.fields.group);
  }

  setScenario(sc: Pick<CbfScenario, "obstacles" | "target">): void {
    this.obstacles.children.forEach((c) => (c as THREE.Mesh).geometry.dispose());
    this.obstacles.clear();
    const mat = new THREE.MeshStandardMaterial({ color: 0x8aa4c8, transparent: true, opacity: 0.28, depthWrite: false, side: THREE.DoubleSide });
    const edges = new THREE.LineBasicMaterial({ color: 0x9fb6d6, transparent: true, opacity: 0.6 });
    for (const o of sc.obstacles) {
      const g = shapeGeometry(o.shape);
      const m = new THREE.Mesh(g, mat);
      m.name = o.name ?? "obstacle";
      if (o.shape.pose) m.applyMatrix4(poseMatrix(o.shape.pose));
      m.add(new THREE.LineSegments(new THREE.EdgesGeometry(g, 20), edges));
      this.obstacles.add(m);
    }
    this.target.matrixAutoUpdate = false;
    this.target.matrix.copy(poseMatrix(sc.target));
  }

  /** Makes room for `count` witness segments (a rollout's pair count). */
  setPairs(count: number): void {
    if (count === this.pairCapacity) return;
    this.pairCapacity = count;
    this.group.remove(this.witnesses);
    this.witnesses.traverse((o) => (o as THREE.Mesh).geometry?.dispose());
    this.witnesses = new Witnesses(this.spec.color, count);
    this.group.add(this.witnesses);
  }

  /** Primitive world poses [x, y, z, qw, qx, qy, qz] × n, from `data` at `offset`. */
  setPoses(data: ArrayLike<number>, offset = 0): void {
    const p = new THREE.Vector3(),
      q = new THREE.Quaternion(),
      one = new THREE.Vector3(1, 1, 1);
    this.links.forEach((m, k) => {
      const o = offset + k * 7;
      p.set(data[o], data[o + 1], data[o + 2]);
      q.set(data[o + 4], data[o + 5], data[o + 6], data[o + 3]);
      m.matrix.compose(p, q, one);
      m.matrixWorldNeedsUpdate = true;
    });
  }

  /** Draws step k of a rollout: its primitives' poses and the witness segments of `pairs`. */
  showStep(store: FrameStore, k: number, pairs: number[]): void {
    this.setPoses(store.poses.data, k * store.primitiveCount * 7);
    this.step = k;
    this.witnesses.set(pairs, store.witnessA.data, store.witnessB.data, k * store.pairCount);
    if (this.fields.hasPoints) this.fields.showStep(store, k, this.robotModel);
  }

  /** Draws the robot at q0 (its primitives' poses, if known), without witnesses. */
  showQ0(poses: Float32Array | null, q0: number[] | null = null): void {
    if (poses) this.setPoses(poses);
    this.step = -1;
    this.witnesses.set([], new Float32Array(0), new Float32Array(0), 0);
    if (this.fields.hasPoints && q0) this.fields.showQ(this.robotModel, q0);
  }

  /** The colour the robot is drawn in (null: a robot without primitives). */
  robotColor(): number | null {
    return (this.links[0]?.material as THREE.MeshStandardMaterial | undefined)?.color.getHex() ?? null;
  }

  setOpacity(opacity: number): void {
    const mat = this.links[0]?.material as THREE.MeshStandardMaterial | undefined;
    if (mat) {
      mat.opacity = opacity;
      mat.depthWrite = opacity >= 1;
    }
  }
}

export class CbfScene {
  /** A world per rollout key, made when a run first needs it. */
  readonly worlds = new Map<string, World>();
  readonly root = new THREE.Group();
  private scenario: Pick<CbfScenario, "obstacles" | "target"> | null = null;

  constructor(
    scene: THREE.Scene,
    private readonly robot: CbfRobot,
  ) {
    scene.add(this.root);
  }

  /** The world of a rollout (a new one when its key is new or now names another rollout). */
  world(spec: RolloutSpec): World {
    let w = this.worlds.get(spec.key);
    if (w && w.spec.label !== spec.label) {
      this.root.remove(w.group);
      w.fields.dispose();
      w.group.traverse((o) => (o as THREE.Mesh).geometry?.dispose());
      w = undefined;
    }
    if (!w) {
      w = new World(spec, this.robot);
      if (this.scenario) w.setScenario(this.scenario);
      this.worlds.set(spec.key, w);
      this.root.add(w.group);
    }
    return w;
  }

  /** Takes the worlds out of the scene (another robot replaces them). */
  remove(): void {
    this.root.removeFromParent();
    for (const w of this.worlds.values()) w.fields.dispose();
    this.root.traverse((o) => (o as THREE.Mesh).geometry?.dispose());
  }

  setScenario(sc: Pick<CbfScenario, "obstacles" | "target">): void {
    this.scenario = sc;
    for (const w of this.worlds.values()) w.setScenario(sc);
  }

  /** Which worlds are visible and where: the rollouts shown, overlaid or side by side. */
  arrange(shown: RolloutSpec[], layout: Layout): void {
    const both = shown.length === 2;
    const side = both && layout === "side";
    for (const w of this.worlds.values()) w.group.visible = false;
    shown.forEach((spec, k) => {
      const w = this.world(spec);
      w.group.visible = true;
      w.group.position.set(0, side && k === 1 ? -SIDE_OFFSET : 0, 0);
      const second = both && !side && k === 1;
      w.obstacles.visible = !second;
      w.target.visible = !second;
      w.name.visible = side;
      w.setOpacity(both && !side ? 0.7 : 1);
      w.fields.setOverlaid(second, spec.color);
    });
  }

  bounds(): THREE.Box3 {
    const box = new THREE.Box3();
    this.root.updateMatrixWorld(true);
    for (const w of this.worlds.values()) {
      if (!w.group.visible) continue;
      box.expandByObject(w.obstacles);
      box.expandByObject(w.robot);
      for (const o of w.fields.objects) box.expandByObject(o.surface);
    }
    return box;
  }
}
