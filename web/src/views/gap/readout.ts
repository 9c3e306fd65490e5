// The numbers the user reads: an overlay on the viewport (GAP beside Euclidean, with the legend
// colours of the witness segments, the witness points' coordinates and the gradient of D drawn
// as arrows) and one line for the status bar.
export interface Validation {
  max_eigenvalue: number;
  ok: boolean;
  samples: number;
}

/** One pair's answer from /api/gap/distance (the `distlab gap` response). */
export interface GapResult {
  lambda: number;
  distance: number;
  witness_a: number[];
  witness_b: number[];
  iterations: number;
  converged: boolean;
  overlap: boolean;
  euclidean: {
    distance: number;
    /** distance when apart, −penetration.depth when overlapping. */
    signed_distance: number;
    witness_a: number[];
    witness_b: number[];
    gradient_a?: number[];
    gradient_b?: number[];
    /** Overlapping shapes: moving B by depth along direction (unit, A → B) separates them. */
    penetration?: { depth: number; direction: number[]; witness_a: number[]; witness_b: number[] };
  };
  gradient_a?: number[];
  gradient_b?: number[];
  validation?: { a?: Validation; b?: Validation };
}

/** Fixed significant digits so the text is stable and comparable with a direct API call. */
export const fmt = (v: number): string => (Number.isFinite(v) ? v.toPrecision(6) : String(v));
/** A vector's components to 6 significant digits; a component below 1e-12 of the largest is 0
 *  (rounding in the server's sums, e.g. 8.6e-17 beside 1). */
export function vec(v: number[]): string {
  const big = Math.max(...v.slice(0, 3).map(Math.abs));
  return `(${v
    .slice(0, 3)
    .map((x) => (Math.abs(x) <= 1e-12 * big || x === 0 ? "0" : fmt(x)))
    .join(", ")})`;
}

export class Readout {
  readonly el: HTMLDivElement;

  constructor(parent: HTMLElement) {
    this.el = document.createElement("div");
    this.el.className = "readout gap-readout";
    this.el.dataset.testid = "gap-readout";
    parent.appendChild(this.el);
    this.waiting();
  }

  waiting(): void {
    this.el.replaceChildren(this.line("muted", "computing…"));
  }

  /** `gradient`: the gradient lines too (when the display shows it and the result has it). */
  show(r: GapResult, solver: string, gradient = false): void {
    const pen = r.euclidean.penetration;
    this.el.classList.remove("stale");
    const grad: HTMLDivElement[] = [];
    if (gradient && r.gradient_a && r.gradient_b) {
      // The server's gradient_x: dD/d(v, ω) of x's pose, world frame, ω about x's own origin.
      for (const [k, g] of [
        ["a", r.gradient_a],
        ["b", r.gradient_b],
      ] as const) {
        grad.push(this.line("legend-grad-lin", `${k === "a" ? "∇D of A" : "∇D of B"}  ∂D/∂p = ${vec(g.slice(0, 3))} m/m`, `grad-${k}-linear`));
        grad.push(this.line("legend-grad-ang", `          ∂D/∂θ = ${vec(g.slice(3, 6))} m/rad`, `grad-${k}-angular`));
      }
      grad.push(this.line("muted", r.overlap ? "          zero on overlap (Λ = 0)" : "          world frame; θ: rotation about the shape's origin", "grad-note"));
    }
    this.el.replaceChildren(
      this.line("legend-gap", `● GAP        D = ${fmt(r.distance)} m`, "gap-d"),
      this.line("legend-gap", `             Λ = ${fmt(r.lambda)} m²`, "gap-lambda"),
      this.line("legend-gap", `             ${r.iterations} iterations (${solver})${r.converged ? "" : " — not converged"}`, "gap-iter"),
      this.line("legend-gap", `             witness a* = ${vec(r.witness_a)} m`, "gap-witness-a"),
      this.line("legend-gap", `             witness b* = ${vec(r.witness_b)} m`, "gap-witness-b"),
      // What a newcomer misreads: D beside d, and a*, b* off the surfaces.
      this.line("muted", "             D is 0 on contact but not the Euclidean d: near contact D ∝ d^(k+1);", "gap-note-d"),
      this.line("muted", "             a*, b* are eq. 2's smooth witness points, off the surfaces", "gap-note-witness"),
      ...grad,
      this.line("legend-euclid", `● Euclidean  d = ${fmt(r.euclidean.distance)} m`, "euclid-d"),
      this.line("legend-euclid", `             signed d = ${fmt(r.euclidean.signed_distance)} m`, "euclid-signed"),
      this.line("legend-euclid", `             nearest a = ${vec(r.euclidean.witness_a)} m`, "euclid-witness-a"),
      this.line("legend-euclid", `             nearest b = ${vec(r.euclidean.witness_b)} m`, "euclid-witness-b"),
      ...(pen ? [this.line("legend-pen", `● penetration depth = ${fmt(pen.depth)} m along (${pen.direction.map((v) => v.toFixed(3)).join(", ")})`, "euclid-pen")] : []),
      this.line(r.overlap ? "legend-bad" : "muted", r.overlap ? "overlap: the shapes intersect (Λ = 0)" : "no overlap", "overlap"),
    );
  }

  /** Keeps the last numbers but marks them as not matching the current input. */
  error(message: string): void {
    this.el.classList.add("stale");
    const old = [...this.el.querySelectorAll(".err")];
    old.forEach((e) => e.remove());
    this.el.appendChild(this.line("legend-bad err", message, "error"));
  }

  text(): string {
    return this.el.textContent ?? "";
  }

  private line(cls: string, text: string, id?: string): HTMLDivElement {
    const d = document.createElement("div");
    d.className = cls;
    d.textContent = text;
    if (id) d.dataset.field = id;
    return d;
  }
}

export function statusLine(r: GapResult, solver: string): string {
  return `GAP D = ${fmt(r.distance)} m · Λ = ${fmt(r.lambda)} · ${r.iterations} it (${solver}) · Euclidean d = ${fmt(r.euclidean.distance)} m${r.euclidean.penetration ? ` · penetration ${fmt(r.euclidean.penetration.depth)} m` : ""}${r.overlap ? " · overlap" : ""}`;
}
