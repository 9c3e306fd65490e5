// The control panel (lil-gui in host.panel): shapes and sizes, gizmo, the gradient arrows, GAP
// parameters with the validator's verdict, level sets and slice, and the sweep. Controllers edit
// the state objects in place and report what kind of change happened; the view decides what to
// recompute.
import { addColorControls } from "../../core/colorbar";
import GUI, { type Controller } from "lil-gui";
import { SHAPE_TYPES, type ShapeState } from "./shapes";
import { exactNumbers } from "../../core/exact_number";
import { AXES, FIELDS, MOTIONS, SOLVERS, SURFACES, formatLevels, parseLevels, sigmaOfEps, type GapState } from "./state";

export type Change = "shape-a" | "shape-b" | "params" | "iso" | "slice-style" | "sweep" | "gizmo" | "display";

export interface GizmoState {
  selected: "a" | "b";
  mode: "translate" | "rotate";
  space: "world" | "local";
}

export class GapPanel {
  readonly gui: GUI;
  readonly verdict: HTMLDivElement;
  private readonly levelsText = { weak: "", strict: "" };
  private readonly levelCtrls: Controller[] = [];
  private readonly sizeCtrls: { a: Controller[]; b: Controller[] } = { a: [], b: [] };
  private readonly sigmaCtrl: Controller;

  constructor(
    parent: HTMLElement,
    private readonly state: GapState,
    readonly gizmo: GizmoState,
    private readonly changed: (c: Change) => void,
    actions: { reset: () => void; copyLink: () => void; frame: () => void },
  ) {
    this.gui = new GUI({ container: parent, title: "GAP explorer" });

    for (const which of ["a", "b"] as const) this.shapeFolder(which);

    const g = this.gui.addFolder("Gizmo");
    g.add(gizmo, "selected", { "shape A": "a", "shape B": "b" })
      .name("drag (s)")
      .onChange(() => changed("gizmo"));
    g.add(gizmo, "mode", ["translate", "rotate"])
      .name("mode (w / e)")
      .onChange(() => changed("gizmo"));
    g.add(gizmo, "space", ["world", "local"])
      .name("axes (q)")
      .onChange(() => changed("gizmo"));

    const d = this.gui.addFolder("Gradient of D");
    d.add(state.display, "gradient")
      .name("show ∇D arrows")
      .onChange(() => changed("display"));
    // Arrow metres per unit of gradient; 0: chosen from the gradient shown (the legend says which).
    d.add(state.display, "linearScale", 0, 10, 0.01)
      .name("∂D/∂p scale (m per m/m, 0 auto)")
      .onFinishChange(() => changed("display"));
    d.add(state.display, "angularScale", 0, 100, 0.1)
      .name("∂D/∂θ scale (m per m/rad, 0 auto)")
      .onFinishChange(() => changed("display"));

    const p = this.gui.addFolder("GAP parameters");
    // No min/max: what the server refuses is the validator's verdict, shown below.
    // Typed values are sent exactly (exactNumbers below); ε drives σ = √(1 − 2ε) unless unlinked.
    p.add(state.params, "h")
      .name("h (eq. 4)")
      .step(0.005)
      .onFinishChange(() => changed("params"));
    p.add(state.params, "k")
      .name("k")
      .step(1)
      .onFinishChange(() => changed("params"));
    p.add(state.params, "eps")
      .name("ε (eq. 6)")
      .step(0.001)
      .onFinishChange(() => {
        this.followEps();
        changed("params");
      });
    this.sigmaCtrl = p
      .add(state.params, "sigma")
      .name("σ (eq. 6)")
      .step(0.001)
      .onFinishChange(() => changed("params"));
    p.add(state.params, "coupled")
      .name("σ = √(1 − 2ε)")
      .onChange(() => {
        this.followEps();
        changed("params");
      });
    this.followEps();
    p.add(state.params, "solver", SOLVERS).onChange(() => changed("params"));
    this.verdict = document.createElement("div");
    this.verdict.className = "gap-verdict";
    this.verdict.dataset.testid = "gap-verdict";
    p.$children.appendChild(this.verdict);

    const l = this.gui.addFolder("Level sets (Fig. 1)");
    l.add(state.iso, "around", { "shape A": "a", "shape B": "b" })
      .name("around")
      .onChange(() => changed("iso"));
    l.add(state.iso, "surfaces", SURFACES)
      .name("iso-surfaces")
      .onChange(() => changed("iso"));
    for (const f of FIELDS) {
      this.levelsText[f] = formatLevels(state.iso[f]);
      const c = l
        .add(this.levelsText, f)
        .name(f === "weak" ? "e_S levels" : "E_S levels")
        .onFinishChange((text: string) => {
          try {
            state.iso[f] = parseLevels(text, f === "weak" ? "e_S levels" : "E_S levels");
            c.domElement.classList.remove("gap-invalid");
            this.onLevelError?.(f, null);
            changed("iso");
          } catch (e) {
            c.domElement.classList.add("gap-invalid");
            this.onLevelError?.(f, e instanceof Error ? e.message : String(e));
          }
        });
      this.levelCtrls.push(c);
    }
    l.add(state.iso, "slice", [...FIELDS, "none"])
      .name("slice field")
      .onChange(() => changed("slice-style"));
    l.add(state.iso, "normal", AXES)
      .name("slice normal")
      .onChange(() => changed("iso"));
    l.add(state.iso, "offset", -1, 1, 0.01)
      .name("slice offset")
      .onFinishChange(() => changed("iso"));
    l.add(state.iso, "spacing", 0, 0.02, 0.0005)
      .name("contour step")
      .onChange(() => changed("slice-style"));
    addColorControls(l.addFolder("slice colours"), state.iso.color, () => changed("slice-style"));

    const s = this.gui.addFolder("Sweep of B");
    s.add(state.sweep, "motion", MOTIONS).onChange(() => changed("sweep"));
    s.add(state.sweep, "axis", AXES).onChange(() => changed("sweep"));
    s.add(state.sweep, "range", 0.01, 3, 0.01)
      .name("half range")
      .onFinishChange(() => changed("sweep"));
    s.add(state.sweep, "samples", 5, 1000, 1).onFinishChange(() => changed("sweep"));

    const a = this.gui.addFolder("Actions");
    a.add(actions, "frame").name("frame both (f)");
    a.add(actions, "copyLink").name("copy link");
    a.add(actions, "reset").name("reset");
    exactNumbers(this.gui);
  }

