// window.distlab.kelvin: read-only views of what the page shows and how long things took, for
// the browser tests and for measuring (nothing here changes the view's state).
import type { KelvinView } from "./kelvin_view";

export interface Timings {
  prepareMs: number[];
  /** σ edit's first mouse event → the iso-surface frames of that σ drawn. */
  strokeToFrameMs: Array<{
    version: number;
    ms: number; // the whole: mouse event → drawn
    waitMs: number; // event → PUT sent (an earlier edit's frames still on their way)
    putMs: number; // PUT round trip
    framesMs: number; // PUT sent → the last frame of this σ arrived (server solve + iso + transfer)
    drawMs: number; // arrival → drawn (decode, geometry upload, render)
    fieldVertices: number;
    lx: number;
  }>;
  /** Mouse event → the surface's σ colours drawn (local, no server round trip). */
  strokeToColourMs: number[];
  sliceMs: number[];
}

export function installHooks(view: KelvinView): void {
  const copy = <T>(x: T): T => structuredClone(x);
  const hooks = Object.freeze({
    get objectId() {
      return view.currentObjectId;
    },
    get object() {
      return copy(view.currentStatus);
    },
    get ready() {
      return view.ready;
    },
    /** Every iso-surface frame accepted (level, sigma_version, vertex/face counts, hash). */
    get frames() {
      return copy(view.frames);
    },
    get shown() {
      return copy(view.shownFrames);
    },
    get sigma() {
      return copy(view.sigma);
    },
    get state() {
      return copy(view.stateJson);
    },
    get timings() {
      return copy(view.timings);
    },
    get sliceSigmaVersion() {
      return view.sliceSigmaVersion;
    },
    get probe() {
      return copy(view.probeReading);
    },
    get displayTriangles() {
      return view.displayTriangles;
    },
    localSigmaAtInputVertices: () => view.localSigmaAtInputVertices(),
    frameStats: () => view.view?.frameStats() ?? null,
    /** Orbits the camera through n frames rendered back to back (each waited for by reading a pixel back)
     *  and puts it back; returns per-frame render times (ms) and the triangles drawn. */
    measureOrbit: (n = 30) => {
      const vp = view.view;
      if (!vp) return null;
      const cam = vp.camera, saved = cam.position.clone(), target = vp.controls.target;
      const gl = vp.renderer.getContext(), times: number[] = [], px = new Uint8Array(4);
      for (let i = 0; i < n; i++) {
        cam.position.sub(target).applyAxisAngle(cam.up, (2 * Math.PI) / n).add(target);
        cam.lookAt(target);
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
    resetFrameStats: () => view.view?.resetFrameStats(),
    /** Canvas pixel position of a world point (tests aim the real mouse with it). */
    toScreen: (p: [number, number, number]) => {
      const vp = view.view;
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
