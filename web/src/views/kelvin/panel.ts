// The right-hand panel (lil-gui): object and l_x, upload, the repair of an upload (every option of
// the server with its limits, the defects found, prepare), σ (presets, base, brush, undo, reset),
// iso-levels, slice, export, and a statistics table. It edits the KelvinState in place and calls
// back; the view decides what that means for the server.
import GUI, { type Controller } from "lil-gui";
import { addColorControls } from "../../core/colorbar";
import { exactNumber, exactNumbers, recheck, setFieldMessage } from "../../core/exact_number";
import { presets } from "./sigma";
import type { Limits } from "../../core/wire";
import { componentChoices, exportFormats, repairs, uploadUnits, type KelvinState } from "./kelvin_state";
import { sliceAxes } from "./slice_layer";

export interface PanelActions {
  objectChanged(): void;
  lxChanged(): void;
  upload(file: File): void;
  unitChanged(): void;
  repairChanged(): void;
  /** Prepare the upload with the repair options chosen. */
  prepare(): void;
  defectsToggled(): void;
  sigmaChanged(): void;
  presetChosen(): void;
  undoStroke(): void;
  resetSigma(): void;
  levelsChanged(): void;
  styleChanged(): void;
  sliceChanged(): void;
  sliceStyleChanged(): void;
  exportShown(): void;
  saveSigma(): void;
  loadSigma(file: File): void;
  frame(): void;
  /** The view's link (an upload by its digest, with its repair) to the clipboard. */
  copyLink(): void;
}

export class Panel {
  readonly gui: GUI;
  readonly stats: HTMLTableElement;
  private levelsText: { levels: string };
  private controllers: Controller[] = [];
  private fileInput: HTMLInputElement;
  private readonly lx: Controller;
  private readonly estimate: HTMLDivElement;
  private readonly lxNote: HTMLDivElement;
  private readonly report: HTMLDivElement;
  private readonly holeEdges: Controller;
  private readonly simplify: Controller;
  private readonly limitsLine: HTMLDivElement;
  private readonly wrapControls: Controller[];
  private readonly repairEstimate: HTMLDivElement;
  private readonly defectsBox: HTMLDivElement;
  /** View settings that are not part of the link. */
  readonly view = { showDefects: true };
  readonly sigmaHistogram: HTMLDivElement;
  private sigmaInput: HTMLInputElement;
  /** Says when the link's σ is in a file that is not loaded yet. */
  readonly sigmaNotice: HTMLDivElement;

