// window.distlab.kelvin: read-only views of what the page shows and how long things took, for
// the browser tests and for measuring (nothing here changes the view's state).
import type { ColorBarState } from "../../core/colorbar";
import type { HistogramData } from "../../core/histogram";
import { Color } from "three";
import type { Viewport } from "../../core/viewport";
import type { IsoFrameInfo } from "../../core/iso_layers";
import type { IsoLegendRow } from "../../core/iso_legend";
import type { ObjectStatus } from "./object_source";
import type { ProbeReading } from "./probe";
import type { SigmaBody } from "./sigma";
import type { SurfaceOrigin } from "./surface_source";
import type { SurfaceLayer } from "./surface_layer";

export interface Timings {
  prepareMs: number[];
  /** σ edit's first mouse event → the iso-surface frames of that σ drawn. */
  strokeToFrameMs: Array<{
    version: number;
    ms: number; // the whole: mouse event → the frame showing it rendered
    waitMs: number; // event → σ sent (an earlier edit's frames still on their way)
    putMs: number; // sent → the server's acknowledgement (socket message, or PUT response)
    serverMs: number; // server: edit received → its last frame sent (solve, iso-surfaces, queueing)
    framesMs: number; // sent → the last frame of this σ arrived (server + transfer)
    decodeMs: number; // msgpack decode of its frames (sum)
    acceptMs: number; // frames → geometries (normals, bounds; sum)
    rafWaitMs: number; // last geometry ready → the animation frame that draws it begins
    renderMs: number; // that frame's render (GPU included when syncRender is set)
    drawMs: number; // last geometry ready → rendered
    fieldVertices: number;
    lx: number;
  }>;
  /** Mouse event → the surface's σ colours drawn (local, no server round trip). */
  strokeToColourMs: number[];
  sliceMs: number[];
}

export interface KelvinHookSource {
  viewport(): Viewport | null;
  objectId(): string | null;
  status(): ObjectStatus | null;
  /** The object is ready and every watched level has a frame for the current σ. */
  ready(): boolean;
  surfaceSource(): SurfaceOrigin | null;
  frames(): IsoFrameInfo[];
  shown(): IsoFrameInfo[];
  sigma(): { body: SigmaBody; version: number };
  stateJson(): Record<string, unknown>;
  timings(): Timings;
  sliceSigmaVersion(): number;
  probe(): ProbeReading | null;
  displayTriangles(): number;
  /** Triangles of a repair's surface drawn over the input (0: none). */
  overlayTriangles(): number;
  /** The upload: the link's reference, its id here, the notice of a link's missing file and its
   *  refusal, the defects drawn (counts, marked edges with their file vertices and positions), the camera. */
  upload(): unknown;
  surface(): SurfaceLayer | null;
  /** σ at the input mesh's vertices, evaluated here (the server sends the same as surface scalars). */
  localSigmaAtInputVertices(): number[];
  /** The colour bars shown (σ on the surface, h on the slice). */
  colorbars(): ColorBarState[];
  sigmaHistogram(): HistogramData | null;
  /** The iso-surface legend's rows (level, colour, opacity, shell drawn). */
  isoLegend(): IsoLegendRow[];
  /** The shells as drawn: level, material colour and opacity, the share of it left facing the viewer. */
  shells(): Array<{ level: number; color: string; opacity: number; facingOpacity: number; visible: boolean }>;
  /** What a ray through a page point meets, nearest first ("surface", "iso 0.25", "slice"). */
  pickAt(x: number, y: number): string[];
}

/** Turns the camera about its up axis around the orbit target. */
function orbitStep(vp: Viewport, angle: number): void {
  const cam = vp.camera,
    target = vp.controls.target;
  cam.position.sub(target).applyAxisAngle(cam.up, angle).add(target);
  cam.lookAt(target);
}

