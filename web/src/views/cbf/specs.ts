// The rollouts of one run: the first one chosen (metric, GAP distance) and the one it is compared
// with, drawn over each other on the same plots and robot. With Kelvin fields the comparison may
// be the same metric with σ = 0 everywhere (pure avoidance) or with each object's convex hull as
// an obstacle instead of its field. Each has a key (hooks, colours, test
// ids: the metric, "2" appended for a second rollout of the same metric), a short name for the
// plots' legends and a long one for the readout, the status line and the legend over the view.
import { gapParams, type CbfState, type GapModeChoice } from "./state";
import type { Metric } from "./types";

/** What a rollout makes of the scenario's Kelvin fields: its σ, σ = 0, or the objects' hulls. */
export type FieldMode = "sigma" | "sigma_zero" | "hull";

export interface RolloutSpec {
  key: string;
  metric: Metric;
  /** How GAP computes D (ignored for Euclidean). */
  gapMode: GapModeChoice;
  fieldMode: FieldMode;
  short: string;
  label: string;
  /** Witnesses, legends and plots; the robot's primitives. */
  color: number;
  robotColor: number;
}

const SHORT: Record<GapModeChoice, string> = { exact: "GAP", as_published_sim: "GAP pub 2e-4/300", as_published_real: "GAP pub 5e-4/20" };
const LABEL: Record<GapModeChoice, string> = { exact: "GAP exact", as_published_sim: "GAP as published (2e-4 / 300)", as_published_real: "GAP as published (5e-4 / 20)" };
// The first rollout of a metric in its usual colour (= --gap, --euclid), a second one in its own.
const COLOR: Record<string, [number, number]> = {
  gap: [0xffb347, 0xf0a040],
  euclidean: [0x6ad1a3, 0x40c8a0],
  gap2: [0x8ab4ff, 0x5f8ee8],
  euclidean2: [0xd68aff, 0xb866e8],
};

const FIELD_SHORT: Record<FieldMode, string> = { sigma: "", sigma_zero: " σ=0", hull: " hull" };
const FIELD_LABEL: Record<FieldMode, string> = { sigma: "", sigma_zero: ", σ = 0", hull: ", object hulls" };

function spec(metric: Metric, gapMode: GapModeChoice, taken: string[], fieldMode: FieldMode = "sigma"): RolloutSpec {
  const key = taken.includes(metric) ? `${metric}2` : metric;
  const [color, robotColor] = COLOR[key];
  const gap = metric === "gap";
  return {
    key,
    metric,
    gapMode: gap ? gapMode : "exact",
    fieldMode,
    short: (gap ? SHORT[gapMode] : "Eucl") + FIELD_SHORT[fieldMode],
    label: (gap ? LABEL[gapMode] : "Euclidean") + FIELD_LABEL[fieldMode],
    color,
    robotColor,
  };
}

function same(a: RolloutSpec, b: RolloutSpec): boolean {
  return a.metric === b.metric && (a.metric === "euclidean" || a.gapMode === b.gapMode) && a.fieldMode === b.fieldMode;
}

/** The rollouts the state asks for (one or two; a comparison with itself is one, and so is a
 *  comparison of fields for a scenario without them). */
export function runSpecs(s: Pick<CbfState, "metric" | "gapMode" | "compare">, hasFields = false): RolloutSpec[] {
  if (s.metric === "both") return [spec("gap", s.gapMode, []), spec("euclidean", "exact", ["gap"])];
  const first = spec(s.metric, s.gapMode, []);
  if (s.compare === "none") return [first];
  if (s.compare === "sigma_zero" || s.compare === "hull") return hasFields ? [first, spec(s.metric, s.gapMode, [first.key], s.compare)] : [first];
  const second = s.compare === "euclidean" ? spec("euclidean", "exact", [first.key]) : spec("gap", s.compare.slice(4) as GapModeChoice, [first.key]);
  return same(first, second) ? [first] : [first, second];
}

/** params.fields / params.field_mode of a rollout's request (none: the scenario's σ). */
export function specFieldParams(r: RolloutSpec, fieldCount: number): Record<string, unknown> {
  if (r.fieldMode === "sigma_zero") return { fields: Array.from({ length: fieldCount }, () => ({ sigma: {} })) };
  if (r.fieldMode === "hull") return { field_mode: "hull" };
  return {};
}

/** params.gap of a rollout's request (null: the scenario's own). */
export function specGapParams(r: RolloutSpec): Record<string, unknown> | null {
  return r.metric === "gap" ? gapParams(r.gapMode) : null;
}

/** Same rollouts (keys and what they compute). */
export function sameSpecs(a: RolloutSpec[], b: RolloutSpec[]): boolean {
  return a.length === b.length && a.every((x, i) => x.key === b[i].key && same(x, b[i]));
}
