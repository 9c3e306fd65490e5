// Painting σ with the mouse: a stroke drops brush stamps where the pointer meets the surface
// (raycast on the input mesh), spaced by half the radius. A stamp paints *towards* the brush
// value (brush_stamp.ts): σ never passes it, however strokes overlap, and a stamp that would
// change nothing is skipped. While painting, orbiting is suspended.
import * as THREE from "three";
import type { BrushSettings } from "./brush_stamp";
import type { Brush, Vec3 } from "./sigma";

export interface BrushHost {
  camera: THREE.Camera;
  canvas: HTMLCanvasElement;
  target(): THREE.Mesh | null;
  /** The stamp at a point, or null when it would change nothing. */
  stampAt(settings: BrushSettings, centre: Vec3): Brush | null;
  setOrbit(enabled: boolean): void;
  /** One new stamp; eventTime is the pointer event's performance.now() time. */
  stamp(b: Brush, eventTime: number, strokeStart: boolean): void;
  strokeEnd(): void;
  hover(point: THREE.Vector3 | null, ev: PointerEvent): void;
}

export class BrushTool {
  enabled = true;
  settings: BrushSettings = { value: 1, radius: 0.1, falloff: 0.05 };
  private raycaster = new THREE.Raycaster();
  private painting = false;
  private last: THREE.Vector3 | null = null;
  private first = false;
  private cursor: THREE.Mesh;
  private offs: Array<() => void> = [];

  constructor(private readonly host: BrushHost) {
    this.cursor = new THREE.Mesh(
      new THREE.RingGeometry(0.9, 1, 48),
      new THREE.MeshBasicMaterial({ color: 0xffffff, transparent: true, opacity: 0.8, depthTest: false, side: THREE.DoubleSide }),
    );
    this.cursor.renderOrder = 50;
    this.cursor.visible = false;
    const c = host.canvas;
    const on = <K extends keyof HTMLElementEventMap>(type: K, f: (ev: HTMLElementEventMap[K]) => void, capture = false) => {
      c.addEventListener(type, f as EventListener, capture);
      this.offs.push(() => c.removeEventListener(type, f as EventListener, capture));
    };
    // Capture phase: we decide before OrbitControls whether this drag paints or orbits.
    on("pointerdown", (ev) => this.down(ev), true);
    on("pointermove", (ev) => this.move(ev));
    on("pointerup", () => this.up());
    on("pointercancel", () => this.up());
    on("pointerleave", () => (this.cursor.visible = false));
  }

  get object3d(): THREE.Object3D {
    return this.cursor;
  }

  get isPainting(): boolean {
    return this.painting;
  }

  private hit(ev: PointerEvent): THREE.Intersection | null {
    const target = this.host.target();
    if (!target) return null;
    const r = this.host.canvas.getBoundingClientRect();
    const ndc = new THREE.Vector2(((ev.clientX - r.left) / r.width) * 2 - 1, -((ev.clientY - r.top) / r.height) * 2 + 1);
    this.raycaster.setFromCamera(ndc, this.host.camera);
    return this.raycaster.intersectObject(target, false)[0] ?? null;
  }

  private down(ev: PointerEvent): void {
    if (!this.enabled || ev.button !== 0 || ev.shiftKey) return;
    const h = this.hit(ev);
    if (!h) return;
    ev.stopImmediatePropagation(); // OrbitControls never sees this drag
    this.host.canvas.setPointerCapture(ev.pointerId);
    this.painting = true;
    this.first = true;
    this.last = null;
    this.host.setOrbit(false);
    this.paintAt(h.point, performance.now());
  }

  private move(ev: PointerEvent): void {
    // A drag that is not painting orbits: no raycast per move (a 200k-triangle pick costs ms).
    const orbiting = !this.painting && ev.buttons !== 0;
    const h = this.enabled && !orbiting ? this.hit(ev) : null;
    this.showCursor(h);
    if (this.painting && h) this.paintAt(h.point, performance.now());
    if (!this.painting) this.host.hover(h ? h.point : null, ev);
  }

  private up(): void {
    if (!this.painting) return;
    this.painting = false;
    this.host.setOrbit(true);
    this.host.strokeEnd();
  }

  private paintAt(p: THREE.Vector3, t: number): void {
    const s = this.settings;
    if (this.last && this.last.distanceTo(p) < Math.max(s.radius * 0.5, 1e-9)) return;
    this.last = p.clone();
    const b = this.host.stampAt(s, [p.x, p.y, p.z]);
    if (!b) return;
    this.host.stamp(b, t, this.first);
    this.first = false;
  }

  private showCursor(h: THREE.Intersection | null): void {
    if (!h || !h.face) {
      this.cursor.visible = false;
      return;
    }
    this.cursor.visible = true;
    this.cursor.position.copy(h.point);
    this.cursor.lookAt(h.point.clone().add(h.face.normal));
    this.cursor.scale.setScalar(Math.max(1e-6, this.settings.radius));
  }

  dispose(): void {
    this.offs.forEach((f) => f());
    this.cursor.geometry.dispose();
    (this.cursor.material as THREE.Material).dispose();
  }
}
