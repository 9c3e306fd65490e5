// window.distlab.cbf: read-only views of what the page shows and how long things took, for the
// browser tests and for measuring (nothing here changes the view's state).
import * as THREE from "three";
import { errorText } from "../../core/api";
import type { ColorBarState } from "../../core/colorbar";
import type { Viewport } from "../../core/viewport";
import type { Results } from "./results";
import type { Run } from "./run";
import type { CbfScene } from "./scene";
import type { RolloutSpec } from "./specs";
import type { CbfState } from "./state";
import type { SweepJson, SweepPlot } from "./sweep";
import type { Timeline } from "./timeline";
import type { DrawTimings } from "./timings";
import type { CbfRobot } from "./types";

/** The view's parts as they are now (read at every hook access: they change with each run). */
export interface CbfParts {
  viewport: Viewport | null;
  state: CbfState;
  timeline: Timeline | null;
  run: Run | null;
  scene: CbfScene | null;
  shown: RolloutSpec[];
  robot: CbfRobot | null;
  results: Results | null;
  timings: DrawTimings;
  error: string | null;
  sweep: SweepJson | null;
  sweepPlot: SweepPlot | null;
  /** The colour bars shown (σ on the object, h at the control points). */
  colorbars: ColorBarState[];
  /** The hover line shown (σ or h under the pointer), or null. */
  hover: string | null;
}

export function installHooks(parts: () => CbfParts): () => void {
  const copy = <T>(x: T): T => structuredClone(x);
  // Rollouts by key: "gap", "euclidean", or "gap2" / "euclidean2" for a second one of a metric.
  const store = (k: string) => parts().run?.rollout(k)?.store;
  const hooks = Object.freeze({
    get state() {
      return copy(parts().state as unknown as Record<string, unknown>);
    },
    /** The step drawn now, and how many steps the timeline holds. */
    get step() {
      return parts().timeline?.step ?? 0;
    },
    get length() {
      return parts().timeline?.length ?? 0;
    },
    get playing() {
      return parts().timeline?.playing ?? false;
    },
    get rollouts() {
      return copy(rollouts(parts().run));
    },
    get lastError() {
      return parts().error;
    },
    /** The robot drawn: its name and joints (as GET /api/cbf/robot names them). */
    get robot() {
      const r = parts().robot;
      return r ? { name: r.name, dof: r.dof, joint_names: [...r.joint_names] } : null;
    },
    /** The rollouts shown: key, label (as in the legends) and colour. */
    get shown() {
      return parts().shown.map((s) => ({ key: s.key, metric: s.metric, gapMode: s.gapMode, short: s.short, label: s.label, color: s.color }));
    },
    record: (k: string) => copy(parts().run?.rollout(k)?.record ?? null),
    frame: (k: string, i: number) => copy(store(k)?.frame(i) ?? null),
    /** Per rollout key: the step drawn, the primitives' world poses and the pairs whose witnesses are shown. */
    drawn: () => copy(drawn(parts())),
    plots: () => {
      const p = parts().results?.plots;
      return copy(p ? { velocity: p.velocity.data(), distance: p.distance.data(), error: p.error.data(), pairs: p.pairs.plot.data() } : {});
    },
    /** The smoothness table as shown: the record's number behind every cell and its text. */
    table: () => copy(table(parts().results?.summary ?? null)),
    timings: () => {
      const { timings: t, results } = parts();
      const p = results?.plots;
      return copy({ arrivalToDrawnMs: t.arrivalToDrawnMs, drawMs: t.drawMs, plotRefreshes: p?.refreshes ?? 0, plotRefreshMs: p?.refreshMs ?? [] });
    },
    /** The last sweep as the server answered it, and what its plot shows. */
    sweep: () => copy({ sweep: parts().sweep, plot: parts().sweepPlot?.plot.data() ?? null }),
    /** Per rollout key shown: its Kelvin objects (σ, shells) and control points as drawn. */
    fields: () => copy(fields(parts())),
    get colorbars() {
      return copy(parts().colorbars);
    },
    get hover() {
      return parts().hover;
    },
    plotsFields: () => {
      const f = parts().results?.plots?.fields;
      return copy(f ? { h: f.h.data(), distance: f.distance.data() } : null);
    },
    /** Page coordinates of a world point (to hover it with the mouse). */
    toScreen: (p: [number, number, number]) => {
      const vp = parts().viewport;
      if (!vp) return null;
      const r = vp.renderer.domElement.getBoundingClientRect();
      const v = new THREE.Vector3(p[0], p[1], p[2]).project(vp.camera);
      return { x: r.left + ((v.x + 1) / 2) * r.width, y: r.top + ((1 - v.y) / 2) * r.height };
    },
    frameStats: () => parts().viewport?.frameStats() ?? null,
    resetFrameStats: () => parts().viewport?.resetFrameStats(),
  });
  const w = window as unknown as { distlab?: Record<string, unknown> };
  w.distlab ??= {};
  w.distlab.cbf = hooks;
  return () => {
    if (w.distlab?.cbf === hooks) delete w.distlab.cbf;
  };
}

