// Readable messages in a corner: API errors ("field: message"), progress notes, successes.
import { errorText } from "./api";

export type ToastKind = "error" | "info" | "ok";

// A view's notes stay in that view: each toast is tagged with the view shown when it was made,
// and opening another view removes them.
let scope = "";

export function setToastScope(view: string): void {
  scope = view;
  document.querySelectorAll<HTMLElement>("#toasts .toast").forEach((el) => {
    if (el.dataset.view !== view) el.remove();
  });
}

export function toast(message: string, kind: ToastKind = "info", ms = kind === "error" ? 8000 : 3000): void {
  const box = document.getElementById("toasts");
  if (!box) return;
  const el = document.createElement("div");
  el.className = `toast toast-${kind}`;
  el.dataset.view = scope;
  el.setAttribute("role", kind === "error" ? "alert" : "status");
  el.textContent = message;
  el.addEventListener("click", () => el.remove());
  box.appendChild(el);
  window.setTimeout(() => el.remove(), ms);
}

/** Shows any thrown value as a readable error; returns its text. */
export function showError(e: unknown, context?: string): string {
  const text = errorText(e);
  const full = context ? `${context}: ${text}` : text;
  toast(full, "error");
  console.warn(full);
  return full;
}
