// View 3, CBF rollouts (issue 6, paper Section IV-B): the robot of the scenario (its URDF's
// collision primitives and joints) in the scenario's obstacles, rollouts computed by the server
// streaming in step by step (GAP beside Euclidean, or any two rollouts overlaid), a timeline to play and scrub, witness segments of the closest pairs, plots of the
// joint velocities, distances and task error, and the records' smoothness and timing numbers.
// A scenario's Kelvin fields (issue 33) add the object painted with σ, the shells of h = 0 and δ
// (or of the iso-levels typed in the panel), the control points coloured by h per step, their
// plots and a hover that reads σ and h.
import * as THREE from "three";
import { api, ApiError, errorText } from "../../core/api";
import { ColorBar } from "../../core/colorbar";
import type { Shortcut } from "../../core/keys";
import { dismissToasts, showError, toast } from "../../core/toast";
import type { View, ViewHost } from "../../core/view";
import { Viewport } from "../../core/viewport";
import "./cbf.css";
import { drawStep } from "./draw_step";
import { installHooks } from "./hooks";
import { primitivePoses } from "./kinematics";
import { BELOW_DELTA } from "./fields";
import { addOverlay, showLegend, type LegendLine } from "./overlay";
import { Panel, type PanelChange } from "./panel";
import { Results } from "./results";
import { stopRouting, type Rollout } from "./rollout";
import { endedStatus, progressFraction, progressLabel, Run, runningStatus } from "./run";
import { CbfScene, type World } from "./scene";
import { cbfShortcuts } from "./shortcuts";
import { runSpecs, sameSpecs, specGapParams, type RolloutSpec } from "./specs";
import { parseValues, runSweep, SweepPlot, type SweepJson } from "./sweep";
import { levelsQuery, parseState, stateJson, type CbfState } from "./state";
import { Timeline } from "./timeline";
import { DrawTimings } from "./timings";
import type { GetResponse } from "../../core/wire";
import type { CbfFeasibility, CbfFieldGeometry, CbfRobot, CbfScenario } from "./types";

export class CbfView implements View {
  private viewport: Viewport | null = null;
  private host!: ViewHost;
  private state!: CbfState;
  private robot: CbfRobot | null = null;
  private scenarios: string[] = [];
  private scenario: CbfScenario | null = null;
  private scene: CbfScene | null = null;
  private timeline: Timeline | null = null;
  private panel: Panel | null = null;
  private results: Results | null = null;
  private run: Run | null = null;
  private readout: HTMLDivElement | null = null;
  private legend: HTMLDivElement | null = null;
  private hover: HTMLDivElement | null = null;
  private sigmaBar: ColorBar | null = null;
  private hBar: ColorBar | null = null;
  private q0Poses: Float32Array | null = null;
  private shown: RolloutSpec[] = [];
  private error: string | null = null;
  private restoreT: number | null = null;
  private readonly timings = new DrawTimings();
  private sweep: SweepJson | null = null;
  private sweepPlot: SweepPlot | null = null;
  private sweepRunning = false;
  /** The iso-levels drawn (as typed): the panel returns to them when the server refuses new ones. */
  private appliedLevels = "";
  private levelsSeq = 0;
  private cleanup: Array<() => void> = [];

