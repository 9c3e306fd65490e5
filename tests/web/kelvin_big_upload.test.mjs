// A scan over what a preparation takes (issue 36): on a server whose max_object_triangles is 2,000,
// a 4,800-triangle box is uploaded; the page sets "simplify" to that limit before it estimates (the
// server refuses the mesh without it, naming simplify.faces), says so, and the object it prepares is
// the simplified surface with the server's one-sided Hausdorff distance.
import { after, before, test } from "node:test";
import assert from "node:assert/strict";
import { launchBrowser, openView, startServer } from "./harness.mjs";
import { gridBox, objText } from "./grid_box.mjs";

const most = 2000;
const env = { server: null, browser: null };
before(async () => {
  env.server = await startServer({
    extra: ["--limit", `max_object_triangles=${most}`],
  });
  env.browser = await launchBrowser();
});
after(async () => {
  await env.browser?.close();
  await env.server?.stop();
});

const hash = (state) =>
  `#/kelvin?s=${encodeURIComponent(JSON.stringify(state))}`;
const K = (page, expr) =>
  page.evaluate(
    `(() => { const k = window.distlab.kelvin; return ${expr}; })()`,
  );

test("an upload over max_object_triangles is simplified to that limit before it is prepared", async () => {
  const box = gridBox([0.4, 0.4, 0.4], 20);
  assert.equal(box.faces.length, 4800);
  const page = await openView(
    env.browser,
    env.server,
    hash({ object: "cube", lx: 0.1, levels: [0] }),
  );
  await page.waitForFunction(() => window.distlab.kelvin.ready === true, null, {
    timeout: 120000,
    polling: 100,
  });
  const creates = [];
  page.on(
    "request",
    (r) =>
      r.method() === "POST" &&
      r.url().endsWith("/api/kelvin/objects") &&
      creates.push(r.postDataJSON()),
  );
  await page.setInputFiles("input[data-testid=kelvin-upload]", {
    name: "fine-box.obj",
    mimeType: "text/plain",
    buffer: Buffer.from(objText(box)),
  });
  await page.waitForFunction(
    () =>
      [...document.querySelectorAll(".toast")].some((t) =>
        t.textContent.includes("fine-box.obj has"),
      ),
    null,
    { timeout: 120000, polling: 100 },
  );
  const toasts = await page.locator(".toast").allTextContents();
  assert.ok(
    toasts.some(
      (t) =>
        t.includes("4,800 triangles") &&
        t.includes(`simplified to ${most.toLocaleString("en")}`),
    ),
    JSON.stringify(toasts),
  );
  assert.equal(await K(page, "k.state.simplify"), most);
  // A clean upload prepares by itself; one with defects waits for the button.
  await page.waitForFunction(
    () =>
      window.distlab.kelvin.upload?.awaitingPrepare ||
      window.distlab.kelvin.object?.simplify_report !== undefined,
    null,
    { timeout: 300000, polling: 100 },
  );
  if (await K(page, "k.upload?.awaitingPrepare"))
    await page
      .getByRole("button", { name: "prepare with these options" })
      .click();
  await page.waitForFunction(
    () =>
      window.distlab.kelvin.object?.simplify_report !== undefined &&
      window.distlab.kelvin.ready === true,
    null,
    { timeout: 300000, polling: 200 },
  );
  assert.equal(creates.length, 1);
  assert.deepEqual(creates[0].simplify, { faces: most });
  const o = await K(page, "k.object");
  assert.equal(o.simplify_report.n_input_faces, 4800);
  assert.ok(
    o.simplify_report.n_faces <= most,
    JSON.stringify(o.simplify_report),
  );
  // A box's flat faces simplify exactly: the distance is zero to rounding.
  assert.ok(
    o.simplify_report.hausdorff.input_to_simplified < 1e-9,
    JSON.stringify(o.simplify_report),
  );
  assert.deepEqual(
    page.problems.filter(
      (p) => !p.includes("the server responded with a status"),
    ),
    [],
  );
});
