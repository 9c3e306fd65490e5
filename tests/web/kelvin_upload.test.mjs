// The Kelvin view's upload dialog (issue 20, item 8) with a real open mesh in millimetres from
// Debian's assimp-testmodels (the spider, 150 × 80 × 193 mm, not closed): the file unit scales it
// to metres, the server's refusal of the open mesh is shown as the server words it, the mesh is
// drawn with its open edges and waits for a repair, and "wrap" (prepared on request) shows the
// wrap's report and its surface over the input's before the object is ready.
import { test } from "node:test";
import assert from "node:assert/strict";
import { existsSync, readFileSync } from "node:fs";
import { openView, screenshot, serverAndBrowser } from "./harness.mjs";

const env = serverAndBrowser();
const spider = "/usr/share/assimp/models/OBJ/spider.obj";

const hash = (state) => `#/kelvin?s=${encodeURIComponent(JSON.stringify(state))}`;
const K = (page, expr) => page.evaluate(`(() => { const k = window.distlab.kelvin; return ${expr}; })()`);
const report = (page) => page.locator("[data-testid=kelvin-upload-report]").textContent();
const select = (page, name) => page.locator(`.lil-controller:has(.lil-name:text-is('${name}')) select`);

test("an open millimetre mesh: its size in metres, the server's refusal, then wrapped with its report and overlay", { skip: !existsSync(spider) && "assimp-testmodels is not installed (.ci/packages.txt)" }, async () => {
  const bytes = readFileSync(spider);
  // The closed form of the size line: the file's own extent per axis, in mm, over 1000.
  const v = bytes.toString("latin1").split("\n").filter((l) => /^v\s/.test(l)).map((l) => l.trim().split(/\s+/).slice(1, 4).map(Number));
  const size = [0, 1, 2].map((k) => Number(((Math.max(...v.map((p) => p[k])) - Math.min(...v.map((p) => p[k]))) / 1000).toPrecision(3)));

  const page = await openView(env.browser, env.server, hash({ object: "cube", lx: 0.1, levels: [0] }));
  await page.waitForFunction(() => window.distlab?.kelvin?.ready === true, null, { timeout: 120000, polling: 100 });
  await select(page, "file unit").selectOption("mm");
  await page.setInputFiles("input[data-testid=kelvin-upload]", { name: "spider.obj", mimeType: "text/plain", buffer: bytes });
  await page.waitForFunction(() => /refused:/.test(document.querySelector("[data-testid=kelvin-upload-report]")?.textContent ?? ""), null, { timeout: 120000 });
  const refused = await report(page);
  assert.ok(refused.includes(`size ${size.join(" × ")} m (file unit mm)`), `"${refused}" gives the size ${size.join(" × ")} m`);
  assert.match(refused, /l_x from [0-9.e-]+ m to [0-9.e-]+ m/);

  // The refusal is the server's own words for this upload at the l_x the view chose.
  const session = (await (await fetch(env.server.url + "api/session", { method: "POST" })).json()).session;
  const headers = { "X-Distlab-Session": session, "Content-Type": "application/octet-stream" };
  const up = await (await fetch(`${env.server.url}api/kelvin/uploads?format=obj&unit=mm`, { method: "POST", headers, body: bytes })).json();
  const lx = await K(page, "k.state.lx");
  const est = await (await fetch(`${env.server.url}api/kelvin/estimate`, { method: "POST", headers: { ...headers, "Content-Type": "application/json" }, body: JSON.stringify({ upload: up.upload, lx }) })).json();
  assert.ok(est.problem, `the server refuses the open spider: ${JSON.stringify(est)}`);
  assert.ok(refused.includes(`refused: ${est.problem.message}`), `"${refused}" shows "${est.problem.message}"`);
  assert.match(est.problem.message, /boundary edge|not closed|manifold/);
  await screenshot(page, "kelvin-upload-refused");

  // Before any repair: the open mesh is drawn with its open edges marked, nothing is prepared.
  const drawn = await K(page, "k.upload");
  assert.ok(drawn.awaitingPrepare && drawn.defects.counts.boundary_edges > 0, JSON.stringify(drawn.defects?.counts));
  const { max_defect_items } = await page.evaluate(() => window.distlab.api.get("/api/limits"));
  assert.equal(drawn.defects.edges.filter((e) => e.kind === "open").length, Math.min(drawn.defects.counts.boundary_edges, max_defect_items));
  assert.equal(await K(page, "k.objectId"), null);

  // Wrap: the report and the wrap's wireframe arrive with the repair, then the object is prepared.
  await select(page, "repair").selectOption("wrap");
  await page.getByRole("button", { name: "prepare with these options" }).click();
  await page.waitForFunction(() => window.distlab.kelvin.overlayTriangles > 0 || /refused/.test(document.querySelector("[data-testid=kelvin-upload-report]")?.textContent ?? ""), null, { timeout: 600000, polling: 200 });
  assert.ok((await K(page, "k.overlayTriangles")) > 0, `no wrap drawn: "${await report(page)}", object ${JSON.stringify(await K(page, "k.object"))}`);
  await page.waitForFunction(() => window.distlab.kelvin.ready === true, null, { timeout: 900000, polling: 500 });
  const status = await K(page, "k.object");
  assert.equal(status.state, "ready");
  assert.equal(status.source.repair, "wrap");
  const r = status.repair_report;
  assert.equal(r.kind, "wrap");
  assert.equal(await K(page, "k.overlayTriangles"), r.n_faces, "the overlay is the wrap the server made");
  const m = (x) => `${Number(x.toPrecision(3))} m`;
  const wrapped = await report(page);
  assert.ok(wrapped.includes(`wrapped at α ${m(r.alpha)}, offset ${m(r.offset)}`), wrapped);
  assert.ok(wrapped.includes(`farthest input → wrap ${m(r.hausdorff.input_to_wrap)}, wrap → input ${m(r.hausdorff.wrap_to_input)}`), wrapped);
  assert.ok(!/refused/.test(wrapped), wrapped);
  // The default α is a twentieth of the diagonal (in metres: the unit reached the server).
  assert.ok(Math.abs(r.alpha - Math.hypot(...size) / 20) < 0.01 * r.alpha, `α ${r.alpha} for a diagonal of ${Math.hypot(...size)} m`);
  await page.waitForTimeout(300);
  await screenshot(page, "kelvin-upload-wrapped");
  assert.deepEqual(page.problems.filter((p) => !p.includes("the server responded with a status")), []);
});

