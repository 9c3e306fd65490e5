// View 3, CBF rollouts (issue 6, paper Section IV-B): the Panda's collision primitives in the
// scenario's obstacles, rollouts computed by the server streaming in step by step (GAP beside
// Euclidean), a timeline to play and scrub, witness segments of the closest pairs, plots of the
// joint velocities, distances and task error, and the records' smoothness and timing numbers.
import * as THREE from "three";
import { api, ApiError } from "../../core/api";
import type { Shortcut } from "../../core/keys";
import { showError, toast } from "../../core/toast";
import type { View, ViewHost } from "../../core/view";
import { Viewport } from "../../core/viewport";
import "./cbf.css";
import { installHooks, type CbfHookSource } from "./hooks";
import { primitivePoses } from "./kinematics";
import { Panel } from "./panel";
import { RolloutPlots } from "./plots";
import type { Rollout } from "./rollout";
import { stopRouting } from "./rollout";
import { Run } from "./run";
import { CbfScene, COLORS } from "./scene";
import { metricsOf, parseState, SPEEDS, stateJson, WITNESS_MODES, type CbfState } from "./state";
import { Summary } from "./summary";
import { Timeline } from "./timeline";
import { METRICS, type CbfRecord, type CbfRobot, type CbfScenario, type Metric } from "./types";

const NAME: Record<Metric, string> = { gap: "GAP", euclidean: "Euclidean" };

export class CbfView implements View, CbfHookSource {
  viewport: Viewport | null = null;
  private host!: ViewHost;
  private state!: CbfState;
  private robot: CbfRobot | null = null;
  private scenarios: string[] = [];
  private scenario: CbfScenario | null = null;
  private scene: CbfScene | null = null;
  private timeline: Timeline | null = null;
  private panel: Panel | null = null;
  private summary: Summary | null = null;
  private plots: RolloutPlots | null = null;
  private run: Run | null = null;
  private readout: HTMLDivElement | null = null;
  private q0Poses: Float32Array | null = null;
  private shown: Metric[] = [];
  private error: string | null = null;
  private restoreT: number | null = null;
  private pendingArrival: number | null = null;
  private latencies: number[] = [];
  private drawMs: number[] = []; // JS time to pose the robots, witnesses, readout and plot cursors
  private cleanup: Array<() => void> = [];

  async mount(host: ViewHost, raw: Record<string, unknown>): Promise<void> {
    this.host = host;
    this.state = parseState(raw);
    document.body.classList.add("cbf-mounted");
    this.cleanup.push(() => document.body.classList.remove("cbf-mounted"));
    const vp = (this.viewport = new Viewport(host.canvas, { up: "z" }));
    vp.camera.position.set(2.1, -1.7, 1.5);
    vp.controls.target.set(0.3, 0, 0.45);
    vp.controls.update();
    this.readout = document.createElement("div");
    this.readout.className = "readout cbf-readout";
    this.readout.dataset.testid = "cbf-readout";
    host.canvas.appendChild(this.readout);
    host.canvas.appendChild(legend());
    this.timeline = new Timeline(host.canvas, (s) => this.draw(s), (speed) => {
      this.state.speed = speed;
      this.save();
    });
    this.timeline.setSpeed(this.state.speed);
    host.showBottom(true);
    host.status("loading the robot and the scenarios…");

    let list: { scenarios: string[] };
    try {
      [this.robot, list] = await Promise.all([api.get<CbfRobot>("/api/cbf/robot"), api.get<{ scenarios: string[] }>("/api/cbf/scenarios")]);
    } catch (e) {
      this.reportError(e, "cannot load the CBF robot and scenarios");
      return;
    }
    if (this.viewport !== vp) return; // unmounted meanwhile
    this.scenarios = list.scenarios;
    this.scene = new CbfScene(vp.scene, this.robot);
    this.q0Poses = null;
    this.panel = new Panel(host.panel, this.state, this.scenarios, {
      run: () => this.blurThen(() => void this.start()),
      cancel: () => this.blurThen(() => void this.run?.cancel()),
      runEdited: (text) => this.runEdited(text),
      revertEdited: () => this.revertEdited(),
      changed: (what) => this.changed(what),
      frame: () => this.blurThen(() => this.frameAll()),
      copyLink: () => void navigator.clipboard?.writeText(location.href).then(() => toast("link copied", "ok")),
    });
    this.summary = new Summary(this.panel.extra);
    this.buildPlots(metricsOf(this.state.metric));
    this.cleanup.push(
      installHooks(this),
      vp.onBeforeRender(() => this.beforeRender()),
    );
    await this.loadScenario();
    if (this.viewport !== vp) return;
    this.frameAll();
    if (this.state.run) {
      this.restoreT = this.state.t;
      void this.start();
    } else {
      host.status("press r (or ▶ run) to compute a rollout");
    }
  }

