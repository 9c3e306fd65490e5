// The probe: h and ∇h at the point under the cursor (on the slice plane, else on the nearest
// iso-surface, or on the object's surface, where σ is shown too), queried from the server (latest
// position wins), ∇h drawn as an arrow. Units: h is −ln U (eq. 9's distance, dimensionless), ∇h
// per metre, σ dimensionless (eq. 24's tanh).
import * as THREE from "three";
import { api } from "../../core/api";
import { Coalescer } from "./coalesce";
import type { QueryResult } from "./slice_layer";

export interface ProbeReading {
  point: [number, number, number];
  h: number | null;
  gradient: [number, number, number] | null;
  inside: boolean;
  sigma_version: number;
  /** What the pointer is on ("surface", "slice", "iso-surface h = …"), and σ there on the surface. */
  on: string;
  sigma?: number;
}

/** Where a probe is taken: what the pointer is on, and σ there when it is the object's surface. */
export interface ProbeTarget {
  on: string;
  sigma?: number;
}

export class Probe {
  readonly arrow = new THREE.ArrowHelper(new THREE.Vector3(1, 0, 0), new THREE.Vector3(), 1, 0xffe066);
  readonly marker = new THREE.Mesh(new THREE.SphereGeometry(1, 12, 8), new THREE.MeshBasicMaterial({ color: 0xffe066 }));
  readonly readout: HTMLDivElement;
  last: ProbeReading | null = null;
  private coalescer: Coalescer<{ p: THREE.Vector3; target: ProbeTarget }>;
  private objectId: string | null = null;
  private length = 0.1;
  onChange: (() => void) | null = null;

  constructor(container: HTMLElement) {
    this.readout = document.createElement("div");
    this.readout.className = "readout kelvin-probe";
    this.readout.hidden = true;
    container.appendChild(this.readout);
    this.arrow.visible = false;
    this.marker.visible = false;
    this.coalescer = new Coalescer(({ p, target }) => this.query(p, target));
  }

  setObject(id: string | null, bounds: THREE.Box3): void {
    this.objectId = id;
    const r = bounds.isEmpty() ? 1 : bounds.getSize(new THREE.Vector3()).length();
    this.length = r * 0.15;
    this.marker.scale.setScalar(r * 0.006);
    this.hide();
  }

  at(point: THREE.Vector3, target: ProbeTarget): void {
    if (this.objectId) this.coalescer.push({ p: point.clone(), target });
  }

  hide(): void {
    this.arrow.visible = this.marker.visible = false;
    this.readout.hidden = true;
    this.onChange?.();
  }

  private async query(p: THREE.Vector3, target: ProbeTarget): Promise<void> {
    const id = this.objectId;
    if (!id) return;
    const r = await api.post<QueryResult>(`/api/kelvin/objects/${id}/query`, { points: [p.toArray()] });
    if (id !== this.objectId) return;
    const reading: ProbeReading = {
      point: p.toArray() as [number, number, number],
      h: r.h[0],
      gradient: r.gradient[0],
      inside: r.inside[0],
      sigma_version: r.sigma_version,
      ...target,
    };
    this.last = reading;
    this.marker.position.copy(p);
    this.marker.visible = true;
    const fmt = (x: number) => (Math.abs(x) >= 1e4 || (Math.abs(x) < 1e-3 && x !== 0) ? x.toExponential(3) : x.toFixed(4));
    const sigma = reading.sigma === undefined ? "" : `\nσ = ${fmt(reading.sigma)} (dimensionless)`;
    const where = `on the ${reading.on}\nx = (${reading.point.map(fmt).join(", ")}) m${sigma}`;
    if (reading.h === null || reading.gradient === null) {
      this.readout.textContent = `${where}\n${reading.inside ? "inside the object: h is not defined" : "outside the meshed domain"}`;
      this.arrow.visible = false;
    } else {
      const g = new THREE.Vector3(...reading.gradient);
      const n = g.length();
      this.readout.textContent = `${where}\nh = ${fmt(reading.h)} (dimensionless, −ln U)\n∇h = (${reading.gradient.map(fmt).join(", ")}) m⁻¹\n|∇h| = ${fmt(n)} m⁻¹`;
      if (n > 0) {
        this.arrow.position.copy(p);
        this.arrow.setDirection(g.clone().normalize());
        this.arrow.setLength(this.length, this.length * 0.25, this.length * 0.12);
        this.arrow.visible = true;
      }
    }
    this.readout.hidden = false;
    this.onChange?.();
  }

  dispose(): void {
    this.coalescer.cancelPending();
    this.readout.remove();
    this.arrow.dispose();
    this.marker.geometry.dispose();
    (this.marker.material as THREE.Material).dispose();
  }
}