// A tiny object and a coarse l_x (issue 37 leftover): l_x 0.1 m on a 1 cm box drew only the
// server's "lx is larger than the object" under the field, with no word of what l_x is or what to
// use. The note relates l_x to the object's diagonal and offers the value an upload starts from;
// it sets it, and the object is prepared; at that l_x the note is gone.
test("a tiny object: the note says what l_x is against its size and sets the suggested value", async () => {
  const { gridBox, objText } = await import("./grid_box.mjs");
  const page = await openView(env.browser, env.server, hash({ object: "cube", lx: 0.1, levels: [0] }));
  await page.waitForFunction(() => window.distlab.kelvin.ready === true, null, { polling: 100 });
  await page.setInputFiles("input[data-testid=kelvin-upload]", { name: "tiny.obj", mimeType: "text/plain", buffer: Buffer.from(objText(gridBox([0.01, 0.01, 0.01], 2))) });
  await page.waitForFunction(() => window.distlab.kelvin.ready === true && window.distlab.kelvin.state.object === "upload", null, { polling: 100 });
  const limits = await page.evaluate(() => window.distlab.api.get("/api/limits"));
  const start = await K(page, "k.state.lx");
  assert.equal(start, Math.max(limits.min_lx, 0.01 * Math.sqrt(3) / 30), "the upload starts at a thirtieth of its diagonal, or this server's smallest l_x");
  const note = page.locator("[data-testid=kelvin-lx-note]");
  assert.ok(await note.isHidden(), "no note while l_x resolves the object");
  const input = page.locator(".lil-controller:has(.lil-name:text-is('l_x')) input");
  await input.fill("0.1");
  await input.press("Enter");
  await note.waitFor({ state: "visible" });
  const text = await note.textContent();
  assert.match(text, /l_x is the edge length of the field's tetrahedra at the surface: 0\.1 m is 5\.8× the object's diagonal \(0\.0173 m\)/, text);
  assert.match(text, new RegExp(`Suggested: ${start} m \\(this server's smallest l_x\\)`), text);
  // Nothing is prepared at l_x 0.1 m: the iso legend does not say its shell is being computed.
  await page.waitForFunction(() => !window.distlab.kelvin.upload.awaitingPrepare && /no field prepared/.test(document.querySelector("[data-testid=iso-legend]")?.textContent ?? ""), null, { timeout: 20000 });
  assert.doesNotMatch(await page.locator("[data-testid=iso-legend]").textContent(), /computing/);
  await page.getByRole("button", { name: `use l_x = ${start} m` }).click();
  await page.waitForFunction((lx) => window.distlab.kelvin.ready === true && window.distlab.kelvin.object?.source?.lx === lx, start, { polling: 100 });
  await note.waitFor({ state: "hidden" });
  assert.deepEqual(page.problems.filter((p) => !p.includes("the server responded with a status")), []);
});