  constructor(container: HTMLElement, state: KelvinState, assets: string[], a: PanelActions) {
    this.gui = new GUI({ container, title: "Semantic distance", width: 300 });
    const obj = this.gui.addFolder("Object");
    const names = assets.includes(state.object) || state.object === "upload" ? assets : [...assets, state.object];
    this.add(
      obj
        .add(state, "object", state.object === "upload" ? [...names, "upload"] : names)
        .name("built-in")
        .onChange(() => a.objectChanged()),
    );
    this.lx = this.add(
      obj
        .add(state, "lx", 0.001, 1, 0.001)
        .name("l_x")
        .onFinishChange(() => a.lxChanged()),
    );
    // What preparing will cost (the server's estimate), shown before the job starts.
    this.estimate = document.createElement("div");
    this.estimate.className = "kelvin-estimate";
    this.estimate.dataset.testid = "kelvin-estimate";
    obj.$children.appendChild(this.estimate);
    // What l_x means for this object when it is too coarse for it, and the value to use.
    this.lxNote = document.createElement("div");
    this.lxNote.className = "kelvin-estimate";
    this.lxNote.dataset.testid = "kelvin-lx-note";
    this.lxNote.hidden = true;
    obj.$children.appendChild(this.lxNote);
    this.fileInput = fileInput(container, ".stl,.obj,.ply,.glb,.off", "kelvin-upload", (f) => a.upload(f));
    // The upload dialog: the file's unit and the repair, then the file; the server's answer (size
    // in metres, the l_x that fits, a refusal, the repair's report) is shown under them.
    this.add(
      obj
        .add(state, "unit", uploadUnits)
        .name("file unit")
        .onChange(() => a.unitChanged()),
    );
    obj.add({ upload: () => this.fileInput.click() }, "upload").name("upload a mesh…");
    obj.add({ frame: () => a.frame() }, "frame").name("frame the object (f)");
    obj.add({ copyLink: () => a.copyLink() }, "copyLink").name("copy link");
    this.report = document.createElement("div");
    this.report.className = "kelvin-estimate kelvin-upload-report";
    this.report.dataset.testid = "kelvin-upload-report";
    obj.$children.appendChild(this.report);

    // The repair: every option the server takes, bounded by its limits; an upload's defects are
    // drawn and counted first, and "prepare" applies the options.
    const rep = this.gui.addFolder("Repair");
    const changed = () => {
      this.showRepairControls(state);
      a.repairChanged();
    };
    this.add(rep.add(state, "repair", repairs).name("repair").onChange(changed));
    this.holeEdges = this.add(rep.add(state, "holeEdges", 0, 1000, 1).name("fix: holes up to (edges)").onFinishChange(changed));
    this.wrapControls = [
      this.add(rep.add(state, "alpha").min(0).name("wrap: α (m; 0: diagonal / 20)").onFinishChange(changed)),
      this.add(rep.add(state, "offset").min(0).name("wrap: offset (m; 0: α / 30)").onFinishChange(changed)),
    ];
    this.simplify = this.add(rep.add(state, "simplify", 0, 200000, 1).name("simplify to (faces; 0: keep)").onFinishChange(changed));
    this.add(rep.add(state, "components", componentChoices).name("components").onChange(changed));
    rep
      .add(this.view, "showDefects")
      .name("show defects")
      .onChange(() => a.defectsToggled());
    rep.add({ prepare: () => a.prepare() }, "prepare").name("prepare with these options");
    const limitsLine = (this.limitsLine = document.createElement("div"));
    limitsLine.className = "kelvin-estimate";
    limitsLine.dataset.testid = "kelvin-repair-limits";
    this.repairEstimate = document.createElement("div");
    this.repairEstimate.className = "kelvin-estimate";
    this.repairEstimate.dataset.testid = "kelvin-repair-estimate";
    this.defectsBox = document.createElement("div");
    this.defectsBox.className = "kelvin-estimate kelvin-defects";
    this.defectsBox.dataset.testid = "kelvin-defects";
    rep.$children.append(this.defectsBox, this.repairEstimate, limitsLine);
    this.showRepairControls(state);

    const sig = this.gui.addFolder("σ (contact allowed where σ > 0)");
    const presetLabels: Record<string, string> = { none: "none (base σ + brushes)" };
    for (const [k, p] of Object.entries(presets)) presetLabels[k] = `wrench (${k}): ${p.label.replace(/^\([abc]\)\s*/, "")}`;
    const presetOptions = Object.fromEntries(Object.entries(presetLabels).map(([k, l]) => [l, k]));
    this.add(
      sig
        .add(state, "preset", presetOptions)
        .name("preset")
        .onChange(() => a.presetChosen()),
    );
    this.add(
      sig
        .add(state, "base", -3, 3, 0.05)
        .name("base σ")
        .onFinishChange(() => a.sigmaChanged()),
    );
    this.add(
      sig
        .add(state.brush, "on")
        .name("brush (b)")
        .onChange(() => a.styleChanged()),
    );
    this.add(
      sig
        .add(state.brush, "value", -3, 3, 0.05)
        .name("brush value")
        .onChange(() => a.styleChanged()),
    );
    this.add(
      sig
        .add(state.brush, "radius", 0, 1, 0.001)
        .name("brush radius")
        .onChange(() => a.styleChanged()),
    );
    this.add(
      sig
        .add(state.brush, "falloff", 0, 1, 0.001)
        .name("brush falloff")
        .onChange(() => a.styleChanged()),
    );
    sig.add({ undo: () => a.undoStroke() }, "undo").name("undo stroke (z)");
    sig.add({ reset: () => a.resetSigma() }, "reset").name("reset σ (r)");
    sig.add({ save: () => a.saveSigma() }, "save").name("save σ file…");
    this.sigmaInput = fileInput(container, ".json,application/json", "kelvin-sigma-file", (f) => a.loadSigma(f));
    sig.add({ load: () => this.sigmaInput.click() }, "load").name("load σ file… (assets/wrench_case_*.json format)");
    this.sigmaNotice = document.createElement("div");
    this.sigmaNotice.className = "kelvin-estimate bad";
    this.sigmaNotice.dataset.testid = "kelvin-sigma-notice";
    this.sigmaNotice.hidden = true;
    sig.$children.appendChild(this.sigmaNotice);
    addColorControls(sig.addFolder("σ colours"), state.sigmaColor, () => a.styleChanged());
    // The histogram of σ over the surface (its owner draws into this box).
    this.sigmaHistogram = document.createElement("div");
    this.sigmaHistogram.className = "kelvin-histogram";
    this.sigmaHistogram.dataset.testid = "sigma-histogram";
    sig.$children.appendChild(this.sigmaHistogram);

    const iso = this.gui.addFolder("Iso-surfaces of h");
    this.levelsText = { levels: state.levels.join(", ") };
    this.add(
      iso
        .add(this.levelsText, "levels")
        .name("levels")
        .onFinishChange((v: string) => {
          const parsed = v
            .split(/[,\s]+/)
            .filter(Boolean)
            .map(Number);
          if (parsed.length && parsed.every(Number.isFinite)) {
            state.levels = [...new Set(parsed)].sort((x, y) => x - y).slice(0, 16);
            a.levelsChanged();
          }
          this.levelsText.levels = state.levels.join(", ");
          this.refresh();
        }),
    );
    this.add(
      iso
        .add(state, "showIso")
        .name("show (i)")
        .onChange(() => a.styleChanged()),
    );
    this.add(
      iso
        .add(state, "opacity", 0.02, 1, 0.01)
        .name("opacity")
        .onChange(() => a.styleChanged()),
    );

    const sl = this.gui.addFolder("Slice plane (h)");
    this.add(
      sl
        .add(state.slice, "show")
        .name("show (s)")
        .onChange(() => a.sliceChanged()),
    );
    this.add(
      sl
        .add(state.slice, "axis", sliceAxes)
        .name("normal")
        .onChange(() => a.sliceChanged()),
    );
    this.add(
      sl
        .add(state.slice, "offset", -1, 1, 0.01)
        .name("offset")
        .onFinishChange(() => a.sliceChanged()),
    );
    addColorControls(sl.addFolder("h colours"), state.sliceColor, () => a.sliceStyleChanged());

    const ex = this.gui.addFolder("Export");
    this.add(ex.add(state, "format", exportFormats).name("format"));
    ex.add({ go: () => a.exportShown() }, "go").name("export shown levels (e)");

    exactNumbers(this.gui);
    this.stats = document.createElement("table");
    this.stats.className = "kelvin-stats";
    container.appendChild(this.stats);
  }

