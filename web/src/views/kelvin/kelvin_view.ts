// Placeholder until the view lands: an empty viewport.
import type { Shortcut } from "../../core/keys";
import type { View, ViewHost } from "../../core/view";
import { Viewport } from "../../core/viewport";

export class KelvinView implements View {
  private viewport: Viewport | null = null;
  mount(host: ViewHost): void {
    this.viewport = new Viewport(host.canvas);
    host.status("Semantic distance: not built yet");
  }
  unmount(): void {
    this.viewport?.dispose();
    this.viewport = null;
  }
  shortcuts(): Shortcut[] {
    return [];
  }
  screenshot(): Promise<Blob> {
    if (!this.viewport) return Promise.reject(new Error("no view"));
    return this.viewport.screenshot();
  }
}