  // ---- scenario ---------------------------------------------------------------------------

  private async loadScenario(): Promise<void> {
    this.dropRun();
    let sc: CbfScenario;
    try {
      sc = this.state.inline
        ? (this.state.inline as unknown as CbfScenario)
        : await api.get<CbfScenario>(`/api/cbf/scenarios/${encodeURIComponent(this.state.scenario)}`);
    } catch (e) {
      this.reportError(e, `scenario "${this.state.scenario}"`);
      return;
    }
    this.scenario = sc;
    this.panel!.editor.value = formatJson(sc);
    this.showScenario(sc);
  }

  /** Draws obstacles, target and the robot at q0 (a malformed edited scenario draws what it can). */
  private showScenario(sc: Pick<CbfScenario, "obstacles" | "target" | "q0">): void {
    try {
      this.scene!.setScenario(sc);
      this.q0Poses = Float32Array.from(primitivePoses(this.robot!, sc.q0).flat());
    } catch {
      /* the server names what is wrong when it is run */
    }
    this.shown = metricsOf(this.state.metric);
    this.scene!.arrange(this.shown, this.state.layout);
    this.draw(this.timeline!.step);
  }

  private runEdited(text: string): void {
    let v: unknown;
    try {
      v = JSON.parse(text);
    } catch (e) {
      this.panel!.setVerdict("bad", `not valid JSON: ${e instanceof Error ? e.message : String(e)}`);
      return;
    }
    if (!v || typeof v !== "object" || Array.isArray(v)) {
      this.panel!.setVerdict("bad", "the scenario must be a JSON object");
      return;
    }
    this.state.inline = v as Record<string, unknown>;
    this.panel!.setScenarios(this.scenarios);
    this.panel!.setVerdict("", "sent…");
    this.dropRun();
    this.scenario = v as CbfScenario;
    this.showScenario(this.scenario);
    void this.start();
  }

  private revertEdited(): void {
    this.state.inline = null;
    this.panel!.setScenarios(this.scenarios);
    this.panel!.setVerdict("", "");
    void this.loadScenario();
    this.save();
  }

  private changed(what: "scenario" | "metric" | "duration" | "speed" | "draw" | "joint" | "layout"): void {
    switch (what) {
      case "scenario":
        void this.loadScenario();
        break;
      case "metric": {
        const want = metricsOf(this.state.metric);
        if (this.run && want.every((m) => this.run!.metrics.includes(m))) {
          this.shown = want; // the run has them: just show those
          this.scene!.arrange(this.shown, this.state.layout);
          this.draw(this.timeline!.step);
        } else if (this.run) this.host.status("press r to run the chosen metric(s)");
        else this.showScenario(this.scenario ?? { obstacles: [], target: { position: [0, 0, 0] }, q0: [] });
        break;
      }
      case "duration":
        if (this.run) this.host.status("press r to run with the new duration");
        break;
      case "speed":
        this.timeline!.setSpeed(this.state.speed);
        break;
      case "layout":
        this.scene!.arrange(this.shown, this.state.layout);
        this.frameAll();
        this.draw(this.timeline!.step);
        break;
      case "draw":
        this.draw(this.timeline!.step);
        break;
      case "joint":
        this.plots?.showJoint(this.state.joint);
        break;
    }
    this.save();
  }