  private add(c: Controller): Controller {
    this.controllers.push(c);
    return c;
  }

  /** Re-reads the state into the widgets (after a preset, reset, undo or URL restore). */
  refresh(levels?: number[]): void {
    if (levels) this.levelsText.levels = levels.join(", ");
    this.controllers.forEach((c) => c.updateDisplay());
  }

  /** The smallest l_x this server accepts: typed values below it are flagged at once. */
  setMinLx(minLx: number): void {
    exactNumber(this.lx, (v) => (v < minLx ? `l_x must be at least ${minLx} m on this server` : null));
    recheck(this.lx);
  }

  /** The expected cost before preparing; a refusal the server would give is shown under l_x too. */
  setEstimate(text: string, problem: { field: string; message: string } | null): void {
    this.estimate.textContent = text;
    this.estimate.classList.toggle("bad", problem !== null);
    if (problem?.field === "lx") setFieldMessage(this.lx, problem.message);
    else recheck(this.lx);
  }

  /** The note on l_x (lx_note.ts), with a button that sets the suggested value. */
  setLxNote(text: string, suggestion: number | null, use: (lx: number) => void): void {
    this.lxNote.hidden = !text;
    this.lxNote.textContent = text;
    if (suggestion === null) return;
    const b = document.createElement("button");
    b.textContent = `use l_x = ${suggestion} m`;
    b.onclick = () => use(suggestion);
    this.lxNote.append(" ", b);
  }