export function installHooks(view: KelvinHookSource): void {
  const copy = <T>(x: T): T => structuredClone(x);
  const hooks = Object.freeze({
    get objectId() {
      return view.objectId();
    },
    get object() {
      return copy(view.status());
    },
    get ready() {
      return view.ready();
    },
    /** "socket" when the shown surface is the frame the socket pushed, "rest" when fetched. */
    get surfaceSource() {
      return view.surfaceSource();
    },
    /** Every iso-surface frame accepted (level, sigma_version, vertex/face counts, hash). */
    get frames() {
      return copy(view.frames());
    },
    get shown() {
      return copy(view.shown());
    },
    get sigma() {
      return copy(view.sigma());
    },
    get state() {
      return copy(view.stateJson());
    },
    get timings() {
      return copy(view.timings());
    },
    get sliceSigmaVersion() {
      return view.sliceSigmaVersion();
    },
    get probe() {
      return copy(view.probe());
    },
    get displayTriangles() {
      return view.displayTriangles();
    },
    get overlayTriangles() {
      return view.overlayTriangles();
    },
    get upload() {
      return copy(view.upload());
    },
    /** The surface's stand-in while orbiting: its triangles and the simplifier's error bound (m). */
    get standIn() {
      const s = view.surface()?.standIn;
      return s ? { triangles: s.triangles, error: s.error } : null;
    },
    /** The stand-in's triangles as corner coordinates (9 numbers each; an index past the
     *  surface's vertices reads as null), for geometric checks. */
    standInTriangles: () => {
      const g = view.surface()?.standIn?.geometry;
      if (!g) return null;
      const index = g.getIndex()!.array,
        pos = g.getAttribute("position");
      return Array.from(index, (v) => [pos.getX(v), pos.getY(v), pos.getZ(v)]).flat();
    },
    localSigmaAtInputVertices: () => view.localSigmaAtInputVertices(),
    get colorbars() {
      return copy(view.colorbars());
    },
    get sigmaHistogram() {
      return copy(view.sigmaHistogram());
    },
    get isoLegend() {
      return copy(view.isoLegend());
    },
    get shells() {
      return copy(view.shells());
    },
    pickAt: (x: number, y: number) => view.pickAt(x, y),
    /** σ and the colour (sRGB bytes) at every k-th display vertex of the surface. */
    surfaceColors: (step = 1) => {
      const s = view.surface();
      if (!s) return null;
      const sigma = s.sigmaValues(),
        col = s.mesh.geometry.getAttribute("color");
      const c = new Color(),
        out: Array<{ sigma: number; rgb: number[] }> = [];
      for (let v = 0; v < sigma.length; v += step) {
        c.setRGB(col.getX(v), col.getY(v), col.getZ(v)).convertLinearToSRGB();
        out.push({ sigma: sigma[v], rgb: [c.r, c.g, c.b].map((x) => Math.round(x * 255)) });
      }
      return { vertices: sigma.length, samples: out };
    },
    /** σ on the surface's display vertices: its smallest and largest value, and the colour range. */
    get sigmaRange() {
      const s = view.surface();
      return s ? { data: [...s.dataRange], color: [...s.colorRange] } : null;
    },
    frameStats: () => view.viewport()?.frameStats() ?? null,
    /** Orbits the camera through n frames rendered back to back (each waited for by reading a pixel back)
     *  and puts it back; returns per-frame render times (ms) and the triangles drawn. */
    measureOrbit: (n = 30) => {
      const vp = view.viewport();
      if (!vp) return null;
      const cam = vp.camera,
        saved = cam.position.clone(),
        target = vp.controls.target;
      const gl = vp.renderer.getContext(),
        times: number[] = [],
        px = new Uint8Array(4);
      for (let i = 0; i < n; i++) {
        orbitStep(vp, (2 * Math.PI) / n);
        const t = performance.now();
        vp.renderer.render(vp.scene, cam);
        gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, px); // waits for the frame (gl.finish does not in Chrome)
        times.push(performance.now() - t);
      }
      cam.position.copy(saved);
      cam.lookAt(target);
      vp.invalidate();
      return { times, triangles: vp.renderer.info.render.triangles, width: gl.drawingBufferWidth, height: gl.drawingBufferHeight };
    },
    resetFrameStats: () => view.viewport()?.resetFrameStats(),
    /** Drags the camera around the object through n animation frames, as the orbit controls do
     *  (start, a camera step per frame, end), without the mouse, whose events (a CDP round trip
     *  each) would pace the frames; resolves to the frame statistics of the drag. */
    orbitDrive: (n = 120) =>
      new Promise((resolve) => {
        const vp = view.viewport();
        if (!vp) return resolve(null);
        vp.resetFrameStats();
        vp.controls.dispatchEvent({ type: "start" });
        let i = 0;
        const step = () => {
          if (i++ === n) {
            const stats = vp.frameStats();
            vp.controls.dispatchEvent({ type: "end" });
            return resolve(stats);
          }
          orbitStep(vp, (2 * Math.PI) / n);
          vp.interacting();
          requestAnimationFrame(step);
        };
        requestAnimationFrame(step);
      }),
    /** Measuring (A/B in one run): orbit with the surface's stand-in, or with the full surface. */
    useStandIn: (on: boolean) => {
      const vp = view.viewport(),
        s = view.surface();
      if (vp && s) vp.setStandIn(s.mesh, on ? (s.standIn?.geometry ?? null) : null);
    },
    /** Measuring: make every frame wait for its pixels (its render time then includes the GPU's). */
    syncRender: (on: boolean) => {
      const vp = view.viewport();
      if (vp) vp.syncRender = on;
    },
    /** GL data uploads (buffers, textures) since the first call, and three.js's resource counts. */
    glUploads: () => {
      const vp = view.viewport();
      if (!vp) return null;
      const gl = vp.renderer.getContext() as WebGL2RenderingContext & { __uploads?: Record<string, number> };
      if (!gl.__uploads) {
        const counts: Record<string, number> = { bufferData: 0, bufferSubData: 0, texImage2D: 0, texSubImage2D: 0, bytes: 0 };
        for (const name of ["bufferData", "bufferSubData", "texImage2D", "texSubImage2D"] as const) {
          const f = (gl[name] as (...a: unknown[]) => unknown).bind(gl);
          (gl as unknown as Record<string, unknown>)[name] = (...args: unknown[]) => {
            counts[name]++;
            const data = args.find((x) => ArrayBuffer.isView(x)) as ArrayBufferView | undefined;
            counts.bytes += data?.byteLength ?? (typeof args[1] === "number" && name === "bufferData" ? args[1] : 0);
            return f(...args);
          };
        }
        gl.__uploads = counts;
      }
      const info = vp.renderer.info;
      return {
        ...gl.__uploads,
        geometries: info.memory.geometries,
        textures: info.memory.textures,
        programs: info.programs?.length ?? 0,
        calls: info.render.calls,
        triangles: info.render.triangles,
      };
    },
    /** Canvas pixel position of a world point (tests aim the real mouse with it). */
    toScreen: (p: [number, number, number]) => {
      const vp = view.viewport();
      if (!vp) return null;
      const r = vp.renderer.domElement.getBoundingClientRect();
      const v = vp.camera.position.clone().set(p[0], p[1], p[2]).project(vp.camera);
      return { x: r.left + ((v.x + 1) / 2) * r.width, y: r.top + ((1 - v.y) / 2) * r.height };
    },
  });
  const w = window as unknown as { distlab?: Record<string, unknown> };
  w.distlab ??= {};
  w.distlab.kelvin = hooks;
}