  // ---- running ----------------------------------------------------------------------------

  private buildPlots(metrics: Metric[]): void {
    this.plots?.dispose();
    this.plots = new RolloutPlots(this.host.bottom, metrics, this.state.joint, (t) => {
      this.timeline!.pause();
      this.timeline!.seek(t / (this.timeline!.dt || 0.01));
    });
  }

  private dropRun(): void {
    this.run?.dispose();
    this.run = null;
    this.host.progress(null);
    this.panel?.setRunning(false);
    this.timeline?.pause();
    this.timeline?.setLength(0, 0, 0.01);
    this.plots?.refresh([]);
    this.summary?.show([]);
  }

  private async start(): Promise<void> {
    if (!this.robot || !this.scene) return;
    this.dropRun();
    const metrics = metricsOf(this.state.metric);
    this.shown = metrics;
    this.error = null;
    this.buildPlots(metrics);
    this.scene.arrange(metrics, this.state.layout);
    this.summary!.show(metrics.map((metric) => ({ metric, record: null })));
    this.state.run = true;
    this.save();
    const scenario = this.state.inline ?? this.state.scenario;
    const run = (this.run = new Run(scenario, metrics, this.state.duration, this.robot.primitives.length, {
      frames: (r, _added, arrived) => this.onFrames(r, arrived),
      progress: (x) => this.onProgress(x),
      ended: (r) => this.onEnded(r),
      done: (x, err) => this.onDone(x, err),
    }));
    this.panel!.setRunning(true);
    this.onProgress(run);
    this.draw(0);
    await run.start();
  }

  private onProgress(run: Run): void {
    if (run !== this.run || run.finished) return;
    const current = run.rollouts.find((r) => r.running && r.id) ?? run.rollouts.find((r) => r.running);
    const what = current ? `${NAME[current.metric]} rollout` : "rollout";
    const steps = current ? ` ${current.stepsDone} / ${current.stepsTotal || "…"} steps` : "";
    this.host.progress(`${what}:${steps}`, run.fraction, () => void run.cancel());
    this.host.status(`computing ${run.metrics.map((m) => NAME[m]).join(", then ")} — frames stream in as they are computed (Esc cancels)`);
  }

  private onFrames(r: Rollout, arrived: number): void {
    const tl = this.timeline!;
    const run = this.run!;
    const world = this.scene!.worlds[r.metric];
    if (r.store) world.setPairs(r.store.pairCount);
    const prevLength = tl.length;
    const length = Math.max(...run.rollouts.map((x) => x.store?.contiguous ?? 0));
    const total = Math.max(...run.rollouts.map((x) => x.stepsTotal));
    const follow = !tl.playing && this.restoreT === null && tl.step >= prevLength - 1;
    tl.setLength(length, total, r.store?.dt ?? 0.01);
    if (this.restoreT !== null && length > Math.round(this.restoreT / tl.dt)) {
      tl.seek(Math.round(this.restoreT / tl.dt), "user");
      this.restoreT = null;
    } else if (follow && length > 0) {
      this.pendingArrival ??= arrived;
      tl.seek(length - 1, "play");
      this.draw(tl.step); // the other world may lag: draw both
    } else if (world.step < tl.step) this.draw(tl.step); // this robot was waiting for these steps
    this.plots?.update(this.sources());
  }

  private onEnded(r: Rollout): void {
    if (r.state === "failed" && r.error) this.reportError(r.error, `${NAME[r.metric]} rollout`);
    this.plots?.refresh(this.sources());
    this.showSummary();
  }

