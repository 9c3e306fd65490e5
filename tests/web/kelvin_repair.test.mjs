// Repair you can see (issue 37, item 2): an upload with a hole and edges in three faces (made
// here: a box without one square, one triangle listed twice) is drawn before anything is prepared,
// with the server's counts and its defects marked on the file's own vertices; every repair option
// is a control bounded by the server's limits; "fix" with a hole size prepares only when asked,
// and its surface is drawn over the input with the one-sided Hausdorff distances the server reports.
import { test } from "node:test";
import assert from "node:assert/strict";
import { openView, screenshot, serverAndBrowser } from "./harness.mjs";
import { edgeUses, gridBox, objText } from "./grid_box.mjs";

const env = serverAndBrowser();

const hash = (state) => `#/kelvin?s=${encodeURIComponent(JSON.stringify(state))}`;
const K = (page, expr) => page.evaluate(`(() => { const k = window.distlab.kelvin; return ${expr}; })()`);
const field = (page, name) => page.locator(`.lil-controller:has(.lil-name:text-is('${name}'))`);
const m = (x) => `${Number(x.toPrecision(3))} m`;

// The 0.4 m box, 2 × 2 squares a face: its z+ face's first square (faces 40, 41) removed, a hole
// of four edges; its first triangle listed again, three edges in three faces.
const side = 0.4,
  cell = side / 2;
const box = gridBox([side, side, side], 2);
const faces = box.faces.filter((_, f) => f !== 40 && f !== 41);
faces.push(box.faces[0]);
const mesh = { vertices: box.vertices, faces };
const uses = edgeUses(faces);
const open = uses.filter((u) => u.n === 1).map((u) => u.edge);
const shared = uses.filter((u) => u.n > 2).map((u) => u.edge);
const sorted = (pairs) => pairs.map((p) => [...p]).sort((a, b) => a[0] - b[0] || a[1] - b[1]);

