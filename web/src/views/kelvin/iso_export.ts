// Export of the shown iso-surfaces: one file per watched level, converted by the server (assimp)
// to the chosen format and handed to the browser as a download.
import { api } from "../../core/api";
import { showError } from "../../core/toast";
import type { ExportFormat } from "./kelvin_state";

/** Downloads `${name}-h${level}.${format}` for each level; a failed level is reported, the others still come. */
export async function downloadIsoSurfaces(objectId: string, name: string, levels: number[], format: ExportFormat): Promise<void> {
  for (const level of levels) {
    try {
      const { blob } = await api.binary(`/api/kelvin/objects/${objectId}/export?level=${level}&format=${format}`);
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