  private onDone(run: Run, error: unknown | null): void {
    if (run !== this.run) return;
    this.host.progress(null);
    this.panel!.setRunning(false);
    if (error) {
      this.reportError(error, "rollout");
      if (run.rollouts.every((r) => !r.store)) {
        this.state.run = false;
        this.save();
      }
    } else this.panel!.setVerdict(this.state.inline ? "ok" : "", this.state.inline ? "the server accepted the edited scenario" : "");
    const tl = this.timeline!;
    if (this.restoreT !== null) {
      tl.seek(Math.round(this.restoreT / tl.dt), "user");
      this.restoreT = null;
    }
    this.showSummary();
    this.plots?.refresh(this.sources());
    this.draw(tl.step);
    if (error) return; // the status line shows the error
    const parts = run.rollouts.map((r) => `${NAME[r.metric]} ${r.state}${r.record ? (r.record.summary.reached ? ", reached the target" : ", target not reached") : ""}`);
    this.host.status(parts.join(" · "));
  }

  private showSummary(): void {
    if (!this.run) return;
    this.summary!.show(
      this.run.rollouts.map((r) => ({
        metric: r.metric,
        record: r.record,
        note: !r.id
          ? r.state === "failed" && r.error
            ? `refused — ${r.error instanceof ApiError ? r.error.readable : r.error.message}`
            : "not run"
          : r.state === "cancelled"
            ? `cancelled after ${r.stepsDone} of ${r.stepsTotal} steps (numbers over those)`
            : r.error
              ? r.error.message
              : undefined,
      })),
    );
  }

  private sources() {
    return (this.run?.rollouts ?? []).map((r) => ({ metric: r.metric, store: r.store }));
  }

  // ---- drawing ----------------------------------------------------------------------------

  private draw(step: number): void {
    const scene = this.scene, vp = this.viewport;
    if (!scene || !vp) return;
    const t0 = performance.now();
    const lines: string[] = [];
    const dt = this.timeline!.dt;
    for (const m of METRICS) {
      const world = scene.worlds[m];
      if (!this.shown.includes(m)) continue;
      const store = this.run?.rollout(m)?.store ?? null;
      if (store && store.contiguous > 0 && store.hasPoses) {
        const k = Math.min(step, store.contiguous - 1);
        world.setPoses(store.poses.data, k * store.primitiveCount * 7);
        world.step = k;
        const mode = this.state.witnesses;
        const pairs = !store.hasPairs || mode === "none" ? [] : mode === "all" ? store.closestPairs(k) : store.closestPairs(k).slice(0, this.state.closest);
        world.witnesses.set(pairs, store.witnessA.data, store.witnessB.data, k * store.pairCount);
        lines.push(this.readoutLine(m, k, store, pairs[0]));
      } else {
        if (this.q0Poses) world.setPoses(this.q0Poses);
        world.step = -1;
        world.witnesses.set([], new Float32Array(0), new Float32Array(0), 0);
        const r = this.run?.rollout(m);
        const why = !r ? "at q0" : r.state === "failed" ? "at q0 — the server refused the rollout" : r.state === "cancelled" ? "at q0 — not run" : "at q0 — waiting for frames…";
        lines.push(`${NAME[m].padEnd(9)} ${why}`);
      }
    }
    if (this.readout) this.readout.textContent = lines.join("\n");
    this.plots?.setTime(this.timeline!.length ? step * dt : null);
    if (this.run) {
      this.state.t = step * dt;
      this.save();
    }
    vp.invalidate();
    this.drawMs.push(performance.now() - t0);
    if (this.drawMs.length > 2000) this.drawMs.splice(0, 1000);
  }

  private readoutLine(m: Metric, k: number, store: NonNullable<Rollout["store"]>, closest: number | undefined): string {
    const f = (v: number, d = 4) => (Number.isFinite(v) ? v.toFixed(d) : "—");
    const flag = store.flags.data[k] === 2 ? "  QP held" : store.flags.data[k] === 1 ? "  QP relaxed" : "";
    const pair = closest !== undefined ? this.run?.rollout(m)?.status?.pairs[closest]?.name ?? "" : "";
    return (
      `${NAME[m].padEnd(9)} t ${(k * store.dt).toFixed(2)} s  clearance ${f(store.minDistance.data[k])} m  ` +
      `min D ${f(store.minD.data[k])} m${pair ? ` (${pair})` : ""}  ‖r‖ ${f(store.taskError.data[k])}  u7 ${f(store.u.data[k * 7 + 6], 3)}${flag}`
    );
  }

