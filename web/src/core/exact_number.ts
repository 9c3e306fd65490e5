// Number fields that keep what the user typed. lil-gui's text input snaps a typed number to the
// controller's step and clamps it to the slider's range (σ 0.9999 became 1); here the typed text
// is parsed as is and set unchanged, and a check (the server's own limits) is shown inline under
// the field. Arrow keys, the wheel and the slider still step.
import { NumberController, type Controller, type GUI } from "lil-gui";

/** A message for a value the server would refuse, or null. */
export type NumberCheck = (value: number) => string | null;

const checks = new WeakMap<Controller, NumberCheck>();

function message(c: Controller): HTMLElement {
  const next = c.domElement.nextElementSibling;
  if (next instanceof HTMLElement && next.classList.contains("field-message")) return next;
  const el = document.createElement("div");
  el.className = "field-message";
  el.setAttribute("role", "alert");
  c.domElement.after(el); // under the field's row
  return el;
}

/** Shows (or clears) the inline message of a number field. */
export function setFieldMessage(c: Controller, text: string | null): void {
  const el = message(c);
  el.textContent = text ?? "";
  el.hidden = !text;
  c.domElement.classList.toggle("field-invalid", Boolean(text));
}

/** Re-runs a field's check on its current value (after the limits it checks against changed). */
export function recheck(c: Controller): void {
  const check = checks.get(c);
  const v = c.getValue() as number;
  setFieldMessage(c, check && Number.isFinite(v) ? check(v) : null);
}

/** Makes one number controller keep typed values exactly, with an optional inline check. */
export function exactNumber(c: Controller, check?: NumberCheck): Controller {
  if (!(c instanceof NumberController)) return c;
  if (check) checks.set(c, check);
  if (c.domElement.dataset.exact) return c;
  c.domElement.dataset.exact = "1";
  const input = c.$input;
  // Capture phase on the widget: runs before lil-gui's own listener on the input, which it stops.
  c.$widget.addEventListener(
    "input",
    (ev) => {
      if (ev.target !== input) return;
      ev.stopPropagation();
      const text = input.value.trim();
      const v = text === "" ? NaN : Number(text);
      if (!Number.isFinite(v)) return setFieldMessage(c, `"${text}" is not a number`);
      c.setValue(v);
      recheck(c);
    },
    true,
  );
  return c;
}

/** Every number field of a panel keeps typed values exactly. */
export function exactNumbers(gui: GUI): void {
  gui.controllersRecursive().forEach((c) => exactNumber(c));
}
