// View 1, the GAP explorer: two shapes dragged with a gizmo, GAP (Λ, D, witness points, the
// gradient of D as arrows) beside the Euclidean distance live, parameters with the validator's verdict, iso-surfaces and a slice
// of e_S / E_S (Fig. 1 in 3D), and a sweep plot of D and dD/ds along a straight motion of B.
import * as THREE from "three";
import { TransformControls } from "three/addons/controls/TransformControls.js";
import { api, ApiError } from "../../core/api";
import type { Shortcut } from "../../core/keys";
import { LatestWins, type LatestResult } from "../../core/latest";
import { dismissToasts, toast } from "../../core/toast";
import type { View, ViewHost } from "../../core/view";
import { Viewport } from "../../core/viewport";
import "./gap.css";
import { IsoLayer } from "./levelsets";
import { GapPanel, type Change, type GizmoState } from "./panel";
import { Readout, statusLine, type GapResult } from "./readout";
import { installSliceHover } from "./slice_hover";
import { ColorBar } from "../../core/colorbar";
import { COLORS, GapScene } from "./scene";
import { GRADIENT_COLORS, GradientArrows } from "./gradient";
import { setPose, shapeBody, shapeRequest } from "./shapes";
import { defaultState, paramsBody, parseState, type GapState } from "./state";
import { Sweep } from "./sweep";

type DistanceInput = Pick<GapState, "a" | "b" | "params"> & { gradient: boolean };

export class GapView implements View {
  private host!: ViewHost;
  private viewport: Viewport | null = null;
  private state: GapState = defaultState();
  private readonly gizmoState: GizmoState = { selected: "b", mode: "translate", space: "world" };
  private scene!: GapScene;
  private gizmo!: TransformControls;
  private panel!: GapPanel;
  private readout!: Readout;
  private iso!: IsoLayer;
  private arrows!: GradientArrows;
  private legendEl!: HTMLElement;
  private sliceReading: () => unknown = () => null;
  private sweep!: Sweep;
  private distance!: LatestWins<DistanceInput, GapResult>;
  private result: GapResult | null = null;
  private lastError = "";
  private sweepTimer = 0;
  private pendingMoves: Array<{ seq: number; t: number }> = [];
  private latencies: number[] = []; // drag step → readout updated (ms)
  private roundTrips: number[] = [];
  private validatedKey = ""; // distance request → response (ms)
  private cleanup: Array<() => void> = [];

  mount(host: ViewHost, raw: Record<string, unknown>): void {
    this.host = host;
    this.state = parseState(raw);
    const vp = (this.viewport = new Viewport(host.canvas, { up: "z" }));
    vp.camera.position.set(0.9, -1.7, 1.3);
    this.scene = new GapScene(vp.scene);
    this.scene.setShape("a", this.state.a);
    this.scene.setShape("b", this.state.b);
    this.arrows = new GradientArrows();
    vp.scene.add(this.arrows.group);

    this.gizmo = new TransformControls(vp.camera, vp.renderer.domElement);
    this.gizmo.size = 0.9;
    vp.scene.add(this.gizmo.getHelper());
    this.gizmo.addEventListener("change", () => vp.invalidate());
    this.gizmo.addEventListener("dragging-changed", (e) => (vp.controls.enabled = !e.value));
    this.gizmo.addEventListener("objectChange", () => this.moved());
    this.gizmo.addEventListener("mouseUp", () => this.scheduleSweep(0));

    this.readout = new Readout(host.canvas);
    host.canvas.appendChild((this.legendEl = legend()));

    this.panel = new GapPanel(host.panel, this.state, this.gizmoState, (c) => this.changed(c), {
      reset: () => this.reset(),
      copyLink: () => void navigator.clipboard?.writeText(location.href).then(() => toast("link copied", "ok")),
      frame: () => this.frameAll(),
    });
    this.panel.onLevelError = (field, m) => (m === null ? dismissToasts(`gap:${field}`) : toast(m, "error", undefined, `gap:${field}`));

    this.iso = new IsoLayer(
      (err) => {
        if (err) this.reportError(err, "level sets");
        else this.cleared("level sets");
        vp.invalidate();
      },
      (busy) => host.progress(busy ? "computing level sets…" : null),
    );
    this.iso.colorBar = new ColorBar(host.canvas, "E_S on the slice", "m²", "colorbar-gap");
    const hover = installSliceHover(vp, this.iso, host.canvas, () => this.state.iso);
    this.cleanup.push(() => hover.remove());
    this.sliceReading = hover.last;
    this.sweep = new Sweep(host.bottom, (err) => (err ? this.reportError(err, "sweep") : this.cleared("sweep")));
    host.showBottom(true);

    this.distance = new LatestWins(
      async (i) => {
        const t0 = performance.now();
        // Property 2 depends on the shapes and parameters, not on the poses: validate only when
        // they changed since the last accepted check (saves ~10 ms of server time per drag step).
        const key = JSON.stringify([shapeBody(i.a), shapeBody(i.b), i.params]);
        const validate = key !== this.validatedKey;
        const body = { a: shapeRequest(i.a), b: shapeRequest(i.b), params: paramsBody(i.params, { gradient: i.gradient, validate }) };
        const r = await api.post<GapResult>("/api/gap/distance", body);
        if (validate && r.validation?.a?.ok && r.validation?.b?.ok) this.validatedKey = key;
        this.roundTrips.push(performance.now() - t0);
        if (this.roundTrips.length > 1000) this.roundTrips.shift();
        return r;
      },
      (r) => this.showDistance(r),
    );

    this.installPicking(vp);
    this.applyGizmo();
    this.attachIso();
    this.frameAll();
    this.requestDistance();
    this.iso.update(this.isoInput());
    this.scheduleSweep(0);
    this.exposeHooks();
  }

