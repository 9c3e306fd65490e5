// The numbers of the finished rollouts, from their records: per joint the total variation of u and
// the largest |Δu|/dt (paper Fig. 4), GAP beside Euclidean with their ratio; the mean compute time
// per control step and its parts; whether the target was reached and the smallest clearance. One
// column per rollout of the run (named as in the plots' legends).
import { errorText } from "../../core/api";
import { downloadLinks } from "./download";
import type { Rollout } from "./rollout";
import type { RolloutSpec } from "./specs";
import type { CbfRecord } from "./types";

const colorCss = (s: RolloutSpec) => `#${s.color.toString(16).padStart(6, "0")}`;

function fmt(v: number | null | undefined, digits = 4): string {
  if (v === null || v === undefined || !Number.isFinite(v)) return "—";
  const a = Math.abs(v);
  return a !== 0 && (a < 1e-3 || a >= 1e5) ? v.toExponential(digits - 1) : v.toPrecision(digits);
}

function cell(tag: "td" | "th", text: string, spec?: RolloutSpec): HTMLElement {
  const c = document.createElement(tag);
  c.textContent = text;
  if (spec) c.style.color = colorCss(spec);
  return c;
}

/** Why a rollout has no numbers, or what its numbers cover (undefined: a whole finished run). */
export function rolloutNote(r: Rollout): string | undefined {
  if (!r.id) return r.state === "failed" && r.error ? `refused — ${errorText(r.error)}` : "not run";
  if (r.state === "cancelled") return `cancelled after ${r.stepsDone} of ${r.stepsTotal} steps (numbers over those)`;
  const failure = r.record?.kelvin?.failure;
  if (failure) return `stopped at step ${failure.step}: ${failure.message}`;
  return r.error ? r.error.message : undefined;
}

/** The smallest finite value over a record's fields of what `of` picks (null: none). */
function fieldMin(r: CbfRecord, of: (f: NonNullable<CbfRecord["kelvin"]>["fields"][number]) => Array<number | null>): number | null {
  let m = Infinity;
  for (const f of r.kelvin?.fields ?? []) for (const v of of(f)) if (v !== null && v < m) m = v;
  return Number.isFinite(m) ? m : null;
}

export class Summary {
  readonly root: HTMLDivElement;

  constructor(container: HTMLElement) {
    this.root = document.createElement("div");
    this.root.className = "cbf-summary";
    this.root.dataset.testid = "cbf-summary";
    container.appendChild(this.root);
    this.show([]);
  }