  /** The server's limits bound the repair's controls and are stated under them. */
  setRepairLimits(limits: Partial<Limits>): void {
    if (limits.max_hole_edges !== undefined) this.holeEdges.max(limits.max_hole_edges);
    if (limits.max_object_triangles !== undefined) this.simplify.max(limits.max_object_triangles);
    this.limitsLine.textContent = repairLimitsText(limits);
  }

  /** Only the chosen repair's options are shown. */
  showRepairControls(state: KelvinState): void {
    this.holeEdges.show(state.repair === "fix");
    this.wrapControls.forEach((c) => c.show(state.repair === "wrap"));
  }

  /** An upload's defects, one line per kind with its mark's colour (none: not an upload). */
  setDefects(lines: Array<{ text: string; color?: string }>): void {
    this.defectsBox.replaceChildren(
      ...lines.map((l) => {
        const p = document.createElement("div");
        p.textContent = l.text;
        if (l.color) p.style.setProperty("--mark", l.color);
        return p;
      }),
    );
  }

  /** What the chosen repair will do or did not get to do (the wrap's prediction, a refusal, "press prepare"). */
  setRepairEstimate(text: string, bad = false): void {
    this.repairEstimate.textContent = text;
    this.repairEstimate.classList.toggle("bad", bad);
  }

  /** The upload dialog's lines (size, refusal, repair report); `bad` marks a refusal. */
  setReport(lines: string[], bad = false): void {
    this.report.replaceChildren(
      ...lines.map((l) => {
        const p = document.createElement("div");
        p.textContent = l;
        return p;
      }),
    );
    this.report.classList.toggle("bad", bad);
  }

  setStats(rows: Array<[string, string]>): void {
    this.stats.replaceChildren(
      ...rows.map(([k, v]) => {
        const tr = document.createElement("tr");
        const a = document.createElement("th");
        a.textContent = k;
        const b = document.createElement("td");
        b.textContent = v;
        tr.append(a, b);
        return tr;
      }),
    );
  }

  dispose(): void {
    this.gui.destroy();
    this.fileInput.remove();
    this.sigmaInput.remove();
    this.stats.remove();
  }
}

/** The server's bounds on the repair options, as the panel states them. */
function repairLimitsText(l: Partial<Limits>): string {
  const n = (x: number | undefined) => (x === undefined ? "?" : x.toLocaleString("en"));
  const mb = l.max_repair_bytes === undefined ? "?" : Math.round(l.max_repair_bytes / 2 ** 20).toLocaleString("en");
  return (
    `this server: fix fills holes of at most ${n(l.max_hole_edges)} edges; a wrap is estimated before it runs and refused over ` +
    `${n(l.max_repair_faces)} faces, ${mb} MB or ${n(l.max_repair_seconds)} s; simplify to 4 … ${n(l.max_object_triangles)} faces`
  );
}

/** A hidden file chooser (a panel button clicks it); each chosen file goes to `chosen`. */
function fileInput(container: HTMLElement, accept: string, testid: string, chosen: (f: File) => void): HTMLInputElement {
  const input = document.createElement("input");
  input.type = "file";
  input.accept = accept;
  input.hidden = true;
  input.dataset.testid = testid;
  input.addEventListener("change", () => {
    const f = input.files?.[0];
    if (f) chosen(f);
    input.value = "";
  });
  container.appendChild(input);
  return input;
}
