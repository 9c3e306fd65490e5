// Hovering the slice plane shows the field's value under the pointer (the value its colour
// shows: the server's grid interpolated bilinearly, as the texture is), with its unit.
import * as THREE from "three";
import type { Viewport } from "../../core/viewport";
import type { IsoLayer } from "./levelsets";
import type { IsoState } from "./state";

export interface SliceReading {
  field: "weak" | "strict";
  value: number | null; // null on S itself and where the field is undefined
  point: [number, number, number];
}

const fmt = (x: number) => (x !== 0 && (Math.abs(x) >= 1e4 || Math.abs(x) < 1e-3) ? x.toExponential(4) : x.toFixed(5));

/** Installs the hover read-out; returns its removal. `last()` is the latest reading (tests). */
export function installSliceHover(vp: Viewport, iso: IsoLayer, parent: HTMLElement, state: () => IsoState): { remove(): void; last(): SliceReading | null } {
  const el = document.createElement("div");
  el.className = "readout gap-slice-readout";
  el.dataset.testid = "gap-slice-readout";
  el.hidden = true;
  parent.appendChild(el);
  const dom = vp.renderer.domElement;
  const ray = new THREE.Raycaster();
  let last: SliceReading | null = null;
  const onMove = (e: PointerEvent) => {
    const field = state().slice;
    if (e.buttons !== 0 || field === "none" || !iso.slice.visible) return void (el.hidden = true);
    const r = dom.getBoundingClientRect();
    ray.setFromCamera(new THREE.Vector2(((e.clientX - r.left) / r.width) * 2 - 1, -((e.clientY - r.top) / r.height) * 2 + 1), vp.camera);
    const hit = ray.intersectObject(iso.slice, false)[0];
    if (!hit?.uv) return void (el.hidden = true);
    const v = iso.slice.valueAt(hit.uv);
    const name = field === "weak" ? "e_S (weak, eq. 5)" : "E_S (strict, eq. 6)";
    last = { field, value: Number.isFinite(v) ? v : null, point: hit.point.toArray() as [number, number, number] };
    el.textContent = `slice at x = (${last.point.map(fmt).join(", ")}) m\n${name} = ${last.value === null ? "0 (in S) or undefined" : `${fmt(v)} m²`}`;
    el.hidden = false;
  };
  const onLeave = () => (el.hidden = true);
  dom.addEventListener("pointermove", onMove);
  dom.addEventListener("pointerleave", onLeave);
  return {
    remove: () => {
      dom.removeEventListener("pointermove", onMove);
      dom.removeEventListener("pointerleave", onLeave);
      el.remove();
    },
    last: () => last,
  };
}