test("an upload's defects are drawn and counted before preparing; fix with a hole size prepares on request, drawn over the input with its distances", async () => {
  assert.equal(open.length, 4);
  assert.equal(shared.length, 3);
  const page = await openView(env.browser, env.server, hash({ object: "cube", lx: 0.1, levels: [0] }));
  await page.waitForFunction(() => window.distlab.kelvin.ready === true, null, { timeout: 120000, polling: 100 });
  const creates = [];
  page.on("request", (r) => r.method() === "POST" && r.url().endsWith("/api/kelvin/objects") && creates.push(r.postDataJSON()));
  await page.setInputFiles("input[data-testid=kelvin-upload]", { name: "holey-box.obj", mimeType: "text/plain", buffer: Buffer.from(objText(mesh)) });
  await page.waitForFunction(() => window.distlab.kelvin.upload?.defects && window.distlab.kelvin.upload.awaitingPrepare, null, { timeout: 120000 });

  // The counts, as the server finds them and the panel says them.
  const up = await K(page, "k.upload");
  assert.deepEqual(up.defects.counts, { boundary_edges: 4, non_manifold_edges: 3, non_manifold_vertices: 0, degenerate_faces: 0, self_intersections: 0, components: 1 });
  const listed = await page.locator("[data-testid=kelvin-defects]").textContent();
  assert.match(listed, /4 open edges \(1 hole: 4 edges\)/, listed);
  assert.match(listed, /3 edges in more than two faces/, listed);
  // The marks: the file's edges at the file's vertices (positions as float32, metres).
  const marked = up.defects.edges;
  assert.deepEqual(sorted(marked.filter((e) => e.kind === "open").map((e) => e.vertices)), sorted(open));
  assert.deepEqual(sorted(marked.filter((e) => e.kind === "non-manifold").map((e) => e.vertices)), sorted(shared));
  for (const e of marked)
    [e.a, e.b].forEach((p, end) => p.forEach((x, k) => assert.ok(Math.abs(x - mesh.vertices[e.vertices[end]][k]) < 1e-7, `${e.kind} edge ${e.vertices}: ${p} vs the file's vertex`)));
  assert.equal(up.defects.vertices, mesh.vertices.length);
  assert.ok(up.defects.marksShown && up.defects.inputShown, "the input and its marks are drawn");
  assert.deepEqual(creates, [], "nothing is prepared before the repair is chosen");
  await screenshot(page, "kelvin-repair-defects");

  // Every repair option is a control; the server's limits are stated.
  const limits = await page.evaluate(() => window.distlab.api.get("/api/limits"));
  const stated = await page.locator("[data-testid=kelvin-repair-limits]").textContent();
  for (const n of [limits.max_hole_edges, limits.max_repair_faces, limits.max_object_triangles]) assert.ok(stated.includes(n.toLocaleString("en")), `"${stated}" states ${n}`);
  await field(page, "repair").locator("select").selectOption("wrap");
  for (const name of ["wrap: α (m; 0: diagonal / 20)", "wrap: offset (m; 0: α / 30)", "simplify to (faces; 0: keep)", "components"]) assert.ok(await field(page, name).isVisible(), name);
  // The wrap's prediction, as POST /api/kelvin/estimate gives it.
  await page.waitForFunction(() => /wrap at α .* faces, .* MB/.test(document.querySelector("[data-testid=kelvin-repair-estimate]")?.textContent ?? ""), null, { timeout: 60000 });

  // fix, holes up to 4 edges, then prepare.
  await field(page, "repair").locator("select").selectOption("fix");
  const hole = field(page, "fix: holes up to (edges)").locator("input");
  await hole.fill("4");
  await hole.press("Enter");
  await page.waitForFunction(() => /fix fills holes of up to 4 edges/.test(document.querySelector("[data-testid=kelvin-repair-estimate]")?.textContent ?? ""), null, { timeout: 60000 });
  assert.deepEqual(creates, [], "choosing options prepares nothing");
  await page.getByRole("button", { name: "prepare with these options" }).click();
  await page.waitForFunction(() => window.distlab.kelvin.ready === true, null, { timeout: 300000, polling: 100 });
  assert.equal(creates.length, 1);
  assert.equal(creates[0].repair, "fix");
  assert.deepEqual(creates[0].repair_options, { max_hole_edges: 4 });
  const o = await K(page, "k.object");
  const r = o.repair_report;
  assert.equal(r.kind, "fix");
  assert.equal(r.steps.filled_holes, 1);
  assert.equal(r.steps.removed_duplicate_faces, 1);
  assert.equal(await K(page, "k.overlayTriangles"), r.n_faces, "the repaired surface is drawn over the input");
  // The patch of a square hole lies within half a square of the input; the input is on the result.
  assert.ok(r.hausdorff.fixed_to_input > 0 && r.hausdorff.fixed_to_input <= (cell / 2) * (1 + 1e-9), JSON.stringify(r.hausdorff));
  assert.ok(r.hausdorff.input_to_fixed < 1e-9, JSON.stringify(r.hausdorff));
  const report = await page.locator("[data-testid=kelvin-upload-report]").textContent();
  assert.ok(report.includes(`farthest input → fixed ${m(r.hausdorff.input_to_fixed)}, fixed → input ${m(r.hausdorff.fixed_to_input)}`), report);
  assert.ok(!(await K(page, "k.upload.defects.inputShown")), "the prepared surface replaces the input's drawing");
  await screenshot(page, "kelvin-repair-fixed");

  // The repaired object is shared as any upload (issue 37 leftover: the panel had no frame or copy
  // link): "copy link" gives the upload by its digest with the repair; opened in another session
  // it is the same repaired object. "frame the object" brings a camera moved away back.
  await page.context().grantPermissions(["clipboard-read", "clipboard-write"]);
  await page.getByRole("button", { name: "copy link" }).click();
  await page.waitForFunction(() => [...document.querySelectorAll(".toast")].some((t) => t.textContent.includes("link copied")));
  const link = await page.evaluate(() => navigator.clipboard.readText());
  const linked = JSON.parse(decodeURIComponent(/\?s=(.*)$/.exec(link)[1]));
  assert.deepEqual(linked.upload, { digest: o.surface_digest, name: "holey-box.obj", bytes: Buffer.byteLength(objText(mesh)), unit: "m" }, link);
  assert.equal(linked.repair, "fix");
  await page.getByRole("button", { name: "frame the object (f)" }).click();
  const framed = await K(page, "k.upload.camera");
  const box = await page.locator("canvas.viewport-canvas").boundingBox();
  await page.mouse.move(box.x + box.width / 2, box.y + box.height / 2);
  await page.mouse.wheel(0, 800); // zoom out
  await page.waitForFunction((z) => Math.abs(window.distlab.kelvin.upload.camera.position[2] - z) > 1e-3, framed.position[2]);
  await page.getByRole("button", { name: "frame the object (f)" }).click();
  const back = await K(page, "k.upload.camera");
  for (const k of ["position", "target"]) back[k].forEach((x, i) => assert.ok(Math.abs(x - framed[k][i]) < 1e-9, `framed ${k}: ${back[k]} vs ${framed[k]}`));
  const other = await openView(env.browser, env.server, "#" + link.split("#")[1]);
  await other.waitForFunction(() => window.distlab.kelvin.ready === true && window.distlab.kelvin.object?.repair_report, null, { timeout: 300000, polling: 100 });
  const opened = await K(other, "k.object");
  assert.equal(opened.surface_digest, o.surface_digest);
  assert.deepEqual([opened.repair_report.kind, opened.repair_report.n_faces, opened.repair_report.steps], [r.kind, r.n_faces, r.steps], "the same repair (its distances are sampled)");
  assert.deepEqual(other.problems, []);
  await other.context().close();
  assert.deepEqual(page.problems.filter((p) => !p.includes("the server responded with a status")), []);
});
