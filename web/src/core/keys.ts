// Keyboard shortcuts: views register theirs while mounted; "?" lists them.
export interface Shortcut {
  key: string; // KeyboardEvent.key, e.g. "r", "Delete", " "
  description: string;
  run: () => void;
}

const global = new Map<string, Shortcut>();
let viewKeys = new Map<string, Shortcut>();

export function registerGlobal(s: Shortcut): void {
  global.set(s.key, s);
}
export function setViewShortcuts(list: Shortcut[]): void {
  viewKeys = new Map(list.map((s) => [s.key, s]));
}
export function allShortcuts(): Shortcut[] {
  return [...global.values(), ...viewKeys.values()];
}

export function installKeyHandler(): void {
  window.addEventListener("keydown", (ev) => {
    const t = ev.target as HTMLElement | null;
    if (t && (t.tagName === "INPUT" || t.tagName === "TEXTAREA" || t.tagName === "SELECT" || t.isContentEditable)) return;
    if (ev.ctrlKey || ev.metaKey || ev.altKey) return;
    const s = viewKeys.get(ev.key) ?? global.get(ev.key);
    if (!s) return;
    ev.preventDefault();
    s.run();
  });
}