  // ---- changes -------------------------------------------------------------------------------

  private moved(): void {
    const k = this.gizmoState.selected;
    setPose(this.state[k], this.scene.groups[k]);
    const seq = this.requestDistance();
    this.pendingMoves.push({ seq, t: performance.now() });
    this.save();
  }

  private changed(c: Change): void {
    switch (c) {
      case "shape-a":
      case "shape-b": {
        const k = c === "shape-a" ? "a" : "b";
        this.scene.setShape(k, this.state[k]);
        if (this.state.iso.around === k) this.iso.update(this.isoInput());
        break;
      }
      case "params":
        this.state.params.k = Math.round(this.state.params.k);
        this.iso.update(this.isoInput());
        break;
      case "iso":
        this.attachIso();
        this.iso.update(this.isoInput());
        break;
      case "slice-style":
        this.iso.restyle(this.state.iso);
        break;
      case "gizmo":
        this.applyGizmo();
        return;
      case "sweep":
        break;
      case "display":
        // The arrows' scale needs no request; the gradient itself does when it was not asked for.
        if (this.state.display.gradient && this.result && !this.result.gradient_a) this.requestDistance();
        else {
          this.showGradient(this.result, { a: this.state.a.position, b: this.state.b.position });
          if (this.result) this.readout.show(this.result, this.state.params.solver, this.state.display.gradient);
        }
        this.viewport?.invalidate();
        this.save();
        return;
    }
    this.viewport?.invalidate();
    this.requestDistance();
    this.scheduleSweep(150);
    this.save();
  }

  private requestDistance(): number {
    const s = this.state;
    return this.distance.submit(structuredClone({ a: s.a, b: s.b, params: s.params, gradient: s.display.gradient }));
  }

