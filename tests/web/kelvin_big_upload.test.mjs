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
    // A small vertex budget makes the page choose a coarse l_x: this test is about simplification
    // (at the page's l_x of a thirtieth of the diagonal the preparation took 40–150 s).
    extra: [
      "--limit",
      `max_object_triangles=${most}`,
      "--limit",
      "max_vertex_estimate=20000",
    ],
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

// Repair advice (issue 37 leftover): the page's advice follows what each server option mends.
// "fix" mends holes within its limit and repeated faces, not intersections, not sheets touching at
// a vertex, not a fin; components "largest" drops what lies in or between other pieces; simplify
// runs before any repair and needs a closed surface, so a defective mesh over max_object_triangles
// is wrapped, not simplified. Each mesh gets its advice, and the advice prepares it.
const field = (page, name) => page.locator(`.lil-controller:has(.lil-name:text-is('${name}'))`);
const moved = (m, d) => ({ vertices: m.vertices.map((p) => p.map((x, k) => x + d[k])), faces: m.faces });
const join = (a, b) => ({ vertices: [...a.vertices, ...b.vertices], faces: [...a.faces, ...b.faces.map((f) => f.map((i) => i + a.vertices.length))] });
const cube = gridBox([0.4, 0.4, 0.4], 1);
const holey = gridBox([0.4, 0.4, 0.4], 2);
const fine = gridBox([0.4, 0.4, 0.4], 20);
const advised = [
  // A hole of 4 edges and a face listed twice: fix, its hole size the hole's.
  { name: "holey.obj", mesh: { vertices: holey.vertices, faces: [...holey.faces.filter((_, f) => f !== 40 && f !== 41), holey.faces[0]] }, repair: "fix", holeEdges: 4, components: "all", text: /repair "fix" with holes up to 4 edges/ },
  // A fin on an edge of a closed box: fix leaves it (its result intersects itself); wrap.
  { name: "fin.obj", mesh: { vertices: [...cube.vertices, [0, 0.5, 0.5]], faces: [...cube.faces, [cube.faces[0][0], cube.faces[0][1], cube.vertices.length]] }, repair: "wrap", components: "all", text: /repair "wrap": fix cannot .*not copies of one face/, fixRefused: true },
  // Two boxes touching at a corner: split, they still touch; the largest piece alone is closed.
  { name: "pinched.obj", mesh: join(cube, moved(cube, [0.4, 0.4, 0.4])), repair: "none", components: "largest", text: /components "largest"/ },
  // Two boxes through each other: the intersections are between the pieces.
  { name: "overlap.obj", mesh: join(cube, moved(cube, [0.2, 0.1, 0.1])), repair: "none", components: "largest", text: /components "largest"/ },
  // Over max_object_triangles with a hole: simplify cannot run on it; wrap (the page sets it).
  { name: "fine-holey.obj", mesh: { vertices: fine.vertices, faces: fine.faces.slice(2) }, repair: "wrap", components: "all", text: /repair "wrap": the mesh is over max_object_triangles/, applied: true },
];

test("the repair advice matches what each option mends, and prepares each mesh", async () => {
  const page = await openView(env.browser, env.server, hash({ object: "cube", lx: 0.1, levels: [0] }));
  await page.waitForFunction(() => window.distlab.kelvin.ready === true, null, { polling: 100 });
  for (const a of advised) {
    const seen = (await page.evaluate(() => window.distlab.kelvin.upload?.id)) ?? null;
    await page.setInputFiles("input[data-testid=kelvin-upload]", { name: a.name, mimeType: "text/plain", buffer: Buffer.from(objText(a.mesh)) });
    await page.waitForFunction((s) => { const u = window.distlab.kelvin.upload; return u?.id && u.id !== s && u.defects?.advice && u.awaitingPrepare; }, seen, { polling: 100 });
    const advice = await K(page, "k.upload.defects.advice");
    const listed = await page.locator("[data-testid=kelvin-defects]").textContent();
    assert.match(listed, a.text, `${a.name}: ${listed}`);
    assert.equal(advice.repair, a.repair, `${a.name}: ${advice.text}`);
    assert.equal(advice.components, a.components, `${a.name}: ${advice.text}`);
    if (a.holeEdges) assert.equal(advice.holeEdges, a.holeEdges);
    if (a.applied) assert.deepEqual(await K(page, "[k.state.repair, k.state.simplify ?? 0]"), [a.repair, 0], "the page's simplify is replaced by the advice");
    const choose = async (repair, components) => {
      await field(page, "repair").locator("select").selectOption(repair);
      await field(page, "components").locator("select").selectOption(components);
      if (a.holeEdges) {
        await field(page, "fix: holes up to (edges)").locator("input").fill(String(a.holeEdges));
        await field(page, "fix: holes up to (edges)").locator("input").press("Enter");
      }
    };
    const l_x = field(page, "l_x").locator("input");
    await l_x.fill("0.1");
    await l_x.press("Enter");
    if (a.fixRefused) {
      // What the server's own message offers ("fix" or "wrap") is not so: fix is refused.
      await choose("fix", "all");
      await page.getByRole("button", { name: "prepare with these options" }).click();
      await page.waitForFunction(() => /repair is not enough/.test(document.querySelector("[data-testid=kelvin-upload-report]")?.textContent ?? ""), null, { polling: 100 });
    }
    await choose(a.repair, a.components);
    await page.getByRole("button", { name: "prepare with these options" }).click();
    await page.waitForFunction((n) => window.distlab.kelvin.ready === true && window.distlab.kelvin.object?.source?.lx === 0.1 && window.distlab.kelvin.state.upload?.name === n, a.name, { polling: 100 });
    const o = await K(page, "k.object");
    assert.equal(o.source.repair, a.repair, `${a.name} prepared with ${JSON.stringify(o.source)}`);
  }
  assert.deepEqual(page.problems.filter((p) => !p.includes("the server responded with a status")), []);
});
