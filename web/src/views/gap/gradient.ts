// The gradient of D drawn in the 3D view. The server's gradient_a / gradient_b are dD/d(v, ω) of
// each shape's pose (distance.hpp: world frame, ω about the shape's own origin): components 0–2
// are ∂D/∂p, metres of D per metre of translation (m/m), drawn as a straight arrow from the
// shape's GAP witness point; components 3–5 are ∂D/∂θ, metres of D per radian of rotation about
// the shape's origin (m/rad), drawn as an axis arrow from the origin with a curved arrow about it
// (the sense of rotation that increases D, right-hand rule). An arrow's length is k × |part|,
// one k per part for both shapes; the legend says k.
import * as THREE from "three";
import { textLabel } from "../../core/label";
import type { DisplayState } from "./state";

export type Vec3 = [number, number, number];

export const GRADIENT_COLORS = { linear: 0xffd166, angular: 0x4dd0e1 };

/** The longest arrow of an automatic scale is at most this long (m), and over 0.4 of it. */
export const AUTO_LENGTH = 0.25;

/** The 1-2-5 step at or below x > 0. */
export function niceBelow(x: number): number {
  const e = Math.floor(Math.log10(x));
  const m = x / 10 ** e;
  return (m >= 5 ? 5 : m >= 2 ? 2 : 1) * 10 ** e;
}

/** Arrow metres per unit of gradient for the largest norm shown: a 1-2-5 step, a function of the
 *  result alone (a link opened elsewhere draws the same lengths). */
export function autoScale(maxNorm: number): number {
  return maxNorm > 0 && Number.isFinite(maxNorm) ? niceBelow(AUTO_LENGTH / maxNorm) : 1;
}

const norm = (v: number[]) => Math.hypot(v[0], v[1], v[2]);
const fmtScale = (x: number) => String(Number(x.toPrecision(3)));

/** Meshes drawn over everything (the arrows start inside or between the translucent shapes). */
function material(color: number): THREE.MeshBasicMaterial {
  return new THREE.MeshBasicMaterial({ color, depthTest: false, depthWrite: false, transparent: true });
}

const UP = new THREE.Vector3(0, 1, 0);
/** An arrow is a THREE.Group of this render order: three.js sorts a group's meshes by it before
 *  their own renderOrder, so the arrows are drawn after the transform handles (TransformControls:
 *  renderOrder Infinity, group order 0), which otherwise cover B's ∂D/∂θ at its origin. */
const ABOVE_HANDLES = 1;
const SHAFT = 0.004; // m
const HEAD = 0.012;

/** A straight arrow from an origin along a direction (a cylinder and a cone along the group's +y),
 *  named at its tip when given a label (whose shape's arrow it is: the two linear arrows start
 *  at nearly the same point between the shapes). */
class StraightArrow extends THREE.Group {
  private readonly shaft: THREE.Mesh;
  private readonly head: THREE.Mesh;
  readonly label: THREE.Sprite | null;
  length = 0;

  constructor(mat: THREE.Material, cylinder: THREE.BufferGeometry, cone: THREE.BufferGeometry, label?: { text: string; color: number }) {
    super();
    this.shaft = new THREE.Mesh(cylinder, mat);
    this.head = new THREE.Mesh(cone, mat);
    for (const m of [this.shaft, this.head]) {
      m.renderOrder = 11;
      m.frustumCulled = false;
      this.add(m);
    }
    this.label = label ? textLabel(label.text, label.color, 0.025) : null;
    if (this.label) this.add(this.label);
    this.visible = false;
    this.renderOrder = ABOVE_HANDLES;
  }

  set(origin: THREE.Vector3, dir: THREE.Vector3, length: number): void {
    this.length = length;
    this.visible = length > 1e-6;
    if (!this.visible) return;
    this.position.copy(origin);
    this.quaternion.setFromUnitVectors(UP, dir.clone().normalize());
    const head = Math.min(0.35 * length, 0.035);
    this.shaft.scale.set(SHAFT, length - head, SHAFT);
    this.shaft.position.set(0, (length - head) / 2, 0);
    this.head.scale.set(HEAD, head, HEAD);
    this.head.position.set(0, length - head / 2, 0);
    this.label?.position.set(0, length + 0.02, 0);
    this.updateMatrixWorld(true);
  }

