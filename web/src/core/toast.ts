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

/** `key` names what the toast is about (an input, a kind of request): a newer toast with the same
 *  key replaces it, and dismissToasts(key) removes it once that input is valid or that request
 *  succeeds (an error must not outlive its cause). */
export function toast(message: string, kind: ToastKind = "info", ms = kind === "error" ? 8000 : 3000, key?: string): void {
  const box = document.getElementById("toasts");
  if (!box) return;
  if (key) dismissToasts(key);
  const el = document.createElement("div");
  el.className = `toast toast-${kind}`;
  el.dataset.view = scope;
  if (key) el.dataset.key = key;
  el.setAttribute("role", kind === "error" ? "alert" : "status");
  el.textContent = message;
  el.addEventListener("click", () => el.remove());
  box.appendChild(el);
  window.setTimeout(() => el.remove(), ms);
}

/** Removes the toasts about `key` (its input became valid, or its request succeeded). */
export function dismissToasts(key: string): void {
  document.querySelectorAll<HTMLElement>("#toasts .toast").forEach((el) => {
    if (el.dataset.key === key) el.remove();
  });
}

/** Shows any thrown value as a readable error (about `key`, see toast); returns its text. */
export function showError(e: unknown, context?: string, key?: string): string {
  const text = errorText(e);
  const full = context ? `${context}: ${text}` : text;
  toast(full, "error", undefined, key);
  console.warn(full);
  return full;
}