  async mount(host: ViewHost, raw: Record<string, unknown>): Promise<void> {
    this.host = host;
    this.state = parseState(raw);
    this.appliedLevels = this.state.isoLevels;
    document.body.classList.add("cbf-mounted");
    this.cleanup.push(() => document.body.classList.remove("cbf-mounted"));
    const vp = (this.viewport = new Viewport(host.canvas, { up: "z" }));
    vp.camera.position.set(2.1, -1.7, 1.5);
    vp.controls.target.set(0.3, 0, 0.45);
    vp.controls.update();
    ({ readout: this.readout, legend: this.legend } = addOverlay(host.canvas));
    this.sigmaBar = new ColorBar(host.canvas, "σ on the object", "dimensionless", "colorbar-sigma");
    this.hBar = new ColorBar(host.canvas, "h at the control points", "dimensionless", "colorbar-h");
    this.hover = document.createElement("div");
    this.hover.className = "cbf-hover";
    this.hover.dataset.testid = "cbf-hover";
    this.hover.hidden = true;
    host.canvas.appendChild(this.hover);
    const onMove = (e: PointerEvent) => this.onPointer(e);
    const onLeave = () => this.hover && (this.hover.hidden = true);
    vp.renderer.domElement.addEventListener("pointermove", onMove);
    vp.renderer.domElement.addEventListener("pointerleave", onLeave);
    this.cleanup.push(() => {
      vp.renderer.domElement.removeEventListener("pointermove", onMove);
      vp.renderer.domElement.removeEventListener("pointerleave", onLeave);
    });
    this.timeline = new Timeline(
      host.canvas,
      (s) => this.draw(s),
      (speed) => {
        this.state.speed = speed;
        this.save();
      },
    );
    this.timeline.setSpeed(this.state.speed);
    host.showBottom(true);
    host.status("loading the robot and the scenarios…");

    let list: { scenarios: string[] };
    try {
      [this.robot, list] = await Promise.all([api.get<CbfRobot>("/api/cbf/robot"), api.get<GetResponse<"/api/cbf/scenarios">>("/api/cbf/scenarios")]);
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
      runEdited: (scenario) => this.runEdited(scenario),
      revertEdited: () => this.revertEdited(),
      changed: (what) => this.changed(what),
      sweep: (parameter, values) => this.blurThen(() => void this.startSweep(parameter, values)),
      frame: () => this.blurThen(() => this.frameAll()),
      frameFields: () => this.blurThen(() => this.frameFields()),
      copyLink: () => void navigator.clipboard?.writeText(location.href).then(() => toast("link copied", "ok")),
    });
    this.results = new Results(host.bottom, this.panel.extra, (t) => {
      this.timeline!.pause();
      this.timeline!.seek(t / (this.timeline!.dt || 0.01));
    });
    this.setRobot(this.robot);
    this.cleanup.push(
      installHooks(() => ({
        viewport: this.viewport,
        state: this.state,
        timeline: this.timeline,
        run: this.run,
        scene: this.scene,
        shown: this.shown,
        robot: this.robot,
        results: this.results,
        timings: this.timings,
        error: this.error,
        sweep: this.sweep,
        sweepPlot: this.sweepPlot,
        colorbars: [this.sigmaBar?.state, this.hBar?.state].filter((b) => b != null),
        hover: this.hover && !this.hover.hidden ? this.hover.textContent : null,
      })),
      vp.onBeforeRender(() => this.timings.beforeRender()),
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
      sc = this.state.inline ? (this.state.inline as unknown as CbfScenario) : await api.get<CbfScenario>(`/api/cbf/scenarios/${encodeURIComponent(this.state.scenario)}`);
    } catch (e) {
      this.reportError(e, `scenario "${this.state.scenario}"`, "cbf:scenario");
      return;
    }
    // The scenario's robot (assets/robots/NAME.urdf) draws the arm: another one replaces the worlds.
    const robotName = sc.robot ?? "panda";
    if (this.robot && this.viewport && robotName !== this.robot.name) {
      try {
        this.robot = await api.get<CbfRobot>(`/api/cbf/robot?name=${encodeURIComponent(robotName)}`);
      } catch (e) {
        this.reportError(e, `robot "${robotName}"`);
        return;
      }
      this.scene!.remove();
      this.scene = new CbfScene(this.viewport.scene, this.robot);
      this.setRobot(this.robot);
    }
    this.scenario = sc;
    dismissToasts("cbf:scenario");
    this.panel!.showScenario(sc);
    this.panel!.showDuration(this.duration());
    this.showScenario(sc);
  }

  /** The robot's joints name the panel's joint list and the plots' series (any number of joints). */
  private setRobot(robot: CbfRobot): void {
    if (this.state.joint > robot.dof) this.state.joint = 0;
    this.panel!.setRobot(robot.name, robot.joint_names);
    this.results!.build(runSpecs(this.state, this.hasFields()), robot.dof, this.state.joint);
  }

  /** Draws obstacles, target and the robot at q0 (a malformed edited scenario draws what it can). */
  private showScenario(sc: Pick<CbfScenario, "obstacles" | "target" | "q0">): void {
    try {
      this.scene!.setScenario(sc);
      this.q0Poses = Float32Array.from(primitivePoses(this.robot!, sc.q0).flat());
    } catch {
      /* the server names what is wrong when it is run */
    }
    this.show(runSpecs(this.state, this.hasFields()));
  }

  /** Shows these rollouts' worlds and names them in the legend. */
  private show(specs: RolloutSpec[]): void {
    this.shown = specs;
    this.scene!.arrange(specs, this.state.layout);
    this.showFields();
    this.draw(this.timeline!.step);
  }

  /** Whether the scenario shown has Kelvin fields (the σ = 0 and hull comparisons need them). */
  private hasFields(): boolean {
    const f = (this.scenario as { fields?: unknown } | null)?.fields;
    return Array.isArray(f) && f.length > 0;
  }

  private runEdited(v: Record<string, unknown>): void {
    this.state.inline = v;
    this.panel!.setScenarios(this.scenarios);
    this.panel!.setVerdict("", "sent…");
    this.dropRun();
    this.scenario = v as CbfScenario;
    this.panel!.showDuration(this.duration());
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

  private changed(what: PanelChange): void {
    switch (what) {
      case "scenario":
        this.state.duration = null; // each scenario runs for its own duration unless set
        void this.loadScenario();
        break;
      case "metric":
      case "gap":
      case "compare": {
        const want = runSpecs(this.state, this.hasFields());
        const run = this.run;
        const have = run ? want.map((w) => run.specs.find((s) => sameSpecs([s], [w]))) : [];
        if (run && have.every((s) => s))
          this.show(have as RolloutSpec[]); // the run has them: just show those
        else if (run) this.host.status("press r to run the chosen rollouts");
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
      case "fields":
        this.showFields();
        this.draw(this.timeline!.step);
        break;
      case "levels":
        void this.applyLevels(); // saves once the server took them
        return;
      case "joint":
        this.results?.showJoint(this.state.joint);
        break;
    }
    this.save();
  }

  // ---- running ----------------------------------------------------------------------------

  private dropRun(): void {
    this.run?.dispose();
    this.run = null;
    if (this.scene) for (const w of this.scene.worlds.values()) w.fields.clear(); // the run's fields go with it
    this.host.progress(null);
    this.panel?.setRunning(false);
    this.timeline?.pause();
    this.timeline?.setLength(0, 0, 0.01);
    this.results?.clear();
  }

  /** The duration to run: the one set in the panel or link, else the scenario's own. */
  private duration(): number {
    const own = this.scenario && typeof this.scenario.duration === "number" ? this.scenario.duration : 35;
    return this.state.duration ?? own;
  }

  private async start(): Promise<void> {
    if (!this.robot || !this.scene) return;
    this.dropRun();
    const specs = runSpecs(this.state, this.hasFields());
    this.error = null;
    this.results!.build(specs, this.robot.dof, this.state.joint);
    this.results!.started(specs);
    this.state.run = true;
    this.save();
    const scenario = this.state.inline ?? this.state.scenario;
    const fields = (this.scenario as { fields?: unknown[] } | null)?.fields;
    const run = (this.run = new Run(
      scenario,
      specs,
      this.duration(),
      Array.isArray(fields) ? fields.length : 0,
      { primitives: this.robot.primitives.length, dof: this.robot.dof },
      {
        frames: (r, _added, arrived) => this.onFrames(r, arrived),
        progress: (x) => this.onProgress(x),
        ended: (r) => this.onEnded(r),
        done: (x, err) => this.onDone(x, err),
        fields: (r) => this.onFields(r),
      },
    ));
    for (const r of run.rollouts) r.fieldLevels = levelsQuery(this.state.isoLevels);
    this.panel!.setRunning(true);
    this.onProgress(run);
    this.show(specs);
    this.draw(0);
    await run.start();
  }

  private onProgress(run: Run): void {
    if (run !== this.run || run.finished) return;
    // A rollout with fields names its control points when the server accepts it.
    for (const r of run.rollouts) {
      const w = this.scene!.world(r.spec);
      if (r.id && r.status?.kelvin && w.fields.owner !== r.id) {
        w.fields.setControlPoints(r.status.kelvin.control_points);
        w.fields.owner = r.id;
        this.showFields();
        this.draw(this.timeline!.step);
      }
    }
    this.host.progress(progressLabel(run), progressFraction(run), () => void run.cancel());
    this.host.status(runningStatus(run));
  }

  /** A rollout's Kelvin objects and shells arrived (GET .../fields): drawn in its world. */
  private onFields(r: Rollout): void {
    if (!this.run?.rollouts.includes(r) || !this.scene) return;
    if (r.levelsError) {
      // The link's iso-levels were refused: the server's default ones are drawn instead (said once).
      if (this.state.isoLevels) this.refuseLevels(r.levelsError, this.state.isoLevels, "");
      r.levelsError = null;
    }
    if (r.geometryError || !r.geometry) {
      this.reportError(r.geometryError ?? new Error("no field geometry"), `${r.spec.label}: Kelvin field geometry`);
      return;
    }
    this.scene.world(r.spec).fields.setGeometry(r.geometry, this.state.sigmaColor);
    this.showFields();
    this.draw(this.timeline!.step);
  }

  /** The iso-levels typed in the panel: every rollout's shells refetched at them (GET .../fields
   *  ?levels=…) and redrawn together, or, if the server refuses them (not numbers: 400, more than
   *  its max_levels: 413), its error shown, the shells kept and the panel back to the levels drawn. */
  private async applyLevels(): Promise<void> {
    const text = this.state.isoLevels;
    const query = levelsQuery(text);
    const seq = ++this.levelsSeq;
    const run = this.run;
    const fetched = run?.rollouts.filter((r) => r.id && r.geometry) ?? [];
    let got: CbfFieldGeometry[];
    try {
      got = await Promise.all(fetched.map((r) => (r.geometryLevels === query ? Promise.resolve(r.geometry!) : r.fetchFields(query))));
    } catch (e) {
      if (seq === this.levelsSeq && this.viewport) this.refuseLevels(e, text, this.appliedLevels);
      return;
    }
    if (seq !== this.levelsSeq || run !== this.run || !this.viewport) return;
    fetched.forEach((r, i) => {
      r.geometry = got[i];
      r.geometryLevels = query;
      this.scene!.world(r.spec).fields.setGeometry(got[i], this.state.sigmaColor);
    });
    for (const r of run?.rollouts ?? []) r.fieldLevels = query; // those still to fetch theirs
    this.appliedLevels = text;
    dismissToasts("cbf:levels");
    if (run) {
      this.showFields();
      this.draw(this.timeline!.step);
      if (fetched.length) this.host.status(`shells at h = ${query || "0 and δ"}`);
    }
    this.save();
  }

  /** The server refused the iso-levels `text`: its error shown, the panel back to `back`. */
  private refuseLevels(e: unknown, text: string, back: string): void {
    this.reportError(e, `iso-levels "${text}"`, "cbf:levels");
    this.state.isoLevels = this.appliedLevels = back;
    this.panel?.refresh();
    this.save();
  }

  /** The fields' drawing options, colour bars and legend lines, for the worlds shown. */
  private showFields(): void {
    if (!this.scene) return;
    const worlds = this.shown.map((s) => this.scene!.world(s));
    const s = this.state;
    for (const w of worlds) {
      w.fields.setVisible({ object: s.fieldObject, shells: s.fieldShells, points: s.fieldPoints });
      w.fields.setSigmaScale(s.sigmaColor);
    }
    const object = worlds.flatMap((w) => w.fields.objects)[0];
    if (this.sigmaBar) {
      this.sigmaBar.visible = !!object && s.fieldObject;
      if (object) this.sigmaBar.update(s.sigmaColor, object.colorRange, Number.isFinite(object.sigmaRange[0]) ? object.sigmaRange : null);
    }
    // h: a sequential map from 0 to the largest h streamed (at least 2δ), red below δ.
    const stores = this.shown.map((sp) => this.run?.rollout(sp.key)?.store).filter((x) => x && x.fieldCount > 0);
    const kelvin = this.run?.rollouts.find((r) => r.status?.kelvin)?.status?.kelvin;
    const delta = kelvin ? Math.max(...kelvin.fields.map((f) => f.delta)) : 0;
    const hMax = Math.max(2 * delta, ...stores.map((x) => (Number.isFinite(x!.hMax) ? x!.hMax : 0)));
    const range: [number, number] = [0, hMax > 0 ? hMax : 1];
    for (const w of worlds) w.fields.setHScale({ map: "viridis", range, delta });
    if (this.hBar) {
      this.hBar.visible = worlds.some((w) => w.fields.hasPoints) && s.fieldPoints;
      this.hBar.update({ map: "viridis", mode: "fixed", min: range[0], max: range[1] }, range, null, {
        marks: [{ value: delta, label: `δ ${delta}` }],
        below: { value: delta, color: BELOW_DELTA },
      });
    }
    showLegend(this.legend!, this.shown, this.fieldLegend(worlds));
  }

  private fieldLegend(worlds: World[]): LegendLine[] {
    const css = (c: THREE.Color) => `#${c.getHexString()}`;
    const lines: LegendLine[] = [];
    worlds.forEach((w, k) => {
      const o = w.fields.objects[0];
      if (!o) return;
      const overlaid = k > 0 && this.state.layout === "overlay";
      if (!overlaid && this.state.fieldObject) lines.push(["#d9a0a0", `▣ ${o.name}: σ painted (colour bar σ: red > 0 contact allowed, blue < 0 forbidden)`]);
      if (this.state.fieldShells)
        for (const l of o.levels) {
          const what =
            Math.abs(l.level) < 1e-12
              ? "zero level set"
              : Math.abs(l.level - o.delta) < 1e-12
                ? "= δ, the barrier's level"
                : l.level < o.delta
                  ? "iso-level, below δ"
                  : "iso-level";
          const text = l.empty ? `◯ h = ${l.level}: not taken (h ≥ ${l.hMin?.toFixed(3)} everywhere)` : `◯ ${w.spec.short}: shell h = ${l.level}${what ? ` (${what})` : ""}`;
          lines.push([css(o.shells.colorOf(l.level)), text]);
        }
    });
    if (this.state.fieldPoints && worlds.some((w) => w.fields.hasPoints)) {
      lines.push([BELOW_DELTA, "● control points coloured by h (colour bar h; red: h < δ)"]);
      lines.push(["#ffe066", "— nearest control point to the object's closest point"]);
    }
    return lines;
  }

  /** σ on an object or a control point's h under the pointer (the hover line). */
  private onPointer(e: PointerEvent): void {
    const vp = this.viewport;
    if (!vp || !this.scene || !this.hover || e.buttons) return;
    const rect = vp.renderer.domElement.getBoundingClientRect();
    const ray = new THREE.Raycaster();
    ray.setFromCamera(new THREE.Vector2(((e.clientX - rect.left) / rect.width) * 2 - 1, -((e.clientY - rect.top) / rect.height) * 2 + 1), vp.camera);
    let best: { text: string; distance: number } | null = null;
    for (const spec of this.shown) {
      const w = this.scene.world(spec);
      const hit = w.fields.pick(ray);
      if (!hit || (best && best.distance <= hit.distance)) continue;
      if (hit.kind === "surface") best = { text: `${hit.object}: σ ${hit.sigma.toFixed(3)} here`, distance: hit.distance };
      else {
        const h = w.fields.pointH[hit.index];
        best = { text: `${w.fields.controlPoint(hit.index)?.name ?? "point"} (${spec.short}): h ${Number.isFinite(h) ? h.toFixed(4) : "—"}`, distance: hit.distance };
      }
    }
    this.hover.hidden = !best;
    if (best) {
      this.hover.textContent = best.text;
      this.hover.style.left = `${e.clientX - this.host.canvas.getBoundingClientRect().left + 14}px`;
      this.hover.style.top = `${e.clientY - this.host.canvas.getBoundingClientRect().top + 14}px`;
    }
  }

  private onFrames(r: Rollout, arrived: number): void {
    const tl = this.timeline!;
    const run = this.run!;
    const world = this.scene!.world(r.spec);
    if (r.store) world.setPairs(r.store.pairCount);
    const prevLength = tl.length;
    const length = Math.max(...run.rollouts.map((x) => x.store?.contiguous ?? 0));
    const total = Math.max(...run.rollouts.map((x) => x.stepsTotal));
    const follow = !tl.playing && this.restoreT === null && tl.step >= prevLength - 1;
    tl.setLength(length, total, r.store?.dt ?? 0.01);
    if (this.restoreT !== null && length > Math.round(this.restoreT / tl.dt)) this.restoreTime();
    else if (follow && length > 0) {
      this.timings.arrived(arrived);
      tl.seek(length - 1, "play");
      this.draw(tl.step); // the other world may lag: draw both
    } else if (world.step < tl.step) this.draw(tl.step); // this robot was waiting for these steps
    if (r.store?.fieldCount) this.showFields(); // h's colour range grows with the frames
    this.results!.frames(run);
  }

  private onEnded(r: Rollout): void {
    if (r.state === "failed" && r.error) this.reportError(r.error, `${r.spec.label} rollout`, "cbf:run");
    if (this.run) this.results!.ended(this.run);
  }

  private onDone(run: Run, error: unknown | null): void {
    if (run !== this.run) return;
    this.host.progress(null);
    this.panel!.setRunning(false);
    if (error) {
      this.reportError(error, "rollout", "cbf:run");
      if (run.rollouts.every((r) => !r.store)) {
        this.state.run = false;
        this.save();
      }
    } else {
      this.panel!.setVerdict(this.state.inline ? "ok" : "", this.state.inline ? "the server accepted the edited scenario" : "");
      dismissToasts("cbf:run");
    }
    if (this.restoreT !== null) this.restoreTime();
    this.results!.ended(run);
    this.draw(this.timeline!.step);
    if (error) return; // the status line shows the error
    this.host.status(endedStatus(run));
    // Then what the exact target allows, so a rollout that stops short says why.
    const scenario = this.state.inline ?? this.state.scenario;
    void api
      .post<CbfFeasibility>("/api/cbf/feasibility", { scenario })
      .then((f) => {
        if (run === this.run) this.host.status(endedStatus(run, f));
      })
      .catch(() => undefined);
  }

  /** A sweep of the first rollout's settings over one params key: one job, then its plot. */
  private async startSweep(parameter: string, text: string): Promise<void> {
    const values = parseValues(text);
    if (!values) {
      showError(new Error("sweep values: numbers separated by commas"), "sweep", "cbf:sweep");
      this.sweepPlot?.setStale("the values typed are not numbers separated by commas; these curves are of the previous sweep");
      return;
    }
    if (this.sweepRunning) return;
    const [first] = runSpecs(this.state, this.hasFields());
    const gap = specGapParams(first);
    const body = {
      scenario: this.state.inline ?? this.state.scenario,
      metric: first.metric,
      params: { duration: this.duration(), record_pairs: false, ...(gap ? { gap } : {}) },
      sweep: { parameter, values },
    };
    this.sweepRunning = true;
    this.sweep = null;
    let id = "";
    try {
      const s = await runSweep(
        body,
        (x) => {
          id = x.id;
          this.sweep = x;
          const job = x.job;
          this.host.progress(`sweep of ${parameter}: ${job?.stage ?? "queued"}`, job?.fraction ?? 0, () => void api.post(`/api/jobs/${id}/cancel`).catch(() => undefined));
        },
        () => !this.viewport,
      );
      this.sweep = s;
      if (!this.viewport) return;
      this.sweepPlot?.dispose();
      this.sweepPlot = new SweepPlot(this.host.bottom, s);
      dismissToasts("cbf:sweep");
      this.host.status(`sweep ${s.job?.state ?? "ended"}: ${s.entries.length} of ${s.values.length} runs of ${first.label} over ${parameter}`);
    } catch (e) {
      this.reportError(e, "sweep", "cbf:sweep");
      // The curves shown are of the previous sweep, not of the one refused.
      this.sweepPlot?.setStale(`the sweep of ${parameter} failed: ${errorText(e)}; these curves are of the previous sweep`);
    } finally {
      this.sweepRunning = false;
      this.host.progress(null);
    }
  }

  /** Returns to the time of a shared link (once: when it is computed, or at the end of the run). */
  private restoreTime(): void {
    const tl = this.timeline!;
    tl.seek(Math.round(this.restoreT! / tl.dt), "user");
    this.restoreT = null;
  }

  // ---- drawing ----------------------------------------------------------------------------

  private draw(step: number): void {
    const vp = this.viewport;
    if (!this.scene || !vp) return;
    const t0 = performance.now();
    const dt = this.timeline!.dt;
    const q0 = { poses: this.q0Poses, q: this.scenario?.q0 ?? null };
    const lines = this.shown.map((s) => drawStep(this.scene!.world(s), this.run?.rollout(s.key), step, q0, this.state));
    if (this.readout) this.readout.textContent = lines.join("\n");
    this.results?.setTime(this.timeline!.length ? step * dt : null);
    if (this.run) {
      this.state.t = step * dt;
      this.save();
    }
    vp.invalidate();
    this.timings.drew(performance.now() - t0);
  }

  private frameAll(): void {
    if (!this.scene || !this.viewport) return;
    const box = this.scene.bounds();
    if (box.isEmpty()) return;
    this.viewport.frame(box.expandByScalar(0.05));
  }

  /** The camera on the Kelvin objects of the rollouts shown (nothing without them). */
  private frameFields(): void {
    if (!this.scene || !this.viewport) return;
    const box = new THREE.Box3();
    this.scene.root.updateMatrixWorld(true);
    for (const s of this.shown) for (const o of this.scene.world(s).fields.objects) box.expandByObject(o.surface);
    if (!box.isEmpty()) this.viewport.frame(box.expandByScalar(0.06));
  }

  /** `key`: what the error is about, its toast going when that succeeds (toast.ts). */
  private reportError(e: unknown, context: string, key?: string): void {
    const text = errorText(e);
    const field = e instanceof ApiError ? (e.field ?? "") : "";
    this.error = text;
    if (field.startsWith("scenario") || field.startsWith("params")) this.panel?.setVerdict("bad", `✗ ${text}`);
    showError(e, context, key);
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

  // ---- View ---------------------------------------------------------------------------------

  shortcuts(): Shortcut[] {
    return cbfShortcuts({
      timeline: () => this.timeline!,
      state: () => this.state,
      refreshPanel: () => this.panel?.refresh(),
      save: () => this.save(),
      dof: () => this.robot?.dof ?? 0,
      changed: (what) => this.changed(what),
      run: () => void this.start(),
      cancel: () => void this.run?.cancel(),
      frame: () => this.frameAll(),
      frameFields: () => this.frameFields(),
    });
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
    this.results?.dispose();
    this.panel?.dispose();
    this.readout?.remove();
    this.legend?.remove();
    this.hover?.remove();
    this.sigmaBar?.dispose();
    this.hBar?.dispose();
    this.sweepPlot?.dispose();
    this.viewport?.dispose();
    this.viewport = null;
    this.host?.progress(null);
  }
}
