// Colour maps for per-vertex scalars (σ on a surface, distances): CPU side, to vertex colours.
import * as THREE from "three";

/** Blue (negative) — white (0) — red (positive), symmetric around 0 with half-width `scale`. */
export function diverging(value: number, scale: number, out = new THREE.Color()): THREE.Color {
  const t = Math.max(-1, Math.min(1, value / Math.max(scale, 1e-12)));
  const blue = [0.23, 0.3, 0.75], white = [0.95, 0.95, 0.95], red = [0.71, 0.02, 0.15];
  const [a, b, s] = t < 0 ? [white, blue, -t] : [white, red, t];
  return out.setRGB(a[0] + (b[0] - a[0]) * s, a[1] + (b[1] - a[1]) * s, a[2] + (b[2] - a[2]) * s, THREE.SRGBColorSpace);
}

/** Writes a "color" attribute from per-vertex scalars. */
export function colorize(geometry: THREE.BufferGeometry, scalars: ArrayLike<number>, scale: number): void {
  const n = scalars.length;
  let attr = geometry.getAttribute("color") as THREE.BufferAttribute | undefined;
  if (!attr || attr.count !== n) {
    attr = new THREE.BufferAttribute(new Float32Array(n * 3), 3);
    geometry.setAttribute("color", attr);
  }
  const c = new THREE.Color();
  for (let i = 0; i < n; i++) {
    diverging(scalars[i], scale, c);
    attr.setXYZ(i, c.r, c.g, c.b);
  }
  attr.needsUpdate = true;
}