  private beforeRender(): void {
    if (this.pendingArrival === null) return;
    const arrived = this.pendingArrival;
    this.pendingArrival = null;
    // Microtasks run after this animation-frame callback, i.e. after the render call.
    queueMicrotask(() => {
      this.latencies.push(performance.now() - arrived);
      if (this.latencies.length > 2000) this.latencies.splice(0, 1000);
    });
  }

  private frameAll(): void {
    if (!this.scene || !this.viewport) return;
    const box = this.scene.bounds();
    if (box.isEmpty()) return;
    this.viewport.frame(box.expandByScalar(0.05));
  }

  private reportError(e: unknown, context: string): void {
    const text = e instanceof ApiError ? e.readable : e instanceof Error ? e.message : String(e);
    const field = e instanceof ApiError ? (e.field ?? "") : "";
    this.error = text;
    if (field.startsWith("scenario") || field.startsWith("params")) this.panel?.setVerdict("bad", `✗ ${text}`);
    showError(e, context);
    this.host.status(`error: ${text}`);
  }

  private save(): void {
    this.host.saveState(stateJson(this.state));
  }

  /** A lil-gui button keeps the focus after a click: drop it so Space does not press it again. */
  private blurThen(f: () => void): void {
    (document.activeElement as HTMLElement | null)?.blur?.();
    f();
  }

  // ---- hooks (read-only) --------------------------------------------------------------------

  stateJson(): Record<string, unknown> {
    return { ...structuredClone(this.state) } as unknown as Record<string, unknown>;
  }
  step(): number {
    return this.timeline?.step ?? 0;
  }
  length(): number {
    return this.timeline?.length ?? 0;
  }
  playing(): boolean {
    return this.timeline?.playing ?? false;
  }
  rollouts() {
    return (this.run?.rollouts ?? []).map((r) => ({
      metric: r.metric,
      id: r.id,
      state: r.state,
      stepsDone: r.stepsDone,
      stepsTotal: r.stepsTotal,
      received: r.store?.received ?? 0,
      contiguous: r.store?.contiguous ?? 0,
      wsMessages: r.wsMessages,
      restPages: r.restPages,
      error: r.error ? (r.error instanceof ApiError ? r.error.readable : r.error.message) : null,
    }));
  }
  record(m: Metric): CbfRecord | null {
    return this.run?.rollout(m)?.record ?? null;
  }
  frame(m: Metric, i: number): unknown {
    return this.run?.rollout(m)?.store?.frame(i) ?? null;
  }
  drawn() {
    const out: Record<string, { step: number; poses: number[]; witnesses: number[] }> = {};
    if (!this.scene) return out;
    for (const m of this.shown) {
      const w = this.scene.worlds[m];
      const poses: number[] = [];
      const p = new THREE.Vector3(), q = new THREE.Quaternion(), s = new THREE.Vector3();
      w.robot.children.forEach((c) => {
        c.matrix.decompose(p, q, s);
        poses.push(p.x, p.y, p.z, q.w, q.x, q.y, q.z);
      });
      out[m] = { step: w.step, poses, witnesses: [...w.witnesses.shown] };
    }
    return out;
  }
  plotData(): ReturnType<CbfHookSource["plotData"]> {
    const p = this.plots;
    return p ? { velocity: p.velocity.data(), distance: p.distance.data(), error: p.error.data() } : {};
  }
  table() {
    return [...(this.summary?.root.querySelectorAll<HTMLElement>("table.cbf-smoothness td[data-value]") ?? [])].map((c) => ({
      metric: c.dataset.metric ?? "",
      key: c.dataset.key ?? "",
      joint: Number(c.dataset.joint),
      value: Number(c.dataset.value),
      text: c.textContent ?? "",
    }));
  }
  timings() {
    return { arrivalToDrawnMs: [...this.latencies], drawMs: [...this.drawMs], plotRefreshes: this.plots?.refreshes ?? 0, plotRefreshMs: [...(this.plots?.refreshMs ?? [])] };
  }
  lastError(): string | null {
    return this.error;
  }