  /** Its start and tip in world coordinates, and its label's text and place (null: hidden). */
  ends(): { origin: Vec3; tip: Vec3; label?: { text: string; at: Vec3 } } | null {
    if (!this.visible) return null;
    const out = { origin: this.position.toArray() as Vec3, tip: this.localToWorld(new THREE.Vector3(0, this.length, 0)).toArray() as Vec3 };
    return this.label ? { ...out, label: { text: String(this.label.userData.text), at: this.label.getWorldPosition(new THREE.Vector3()).toArray() as Vec3 } } : out;
  }
}

/** ∂D/∂θ: the axis arrow and, around it, three quarters of a circle ending in a cone (the sense
 *  of rotation about the axis that increases D). */
class CurvedArrow extends THREE.Group {
  readonly axis: StraightArrow;
  private readonly arc: THREE.Mesh;
  private readonly head: THREE.Mesh;
  radius = 0;

  constructor(mat: THREE.Material, cylinder: THREE.BufferGeometry, cone: THREE.BufferGeometry) {
    super();
    this.axis = new StraightArrow(mat, cylinder, cone);
    this.arc = new THREE.Mesh(new THREE.BufferGeometry(), mat);
    this.head = new THREE.Mesh(cone, mat);
    for (const m of [this.arc, this.head]) {
      m.renderOrder = 11;
      m.frustumCulled = false;
    }
    this.axis.add(this.arc, this.head);
    this.add(this.axis);
    this.renderOrder = ABOVE_HANDLES;
  }

  set(origin: THREE.Vector3, dir: THREE.Vector3, length: number): void {
    this.axis.set(origin, dir, length);
    if (!this.axis.visible) return;
    // In the axis arrow's frame (+y along the axis): a rotation by t about +y takes (R, 0, 0) to
    // (R cos t, 0, −R sin t); the arc runs that way from t = 0 to 1.5π around y = 0.6 length.
    const R = (this.radius = Math.min(0.06, Math.max(0.015, 0.3 * length)));
    const y = 0.6 * length;
    const end = 1.5 * Math.PI;
    const curve = new THREE.CatmullRomCurve3(Array.from({ length: 33 }, (_, i) => new THREE.Vector3(R * Math.cos((end * i) / 32), y, -R * Math.sin((end * i) / 32))));
    this.arc.geometry.dispose();
    this.arc.geometry = new THREE.TubeGeometry(curve, 48, SHAFT * 0.8, 6, false);
    const tangent = new THREE.Vector3(-Math.sin(end), 0, -Math.cos(end));
    this.head.quaternion.setFromUnitVectors(UP, tangent);
    this.head.scale.set(HEAD, 0.025, HEAD);
    this.head.position.set(R * Math.cos(end), y, -R * Math.sin(end)).addScaledVector(tangent, 0.0125);
    this.axis.updateMatrixWorld(true);
  }

  /** Frees its arc (the cylinder, cone and materials are the layer's). */
  release(): void {
    this.arc.geometry.dispose();
  }
}

export interface GradientInput {
  witness_a: number[];
  witness_b: number[];
  gradient_a: number[];
  gradient_b: number[];
}

type ArrowEnds = NonNullable<ReturnType<StraightArrow["ends"]>>;

/** What is drawn, in world coordinates, for the tests: each arrow's start, tip and label. */
export interface DrawnGradient {
  scales: { linear: number; angular: number };
  a: { linear: ArrowEnds | null; angular: ArrowEnds | null };
  b: { linear: ArrowEnds | null; angular: ArrowEnds | null };
}

