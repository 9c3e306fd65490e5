// A plane coloured by a scalar field sampled on an nu × nv grid (u fastest), with contour lines
// drawn in the fragment shader (shaders/scalar_slice.frag). NaN samples show as grey.
import * as THREE from "three";
import fragmentShader from "../../../shaders/scalar_slice.frag?raw";
import vertexShader from "../../../shaders/scalar_slice.vert?raw";

export interface SliceSamples {
  center: [number, number, number];
  u: [number, number, number]; // unit direction of the first grid axis
  v: [number, number, number];
  size: [number, number]; // extent along u and v
  resolution: [number, number]; // nu, nv
  values: Float32Array; // nu * nv, u fastest
}

export class SlicePlane extends THREE.Mesh<THREE.PlaneGeometry, THREE.ShaderMaterial> {
  private texture: THREE.DataTexture | null = null;

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
          diverging: { value: 1 },
        },
        side: THREE.DoubleSide,
        transparent: true,
        depthWrite: false,
      }),
    );
    this.renderOrder = 1;
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
    this.material.uniforms.field.value = tex;
    // Plane geometry spans [-0.5, 0.5]² with uv (0,0) at (-0.5, -0.5): orient u, v, normal.
    const u = new THREE.Vector3(...s.u).normalize();
    const v = new THREE.Vector3(...s.v).normalize();
    const n = new THREE.Vector3().crossVectors(u, v).normalize();
    const basis = new THREE.Matrix4().makeBasis(u.multiplyScalar(s.size[0]), v.multiplyScalar(s.size[1]), n);
    basis.setPosition(new THREE.Vector3(...s.center));
    this.matrixAutoUpdate = false;
    this.matrix.copy(basis);
    this.matrixWorldNeedsUpdate = true;
  }

  /** Colour range and contour spacing; diverging maps centre on 0 (signed distances). */
  setStyle(opts: { range?: [number, number]; spacing?: number; diverging?: boolean; opacity?: number }): void {
    const u = this.material.uniforms;
    if (opts.range) u.range.value.set(opts.range[0], opts.range[1]);
    if (opts.spacing !== undefined) u.spacing.value = opts.spacing;
    if (opts.diverging !== undefined) u.diverging.value = opts.diverging ? 1 : 0;
    if (opts.opacity !== undefined) u.opacity.value = opts.opacity;
  }

  override dispose(): void {
    this.texture?.dispose();
    this.geometry.dispose();
    this.material.dispose();
  }
}
