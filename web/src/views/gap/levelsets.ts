// Iso-surfaces of e_S (weak, eq. 5) and E_S (strict, eq. 6) around one shape, transparent and
// nested, and a slice plane coloured by either field with contour lines (the paper's Fig. 1 in
// 3D). Requested in the shape's own frame and attached to the shape's group, so dragging the shape
// moves them without asking the server again; only size, parameter and level edits refetch.
import * as THREE from "three";
import { api } from "../../core/api";
import { ColorBar } from "../../core/colorbar";
import { finiteRange, resolveRange } from "../../core/colormap";
import { LatestWins, type LatestResult } from "../../core/latest";
import { floats, toGeometry, type MeshFrame } from "../../core/meshframe";
import { SlicePlane } from "../../core/slice";
import { boundingRadius, shapeBody, type ShapeState } from "./shapes";
import { paramsBody, type GapParams, type IsoState } from "./state";

interface LevelsetsResponse {
  type: "gap_levelsets";
  surfaces: Array<MeshFrame & { field: "weak" | "strict"; level: number }>;
  plane?: {
    center: [number, number, number];
    u: [number, number, number];
    v: [number, number, number];
    size: [number, number];
    resolution: [number, number];
    weak: Uint8Array;
    strict: Uint8Array;
  };
}

export interface IsoInput {
  shape: ShapeState;
  params: GapParams;
  iso: IsoState;
}

const NORMALS = { x: [1, 0, 0], y: [0, 1, 0], z: [0, 0, 1] } as const;
// Hues of the two fields' surfaces: weak in blues, strict in oranges (inner levels lighter).
const HUES = { weak: 0.58, strict: 0.08 };

export class IsoLayer {
  readonly group = new THREE.Group();
  readonly slice = new SlicePlane();
  private readonly requests: LatestWins<IsoInput, LevelsetsResponse>;
  /** The slice's colour bar (set by the view, in its canvas). */
  colorBar: ColorBar | null = null;
  private planeFields: { weak: Float32Array; strict: Float32Array; meta: NonNullable<LevelsetsResponse["plane"]> } | null = null;
  /** What the user sees (tests): the surfaces and the slice currently shown. */
  shown: { surfaces: Array<{ field: string; level: number; triangles: number }>; slice: string; sliceRange: [number, number] | null } = {
    surfaces: [],
    slice: "none",
    sliceRange: null,
  };

  constructor(
    private readonly onUpdate: (error: unknown | null) => void,
    private readonly onBusy: (busy: boolean) => void,
  ) {
    this.group.name = "iso";
    this.slice.visible = false;
    this.group.add(this.slice);
    this.requests = new LatestWins(
      (i) => this.fetch(i),
      (r) => this.apply(r),
    );
  }

  get requestsSent(): number {
    return this.requests.sent;
  }

  update(input: IsoInput): void {
    this.onBusy(true);
    this.requests.submit(structuredClone(input));
  }

  /** Re-colours the slice without asking the server (field, spacing changed). */
  restyle(iso: IsoState): void {
    if (!this.planeFields || iso.slice === "none") {
      this.slice.visible = false;
      this.shown.slice = "none";
      if (this.colorBar) this.colorBar.visible = false;
      return;
    }
    // Both fields are exactly 0 on the set S itself: draw it as "inside" (the shader's NaN grey).
    const f = Float32Array.from(iso.slice === "weak" ? this.planeFields.weak : this.planeFields.strict, (x) => (x === 0 ? NaN : x));
    const data = finiteRange(f);
    const range = resolveRange(iso.color, ...data);
    const m = this.planeFields.meta;
    this.slice.setSamples({ center: m.center, u: m.u, v: m.v, size: m.size, resolution: m.resolution, values: f, atNodes: true });
    this.slice.setStyle({ range, spacing: iso.spacing, map: iso.color.map, opacity: 0.85 });
    this.slice.visible = true;
    this.shown.slice = iso.slice;
    this.shown.sliceRange = range;
    if (this.colorBar) {
      this.colorBar.retitle(iso.slice === "weak" ? "e_S on the slice (weak, eq. 5)" : "E_S on the slice (strict, eq. 6)");
      this.colorBar.update(iso.color, range, Number.isFinite(data[0]) ? data : null);
      this.colorBar.visible = true;
    }
  }

  private fetch(i: IsoInput): Promise<LevelsetsResponse> {
    const n = NORMALS[i.iso.normal];
    const side = 2 * Math.max(2.2 * boundingRadius(i.shape), boundingRadius(i.shape) + 0.4);
    const want = i.iso.surfaces;
    const body = {
      shape: shapeBody(i.shape),
      params: paramsBody(i.params, { gradient: undefined, solver: undefined }),
      levels: {
        weak: want === "weak" || want === "both" ? i.iso.weak : [],
        strict: want === "strict" || want === "both" ? i.iso.strict : [],
      },
      grid: { resolution: 48 },
      plane: { center: n.map((c) => c * i.iso.offset), normal: [...n], size: [side, side], resolution: [200, 200] },
    };
    return api.msgpack<LevelsetsResponse>("POST", "/api/gap/levelsets", stripUndefined(body));
  }

  private apply(r: LatestResult<IsoInput, LevelsetsResponse>): void {
    this.onBusy(false);
    if (r.error !== undefined || !r.output) {
      this.onUpdate(r.error ?? new Error("no level sets"));
      return;
    }
    const out = r.output;
    for (const o of [...this.group.children]) {
      if (o === this.slice) continue;
      this.group.remove(o);
      const m = o as THREE.Mesh;
      m.geometry.dispose();
      (m.material as THREE.Material).dispose();
    }
    const byField = { weak: out.surfaces.filter((s) => s.field === "weak"), strict: out.surfaces.filter((s) => s.field === "strict") };
    this.shown.surfaces = [];
    for (const field of ["weak", "strict"] as const) {
      const list = [...byField[field]].sort((a, b) => b.level - a.level); // outer first
      list.forEach((s, rank) => {
        if (s.n_faces === 0) return;
        const inner = list.length > 1 ? rank / (list.length - 1) : 1;
        const mat = new THREE.MeshLambertMaterial({
          color: new THREE.Color().setHSL(HUES[field], 0.85, 0.45 + 0.2 * inner),
          transparent: true,
          opacity: 0.18 + 0.12 * inner,
          depthWrite: false,
          side: THREE.DoubleSide,
          forceSinglePass: true, // one pass per surface: the nested shells stay readable at half the fill
        });
        const mesh = new THREE.Mesh(toGeometry(s), mat);
        mesh.name = `${field}-${s.level}`;
        mesh.renderOrder = 2 + rank;
        this.group.add(mesh);
        this.shown.surfaces.push({ field, level: s.level, triangles: s.n_faces });
      });
    }
    this.planeFields = out.plane ? { weak: floats(out.plane.weak), strict: floats(out.plane.strict), meta: out.plane } : null;
    this.restyle(r.input.iso);
    this.onUpdate(null);
  }

  dispose(): void {
    this.requests.dispose();
    this.group.traverse((o) => {
      const m = o as THREE.Mesh;
      if (m === this.slice) return;
      m.geometry?.dispose();
      (m.material as THREE.Material | undefined)?.dispose();
    });
    this.slice.dispose();
    this.colorBar?.dispose();
  }
}

function stripUndefined<T>(x: T): T {
  return JSON.parse(JSON.stringify(x)) as T;
}
