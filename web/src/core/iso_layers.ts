// Iso-surfaces of h from the server's mesh frames (the Kelvin view's pushed frames, the CBF view's
// rollout fields): transparent, nested (outer shells drawn first), the zero level set (the safe
// set's boundary) opaque-ish orange, the others blue and fainter the further out; or all in one
// tint (a second rollout's shells over the first's). A frame older than the one shown
// (sigma_version) is dropped.
import * as THREE from "three";
import { toGeometry, type MeshFrame } from "./meshframe";
import { isSoftwareRenderer } from "./viewport";

export interface IsoFrameInfo {
  level: number;
  index: number;
  sigma_version: number;
  n_vertices: number;
  n_faces: number;
  hash: string;
  receivedAt: number;
}

type ShellMaterial = THREE.MeshStandardMaterial | THREE.MeshLambertMaterial;

interface Shell {
  mesh: THREE.Mesh<THREE.BufferGeometry, ShellMaterial>;
  info: IsoFrameInfo;
}

/** A shell's material. The shells are large translucent surfaces in front of everything, so a
 *  frame's cost on a software rasteriser (SwiftShader, llvmpipe) is mostly their fragments: there
 *  they are shaded by the Lambert model in one pass (three.js draws a double-sided transparent
 *  material in two, back faces then front), which measured a frame of the cube at l_x 0.05 with
 *  two shells 203 -> 129 ms. Both faces have the same colour and opacity, so the blend is the same
 *  in either order; only their shading differs slightly. A GPU keeps the physically based look. */
function shellMaterial(): ShellMaterial {
  const common = { transparent: true, depthWrite: false, side: THREE.DoubleSide };
  const m = isSoftwareRenderer() ? new THREE.MeshLambertMaterial({ ...common, forceSinglePass: true }) : new THREE.MeshStandardMaterial({ ...common, roughness: 0.6 });
  facingFade(m);
  return m;
}

/** How much of a shell's opacity is left where it faces the viewer (1 where seen edge-on). */
export const FACING_OPACITY = 0.1;

/** A shell h = level meets the object's surface along the contour σ = level (on the surface h = σ)
 *  and runs close to it beside that contour; seen through it, translucent and lit facet by facet
 *  at the field's resolution, the σ colours of the surface were tinted patch by patch (blotchy),
 *  and the zero shell's orange shifted every σ colour away from its colour bar. Here a shell's
 *  opacity falls to FACING_OPACITY of itself where it faces the viewer and stays where it is seen
 *  edge-on: the shells read by their outlines (as in x-ray views of nested surfaces) and the
 *  surface's colours show through them nearly unchanged. */
function facingFade(m: ShellMaterial): void {
  m.userData.facingOpacity = FACING_OPACITY;
  m.onBeforeCompile = (shader) => {
    shader.uniforms.facingOpacity = { value: FACING_OPACITY };
    shader.fragmentShader = shader.fragmentShader.replace("void main() {", "uniform float facingOpacity;\nvoid main() {").replace(
      "#include <normal_fragment_maps>",
      `#include <normal_fragment_maps>
      {
        float facing = abs( dot( normalize( normal ), normalize( vViewPosition ) ) );
        float edge = 1.0 - facing;
        diffuseColor.a *= mix( facingOpacity, 1.0, pow( edge, 4.0 ) );
      }`,
    );
  };
  m.customProgramCacheKey = () => "iso-shell-facing-fade";
}

const ZERO = new THREE.Color(0xff9f1c);
const OUTER = new THREE.Color(0x4fa3ff);

export class IsoLayers {
  readonly group = new THREE.Group();
  private shells = new Map<number, Shell>();
  private levels: number[] = [];
  private tint: THREE.Color | null = null;
  opacity = 0.28;

  setLevels(levels: number[]): void {
    this.levels = [...levels].sort((a, b) => a - b);
    for (const [level, s] of this.shells)
      if (!this.levels.includes(level)) {
        this.group.remove(s.mesh);
        s.mesh.geometry.dispose();
        s.mesh.material.dispose();
        this.shells.delete(level);
      }
    this.restyle();
  }

