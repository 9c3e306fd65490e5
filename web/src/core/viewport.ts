// One three.js viewport per view: renderer, perspective camera, orbit controls, lights, grid.
// Renders on demand (invalidate()) so an idle tab costs nothing; frame statistics are kept for
// the status bar and the browser tests (window.distlab.stats()).
import * as THREE from "three";
import { OrbitControls } from "three/addons/controls/OrbitControls.js";

export class Viewport {
  readonly renderer: THREE.WebGLRenderer;
  readonly scene = new THREE.Scene();
  readonly camera: THREE.PerspectiveCamera;
  readonly controls: OrbitControls;
  readonly grid: THREE.GridHelper;
  private dirty = true;
  private raf = 0;
  private resizeObserver: ResizeObserver;
  private frameTimes: number[] = []; // ms between rendered frames while interacting
  private lastFrame = 0;
  private beforeRender = new Set<() => void>();

  constructor(readonly container: HTMLElement, opts: { up?: "y" | "z" } = {}) {
    this.renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
    this.renderer.setPixelRatio(Math.min(window.devicePixelRatio, 2));
    this.renderer.localClippingEnabled = true;
    this.renderer.domElement.classList.add("viewport-canvas");
    container.appendChild(this.renderer.domElement);

    this.scene.background = new THREE.Color(0x15181d);
    this.camera = new THREE.PerspectiveCamera(45, 1, 0.001, 200);
    if (opts.up === "z") this.camera.up.set(0, 0, 1);
    this.camera.position.set(1.6, 1.2, 1.6);
    this.controls = new OrbitControls(this.camera, this.renderer.domElement);
    this.controls.enableDamping = false;
    this.controls.addEventListener("change", () => this.invalidate());

    this.scene.add(new THREE.HemisphereLight(0xffffff, 0x334455, 1.6));
    const sun = new THREE.DirectionalLight(0xffffff, 1.8);
    sun.position.set(2, 3, 4);
    this.scene.add(sun);
    this.grid = new THREE.GridHelper(4, 40, 0x3a4049, 0x262b31);
    if (opts.up === "z") this.grid.rotation.x = Math.PI / 2;
    this.scene.add(this.grid);

    this.resizeObserver = new ResizeObserver(() => this.resize());
    this.resizeObserver.observe(container);
    this.resize();
    const loop = (now: number) => {
      this.raf = requestAnimationFrame(loop);
      if (!this.dirty) return;
      this.dirty = false;
      this.beforeRender.forEach((f) => f());
      this.renderer.render(this.scene, this.camera);
      if (this.lastFrame && now - this.lastFrame < 250) {
        this.frameTimes.push(now - this.lastFrame);
        if (this.frameTimes.length > 240) this.frameTimes.shift();
      }
      this.lastFrame = now;
    };
    this.raf = requestAnimationFrame(loop);
  }

  invalidate(): void {
    this.dirty = true;
  }

  onBeforeRender(f: () => void): () => void {
    this.beforeRender.add(f);
    return () => this.beforeRender.delete(f);
  }

  /** Median and 95th percentile frame interval (ms) of recent interactive frames. */
  frameStats(): { frames: number; medianMs: number; p95Ms: number; triangles: number } {
    const s = [...this.frameTimes].sort((a, b) => a - b);
    const q = (p: number) => (s.length ? s[Math.min(s.length - 1, Math.floor(p * s.length))] : 0);
    return { frames: s.length, medianMs: q(0.5), p95Ms: q(0.95), triangles: this.renderer.info.render.triangles };
  }
  resetFrameStats(): void {
    this.frameTimes = [];
    this.lastFrame = 0;
  }

  /** Frames the camera on a bounding box. */
  frame(box: THREE.Box3): void {
    if (box.isEmpty()) return;
    const c = box.getCenter(new THREE.Vector3());
    const r = Math.max(1e-3, box.getSize(new THREE.Vector3()).length() / 2);
    const dir = this.camera.position.clone().sub(this.controls.target).normalize();
    this.controls.target.copy(c);
    this.camera.position.copy(c).addScaledVector(dir, r / Math.sin((this.camera.fov * Math.PI) / 360) * 1.1);
    this.camera.near = r / 100;
    this.camera.far = r * 100;
    this.camera.updateProjectionMatrix();
    this.controls.update();
    this.invalidate();
  }

  /** PNG of the current view. */
  screenshot(): Promise<Blob> {
    this.renderer.render(this.scene, this.camera);
    return new Promise((resolve, reject) =>
      this.renderer.domElement.toBlob((b) => (b ? resolve(b) : reject(new Error("screenshot failed"))), "image/png"),
    );
  }

  private resize(): void {
    const w = Math.max(1, this.container.clientWidth);
    const h = Math.max(1, this.container.clientHeight);
    this.renderer.setSize(w, h, false);
    this.camera.aspect = w / h;
    this.camera.updateProjectionMatrix();
    this.invalidate();
  }

  dispose(): void {
    cancelAnimationFrame(this.raf);
    this.resizeObserver.disconnect();
    this.controls.dispose();
    this.scene.traverse((o) => {
      const m = o as THREE.Mesh;
      m.geometry?.dispose();
      const mat = m.material as THREE.Material | THREE.Material[] | undefined;
      if (Array.isArray(mat)) mat.forEach((x) => x.dispose());
      else mat?.dispose();
    });
    this.renderer.dispose();
    this.renderer.domElement.remove();
  }
}