  // ---- View ---------------------------------------------------------------------------------

  shortcuts(): Shortcut[] {
    const tl = () => this.timeline!;
    const stepBy = (n: number) => () => {
      tl().pause();
      tl().seek(tl().step + n);
    };
    const speed = (dir: 1 | -1) => () => {
      const i = SPEEDS.findIndex((s) => s >= this.state.speed);
      const next = SPEEDS[Math.max(0, Math.min(SPEEDS.length - 1, (i < 0 ? SPEEDS.length - 1 : i) + dir))];
      this.state.speed = next;
      tl().setSpeed(next);
      this.panel?.refresh();
      this.save();
    };
    return [
      { key: " ", description: "play / pause", run: () => tl().toggle() },
      { key: "ArrowLeft", description: "one step back (pauses)", run: stepBy(-1) },
      { key: "ArrowRight", description: "one step forward (pauses)", run: stepBy(1) },
      { key: "PageDown", description: "1 s back", run: () => stepBy(-Math.round(1 / tl().dt))() },
      { key: "PageUp", description: "1 s forward", run: () => stepBy(Math.round(1 / tl().dt))() },
      { key: "Home", description: "first step", run: () => (tl().pause(), tl().seek(0)) },
      { key: "End", description: "last step computed", run: () => (tl().pause(), tl().seek(tl().length - 1)) },
      { key: "[", description: "slower playback", run: speed(-1) },
      { key: "]", description: "faster playback", run: speed(1) },
      { key: "r", description: "run the rollout(s)", run: () => void this.start() },
      { key: "Escape", description: "cancel the running rollout", run: () => void this.run?.cancel() },
      {
        key: "w",
        description: "witness pairs: closest → all → none",
        run: () => {
          this.state.witnesses = WITNESS_MODES[(WITNESS_MODES.indexOf(this.state.witnesses) + 1) % WITNESS_MODES.length];
          this.panel?.refresh();
          this.changed("draw");
        },
      },
      {
        key: "j",
        description: "plot joints: all → 1 → … → 7",
        run: () => {
          this.state.joint = (this.state.joint + 1) % 8;
          this.panel?.refresh();
          this.changed("joint");
        },
      },
      {
        key: "l",
        description: "two robots: overlay / side by side",
        run: () => {
          this.state.layout = this.state.layout === "overlay" ? "side" : "overlay";
          this.panel?.refresh();
          this.changed("layout");
        },
      },
      { key: "f", description: "frame the scene", run: () => this.frameAll() },
    ];
  }

  screenshot(): Promise<Blob> {
    if (!this.viewport) return Promise.reject(new Error("no view"));
    return this.viewport.screenshot();
  }

  unmount(): void {
    this.run?.dispose();
    this.run = null;
    stopRouting();
    this.cleanup.forEach((f) => f());
    this.cleanup = [];
    this.timeline?.dispose();
    this.plots?.dispose();
    this.summary?.dispose();
    this.panel?.dispose();
    this.readout?.remove();
    this.viewport?.dispose();
    this.viewport = null;
    this.host?.progress(null);
  }
}

/** Indented JSON with arrays of numbers kept on one line (the editor stays readable). */
function formatJson(v: unknown): string {
  return JSON.stringify(v, null, 1).replace(/\[\s*(-?[\d.eE+-]+(?:,\s*-?[\d.eE+-]+)*)\s*\]/g, (_m, inner: string) => `[${inner.replace(/\s+/g, " ")}]`);
}

function legend(): HTMLElement {
  const el = document.createElement("div");
  el.className = "cbf-legend";
  const hex = (c: number) => `#${c.toString(16).padStart(6, "0")}`;
  for (const [color, text] of [
    [hex(COLORS.gap), "■ GAP controller, ● its witness points"],
    [hex(COLORS.euclidean), "■ Euclidean controller, ● nearest points"],
    ["#9fb6d6", "□ obstacles; axes = target frame"],
  ]) {
    const d = document.createElement("div");
    d.style.color = color;
    d.textContent = text;
    el.appendChild(d);
  }
  return el;
}