function rollouts(run: Run | null) {
  return (run?.rollouts ?? []).map((r) => ({
    key: r.spec.key,
    label: r.spec.label,
    metric: r.metric,
    id: r.id,
    state: r.state,
    stepsDone: r.stepsDone,
    stepsTotal: r.stepsTotal,
    received: r.store?.received ?? 0,
    contiguous: r.store?.contiguous ?? 0,
    wsMessages: r.wsMessages,
    restPages: r.restPages,
    error: r.error ? errorText(r.error) : null,
  }));
}

function drawn({ scene, shown }: CbfParts) {
  const out: Record<string, { step: number; poses: number[]; witnesses: number[]; visible: boolean; color: number | null }> = {};
  if (!scene) return out;
  for (const spec of shown) {
    const w = scene.world(spec);
    const poses: number[] = [];
    const p = new THREE.Vector3(),
      q = new THREE.Quaternion(),
      s = new THREE.Vector3();
    w.robot.children.forEach((c) => {
      c.matrix.decompose(p, q, s);
      poses.push(p.x, p.y, p.z, q.w, q.x, q.y, q.z);
    });
    out[spec.key] = { step: w.step, poses, witnesses: [...w.witnesses.shown], visible: w.group.visible, color: w.robotColor() };
  }
  return out;
}

function fields({ scene, shown }: CbfParts) {
  const out: Record<string, unknown> = {};
  if (!scene) return out;
  for (const spec of shown) {
    const f = scene.world(spec).fields;
    const p = new THREE.Vector3();
    out[spec.key] = {
      owner: f.owner,
      objects: f.objects.map((o) => ({
        name: o.name,
        delta: o.delta,
        visible: o.surface.visible && o.group.visible,
        vertices: o.surface.geometry.getAttribute("position").count,
        faces: (o.surface.geometry.index?.count ?? 0) / 3,
        sigmaRange: o.sigmaRange,
        colorRange: o.colorRange,
        colors: distinctColors(o.surface.geometry.getAttribute("color") as THREE.BufferAttribute),
        shells: o.shells.meshes().map((m) => ({
          level: m.userData.level as number,
          faces: (m.geometry.index?.count ?? 0) / 3,
          visible: m.visible && o.shells.group.visible,
          color: (m.material as THREE.MeshStandardMaterial).color.getHex(),
          opacity: (m.material as THREE.MeshStandardMaterial).opacity,
        })),
        levels: o.levels,
      })),
      points: f.hasPoints
        ? { count: f.pointH.length, h: Array.from(f.pointH), colors: f.pointColors(), positions: f.pointH.length ? Array.from(f.pointAt(0, p).toArray()) : [] }
        : null,
    };
  }
  return out;
}

/** How many distinct vertex colours a colour attribute holds (a painted surface has many). */
function distinctColors(attr: THREE.BufferAttribute | undefined): number {
  if (!attr) return 0;
  const seen = new Set<string>();
  for (let i = 0; i < attr.count && seen.size < 1000; i++) seen.add(`${attr.getX(i).toFixed(3)},${attr.getY(i).toFixed(3)},${attr.getZ(i).toFixed(3)}`);
  return seen.size;
}

function table(summary: Results["summary"] | null) {
  return [...(summary?.root.querySelectorAll<HTMLElement>("table.cbf-smoothness td[data-value]") ?? [])].map((c) => ({
    metric: c.dataset.metric ?? "",
    key: c.dataset.key ?? "",
    joint: Number(c.dataset.joint),
    value: Number(c.dataset.value),
    text: c.textContent ?? "",
  }));
}
