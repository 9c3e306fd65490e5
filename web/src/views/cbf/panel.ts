// The control panel (lil-gui in host.panel): the rollout to run (scenario, metric or both, the
// rollout compared with it, duration), playback and drawing options, an editor for the scenario JSON (posted inline, the
// server's verdict shown under it), and the numbers of the finished run (Summary) below.
import GUI, { type Controller } from "lil-gui";
import { addColorControls } from "../../core/colorbar";
import { METRIC_CHOICES, SPEEDS, WITNESS_MODES, type CbfState, type CompareChoice, type GapModeChoice } from "./state";

export type PanelChange = "scenario" | "metric" | "gap" | "compare" | "duration" | "speed" | "draw" | "joint" | "layout" | "fields" | "levels";

export interface PanelActions {
  run(): void;
  cancel(): void;
  /** The editor's text parsed as a JSON object (the panel refuses anything else itself). */
  runEdited(scenario: Record<string, unknown>): void;
  revertEdited(): void;
  changed(what: PanelChange): void;
  /** A sweep of one params key over these values (as typed), with the first rollout's settings. */
  sweep(parameter: string, values: string): void;
  frame(): void;
  /** Frames the Kelvin objects (and the control points near them). */
  frameFields(): void;
  copyLink(): void;
}

export class Panel {
  private readonly gui: GUI;
  private scenarioCtrl: Controller;
  private readonly runCtrl: Controller;
  private readonly cancelCtrl: Controller;
  private readonly editor: HTMLTextAreaElement;
  readonly verdict: HTMLDivElement;
  readonly extra: HTMLDivElement;
  private readonly proxy: { scenario: string; joint: string };
  private readonly folder: GUI;
  private readonly duration: { own: number; duration: number };
  private readonly durationCtrl: Controller;
  private readonly playback: GUI;
  private jointCtrl: Controller | null = null;

  constructor(
    container: HTMLElement,
    private readonly state: CbfState,
    scenarios: string[],
    private readonly actions: PanelActions,
  ) {
    this.gui = new GUI({ container, title: "CBF rollouts (paper IV-B)" });
    const r = (this.folder = this.gui.addFolder("Rollout"));
    this.proxy = { scenario: state.inline ? "(edited)" : state.scenario, joint: state.joint === 0 ? "all" : String(state.joint) };
    this.scenarioCtrl = this.scenarioSelect(scenarios);
    r.add(state, "metric", { "GAP & Euclidean": "both", "GAP only": "gap", "Euclidean only": "euclidean" } satisfies Record<string, (typeof METRIC_CHOICES)[number]>)
      .name("metric")
      .onChange(() => actions.changed("metric"));
    // No upper bound here: the server states its limit (and refuses more with a readable message).
    r.add(state, "gapMode", { "exact (converged)": "exact", "as published, 2e-4 / 300": "as_published_sim", "as published, 5e-4 / 20": "as_published_real" } satisfies Record<
      string,
      GapModeChoice
    >)
      .name("GAP distance")
      .onChange(() => actions.changed("gap"));
    r.add(state, "compare", {
      nothing: "none",
      Euclidean: "euclidean",
      "GAP exact": "gap_exact",
      "GAP as published, 2e-4 / 300": "gap_as_published_sim",
      "GAP as published, 5e-4 / 20": "gap_as_published_real",
      "σ = 0 (pure avoidance; Kelvin fields)": "sigma_zero",
      "object hulls (Euclidean; Kelvin fields)": "hull",
    } satisfies Record<string, CompareChoice>)
      .name("compare with")
      .onChange(() => actions.changed("compare"));
    // Shows the scenario's own duration until the user sets one (state.duration null).
    const dur = { own: 35 } as { own: number; duration: number };
    Object.defineProperty(dur, "duration", {
      get: () => state.duration ?? dur.own,
      set: (v: number) => {
        state.duration = v;
      },
    });
    this.duration = dur;
    this.durationCtrl = r
      .add(dur, "duration")
      .min(0.01)
      .step(0.01)
      .name("duration (s)")
      .onFinishChange(() => actions.changed("duration"));
    this.runCtrl = r.add(actions, "run").name("▶ run (r)");
    this.cancelCtrl = r.add(actions, "cancel").name("cancel (Esc)");
    this.cancelCtrl.disable();

    const p = (this.playback = this.gui.addFolder("Playback and drawing"));
    p.add(state, "speed", [...SPEEDS])
      .name("speed")
      .onChange(() => actions.changed("speed"));
    p.add(state, "layout", { overlay: "overlay", "side by side": "side" })
      .name("two robots")
      .onChange(() => actions.changed("layout"));
    p.add(state, "witnesses", [...WITNESS_MODES])
      .name("witness pairs (w)")
      .onChange(() => actions.changed("draw"));
    p.add(state, "closest", 1, 60, 1)
      .name("closest how many")
      .onChange(() => actions.changed("draw"));
    p.add(actions, "frame").name("frame the scene (f)");
    p.add(actions, "copyLink").name("copy link");

    const k = this.gui.addFolder("Kelvin fields (scenarios with objects)");
    k.add(state, "fieldObject")
      .name("object, σ painted")
      .onChange(() => actions.changed("fields"));
    k.add(state, "fieldShells")
      .name("shells (iso-levels of h)")
      .onChange(() => actions.changed("fields"));
    // The levels of h drawn as shells (GET .../fields?levels=…): refetched when typed (Enter or
    // leaving the field); the server refuses what is not a list of numbers or too long a one.
    const levels = k
      .add(state, "isoLevels")
      .name("iso-levels")
      .onFinishChange(() => actions.changed("levels"));
    levels.domElement.title = "values of h, comma-separated (empty: 0 and δ)";
    levels.domElement.dataset.testid = "cbf-iso-levels";
    k.add(state, "fieldPoints")
      .name("control points (h)")
      .onChange(() => actions.changed("fields"));
    k.add(actions, "frameFields").name("frame the object (o)");
    addColorControls(k.addFolder("σ colours"), state.sigmaColor, () => actions.changed("fields"));
    k.close();

    const sw = this.gui.addFolder("Parameter sweep (one server job)");
    const sweep = { parameter: "margins.gap.obstacle", values: "0.002, 0.0005, 0.0002, 0.0001", run: () => actions.sweep(sweep.parameter, sweep.values) };
    sw.add(sweep, "parameter").name("params key");
    sw.add(sweep, "values").name("values");
    sw.add(sweep, "run").name("▶ run sweep");
    sw.close();

    const e = this.gui.addFolder("Scenario JSON (edit and run inline)");
    e.close();
    this.editor = document.createElement("textarea");
    this.editor.className = "cbf-editor";
    this.editor.spellcheck = false;
    this.editor.rows = 14;
    this.editor.dataset.testid = "cbf-editor";
    this.verdict = document.createElement("div");
    this.verdict.className = "cbf-verdict";
    this.verdict.dataset.testid = "cbf-verdict";
    const buttons = document.createElement("div");
    buttons.className = "cbf-buttons";
    const runB = document.createElement("button");
    runB.textContent = "run this scenario";
    runB.dataset.testid = "cbf-run-edited";
    runB.addEventListener("click", () => this.runEdited());
    const revB = document.createElement("button");
    revB.textContent = "revert";
    revB.addEventListener("click", () => actions.revertEdited());
    buttons.append(runB, revB);
    e.$children.append(this.editor, buttons, this.verdict);

    this.extra = document.createElement("div");
    container.appendChild(this.extra);
  }

