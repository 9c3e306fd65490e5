// The user's own scene items (distlab.Client.scene): meshes, points, line segments and coordinate
// frames the session's client put on the server, which relays them here as "scene_item" frames
// (the mesh-frame codec) and scene_pose / scene_remove / scene_clear messages. This is their store,
// kept by the shell across view switches and free of three.js (the shell's chunk stays small);
// user_scene_draw.ts draws them in each view's viewport. An item with a view ("gap", "kelvin",
// "cbf") shows only there, "all" everywhere.
import type { MeshFrame } from "./meshframe";
import type { Socket } from "./socket";

export interface Pose {
  position?: number[];
  quaternion?: number[]; // w x y z
}

export interface ItemFrame extends MeshFrame {
  type: "scene_item";
  name: string;
  kind: "mesh" | "points" | "lines" | "frame";
  view: string;
  colors?: Uint8Array;
  color?: number[];
  size?: number;
  pose?: Pose;
}

/** What changed: an item added or replaced, moved, removed (null: all), or the view shown. */
export type SceneChange = { item: ItemFrame } | { moved: ItemFrame } | { removed: string | null } | { view: string };

const items = new Map<string, ItemFrame>();
const listeners = new Set<(c: SceneChange) => void>();
let view = "gap"; // the view the shell shows (it says so before mounting one)
let probe: (() => Map<string, { visible: boolean; position: number[] }>) | null = null;

const emit = (c: SceneChange) => listeners.forEach((f) => f(c));

export function sceneItems(): Iterable<ItemFrame> {
  return items.values();
}
export function sceneView(): string {
  return view;
}
export function onSceneChange(f: (c: SceneChange) => void): () => void {
  listeners.add(f);
  return () => listeners.delete(f);
}

/** The shell is about to show this view ("gap", "kelvin", "cbf"): its items are the ones drawn. */
export function userSceneView(id: string): void {
  view = id;
  emit({ view });
}

/** Follows the socket's scene messages (call before the socket starts). */
export function startUserScene(socket: Socket): void {
  socket.onFrame((f) => {
    if (f.type !== "scene_item") return;
    const frame = f as unknown as ItemFrame;
    items.set(frame.name, frame);
    emit({ item: frame });
  });
  socket.on("scene_pose", (m) => {
    const frame = items.get(m.name as string);
    if (!frame) return;
    frame.pose = m.pose as Pose;
    emit({ moved: frame });
  });
  socket.on("scene_remove", (m) => {
    if (items.delete(m.name as string)) emit({ removed: m.name as string });
  });
  const clear = () => {
    items.clear();
    emit({ removed: null });
  };
  socket.on("scene_clear", clear);
  socket.on("hello", clear); // a (re)connection's hello is followed by every item again
}

/** The drawing's report of what it shows (user_scene_draw.ts registers it). */
export function setSceneProbe(f: typeof probe): void {
  probe = f;
}

/** Test hook: what the page holds and what its view draws. */
export function userSceneItems(): Array<{ name: string; kind: string; view: string; visible: boolean; vertices: number; position: number[] }> {
  const drawn = probe?.() ?? new Map<string, { visible: boolean; position: number[] }>();
  return [...items.values()].map((f) => ({
    name: f.name,
    kind: f.kind,
    view: f.view,
    visible: drawn.get(f.name)?.visible ?? false,
    vertices: f.n_vertices,
    position: drawn.get(f.name)?.position ?? [],
  }));
}
