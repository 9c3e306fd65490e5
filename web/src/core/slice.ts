// A plane coloured by a scalar field sampled on an nu × nv grid (u fastest), with contour lines
// drawn in the fragment shader (shaders/scalar_slice.frag). NaN samples show as grey.
import * as THREE from "three";
import { colormapBytes, isDiverging, type ColormapName } from "./colormap";
import fragmentShader from "../../../shaders/scalar_slice.frag?raw";
import vertexShader from "../../../shaders/scalar_slice.vert?raw";

export interface SliceSamples {
  center: [number, number, number];
  u: [number, number, number]; // unit direction of the first grid axis
  v: [number, number, number];
  size: [number, number]; // extent along u and v
  resolution: [number, number]; // nu, nv
  values: Float32Array; // nu * nv, u fastest
  /** Samples at the nodes of a grid spanning `size` (edges included, spacing size / (n − 1)), as
   *  the GAP level-set endpoint takes them; otherwise at the centres of n × n cells of `size`. */
  atNodes?: boolean;
}

export class SlicePlane extends THREE.Mesh<THREE.PlaneGeometry, THREE.ShaderMaterial> {
  private texture: THREE.DataTexture | null = null;
  private lut: THREE.DataTexture | null = null;
  private samples: SliceSamples | null = null;
  private map: ColormapName | null = null;

  constructor() {
    super(
      new THREE.PlaneGeometry(1, 1),
      new THREE.ShaderMaterial({
        vertexShader,
        fragmentShader,
        uniforms: {
          field: { value: null },
          range: { value: new THREE.Vector2(0, 1) },
          spacing: { value: 0.05 },
          opacity: { value: 0.92 },
          centred: { value: 1 },
          colormap: { value: null },
        },
        side: THREE.DoubleSide,
        transparent: true,
        depthWrite: false,
      }),
    );
    this.renderOrder = 1;
    this.setStyle({ map: "coolwarm" });
  }

  setSamples(s: SliceSamples): void {
    const [nu, nv] = s.resolution;
    if (s.values.length !== nu * nv) throw new Error("slice: values do not match the resolution");
    this.texture?.dispose();
    const tex = new THREE.DataTexture(s.values, nu, nv, THREE.RedFormat, THREE.FloatType);
    tex.magFilter = THREE.LinearFilter;
    tex.minFilter = THREE.LinearFilter;
    tex.needsUpdate = true;
    this.texture = tex;
    this.samples = s;
    this.material.uniforms.field.value = tex;
    // Plane geometry spans [-0.5, 0.5]² with uv (0,0) at (-0.5, -0.5): orient u, v, normal.
    const u = new THREE.Vector3(...s.u).normalize();
    const v = new THREE.Vector3(...s.v).normalize();
    const n = new THREE.Vector3().crossVectors(u, v).normalize();
    // Texel centres sit at (i + 0.5) / n of the drawn plane: for node samples it reaches half a
    // spacing beyond the outer nodes, so that each texel centre is on its sample's point.
    const [su, sv] = s.atNodes ? [(s.size[0] * nu) / (nu - 1), (s.size[1] * nv) / (nv - 1)] : s.size;
    const basis = new THREE.Matrix4().makeBasis(u.multiplyScalar(su), v.multiplyScalar(sv), n);
    basis.setPosition(new THREE.Vector3(...s.center));
    this.matrixAutoUpdate = false;
    this.matrix.copy(basis);
    this.matrixWorldNeedsUpdate = true;
  }

  /** The field at texture coordinates (uv in [0, 1]², as a raycast's hit gives them), bilinear as
   *  the texture is sampled: the value the colour under the pointer shows. NaN where undefined. */
  valueAt(uv: THREE.Vector2): number {
    const s = this.samples;
    if (!s) return NaN;
    const [nu, nv] = s.resolution;
    const x = Math.min(nu - 1, Math.max(0, uv.x * nu - 0.5)),
      y = Math.min(nv - 1, Math.max(0, uv.y * nv - 0.5));
    const i = Math.min(nu - 2, Math.floor(x)),
      j = Math.min(nv - 2, Math.floor(y));
    const a = x - i,
      b = y - j,
      f = (p: number, q: number) => s.values[q * nu + p];
    return (1 - b) * ((1 - a) * f(i, j) + a * f(i + 1, j)) + b * ((1 - a) * f(i, j + 1) + a * f(i + 1, j + 1));
  }

  /** Colour range and contour spacing; diverging maps centre on 0 (signed distances). */
  setStyle(opts: { range?: [number, number]; spacing?: number; map?: ColormapName; opacity?: number }): void {
    const u = this.material.uniforms;
    if (opts.range) u.range.value.set(opts.range[0], opts.range[1]);
    if (opts.spacing !== undefined) u.spacing.value = opts.spacing;
    if (opts.map !== undefined && opts.map !== this.map) {
      this.map = opts.map;
      this.lut?.dispose();
      const lut = (this.lut = new THREE.DataTexture(colormapBytes(opts.map), 256, 1, THREE.RGBAFormat, THREE.UnsignedByteType));
      lut.magFilter = lut.minFilter = THREE.LinearFilter;
      lut.needsUpdate = true;
      u.colormap.value = lut;
      u.centred.value = isDiverging(opts.map) ? 1 : 0;
    }
    if (opts.opacity !== undefined) u.opacity.value = opts.opacity;
  }

  override dispose(): void {
    this.texture?.dispose();
    this.lut?.dispose();
    this.geometry.dispose();
    this.material.dispose();
  }
}
