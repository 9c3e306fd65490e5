// One three.js viewport per view: renderer, perspective camera, orbit controls, lights, grid.
// Renders on demand: invalidate() (camera moved, new data, resize, an animation step) asks for
// one animation frame, so an idle tab runs no frame callbacks at all. Frame statistics are kept
// for the status bar and the browser tests (window.distlab.stats()).
import * as THREE from "three";
import { OrbitControls } from "three/addons/controls/OrbitControls.js";
import { drawUserScene } from "./user_scene_draw";

let softwareRenderer: boolean | null = null;

/** True when WebGL is rasterised on the CPU. */
export function isSoftwareRenderer(): boolean {
  if (softwareRenderer !== null) return softwareRenderer;
  const gl = document.createElement("canvas").getContext("webgl2");
  const ext = gl?.getExtension("WEBGL_debug_renderer_info");
  const name = gl && ext ? String(gl.getParameter(ext.UNMASKED_RENDERER_WEBGL)) : "";
  gl?.getExtension("WEBGL_lose_context")?.loseContext();
  softwareRenderer = /swiftshader|llvmpipe|softpipe|software/i.test(name);
  return softwareRenderer;
}

/** Antialiasing: on a GPU; off on a software renderer; localStorage "distlab.antialias" = "on"/"off" overrides. */
function antialiasWanted(): boolean {
  const forced = localStorage.getItem("distlab.antialias");
  return forced === "on" ? true : forced === "off" ? false : !isSoftwareRenderer();
}

/** Pixel-ratio factor of the frames drawn while the user drags or paints: 0.5 on a software
 *  renderer, where a frame's cost grows with its fragments (a quarter of them here), 1 on a GPU;
 *  localStorage "distlab.interactiveScale" (0 < x <= 1) overrides. */
function interactiveScaleWanted(): number {
  const forced = Number(localStorage.getItem("distlab.interactiveScale"));
  return forced > 0 && forced <= 1 ? forced : isSoftwareRenderer() ? 0.5 : 1;
}

/** Triangles of the stand-in drawn for a large mesh while the camera is dragged (stand_in.ts):
 *  25k on a software renderer, none on a GPU (0); localStorage "distlab.standInTriangles" overrides. */
function standInTrianglesWanted(): number {
  const forced = Number(localStorage.getItem("distlab.standInTriangles")?.trim() || NaN); // unset, "" or junk: NaN
  if (forced >= 0) return Math.floor(forced);
  return isSoftwareRenderer() ? 25_000 : 0;
}

/** After the last interactive frame, this long without one brings the full resolution back. */
const SETTLE_MS = 250;

export class Viewport {
  readonly renderer: THREE.WebGLRenderer;
  readonly scene = new THREE.Scene();
  readonly camera: THREE.PerspectiveCamera;
  readonly controls: OrbitControls;
  readonly grid: THREE.GridHelper;
  private raf = 0; // the requested animation frame (0: none)
  private disposed = false;
  private readonly fullRatio = Math.min(window.devicePixelRatio, 2);
  private readonly interactiveScale = interactiveScaleWanted();
  private interactiveUntil = 0; // performance.now() until which frames use the interactive scale
  private settleTimer = 0;
  private lowRes = false;
  private dragging = false; // the orbit controls are between their start and end events
  /** Stand-in size for large meshes while orbiting (0: stand-ins are not used). */
  readonly standInTriangles = standInTrianglesWanted();
  private standIns = new Map<THREE.Mesh, THREE.BufferGeometry>();
  private standInFrames = 0; // frames drawn with the stand-ins
  private standInFrameTriangles = 0; // triangles drawn in the last of them
  private resizeObserver: ResizeObserver;
  private frameTimes: number[] = []; // ms between rendered frames while interacting
  private cpuTimes: number[] = []; // main-thread ms per frame: before-render hooks + render() call
  private lastFrame = 0;
  private beforeRender = new Set<() => void>();
  private afterRender = new Set<(renderMs: number) => void>();
  /** Measuring only: read one pixel back after each frame so its time includes the GPU's (a stall). */
  syncRender = false;
  private readonly pixel = new Uint8Array(4);
  private readonly stopUserScene: () => void;