  private showDistance(r: LatestResult<DistanceInput, GapResult>): void {
    const now = performance.now();
    this.pendingMoves = this.pendingMoves.filter((m) => {
      if (m.seq > r.seq) return true;
      this.latencies.push(now - m.t);
      return false;
    });
    if (this.latencies.length > 1000) this.latencies.splice(0, this.latencies.length - 1000);
    if (r.error !== undefined || !r.output) {
      this.result = null;
      this.validatedKey = ""; // the next request checks Property 2 again (and re-colours the verdict)
      this.scene.gap.set(null, null);
      this.scene.euclid.set(null, null);
      this.scene.pen.set(null, null);
      this.showGradient(null, null);
      const text = this.reportError(r.error, "distance");
      this.readout.error(text);
      this.host.status(`refused or failed — see the readout (${r.error instanceof ApiError && r.error.field ? r.error.field : "error"})`);
      this.viewport?.invalidate();
      return;
    }
    const res = (this.result = r.output);
    this.cleared("distance"); // the input the server refused is valid again
    this.readout.show(res, r.input.params.solver, this.state.display.gradient);
    this.showGradient(res, { a: r.input.a.position, b: r.input.b.position });
    this.host.status(statusLine(res, r.input.params.solver));
    this.scene.gap.set(res.witness_a, res.witness_b);
    this.scene.euclid.set(res.euclidean.witness_a, res.euclidean.witness_b);
    const pen = res.euclidean.penetration;
    this.scene.pen.set(pen?.witness_a ?? null, pen?.witness_b ?? null);
    const va = res.validation?.a,
      vb = res.validation?.b;
    if (va && vb)
      this.panel.setVerdict(va.ok && vb.ok, `✓ Property 2 holds: largest Hessian eigenvalue of E_S ${va.max_eigenvalue.toFixed(4)} (A), ${vb.max_eigenvalue.toFixed(4)} (B) < 1`);
    this.viewport?.invalidate();
  }

  /** The arrows of a result's gradient (null: none) and their legend lines with the scale. */
  private showGradient(r: GapResult | null, origins: { a: number[]; b: number[] } | null): void {
    const o = origins ?? { a: [0, 0, 0], b: [0, 0, 0] };
    this.arrows.set(r, { a: o.a as [number, number, number], b: o.b as [number, number, number] }, this.state.display);
    const text = this.arrows.legend();
    for (const k of ["linear", "angular"] as const) {
      const el = this.legendEl.querySelector<HTMLElement>(`[data-testid=gap-legend-grad-${k}]`);
      if (!el) continue;
      el.textContent = text[k];
      el.hidden = !text[k];
    }
  }

  /** A request of this kind succeeded: its error toast goes (and the same error would show again). */
  private cleared(what: string): void {
    dismissToasts(`gap:${what}`);
    if (what === "distance" || this.lastError.startsWith(`${what}: `)) this.lastError = "";
  }

  /** Shows an error readably (toast once per distinct message, red verdict for parameters). */
  private reportError(e: unknown, what: string): string {
    const text = e instanceof ApiError ? e.readable : e instanceof Error ? e.message : String(e);
    const field = e instanceof ApiError ? (e.field ?? "") : "";
    if (field.startsWith("params") || field === "a" || field === "b") this.panel.setVerdict(false, `✗ refused — ${text}`);
    // A refused parameter set fails the distance, the sweep and the level sets alike: the
    // verdict and the readout show it, one toast (from the distance) is enough.
    const refusal = field.startsWith("params") || field === "a" || field === "b" || /^pairs\[\d+\]\.(a|b|params)/.test(field);
    const key = `${what}: ${text}`;
    if (key !== this.lastError && (!refusal || what === "distance")) {
      this.lastError = key;
      toast(`${what}: ${text}`, "error", undefined, `gap:${what}`);
    }
    return text;
  }

  private scheduleSweep(ms: number): void {
    clearTimeout(this.sweepTimer);
    this.sweepTimer = window.setTimeout(() => {
      const s = this.state;
      this.sweep.update({ a: s.a, b: s.b, params: s.params, sweep: s.sweep });
    }, ms);
  }

  private isoInput() {
    const s = this.state;
    return { shape: s[s.iso.around], params: s.params, iso: s.iso };
  }

  private attachIso(): void {
    this.scene.groups[this.state.iso.around].add(this.iso.group);
  }

  private applyGizmo(): void {
    const g = this.gizmoState;
    this.gizmo.attach(this.scene.groups[g.selected]);
    this.gizmo.setMode(g.mode);
    this.gizmo.setSpace(g.space);
    this.scene.select(g.selected);
    this.panel.refresh();
    this.viewport?.invalidate();
  }

  private save(): void {
    this.host.saveState(structuredClone(this.state) as unknown as Record<string, unknown>);
  }

