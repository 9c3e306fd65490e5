// Shareable URLs: location.hash is "#/<view>?s=<JSON of the view's state>". Views read their
// state once when mounted and write it (debounced, replaceState) whenever the user changes it.
// A long state (many σ brush stamps) is compressed: "?z=<base64url of the JSON deflated>"
// (CompressionStream); one still over LINK_BUDGET is replaced by the view's smaller form.
export interface Route {
  view: string;
  state: Record<string, unknown>;
}

/** The longest link written: 8 KB, the request-line limit of common servers (nginx, Apache) and
 *  proxies, which a link pasted into a mail or chat client may pass through (browsers take more). */
export const LINK_BUDGET = 8192;

export async function parseHash(hash = location.hash): Promise<Route> {
  const m = /^#\/([a-z0-9_-]+)(?:\?(.*))?$/i.exec(hash);
  if (!m) return { view: "", state: {} };
  const params = new URLSearchParams(m[2] ?? "");
  let state: Record<string, unknown> = {};
  let s = params.get("s");
  const z = params.get("z");
  if (z && !s) s = await inflate(z).catch(() => null);
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

/** The hash of a state: plain JSON (readable, hand-editable) while the link is within LINK_BUDGET,
 *  compressed beyond; null when even that is over it. */
export async function compactHash(view: string, state: Record<string, unknown>): Promise<string | null> {
  const plain = hashFor(view, state);
  if (location.href.split("#")[0].length + plain.length <= LINK_BUDGET) return plain;
  const z = `#/${view}?z=${await deflate(JSON.stringify(state))}`;
  return location.href.split("#")[0].length + z.length <= LINK_BUDGET ? z : null;
}

/** The smaller state a view gives for a link over LINK_BUDGET (its reference to a file). */
export type Shrink = (s: Record<string, unknown>) => Promise<Record<string, unknown>>;

/** The link a state is written as: compactHash, or `shrink`'s form when that is over LINK_BUDGET. */
export async function linkFor(view: string, state: Record<string, unknown>, shrink?: Shrink): Promise<string> {
  return (await compactHash(view, state)) ?? (await compactHash(view, shrink ? await shrink(state) : {})) ?? `#/${view}`;
}

let pending: number | undefined;
let writes = 0;
/** Records a view's state in the URL without adding a history entry per drag step. A state whose
 *  link would be over LINK_BUDGET is written as `shrink` makes it (the view's reference to a file).
 *  The write lands only while the hash still routes to `view`: a write left pending by a view the
 *  user has just left (its change, then a tab click within the 150 ms) must not turn the new
 *  view's link back into the old one's. */
export function writeState(view: string, state: Record<string, unknown>, shrink?: Shrink): void {
  clearTimeout(pending);
  const ticket = ++writes;
  pending = window.setTimeout(async () => {
    const h = await linkFor(view, state, shrink);
    if (ticket === writes && routedView() === view && h !== location.hash) history.replaceState(null, "", h);
  }, 150);
}

/** Drops the state write not yet made (the shell calls it when it leaves a view). */
export function cancelStateWrite(): void {
  clearTimeout(pending);
  writes++;
}

/** The view the hash routes to now ("" for none), as parseHash reads it. */
function routedView(hash = location.hash): string {
  return /^#\/([a-z0-9_-]+)(?:\?|$)/i.exec(hash)?.[1].toLowerCase() ?? "";
}

function toBase64Url(bytes: Uint8Array): string {
  let bin = "";
  for (let i = 0; i < bytes.length; i += 0x8000) bin += String.fromCharCode(...bytes.subarray(i, i + 0x8000));
  return btoa(bin).replace(/\+/g, "-").replace(/\//g, "_").replace(/=+$/, "");
}

async function deflate(text: string): Promise<string> {
  const stream = new Blob([text]).stream().pipeThrough(new CompressionStream("deflate-raw"));
  return toBase64Url(new Uint8Array(await new Response(stream).arrayBuffer()));
}

async function inflate(z: string): Promise<string> {
  const bin = atob(z.replace(/-/g, "+").replace(/_/g, "/"));
  const bytes = Uint8Array.from(bin, (c) => c.charCodeAt(0));
  return new Response(new Blob([bytes]).stream().pipeThrough(new DecompressionStream("deflate-raw"))).text();
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