  constructor(
    readonly container: HTMLElement,
    opts: { up?: "y" | "z" } = {},
  ) {
    // MSAA quadruples a software rasteriser's per-pixel work (SwiftShader, llvmpipe: no GPU),
    // where it makes every frame several times slower; a GPU does it almost for free.
    this.renderer = new THREE.WebGLRenderer({ antialias: antialiasWanted(), preserveDrawingBuffer: true });
    this.renderer.setPixelRatio(this.fullRatio);
    this.renderer.localClippingEnabled = true;
    this.renderer.domElement.classList.add("viewport-canvas");
    container.appendChild(this.renderer.domElement);

    this.scene.background = new THREE.Color(0x15181d);
    this.camera = new THREE.PerspectiveCamera(45, 1, 0.001, 200);
    if (opts.up === "z") this.camera.up.set(0, 0, 1);
    this.camera.position.set(1.6, 1.2, 1.6);
    this.controls = new OrbitControls(this.camera, this.renderer.domElement);
    this.controls.enableDamping = false;
    this.controls.addEventListener("start", () => (this.dragging = true));
    this.controls.addEventListener("end", () => {
      this.dragging = false;
      // The full meshes again: the settle frame draws them, or at once when there is none.
      if (this.interactiveScale >= 1) this.invalidate();
    });
    this.controls.addEventListener("change", () => (this.dragging ? this.interacting() : this.invalidate()));

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
    this.stopUserScene = drawUserScene(this); // the user's own items (Client.scene) in every view
  }

  /** Something visible changed: draw it at the next animation frame (once, however often called). */
  invalidate(): void {
    if (this.raf || this.disposed) return;
    this.raf = requestAnimationFrame((now) => this.draw(now));
  }

  /** The user is interacting (orbiting, painting): draw at the next animation frame at the
   *  interactive resolution, and at full resolution once it has been quiet for SETTLE_MS. */
  interacting(): void {
    if (this.interactiveScale < 1 && !this.disposed) {
      this.interactiveUntil = performance.now() + SETTLE_MS;
      window.clearTimeout(this.settleTimer);
      this.settleTimer = window.setTimeout(() => this.invalidate(), SETTLE_MS + 10);
    }
    this.invalidate();
  }

  /** True while frames are drawn at the interactive (reduced) resolution. */
  get interactiveResolution(): boolean {
    return this.lowRes;
  }

  /** Resizes the drawing buffer. On SwiftShader that makes setSize wait for the GPU process
   *  (synchronous GetGLError / CheckFramebufferStatus, 6-77 ms, twice per σ stroke; Chrome trace).
   *  Tried instead: a fixed-size canvas with interactive frames drawn into a half-size render
   *  target and blitted up. No waits, but slower overall (the full-size blit and compositing):
   *  stroke → frame median 78 → 102 ms (--disable-gpu), 82 → 93 ms (GPU compositing), orbit
   *  frame interval 33 → 50 ms; so the canvas is still resized. */
  private setLowRes(low: boolean): void {
    if (low === this.lowRes) return;
    this.lowRes = low;
    this.renderer.setPixelRatio(this.fullRatio * (low ? this.interactiveScale : 1)); // keeps the CSS size
  }

  /** While the camera is dragged, `mesh` is drawn as `standIn` (a simplification sharing its
   *  vertex attributes); null removes it. The caller owns and disposes both geometries. */
  setStandIn(mesh: THREE.Mesh, standIn: THREE.BufferGeometry | null): void {
    if (standIn) this.standIns.set(mesh, standIn);
    else this.standIns.delete(mesh);
  }