export class GradientArrows {
  readonly group = new THREE.Group();
  private readonly linear: { a: StraightArrow; b: StraightArrow };
  private readonly angular: { a: CurvedArrow; b: CurvedArrow };
  private readonly geometries: THREE.BufferGeometry[];
  private readonly materials: THREE.Material[];
  /** The scales in use (arrow metres per m/m and per m/rad). */
  scales = { linear: 1, angular: 1 };
  /** A gradient is drawn (false: hidden, or no gradient: overlap, an error, display off). */
  shown = false;

  constructor() {
    const cylinder = new THREE.CylinderGeometry(1, 1, 1, 10);
    const cone = new THREE.ConeGeometry(1, 1, 16);
    const lin = material(GRADIENT_COLORS.linear);
    const ang = material(GRADIENT_COLORS.angular);
    this.geometries = [cylinder, cone];
    this.materials = [lin, ang];
    const named = (k: string) => ({ text: `∂D/∂p ${k}`, color: GRADIENT_COLORS.linear });
    this.linear = { a: new StraightArrow(lin, cylinder, cone, named("A")), b: new StraightArrow(lin, cylinder, cone, named("B")) };
    this.angular = { a: new CurvedArrow(ang, cylinder, cone), b: new CurvedArrow(ang, cylinder, cone) };
    this.group.add(this.linear.a, this.linear.b, this.angular.a, this.angular.b);
    this.group.name = "gradient-arrows";
  }

  /** Draws a result's gradients (null or without gradients: hides them). `origins`: the shapes'
   *  origins of the request that gave it. */
  set(r: Partial<GradientInput> | null, origins: { a: Vec3; b: Vec3 }, display: DisplayState): void {
    const ga = r?.gradient_a,
      gb = r?.gradient_b;
    const ok = display.gradient && !!ga && !!gb && !!r?.witness_a && !!r?.witness_b && norm(ga) + norm(ga.slice(3)) + norm(gb) + norm(gb.slice(3)) > 0;
    this.shown = ok;
    this.group.visible = ok;
    if (!ok) return;
    this.scales = {
      linear: display.linearScale > 0 ? display.linearScale : autoScale(Math.max(norm(ga), norm(gb))),
      angular: display.angularScale > 0 ? display.angularScale : autoScale(Math.max(norm(ga.slice(3)), norm(gb.slice(3)))),
    };
    const put = (k: "a" | "b", g: number[], witness: number[]) => {
      const lin = new THREE.Vector3(g[0], g[1], g[2]);
      const ang = new THREE.Vector3(g[3], g[4], g[5]);
      this.linear[k].set(new THREE.Vector3(witness[0], witness[1], witness[2]), lin, this.scales.linear * lin.length());
      this.angular[k].set(new THREE.Vector3(...origins[k]), ang, this.scales.angular * ang.length());
    };
    put("a", ga, r.witness_a!);
    put("b", gb, r.witness_b!);
  }

  drawn(): DrawnGradient | null {
    if (!this.shown) return null;
    const of = (k: "a" | "b") => ({ linear: this.linear[k].ends(), angular: this.angular[k].axis.ends() });
    return { scales: { ...this.scales }, a: of("a"), b: of("b") };
  }

  /** The legend's two lines: what each arrow is and its scale (a reference length of 0.1 m). */
  legend(): { linear: string; angular: string } {
    if (!this.shown) return { linear: "", angular: "" };
    return {
      linear: `→ ∂D/∂p (m/m, linear part) from the witness point: 0.1 m of arrow = ${fmtScale(0.1 / this.scales.linear)} m/m`,
      angular: `↻ ∂D/∂θ (m/rad, angular part) about the origin: 0.1 m of axis = ${fmtScale(0.1 / this.scales.angular)} m/rad`,
    };
  }

  dispose(): void {
    for (const arrow of [this.linear.a, this.linear.b]) {
      arrow.label?.material.map?.dispose();
      arrow.label?.material.dispose();
    }
    this.angular.a.release();
    this.angular.b.release();
    this.geometries.forEach((g) => g.dispose());
    this.materials.forEach((m) => m.dispose());
  }
}