  /** Takes a pushed frame; returns its description, or null when stale or not a watched level. */
  accept(frame: MeshFrame, level: number, sigmaVersion: number): IsoFrameInfo | null {
    if (!this.levels.includes(level)) return null;
    const old = this.shells.get(level);
    if (old && old.info.sigma_version > sigmaVersion) return null;
    const info: IsoFrameInfo = {
      level,
      index: Number(frame.index ?? 0),
      sigma_version: sigmaVersion,
      n_vertices: frame.n_vertices,
      n_faces: frame.n_faces,
      hash: hashBytes(frame.positions),
      receivedAt: performance.now(),
    };
    const geometry = toGeometry(frame);
    if (old) {
      old.mesh.geometry.dispose();
      old.mesh.geometry = geometry;
      old.info = info;
    } else {
      const mesh = new THREE.Mesh(geometry, shellMaterial());
      mesh.userData.level = level;
      this.group.add(mesh);
      this.shells.set(level, { mesh, info });
    }
    this.restyle();
    return info;
  }

  shown(): IsoFrameInfo[] {
    return [...this.shells.values()].map((s) => s.info).sort((a, b) => a.level - b.level);
  }

  meshes(): THREE.Mesh[] {
    return [...this.shells.values()].map((s) => s.mesh);
  }

  /** The level a shell's mesh shows, or null for another object. */
  levelOf(o: THREE.Object3D): number | null {
    for (const [level, s] of this.shells) if (s.mesh === o) return level;
    return null;
  }

  setVisible(v: boolean): void {
    this.group.visible = v;
  }

  setOpacity(o: number): void {
    this.opacity = o;
    this.restyle();
  }

  /** Every shell in one colour, lighter further out (null: orange zero level, blue others). */
  setTint(color: number | null): void {
    this.tint = color === null ? null : new THREE.Color(color);
    this.restyle();
  }

  /** The colour a level's shell is drawn in (legends). */
  colorOf(level: number): THREE.Color {
    const positive = this.levels.filter((l) => l > 0);
    const top = positive.length ? Math.max(...positive) : 1;
    const out = Math.max(0, Math.min(1, level / top));
    if (this.tint) return this.tint.clone().lerp(new THREE.Color(0xffffff), 0.45 * out);
    return Math.abs(level) < 1e-12 ? ZERO.clone() : OUTER.clone().lerp(new THREE.Color(0x9fd0ff), out);
  }

  /** The opacity a level's shell is drawn with (where seen edge-on; facing the viewer, FACING_OPACITY of it). */
  opacityOf(level: number): number {
    const positive = this.levels.filter((l) => l > 0);
    const top = positive.length ? Math.max(...positive) : 1;
    return Math.abs(level) < 1e-12 ? Math.min(1, this.opacity + 0.15) : this.opacity * (1 - 0.5 * Math.max(0, Math.min(1, level / top)));
  }

  clear(): void {
    this.setLevels([]);
  }

  private restyle(): void {
    for (const [level, s] of this.shells) {
      const m = s.mesh.material;
      m.color.copy(this.colorOf(level));
      m.opacity = this.opacityOf(level);
      // Colour and opacity are uniforms: no needsUpdate (that re-derives the program every frame).
      // Transparent shells without depth writes: draw the outermost (largest level) first.
      s.mesh.renderOrder = 10 - this.levels.indexOf(level) / Math.max(1, this.levels.length);
    }
  }
}

/** FNV-1a over the bytes (tests compare meshes by hash). */
export function hashBytes(b: Uint8Array): string {
  let h = 0x811c9dc5;
  for (let i = 0; i < b.length; i++) {
    h ^= b[i];
    h = Math.imul(h, 0x01000193);
  }
  return (h >>> 0).toString(16).padStart(8, "0");
}
