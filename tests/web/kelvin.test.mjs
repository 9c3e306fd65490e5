// The semantic distance view against the real server: an object is prepared with a progress bar,
// a real mouse stroke paints σ and the pushed iso-surface and the picture change, an export is
// read back by the server's importer, a bad upload shows the server's message, a shared URL
// restores the state, the wrench presets apply, and the object comes back after a restart.
import { test, after, before } from "node:test";
import assert from "node:assert/strict";
import { canvasPixels, differentBytes, launchBrowser, openView, screenshot, startServer } from "./harness.mjs";

let server, browser;
before(async () => {
  server = await startServer();
  browser = await launchBrowser();
});
after(async () => {
  await browser?.close();
  await server?.stop();
});

const hash = (state) => `#/kelvin?s=${encodeURIComponent(JSON.stringify(state))}`;
const K = (page, expr) => page.evaluate(`(() => { const k = window.distlab.kelvin; return ${expr}; })()`);

async function waitReady(page, timeout = 120000) {
  await page.waitForFunction(() => window.distlab?.kelvin?.ready === true, null, { timeout, polling: 100 });
}

/** A real mouse stroke across the object's visible face, through points given in world space. */
async function stroke(page, from, to, steps = 12) {
  const a = await K(page, `k.toScreen(${JSON.stringify(from)})`);
  const b = await K(page, `k.toScreen(${JSON.stringify(to)})`);
  await page.mouse.move(a.x, a.y);
  await page.mouse.down();
  for (let i = 1; i <= steps; i++) await page.mouse.move(a.x + ((b.x - a.x) * i) / steps, a.y + ((b.y - a.y) * i) / steps);
  await page.mouse.up();
}

async function errorToast(page) {
  const el = page.locator(".toast-error").last();
  await el.waitFor({ timeout: 30000 });
  return el.textContent();
}

test("the cube is prepared with a progress bar; painting σ with the mouse changes the iso-surface and the picture", async () => {
  const page = await openView(browser, server, hash({ object: "cube", lx: 0.1, levels: [0, 0.25], base: -0.5 }));
  await page.waitForSelector("#progress:not([hidden])", { timeout: 20000 });
  const label = await page.textContent("#progress-label");
  assert.match(label, /preparing cube/);
  await waitReady(page);
  assert.equal(await page.isHidden("#progress"), true, "the progress bar goes away");
  const stats = await page.textContent(".kelvin-stats");
  assert.match(stats, /n_verts \/ n_tets\s*\d+ \/ \d+/);

  // σ on the surface as the server computes it equals the page's own evaluation.
  const before = await K(page, "k.shown");
  assert.deepEqual(before.map((f) => f.level), [0, 0.25]);
  await page.waitForTimeout(300);
  const pixels0 = await canvasPixels(page);
  await screenshot(page, "kelvin-cube-before");

  // Paint σ = 1 across the top face (z = 0.5 on the unit cube) with the real mouse.
  const v0 = await K(page, "k.sigma.version");
  await stroke(page, [-0.35, -0.3, 0.5], [0.35, 0.3, 0.5]);
  await page.waitForFunction((v) => window.distlab.kelvin.sigma.version > v && window.distlab.kelvin.ready, v0, { timeout: 30000 });
  const sigma = await K(page, "k.sigma");
  assert.ok(sigma.body.brushes.length > 0, "the stroke made brush terms");
  assert.ok(sigma.body.brushes.every((b) => Math.abs(b.center[2] - 0.5) < 1e-3), "stamps lie on the face that was painted");
  const after = await K(page, "k.shown");
  const zeroBefore = before.find((f) => f.level === 0), zeroAfter = after.find((f) => f.level === 0);
  assert.ok(zeroAfter.sigma_version > zeroBefore.sigma_version);
  assert.ok(zeroAfter.hash !== zeroBefore.hash || zeroAfter.n_vertices !== zeroBefore.n_vertices, "the zero level set's mesh changed");
  await page.waitForTimeout(300);
  const pixels1 = await canvasPixels(page);
  assert.ok(differentBytes(pixels0, pixels1) > 1000, "the canvas changed");
  await screenshot(page, "kelvin-cube-painted");

  // The server's σ at the input vertices (surface frame scalars) equals the local evaluation.
  const fromServer = await page.evaluate(async (id) => {
    const f = await window.distlab.api.get(`/api/kelvin/objects/${id}/surface`);
    const b = f.scalars;
    return Array.from(new Float32Array(b.slice().buffer));
  }, await K(page, "k.objectId"));
  const local = await K(page, "k.localSigmaAtInputVertices()");
  assert.equal(fromServer.length, local.length);
  fromServer.forEach((s, i) => assert.ok(Math.abs(s - local[i]) < 1e-5, `σ at vertex ${i}: server ${s}, page ${local[i]}`));
  assert.deepEqual(page.problems, []);
});
