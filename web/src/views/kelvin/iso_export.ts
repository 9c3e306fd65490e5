// Export of the shown iso-surfaces: one file per watched level, converted by the server (assimp)
// to the chosen format and handed to the browser as a download.
import { api } from "../../core/api";
import { showError, toast } from "../../core/toast";
import type { SurfaceCheck } from "../../core/wire";
import type { ExportFormat } from "./kelvin_state";

/** Downloads `${name}-h${level}.${format}` for each level; a failed level is reported, the others still come. */
export async function downloadIsoSurfaces(objectId: string, name: string, levels: number[], format: ExportFormat): Promise<void> {
  for (const level of levels) {
    try {
      const { blob, headers } = await api.binary(`/api/kelvin/objects/${objectId}/export?level=${level}&format=${format}`);
      // The server's own check of the file (closed 2-manifold; it refuses to export anything else).
      const check = JSON.parse(headers.get("x-distlab-surface-check") ?? "null") as SurfaceCheck | null;
      if (check) toast(`h = ${level}: closed 2-manifold, ${check.components} component${check.components === 1 ? "" : "s"}, volume ${check.volume.toPrecision(4)} m³`, "ok");
      const a = document.createElement("a");
      a.href = URL.createObjectURL(blob);
      a.download = `${name}-h${level}.${format}`;
      a.click();
      window.setTimeout(() => URL.revokeObjectURL(a.href), 2000);
    } catch (e) {
      showError(e, `export of level ${level}`);
    }
  }
}
