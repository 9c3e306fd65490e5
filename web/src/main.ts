// The shell: tabs for the three views, hash routing with shareable state, connection status,
// progress bar, screenshot, shortcuts. Views are loaded lazily (one chunk each).
import "./style.css";
import { api } from "./core/api";
import { allShortcuts, installKeyHandler, registerGlobal, setViewShortcuts } from "./core/keys";
import { socket } from "./core/socket";
import { setToastScope, showError } from "./core/toast";
import { cancelStateWrite, hashFor, linkFor, parseHash, writeState, type Shrink } from "./core/urlstate";
import { startUserScene, userSceneItems, userSceneView } from "./core/user_scene";
import type { View, ViewEntry, ViewHost } from "./core/view";

const views: ViewEntry[] = [
  { id: "gap", title: "GAP explorer", load: async () => new (await import("./views/gap/gap_view")).GapView() },
  { id: "kelvin", title: "Semantic distance", load: async () => new (await import("./views/kelvin/kelvin_view")).KelvinView() },
  { id: "cbf", title: "CBF rollouts", load: async () => new (await import("./views/cbf/cbf_view")).CbfView() },
];

const $ = <T extends HTMLElement>(id: string) => document.getElementById(id) as T;
let current: { id: string; view: View } | null = null;
let mounting = 0;

// What every view's host shares; hostFor adds the state writes of one view.
const host: Omit<ViewHost, "saveState"> = {
  canvas: $("canvas"),
  panel: $("panel"),
  bottom: $("bottom"),
  showBottom(show) {
    $("bottom").hidden = !show;
    document.body.classList.toggle("with-bottom", show);
  },
  status(text) {
    $("status").textContent = text;
  },
  progress(label, fraction, onCancel) {
    const box = $("progress");
    box.hidden = label === null;
    if (label === null) return;
    $("progress-label").textContent = label;
    const bar = $<HTMLProgressElement>("progress-bar");
    if (fraction === undefined) bar.removeAttribute("value");
    else bar.value = Math.max(0, Math.min(1, fraction));
    const cancel = $<HTMLButtonElement>("progress-cancel");
    cancel.hidden = !onCancel;
    cancel.onclick = onCancel ?? null;
  },
};

/** Each view's last state while the page is open: its tab links to it, and leaving a view and
 *  coming back (tab, key, or a bare #/<view>) mounts it again as it was left (a GAP shape moved, an
 *  upload), instead of its defaults. Kept unshrunk: a link over the budget restores in full here. */
const kept = new Map<string, { state: Record<string, unknown>; shrink?: Shrink; href: string }>();

function keep(id: string, state: Record<string, unknown>, shrink?: Shrink): void {
  const entry = { state, shrink, href: hashFor(id, state) };
  kept.set(id, entry);
  void linkFor(id, state, shrink).then((href) => {
    if (kept.get(id) !== entry) return;
    entry.href = href;
    const tab = document.querySelector<HTMLAnchorElement>(`#tabs a[data-view=${id}]`);
    if (tab) tab.href = href;
  });
}

/** The host a view is mounted with: the shell's, but its state writes go to the URL only while
 *  that view is the one shown. A view left behind (its debounced writes, a job or a request that
 *  ends after the switch) never writes another view's link. */
function hostFor(id: string, view: View): ViewHost {
  return {
    ...host,
    saveState(state, shrink) {
      if (current?.view !== view) return;
      keep(id, state, shrink);
      writeState(id, state, shrink);
    },
  };
}

async function route(): Promise<void> {
  const { view: id, state: linked } = await parseHash();
  const entry = views.find((v) => v.id === id) ?? views[0];
  if (!views.some((v) => v.id === id)) {
    history.replaceState(null, "", hashFor(entry.id));
  }
  if (current?.id === entry.id) return; // state edits within a view do not remount it
  const ticket = ++mounting;
  setToastScope(entry.id);
  userSceneView(entry.id);
  cancelStateWrite(); // the view being left may have a write pending
  current?.view.unmount();
  current = null;
  host.canvas.replaceChildren();
  host.panel.replaceChildren();
  host.bottom.replaceChildren();
  host.showBottom(false);
  host.progress(null);
  host.status("");
  document.querySelectorAll<HTMLAnchorElement>("#tabs a").forEach((a) => a.classList.toggle("active", a.dataset.view === entry.id));
  document.title = `distlab · ${entry.title}`;
  const last = kept.get(entry.id);
  const back = last !== undefined && (location.hash === hashFor(entry.id) || location.hash === last.href);
  const state = back ? last.state : linked;
  try {
    const view = await entry.load();
    if (ticket !== mounting) return;
    current = { id: entry.id, view };
    setViewShortcuts(view.shortcuts());
    const viewHost = hostFor(entry.id, view);
    viewHost.saveState(state, back ? last.shrink : undefined); // the address bar and the tab show the state mounted
    await view.mount(viewHost, state);
  } catch (e) {
    showError(e, `cannot open ${entry.title}`);
  }
}

async function screenshot(): Promise<void> {
  if (!current) return;
  const blob = await current.view.screenshot();
  const a = document.createElement("a");
  a.href = URL.createObjectURL(blob);
  a.download = `distlab-${current.id}-${new Date().toISOString().replace(/[:.]/g, "-")}.png`;
  a.click();
  window.setTimeout(() => URL.revokeObjectURL(a.href), 1000);
}

function showHelp(): void {
  const table = $("help-table");
  table.replaceChildren(
    ...allShortcuts().map((s) => {
      const tr = document.createElement("tr");
      const k = document.createElement("td");
      k.innerHTML = `<kbd></kbd>`;
      k.firstElementChild!.textContent = s.key === " " ? "Space" : s.key;
      const d = document.createElement("td");
      d.textContent = s.description;
      tr.append(k, d);
      return tr;
    }),
  );
  $<HTMLDialogElement>("help-dialog").showModal();
}

function boot(): void {
  const tabs = $("tabs");
  views.forEach((v, i) => {
    const a = document.createElement("a");
    a.href = hashFor(v.id);
    a.textContent = v.title;
    a.dataset.view = v.id;
    a.title = `${v.title} (${i + 1})`;
    tabs.appendChild(a);
    registerGlobal({ key: String(i + 1), description: `open ${v.title}`, run: () => (location.hash = hashFor(v.id)) });
  });
  registerGlobal({ key: "p", description: "save a screenshot", run: () => void screenshot() });
  registerGlobal({ key: "?", description: "show these shortcuts", run: showHelp });
  installKeyHandler();
  $("screenshot").addEventListener("click", () => void screenshot());
  $("help").addEventListener("click", showHelp);
  socket.onState((s) => {
    const el = $("connection");
    el.textContent = s === "open" ? "connected" : s === "connecting" ? "connecting…" : "offline — reconnecting";
    el.className = `conn-${s}`;
  });
  startUserScene(socket);
  socket.start();
  window.addEventListener("hashchange", () => void route());
  void route();
  // A page opened by Client.record (?record=ID) records its view (a chunk of its own).
  if (new URLSearchParams(location.search).has("record")) void import("./core/recorder").then((m) => m.recordIfAsked());
  // Test and debugging hooks (read-only views of what the user sees).
  Object.assign(window, { distlab: Object.assign((window as unknown as { distlab?: object }).distlab ?? {}, { api, socket, screenshot, scene: userSceneItems }) });
}

boot();
