// The user's own scene items (distlab.Client.scene): meshes, points, line segments and coordinate
// frames the session's client put on the server, which relays them here as "scene_item" frames
// (the mesh-frame codec) and scene_pose / scene_remove / scene_clear messages. They live in one
// group that moves into each view's viewport as it is made, so they survive view switches; an
// item with a view ("gap", "kelvin", "cbf") shows only there, "all" everywhere.
import * as THREE from "three";
import { finiteRange, VertexColorizer } from "./colormap";
import { floats, toGeometry, uints, type MeshFrame } from "./meshframe";
import type { Socket } from "./socket";
import { onViewportCreated, type Viewport } from "./viewport";

interface Pose {
  position?: number[];
  quaternion?: number[]; // w x y z
}

interface ItemFrame extends MeshFrame {
  type: "scene_item";
  name: string;
  kind: "mesh" | "points" | "lines" | "frame";
  view: string;
  colors?: Uint8Array;
  color?: number[];
  size?: number;
  pose?: Pose;
  n_segments?: number;
}

const group = new THREE.Group();
group.name = "user scene";
const items = new Map<string, { frame: ItemFrame; object: THREE.Object3D }>();
let viewport: Viewport | null = null;

let view = "gap"; // the view the shell shows (it says so before mounting one)

function applyPose(o: THREE.Object3D, pose?: Pose): void {
  const p = pose?.position ?? [0, 0, 0];
  const q = pose?.quaternion ?? [1, 0, 0, 0];
  o.position.set(p[0], p[1], p[2]);
  o.quaternion.set(q[1], q[2], q[3], q[0]);
}

/** Per-vertex colours (given, or the values through viridis), else the item's one colour. */
function colouring(frame: ItemFrame, geometry: THREE.BufferGeometry): { color: THREE.Color; vertexColors: boolean } {
  if (frame.colors) {
    geometry.setAttribute("color", new THREE.BufferAttribute(floats(frame.colors), 3));
    return { color: new THREE.Color(1, 1, 1), vertexColors: true };
  }
  if (frame.scalars) {
    const values = floats(frame.scalars);
    const attr = new THREE.BufferAttribute(new Float32Array(values.length * 3), 3);
    const colorizer = new VertexColorizer();
    const [lo, hi] = finiteRange(values);
    colorizer.set("viridis", [lo, hi > lo ? hi : lo + 1]);
    colorizer.write(attr, values);
    geometry.setAttribute("color", attr);
    return { color: new THREE.Color(1, 1, 1), vertexColors: true };
  }
  const c = frame.color ?? [0.9, 0.55, 0.2];
  return { color: new THREE.Color().setRGB(c[0], c[1], c[2], THREE.SRGBColorSpace), vertexColors: false };
}

function build(frame: ItemFrame): THREE.Object3D {
  if (frame.kind === "frame") return new THREE.AxesHelper(frame.size ?? 0.1);
  if (frame.kind === "mesh") {
    const g = toGeometry(frame);
    const { color, vertexColors } = colouring(frame, g);
    return new THREE.Mesh(g, new THREE.MeshStandardMaterial({ color, vertexColors, side: THREE.DoubleSide, roughness: 0.7 }));
  }
  const g = new THREE.BufferGeometry();
  g.setAttribute("position", new THREE.BufferAttribute(floats(frame.positions), 3));
  const { color, vertexColors } = colouring(frame, g);
  if (frame.kind === "points") return new THREE.Points(g, new THREE.PointsMaterial({ color, vertexColors, size: frame.size ?? 6, sizeAttenuation: false }));
  g.setIndex(new THREE.BufferAttribute(uints(frame.indices), 1));
  return new THREE.LineSegments(g, new THREE.LineBasicMaterial({ color, vertexColors }));
}

function dispose(o: THREE.Object3D): void {
  o.traverse((x) => {
    const m = x as THREE.Mesh;
    m.geometry?.dispose();
    (m.material as THREE.Material | undefined)?.dispose();
  });
}

function showFor(shown: string): void {
  for (const { frame, object } of items.values()) object.visible = frame.view === "all" || frame.view === shown;
  viewport?.invalidate();
}

/** The shell is about to show this view ("gap", "kelvin", "cbf"): its items are the ones drawn. */
export function userSceneView(id: string): void {
  view = id;
  showFor(view);
}

function remove(name: string): void {
  const item = items.get(name);
  if (!item) return;
  group.remove(item.object);
  dispose(item.object);
  items.delete(name);
}

/** Follows the socket's scene messages and every viewport made from now on. */
export function startUserScene(socket: Socket): void {
  onViewportCreated((vp) => {
    viewport = vp;
    vp.scene.add(group); // leaves the previous view's scene
    showFor(view);
  });
  socket.onFrame((f) => {
    if (f.type !== "scene_item") return;
    const frame = f as unknown as ItemFrame;
    remove(frame.name);
    const object = build(frame);
    object.name = frame.name;
    applyPose(object, frame.pose);
    items.set(frame.name, { frame, object });
    group.add(object);
    showFor(view);
  });
  socket.on("scene_pose", (m) => {
    const item = items.get(m.name as string);
    if (!item) return;
    item.frame.pose = m.pose as Pose;
    applyPose(item.object, item.frame.pose);
    viewport?.invalidate();
  });
  socket.on("scene_remove", (m) => {
    remove(m.name as string);
    viewport?.invalidate();
  });
  socket.on("scene_clear", () => {
    for (const name of [...items.keys()]) remove(name);
    viewport?.invalidate();
  });
  // A reconnection's "hello" is followed by every item again: start from none.
  socket.on("hello", () => {
    for (const name of [...items.keys()]) remove(name);
  });
}

/** Test hook: what the page holds and shows. */
export function userSceneItems(): Array<{ name: string; kind: string; view: string; visible: boolean; vertices: number; position: number[] }> {
  return [...items.values()].map(({ frame, object }) => ({
    name: frame.name,
    kind: frame.kind,
    view: frame.view,
    visible: object.visible && group.parent !== null,
    vertices: frame.n_vertices,
    position: object.position.toArray(),
  }));
}

/** The viewport the items are drawn in now (the recorder's canvas). */
export function currentViewport(): Viewport | null {
  return viewport;
}
