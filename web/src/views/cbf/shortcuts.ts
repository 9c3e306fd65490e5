// The view's keyboard shortcuts: play/pause and stepping on the timeline, playback speed, run and
// cancel, and cycling how witnesses, joints and the two robots are drawn.
import type { Shortcut } from "../../core/keys";
import { SPEEDS, WITNESS_MODES, type CbfState } from "./state";
import type { Timeline } from "./timeline";

export interface ShortcutTarget {
  timeline(): Timeline;
  state(): CbfState;
  /** The panel shows the state as it is now. */
  refreshPanel(): void;
  save(): void;
  /** The robot's joint count (j cycles all → 1 → … → dof). */
  dof(): number;
  changed(what: "draw" | "joint" | "layout"): void;
  run(): void;
  cancel(): void;
  frame(): void;
  /** The camera on the Kelvin objects. */
  frameFields(): void;
}

export function cbfShortcuts(v: ShortcutTarget): Shortcut[] {
  const tl = () => v.timeline();
  const stepBy = (n: number) => () => {
    tl().pause();
    tl().seek(tl().step + n);
  };
  const speed = (dir: 1 | -1) => () => {
    const state = v.state();
    const i = SPEEDS.findIndex((s) => s >= state.speed);
    const next = SPEEDS[Math.max(0, Math.min(SPEEDS.length - 1, (i < 0 ? SPEEDS.length - 1 : i) + dir))];
    state.speed = next;
    tl().setSpeed(next);
    v.refreshPanel();
    v.save();
  };
  /** Sets the next value of a drawing option and redraws. */
  const cycle = (set: (s: CbfState) => void, what: "draw" | "joint" | "layout") => () => {
    set(v.state());
    v.refreshPanel();
    v.changed(what);
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
    { key: "r", description: "run the rollout(s)", run: () => v.run() },
    { key: "Escape", description: "cancel the running rollout", run: () => v.cancel() },
    {
      key: "w",
      description: "witness pairs: closest → all → none",
      run: cycle((s) => (s.witnesses = WITNESS_MODES[(WITNESS_MODES.indexOf(s.witnesses) + 1) % WITNESS_MODES.length]), "draw"),
    },
    { key: "j", description: "plot joints: all → 1 → … → the last", run: cycle((s) => (s.joint = (s.joint + 1) % (v.dof() + 1)), "joint") },
    { key: "l", description: "two robots: overlay / side by side", run: cycle((s) => (s.layout = s.layout === "overlay" ? "side" : "overlay"), "layout") },
    { key: "f", description: "frame the scene", run: () => v.frame() },
    { key: "o", description: "frame the Kelvin object", run: () => v.frameFields() },
  ];
}