  private draw(now: number): void {
    this.raf = 0;
    this.setLowRes(performance.now() < this.interactiveUntil);
    const t0 = performance.now();
    this.beforeRender.forEach((f) => f());
    const t1 = performance.now();
    const swapped: Array<[THREE.Mesh, THREE.BufferGeometry]> = [];
    if (this.dragging)
      for (const [mesh, standIn] of this.standIns)
        if (mesh.parent) {
          swapped.push([mesh, mesh.geometry]);
          mesh.geometry = standIn;
        }
    this.renderer.render(this.scene, this.camera);
    swapped.forEach(([mesh, full]) => (mesh.geometry = full));
    if (swapped.length) {
      this.standInFrames++;
      this.standInFrameTriangles = this.renderer.info.render.triangles;
    }
    if (this.syncRender) {
      const gl = this.renderer.getContext();
      gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, this.pixel); // waits for the frame (gl.finish does not in Chrome)
    }
    const t2 = performance.now();
    this.afterRender.forEach((f) => f(t2 - t1));
    if (this.lastFrame && now - this.lastFrame < 250) {
      this.frameTimes.push(now - this.lastFrame);
      this.cpuTimes.push(t2 - t0);
      if (this.frameTimes.length > 240) this.frameTimes.shift();
      if (this.cpuTimes.length > 240) this.cpuTimes.shift();
    }
    this.lastFrame = now;
  }

  onBeforeRender(f: () => void): () => void {
    this.beforeRender.add(f);
    return () => this.beforeRender.delete(f);
  }

  /** Called after each rendered frame with the render's duration (ms; GPU included when syncRender). */
  onAfterRender(f: (renderMs: number) => void): () => void {
    this.afterRender.add(f);
    return () => this.afterRender.delete(f);
  }

  /** Median and 95th percentile frame interval (ms) of recent interactive frames, and the main
   *  thread's time per frame (hooks + render call, without waiting for the GPU). */
  frameStats(): {
    frames: number;
    medianMs: number;
    p95Ms: number;
    cpuMedianMs: number;
    cpuP95Ms: number;
    triangles: number;
    standInFrames: number;
    standInFrameTriangles: number;
  } {
    const q = (a: number[], p: number) => {
      const s = [...a].sort((x, y) => x - y);
      return s.length ? s[Math.min(s.length - 1, Math.floor(p * s.length))] : 0;
    };
    const ft = this.frameTimes,
      ct = this.cpuTimes;
    return {
      frames: ft.length,
      medianMs: q(ft, 0.5),
      p95Ms: q(ft, 0.95),
      cpuMedianMs: q(ct, 0.5),
      cpuP95Ms: q(ct, 0.95),
      triangles: this.renderer.info.render.triangles,
      standInFrames: this.standInFrames,
      standInFrameTriangles: this.standInFrameTriangles,
    };
  }
  resetFrameStats(): void {
    this.standInFrames = this.standInFrameTriangles = 0;
    this.frameTimes = [];
    this.cpuTimes = [];
    this.lastFrame = 0;
  }

  /** Frames the camera on a bounding box. */
  frame(box: THREE.Box3): void {
    if (box.isEmpty()) return;
    const c = box.getCenter(new THREE.Vector3());
    const r = Math.max(1e-3, box.getSize(new THREE.Vector3()).length() / 2);
    const dir = this.camera.position.clone().sub(this.controls.target).normalize();
    this.controls.target.copy(c);
    this.camera.position.copy(c).addScaledVector(dir, (r / Math.sin((this.camera.fov * Math.PI) / 360)) * 1.1);
    this.camera.near = r / 100;
    this.camera.far = r * 100;
    this.camera.updateProjectionMatrix();
    this.controls.update();
    this.invalidate();
  }

  /** PNG of the current view. */
  screenshot(): Promise<Blob> {
    this.setLowRes(false);
    this.renderer.render(this.scene, this.camera);
    return new Promise((resolve, reject) => this.renderer.domElement.toBlob((b) => (b ? resolve(b) : reject(new Error("screenshot failed"))), "image/png"));
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
    this.stopUserScene();
    this.disposed = true;
    cancelAnimationFrame(this.raf);
    window.clearTimeout(this.settleTimer);
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
