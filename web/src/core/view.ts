// What the shell gives a view, and what a view gives the shell.
import type { Shortcut } from "./keys";
import type { Shrink } from "./urlstate";

export interface ViewHost {
  /** Fills the main area; a view puts its Viewport here. */
  readonly canvas: HTMLElement;
  /** Right-hand panel for controls (lil-gui lives here). */
  readonly panel: HTMLElement;
  /** Bottom strip for plots and readouts; hidden until a view calls showBottom(true). */
  readonly bottom: HTMLElement;
  showBottom(show: boolean): void;
  /** Persist the view's state in the URL (shareable links); `shrink` gives the state to write
   *  when the link would be too long (see urlstate.ts). Only while the view is shown: once the
   *  user has left it, its calls (and its writes still pending) change nothing. */
  saveState(state: Record<string, unknown>, shrink?: Shrink): void;
  /** A line of text in the status bar (e.g. "D = 0.1234 m"). */
  status(text: string): void;
  /** Progress bar: fraction in [0, 1], or null to hide. */
  progress(label: string | null, fraction?: number, onCancel?: () => void): void;
}

export interface View {
  /** Builds the DOM and starts talking to the server; `state` comes from the URL. */
  mount(host: ViewHost, state: Record<string, unknown>): void | Promise<void>;
  /** Stops everything the view started (listeners, jobs it owns, GPU memory). */
  unmount(): void;
  shortcuts(): Shortcut[];
  screenshot(): Promise<Blob>;
}

export interface ViewEntry {
  id: string;
  title: string;
  load: () => Promise<View>;
}
