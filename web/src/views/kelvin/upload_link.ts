// What a link to an uploaded mesh shows on a server that does not hold that mesh: which file it
// is (name, size, unit, the mesh's digest) and a button to upload it; the server checks that the
// file given is that mesh (?digest=) and a different one is refused here, in words. No other
// object is shown meanwhile.
import type { UploadRef } from "./kelvin_state";

const bytesText = (n: number) =>
  n >= 1 << 20 ? `${(n / (1 << 20)).toFixed(1)} MB (${n.toLocaleString("en")} bytes)` : n >= 1024 ? `${(n / 1024).toFixed(1)} kB (${n.toLocaleString("en")} bytes)` : `${n} bytes`;

export class UploadNotice {
  readonly el: HTMLDivElement;
  private readonly what: HTMLDivElement;
  private readonly refusal: HTMLDivElement;
  private readonly button: HTMLButtonElement;
  private readonly input: HTMLInputElement;
  /** The mesh the notice asks for (null: a link made before links named their uploads). */
  ref: UploadRef | null = null;

  constructor(container: HTMLElement, chosen: (f: File) => void) {
    this.el = document.createElement("div");
    this.el.className = "kelvin-link-notice";
    this.el.dataset.testid = "kelvin-link-notice";
    this.el.setAttribute("role", "alertdialog");
    this.el.hidden = true;
    this.what = document.createElement("div");
    this.refusal = document.createElement("div");
    this.refusal.className = "bad";
    this.refusal.dataset.testid = "kelvin-link-refusal";
    this.input = document.createElement("input");
    this.input.type = "file";
    this.input.accept = ".stl,.obj,.ply,.glb,.off";
    this.input.hidden = true;
    this.input.dataset.testid = "kelvin-link-upload";
    this.input.addEventListener("change", () => {
      const f = this.input.files?.[0];
      if (f) chosen(f);
      this.input.value = "";
    });
    this.button = document.createElement("button");
    this.button.type = "button";
    this.button.addEventListener("click", () => this.input.click());
    this.el.append(this.what, this.button, this.refusal, this.input);
    container.appendChild(this.el);
  }

  get shown(): boolean {
    return !this.el.hidden;
  }

  show(ref: UploadRef | null): void {
    this.ref = ref;
    this.refusal.textContent = "";
    this.what.replaceChildren();
    const line = (text: string, strong = false) => {
      const p = document.createElement(strong ? "strong" : "p");
      p.textContent = text;
      this.what.appendChild(p);
    };
    if (ref) {
      line("This link shows an uploaded mesh that this server does not hold.", true);
      line(`File: ${ref.name}, ${bytesText(ref.bytes)}, read in ${ref.unit}.`);
      line(`Mesh digest (SHA-256 of the mesh as read): ${ref.digest}`);
      line("Upload that file to see the view: the server checks that it is the same mesh.");
      this.button.textContent = `upload ${ref.name}…`;
    } else {
      line("This link shows an uploaded mesh but does not say which (it was made before links named their files).", true);
      line("Upload the file to see the view; it cannot be checked against the link.");
      this.button.textContent = "upload the file…";
    }
    this.el.hidden = false;
  }

  /** The file given is not the linked one: the server's words, under the request. */
  refused(text: string): void {
    this.refusal.textContent = text;
  }

  hide(): void {
    this.el.hidden = true;
    this.refusal.textContent = "";
  }

  get text(): string | null {
    return this.el.hidden ? null : (this.el.textContent ?? "");
  }

  get refusalText(): string {
    return this.refusal.textContent ?? "";
  }

  dispose(): void {
    this.el.remove();
  }
}
