// Draws the user's scene items (user_scene.ts) in a view's viewport: one three.js object per item
// in a group of the viewport's scene, following the store's changes until the viewport goes.
import * as THREE from "three";
import { finiteRange, VertexColorizer } from "./colormap";
import { floats, toGeometry, uints } from "./meshframe";
import { onSceneChange, sceneItems, sceneView, setSceneProbe, type ItemFrame, type Pose } from "./user_scene";
import type { Viewport } from "./viewport";

let current: Viewport | null = null;

/** The viewport the items are drawn in now (the recorder's canvas). */
export function currentViewport(): Viewport | null {
  return current;
}

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

/** Draws the items in `vp` from now on; the returned function stops (before vp is disposed). */
export function drawUserScene(vp: Viewport): () => void {
  const group = new THREE.Group();
  group.name = "user scene";
  vp.scene.add(group);
  const objects = new Map<string, { frame: ItemFrame; object: THREE.Object3D }>();
  const show = ({ frame, object }: { frame: ItemFrame; object: THREE.Object3D }) => (object.visible = frame.view === "all" || frame.view === sceneView());
  const remove = (name: string) => {
    const o = objects.get(name);
    if (!o) return;
    group.remove(o.object);
    dispose(o.object);
    objects.delete(name);
  };
  const add = (frame: ItemFrame) => {
    remove(frame.name);
    const o = { frame, object: build(frame) };
    o.object.name = frame.name;
    applyPose(o.object, frame.pose);
    show(o);
    objects.set(frame.name, o);
    group.add(o.object);
  };
  for (const frame of sceneItems()) add(frame);
  const off = onSceneChange((c) => {
    if ("item" in c) add(c.item);
    else if ("moved" in c) {
      const o = objects.get(c.moved.name);
      if (o) applyPose(o.object, c.moved.pose);
    } else if ("removed" in c) {
      for (const name of c.removed === null ? [...objects.keys()] : [c.removed]) remove(name);
    } else objects.forEach(show);
    vp.invalidate();
  });
  current = vp;
  setSceneProbe(() => new Map([...objects].map(([name, { object }]) => [name, { visible: object.visible, position: object.position.toArray() }])));
  return () => {
    off();
    if (current === vp) {
      current = null;
      setSceneProbe(null);
    }
  };
}