  private reset(): void {
    const d = defaultState();
    const s = this.state;
    for (const k of ["a", "b"] as const) {
      const size = s[k].size;
      Object.assign(s[k], d[k], { size });
      size.splice(0, 3, ...d[k].size);
      this.scene.setShape(k, s[k]);
    }
    Object.assign(s.params, d.params);
    Object.assign(s.iso, d.iso);
    Object.assign(s.sweep, d.sweep);
    Object.assign(s.display, d.display);
    this.panel.refresh();
    this.changed("iso");
    this.frameAll();
  }

  private nudge(axis: 0 | 1 | 2, step: number): void {
    const g = this.scene.groups[this.gizmoState.selected];
    g.position.setComponent(axis, g.position.getComponent(axis) + step);
    g.updateMatrixWorld(true);
    this.moved();
    this.scheduleSweep(250);
    this.viewport?.invalidate();
  }

  private frameAll(): void {
    const box = new THREE.Box3();
    for (const k of ["a", "b"] as const) box.expandByObject(this.scene.meshes[k]);
    this.viewport?.frame(box.expandByScalar(0.15));
  }

  // ---- picking: a click (not a drag) on a shape selects it for the gizmo -----------------------

  private installPicking(vp: Viewport): void {
    const dom = vp.renderer.domElement;
    let down: { x: number; y: number } | null = null;
    const onDown = (e: PointerEvent) => (down = { x: e.clientX, y: e.clientY });
    const onUp = (e: PointerEvent) => {
      if (!down || Math.hypot(e.clientX - down.x, e.clientY - down.y) > 4 || this.gizmo.dragging) return;
      down = null;
      const r = dom.getBoundingClientRect();
      const ndc = new THREE.Vector2(((e.clientX - r.left) / r.width) * 2 - 1, -((e.clientY - r.top) / r.height) * 2 + 1);
      const ray = new THREE.Raycaster();
      ray.setFromCamera(ndc, vp.camera);
      const hit = ray.intersectObjects([this.scene.meshes.a, this.scene.meshes.b], false)[0];
      const k = hit?.object.userData.shape as "a" | "b" | undefined;
      if (k && k !== this.gizmoState.selected) {
        this.gizmoState.selected = k;
        this.applyGizmo();
      }
    };
    dom.addEventListener("pointerdown", onDown);
    dom.addEventListener("pointerup", onUp);
    this.cleanup.push(() => {
      dom.removeEventListener("pointerdown", onDown);
      dom.removeEventListener("pointerup", onUp);
    });
  }

  // ---- hooks for tests and measurements (read-only) --------------------------------------------

  private exposeHooks(): void {
    const vp = this.viewport!;
    const hooks = {
      result: () => structuredClone(this.result),
      D: () => this.result?.distance ?? null,
      lambda: () => this.result?.lambda ?? null,
      euclidean: () => this.result?.euclidean.distance ?? null,
      /** Witness points drawn in the 3D view (null: hidden). */
      drawn: () => ({ gap: this.scene.gap.ends, euclid: this.scene.euclid.ends, pen: this.scene.pen.ends }),
      /** The gradient arrows drawn (world start and tip of each, the scales in use; null: none). */
      arrows: () => this.arrows.drawn(),
      requests: () => this.distance.sent,
      inFlight: () => this.distance.inFlight,
      readout: () => this.readout.text(),
      state: () => structuredClone(this.state),
      selected: () => this.gizmoState.selected,
      sweep: () => ({ data: this.sweep.last, plots: [this.sweep.dPlot.data(), this.sweep.derivPlot.data()], requests: this.sweep.requestsSent }),
      iso: () => ({ ...structuredClone(this.iso.shown), requests: this.iso.requestsSent }),
      colorbar: () => this.iso.colorBar?.state ?? null,
      sliceReading: () => this.sliceReading(),
      latencies: () => [...this.latencies],
      roundTrips: () => [...this.roundTrips],
      frameStats: () => vp.frameStats(),
      resetFrameStats: () => vp.resetFrameStats(),
      gizmoAxis: () => this.gizmo.axis,
      /** Page coordinates of a world point (to aim the mouse at the gizmo). */
      toScreen: (p: [number, number, number]) => {
        const v = new THREE.Vector3(...p).project(vp.camera);
        const r = vp.renderer.domElement.getBoundingClientRect();
        return { x: r.left + ((v.x + 1) / 2) * r.width, y: r.top + ((1 - v.y) / 2) * r.height };
      },
    };
    const w = window as unknown as { distlab?: Record<string, unknown> };
    w.distlab = Object.assign(w.distlab ?? {}, { gap: hooks });
    this.cleanup.push(() => delete w.distlab?.gap);
  }

