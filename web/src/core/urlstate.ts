// Shareable URLs: location.hash is "#/<view>?s=<JSON of the view's state>". Views read their
// state once when mounted and write it (debounced, replaceState) whenever the user changes it.
export interface Route {
  view: string;
  state: Record<string, unknown>;
}

export function parseHash(hash = location.hash): Route {
  const m = /^#\/([a-z0-9_-]+)(?:\?(.*))?$/i.exec(hash);
  if (!m) return { view: "", state: {} };
  const params = new URLSearchParams(m[2] ?? "");
  let state: Record<string, unknown> = {};
  const s = params.get("s");
  if (s) {
    try {
      const v = JSON.parse(s) as unknown;
      if (v && typeof v === "object" && !Array.isArray(v)) state = v as Record<string, unknown>;
    } catch {
      /* a mangled URL falls back to the defaults */
    }
  }
  return { view: m[1].toLowerCase(), state };
}

export function hashFor(view: string, state?: Record<string, unknown>): string {
  if (!state || Object.keys(state).length === 0) return `#/${view}`;
  return `#/${view}?s=${encodeURIComponent(JSON.stringify(state))}`;
}

let pending: number | undefined;
/** Records a view's state in the URL without adding a history entry per drag step. */
export function writeState(view: string, state: Record<string, unknown>): void {
  clearTimeout(pending);
  pending = window.setTimeout(() => {
    const h = hashFor(view, state);
    if (h !== location.hash) history.replaceState(null, "", h);
  }, 150);
}

/** Typed reads with defaults, so a hand-edited URL can't inject the wrong type. */
export function num(v: unknown, fallback: number, min = -Infinity, max = Infinity): number {
  return typeof v === "number" && Number.isFinite(v) ? Math.min(max, Math.max(min, v)) : fallback;
}
export function str<T extends string>(v: unknown, allowed: readonly T[], fallback: T): T {
  return typeof v === "string" && (allowed as readonly string[]).includes(v) ? (v as T) : fallback;
}
export function numArray(v: unknown, n: number, fallback: number[]): number[] {
  return Array.isArray(v) && v.length === n && v.every((x) => typeof x === "number" && Number.isFinite(x)) ? (v as number[]) : fallback;
}