  private scenarioSelect(scenarios: string[]): Controller {
    const options = [...scenarios];
    if (this.state.inline) options.push("(edited)");
    const c = this.folder
      .add(this.proxy, "scenario", options)
      .name("scenario")
      .onChange((v: string) => {
        if (v === "(edited)") return;
        this.state.scenario = v;
        this.state.inline = null;
        this.actions.changed("scenario");
      });
    // Keep it first in its folder.
    this.folder.$children.prepend(c.domElement);
    return c;
  }

  /** The robot of the scenario: its name in the title, its joints in the joint list. */
  setRobot(name: string, jointNames: string[]): void {
    this.gui.title(`CBF rollouts — ${name} (paper IV-B)`);
    this.jointCtrl?.destroy();
    const options: Record<string, string> = { all: "all" };
    jointNames.forEach((n, j) => (options[`${j + 1} (${n})`] = String(j + 1)));
    this.proxy.joint = this.state.joint === 0 ? "all" : String(this.state.joint);
    this.jointCtrl = this.playback
      .add(this.proxy, "joint", options)
      .name("plot joints (j)")
      .onChange((v: string) => {
        this.state.joint = v === "all" ? 0 : Number(v);
        this.actions.changed("joint");
      });
    this.jointCtrl.domElement.dataset.testid = "cbf-joint-select";
    this.playback.$children.insertBefore(this.jointCtrl.domElement, this.playback.$children.children[4] ?? null);
  }

  /** The duration the panel shows when none is set: the scenario's own. */
  showDuration(own: number): void {
    this.duration.own = own;
    this.durationCtrl.updateDisplay();
  }

  /** Shows a scenario in the editor. */
  showScenario(sc: unknown): void {
    this.editor.value = formatJson(sc);
  }

  private runEdited(): void {
    let v: unknown;
    try {
      v = JSON.parse(this.editor.value);
    } catch (e) {
      this.setVerdict("bad", `not valid JSON: ${e instanceof Error ? e.message : String(e)}`);
      return;
    }
    if (!v || typeof v !== "object" || Array.isArray(v)) {
      this.setVerdict("bad", "the scenario must be a JSON object");
      return;
    }
    this.actions.runEdited(v as Record<string, unknown>);
  }

  /** Rebuilds the scenario list (e.g. "(edited)" appears or goes). */
  setScenarios(scenarios: string[]): void {
    this.proxy.scenario = this.state.inline ? "(edited)" : this.state.scenario;
    this.scenarioCtrl.destroy();
    this.scenarioCtrl = this.scenarioSelect(scenarios);
  }

  setRunning(running: boolean): void {
    this.runCtrl.name(running ? "running…" : "▶ run (r)");
    if (running) this.cancelCtrl.enable();
    else this.cancelCtrl.disable();
  }

  setVerdict(kind: "ok" | "bad" | "", text: string): void {
    this.verdict.textContent = text;
    this.verdict.className = `cbf-verdict ${kind}`;
  }

  refresh(): void {
    this.proxy.joint = this.state.joint === 0 ? "all" : String(this.state.joint);
    this.gui.controllersRecursive().forEach((c) => c.updateDisplay());
  }

  dispose(): void {
    this.gui.destroy();
    this.extra.remove();
  }
}

/** Indented JSON with arrays of numbers kept on one line (the editor stays readable). */
function formatJson(v: unknown): string {
  return JSON.stringify(v, null, 1).replace(/\[\s*(-?[\d.eE+-]+(?:,\s*-?[\d.eE+-]+)*)\s*\]/g, (_m, inner: string) => `[${inner.replace(/\s+/g, " ")}]`);
}