  show(records: Array<{ spec: RolloutSpec; record: CbfRecord | null; note?: string }>): void {
    this.root.replaceChildren();
    const h = document.createElement("h3");
    h.textContent = "Smoothness of u (paper Fig. 4)";
    this.root.appendChild(h);
    const done = records.filter((r) => r.record) as Array<{ spec: RolloutSpec; record: CbfRecord }>;
    if (done.length === 0) {
      const p = document.createElement("p");
      p.className = "cbf-muted";
      p.textContent = records.length ? "computed when the rollout ends…" : "run a rollout (r) to see the numbers";
      if (!records.some((r) => r.note)) this.root.appendChild(p);
      this.notes(records);
      return;
    }
    const table = document.createElement("table");
    table.className = "cbf-smoothness";
    table.dataset.testid = "cbf-smoothness";
    const head = document.createElement("tr");
    head.append(cell("th", "joint"));
    for (const what of ["TV", "max|Δu|/dt"]) for (const r of done) head.append(cell("th", `${what} ${r.spec.short}`, r.spec));
    const thead = document.createElement("thead");
    thead.appendChild(head);
    table.appendChild(thead);
    const body = document.createElement("tbody");
    for (let j = 0; j < done[0].record.smoothness.total_variation.length; j++) {
      const tr = document.createElement("tr");
      tr.append(cell("td", String(j + 1)));
      for (const key of ["total_variation", "max_rate"] as const)
        for (const r of done) {
          const v = r.record.smoothness[key][j];
          const c = cell("td", fmt(v), r.spec);
          c.dataset.value = String(v); // the record's number, unrounded (tests compare it)
          c.dataset.metric = r.spec.key;
          c.dataset.key = key;
          c.dataset.joint = String(j);
          tr.append(c);
        }
      body.appendChild(tr);
    }
    table.appendChild(body);
    this.root.appendChild(table);
    const unitNote = document.createElement("p");
    unitNote.className = "cbf-muted";
    unitNote.textContent = "TV = Σ|u[k+1] − u[k]| (rad/s); max|Δu|/dt in rad/s².";
    this.root.appendChild(unitNote);

    const h2 = document.createElement("h3");
    h2.textContent = "Compute time per control step (mean, µs)";
    this.root.appendChild(h2);
    const t = document.createElement("table");
    t.className = "cbf-timing";
    t.dataset.testid = "cbf-timing";
    const th = document.createElement("tr");
    th.append(cell("th", ""), ...done.map((r) => cell("th", r.spec.short, r.spec)));
    t.appendChild(th);
    const rows: Array<[string, (r: CbfRecord) => number | null, number?]> = [
      ["whole step", (r) => r.timing.step_us_mean, 1],
      ["distances + gradients", (r) => r.timing.distance_us_mean, 1],
      ["QP", (r) => r.timing.qp_us_mean, 1],
      ["kinematics", (r) => r.timing.kinematics_us_mean, 1],
      ["audit (true clearance)", (r) => r.timing.audit_us_mean, 1],
      ["wall time of the run (s)", (r) => r.timing.wall_s],
      ["steps", (r) => r.steps],
      ["reached the target", (r) => (r.summary.reached ? 1 : 0)],
      ["final ‖r‖", (r) => r.summary.final_task_error],
      ["min clearance (m)", (r) => r.summary.min_distance],
      ["infeasible steps", (r) => r.infeasible_steps.length],
    ];
    // Kelvin fields (issue 33): the outcomes the semantic run is read by.
    if (done.some((r) => r.record.kelvin))
      rows.push(
        ["min h over the run (≥ δ)", (r) => fieldMin(r, (f) => f.h.flat())],
        ["δ", (r) => fieldMin(r, (f) => [f.delta])],
        ["final distance to allowed faces (m)", (r) => fieldMin(r, (f) => f.allowed_distance.slice(-1))],
        ["min distance to forbidden faces (m)", (r) => fieldMin(r, (f) => f.forbidden_distance)],
        ["safety distance (m)", (r) => fieldMin(r, (f) => [f.safety_distance])],
        ["closest point's σ at the end", (r) => r.kelvin?.fields[0]?.closest_sigma.at(-1) ?? null],
        ["a field row failed at step", (r) => r.kelvin?.failure?.step ?? null],
      );
    for (const [name, get, fixed] of rows) {
      const tr = document.createElement("tr");
      tr.append(cell("td", name));
      for (const r of done) {
        const v = get(r.record);
        const text = name === "reached the target" ? (v ? "yes" : "no") : fixed !== undefined && v !== null ? v.toFixed(fixed) : fmt(v);
        const c = cell("td", text, r.spec);
        if (v !== null) c.dataset.value = String(v);
        tr.append(c);
      }
      t.appendChild(tr);
    }
    this.root.appendChild(t);
    if (done.length === 2) {
      const [a, b] = done;
      const p = document.createElement("p");
      p.className = "cbf-muted";
      const ratio = a.record.timing.step_us_mean / b.record.timing.step_us_mean;
      p.textContent = `${a.spec.label} step / ${b.spec.label} step = ${ratio.toFixed(2)}× (one after the other in this server, on a shared machine: a rough comparison; distlab-bench-cbf measures it properly).`;
      this.root.appendChild(p);
    }
    for (const r of done) this.root.appendChild(downloadLinks(r.spec.key, r.spec.label, r.record));
    this.notes(records);
  }

  private notes(records: Array<{ spec: RolloutSpec; note?: string }>): void {
    for (const r of records) {
      if (!r.note) continue;
      const p = document.createElement("p");
      p.className = "cbf-note";
      p.textContent = `${r.spec.label}: ${r.note}`;
      this.root.appendChild(p);
    }
  }

  dispose(): void {
    this.root.remove();
  }
}