  /** Coupled: σ is √(1 − 2ε) and not editable (unchanged where 1 − 2ε < 0: the verdict says why). */
  private followEps(): void {
    const p = this.state.params;
    this.sigmaCtrl.disable(p.coupled);
    const s = p.coupled ? sigmaOfEps(p.eps) : null;
    if (s !== null) p.sigma = s;
    this.sigmaCtrl.updateDisplay();
  }

  /** A level list typed in field `field` ("weak" or "strict") is invalid (its message) or valid again (null). */
  onLevelError?: (field: string, message: string | null) => void;

  private shapeFolder(which: "a" | "b"): void {
    const s: ShapeState = this.state[which];
    const f = this.gui.addFolder(which === "a" ? "Shape A" : "Shape B");
    f.add(s, "type", SHAPE_TYPES).onChange(() => {
      this.showSizes(which);
      this.changed(`shape-${which}`);
    });
    const c = this.sizeCtrls[which];
    const done = () => this.changed(`shape-${which}`);
    c.push(f.add(s.size, "0", 0.02, 2, 0.01).name("size x").onFinishChange(done));
    c.push(f.add(s.size, "1", 0.02, 2, 0.01).name("size y").onFinishChange(done));
    c.push(f.add(s.size, "2", 0.02, 2, 0.01).name("size z").onFinishChange(done));
    c.push(f.add(s, "radius", 0.01, 1, 0.005).onFinishChange(done));
    c.push(f.add(s, "height", 0.01, 2, 0.01).onFinishChange(done));
    this.showSizes(which);
  }

  private showSizes(which: "a" | "b"): void {
    const t = this.state[which].type;
    const [x, y, z, r, h] = this.sizeCtrls[which];
    for (const c of [x, y, z]) c.show(t === "box");
    r.show(t !== "box");
    h.show(t === "cylinder" || t === "capsule" || t === "polytope");
    r.name(t === "polytope" ? "radius (pentagon)" : "radius");
    h.name(t === "capsule" ? "length (core)" : "height");
  }

  /** After the state was replaced (reset, restore): show its values. */
  refresh(): void {
    this.levelsText.weak = formatLevels(this.state.iso.weak);
    this.levelsText.strict = formatLevels(this.state.iso.strict);
    this.gui.controllersRecursive().forEach((c) => c.updateDisplay());
    this.followEps();
    this.showSizes("a");
    this.showSizes("b");
  }

  setVerdict(ok: boolean | null, text: string): void {
    this.verdict.textContent = text;
    this.verdict.classList.toggle("ok", ok === true);
    this.verdict.classList.toggle("bad", ok === false);
  }

  dispose(): void {
    this.gui.destroy();
  }
}
