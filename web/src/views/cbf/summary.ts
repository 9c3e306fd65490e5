// The numbers of the finished rollouts, from their records: per joint the total variation of u and
// the largest |Δu|/dt (paper Fig. 4), GAP beside Euclidean with their ratio; the mean compute time
// per control step and its parts; whether the target was reached and the smallest clearance.
import { errorText } from "../../core/api";
import { downloadLinks } from "./download";
import type { Rollout } from "./rollout";
import type { CbfRecord, Metric } from "./types";

const NAME: Record<Metric, string> = { gap: "GAP", euclidean: "Eucl." };

function fmt(v: number | null | undefined, digits = 4): string {
  if (v === null || v === undefined || !Number.isFinite(v)) return "—";
  const a = Math.abs(v);
  return a !== 0 && (a < 1e-3 || a >= 1e5) ? v.toExponential(digits - 1) : v.toPrecision(digits);
}

function cell(tag: "td" | "th", text: string, cls?: string): HTMLElement {
  const c = document.createElement(tag);
  c.textContent = text;
  if (cls) c.className = cls;
  return c;
}

/** Why a rollout has no numbers, or what its numbers cover (undefined: a whole finished run). */
export function rolloutNote(r: Rollout): string | undefined {
  if (!r.id) return r.state === "failed" && r.error ? `refused — ${errorText(r.error)}` : "not run";
  if (r.state === "cancelled") return `cancelled after ${r.stepsDone} of ${r.stepsTotal} steps (numbers over those)`;
  return r.error ? r.error.message : undefined;
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

  show(records: Array<{ metric: Metric; record: CbfRecord | null; note?: string }>): void {
    this.root.replaceChildren();
    const h = document.createElement("h3");
    h.textContent = "Smoothness of u (paper Fig. 4)";
    this.root.appendChild(h);
    const done = records.filter((r) => r.record) as Array<{ metric: Metric; record: CbfRecord }>;
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
    for (const what of ["TV", "max|Δu|/dt"]) for (const r of done) head.append(cell("th", `${what} ${NAME[r.metric]}`, `cbf-${r.metric}`));
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
          const c = cell("td", fmt(v), `cbf-${r.metric}`);
          c.dataset.value = String(v); // the record's number, unrounded (tests compare it)
          c.dataset.metric = r.metric;
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
    th.append(cell("th", ""), ...done.map((r) => cell("th", NAME[r.metric], `cbf-${r.metric}`)));
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
    for (const [name, get, fixed] of rows) {
      const tr = document.createElement("tr");
      tr.append(cell("td", name));
      for (const r of done) {
        const v = get(r.record);
        const text = name === "reached the target" ? (v ? "yes" : "no") : fixed !== undefined && v !== null ? v.toFixed(fixed) : fmt(v);
        const c = cell("td", text, `cbf-${r.metric}`);
        if (v !== null) c.dataset.value = String(v);
        tr.append(c);
      }
      t.appendChild(tr);
    }
    this.root.appendChild(t);
    if (done.length === 2) {
      const [g, e] = [done.find((r) => r.metric === "gap")!, done.find((r) => r.metric === "euclidean")!];
      const p = document.createElement("p");
      p.className = "cbf-muted";
      const ratio = g.record.timing.step_us_mean / e.record.timing.step_us_mean;
      p.textContent = `GAP step / Euclidean step = ${ratio.toFixed(2)}× (one after the other in this server, on a shared machine: a rough comparison; distlab-bench-cbf measures it properly).`;
      this.root.appendChild(p);
    }
    for (const r of done) this.root.appendChild(downloadLinks(r.metric, NAME[r.metric], r.record));
    this.notes(records);
  }

  private notes(records: Array<{ metric: Metric; note?: string }>): void {
    for (const r of records) {
      if (!r.note) continue;
      const p = document.createElement("p");
      p.className = "cbf-note";
      p.textContent = `${NAME[r.metric]}: ${r.note}`;
      this.root.appendChild(p);
    }
  }

  dispose(): void {
    this.root.remove();
  }
}
