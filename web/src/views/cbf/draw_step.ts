// One rollout's world at a step of the timeline: the robot posed from its rollout's frames (at q0
// before they come), the witness pairs the state asks for, its control points, and the readout
// lines of that step.
import { fieldLines, q0Line, stepLine } from "./overlay";
import type { Rollout } from "./rollout";
import type { World } from "./scene";
import type { CbfState } from "./state";

/** Draws `world` at `step` of rollout `r` and returns its readout lines. */
export function drawStep(
  world: World,
  r: Rollout | undefined,
  step: number,
  q0: { poses: Float32Array | null; q: number[] | null },
  state: Pick<CbfState, "witnesses" | "closest">,
): string {
  const store = r?.store ?? null;
  if (!store || store.contiguous === 0 || !store.hasPoses) {
    world.showQ0(q0.poses, q0.q);
    return q0Line(world.spec, r);
  }
  const k = Math.min(step, store.contiguous - 1);
  const mode = state.witnesses;
  const pairs = !store.hasPairs || mode === "none" ? [] : mode === "all" ? store.closestPairs(k) : store.closestPairs(k).slice(0, state.closest);
  world.showStep(store, k, pairs);
  const line = stepLine(world.spec, k, store, pairs[0] !== undefined ? (r?.status?.pairs[pairs[0]]?.name ?? "") : "");
  const kelvin = r?.status?.kelvin;
  if (!kelvin || store.fieldCount === 0) return line;
  return [
    line,
    ...fieldLines(
      world.spec,
      k,
      store,
      kelvin.control_points.map((c) => c.name),
      kelvin.fields,
    ),
  ].join("\n");
}