  unmount(): void {
    clearTimeout(this.sweepTimer);
    this.cleanup.forEach((f) => f());
    this.distance?.dispose();
    this.iso?.dispose();
    this.arrows?.dispose();
    this.sweep?.dispose();
    this.gizmo?.detach();
    this.gizmo?.dispose();
    this.panel?.dispose();
    this.viewport?.dispose();
    this.viewport = null;
    this.host?.progress(null);
  }

  shortcuts(): Shortcut[] {
    const set = (p: Partial<GizmoState>) => () => {
      Object.assign(this.gizmoState, p);
      this.applyGizmo();
    };
    return [
      { key: "w", description: "gizmo: translate", run: set({ mode: "translate" }) },
      { key: "e", description: "gizmo: rotate", run: set({ mode: "rotate" }) },
      { key: "q", description: "gizmo: world / local axes", run: () => set({ space: this.gizmoState.space === "world" ? "local" : "world" })() },
      { key: "s", description: "drag the other shape (A / B)", run: () => set({ selected: this.gizmoState.selected === "a" ? "b" : "a" })() },
      { key: "f", description: "frame both shapes", run: () => this.frameAll() },
      { key: "l", description: "slice: E_S → e_S → none", run: () => this.cycleSlice() },
      { key: "ArrowLeft", description: "nudge the dragged shape −x by 1 cm", run: () => this.nudge(0, -0.01) },
      { key: "ArrowRight", description: "nudge +x by 1 cm", run: () => this.nudge(0, 0.01) },
      { key: "ArrowDown", description: "nudge −y by 1 cm", run: () => this.nudge(1, -0.01) },
      { key: "ArrowUp", description: "nudge +y by 1 cm", run: () => this.nudge(1, 0.01) },
      { key: "PageDown", description: "nudge −z by 1 cm", run: () => this.nudge(2, -0.01) },
      { key: "PageUp", description: "nudge +z by 1 cm", run: () => this.nudge(2, 0.01) },
    ];
  }

  private cycleSlice(): void {
    const order = ["strict", "weak", "none"] as const;
    this.state.iso.slice = order[(order.indexOf(this.state.iso.slice) + 1) % order.length];
    this.panel.refresh();
    this.changed("slice-style");
  }

  screenshot(): Promise<Blob> {
    if (!this.viewport) return Promise.reject(new Error("no view"));
    return this.viewport.screenshot();
  }
}

function legend(): HTMLElement {
  const el = document.createElement("div");
  el.className = "gap-legend";
  const hex = (c: number) => `#${c.toString(16).padStart(6, "0")}`;
  const items: Array<[string, string]> = [
    [hex(COLORS.gap), "● GAP witness points a*, b* (smooth: off the surfaces)"],
    [hex(COLORS.euclid), "● Euclidean nearest points"],
    [hex(COLORS.pen), "● Euclidean penetration witness points (overlap)"],
    ["#5b9bd5", "■ e_S iso-surfaces (weak, eq. 5)"],
    ["#f0a050", "■ E_S iso-surfaces (strict, eq. 6)"],
  ];
  for (const [color, text] of items) {
    const d = document.createElement("div");
    d.style.color = color;
    d.textContent = text;
    el.appendChild(d);
  }
  // The gradient arrows' lines, with their scale (filled in by showGradient).
  for (const k of ["linear", "angular"] as const) {
    const d = document.createElement("div");
    d.style.color = hex(GRADIENT_COLORS[k]);
    d.dataset.testid = `gap-legend-grad-${k}`;
    d.hidden = true;
    el.appendChild(d);
  }
  return el;
}
