// Links that never lie (issue 37, item 1), on two servers: a Kelvin link made on server A with an
// uploaded mesh (in millimetres) and σ strokes names the upload by its digest, file name, size and
// unit. Opened afresh on A (another session) it reproduces the view: the same mesh (digest, vertex
// count), the same strokes, levels, l_x and camera. On B, started with an empty data directory,
// it names the file and asks for it: nothing is prepared and no other object (the cube) is loaded;
// a different file is refused by the server's check; the right file reproduces the view.
import { after, test } from "node:test";
import assert from "node:assert/strict";
import { kelvinStroke, openView, screenshot, serverAndBrowser, startServer } from "./harness.mjs";
import { gridBox, objText } from "./grid_box.mjs";

const env = serverAndBrowser();
let serverB = null;
after(async () => {
  await serverB?.stop();
});

const hash = (state) => `#/kelvin?s=${encodeURIComponent(JSON.stringify(state))}`;
const K = (page, expr) => page.evaluate(`(() => { const k = window.distlab.kelvin; return ${expr}; })()`);
const field = (page, name) => page.locator(`.lil-controller:has(.lil-name:text-is('${name}'))`);
async function type(page, name, text) {
  const input = field(page, name).locator("input");
  await input.fill(text);
  await input.press("Enter");
}
async function waitReady(page, timeout = 300000) {
  await page.waitForFunction(() => window.distlab?.kelvin?.ready === true, null, { timeout, polling: 100 });
}
/** The Kelvin requests a page sends, from its start. */
function kelvinRequests(page) {
  const seen = [];
  page.on("request", (r) => {
    if (r.url().includes("/api/kelvin/")) seen.push({ method: r.method(), path: new URL(r.url()).pathname, body: r.postData() ?? "" });
  });
  return seen;
}

// A 600 × 400 × 300 mm box, 4 × 4 squares a face (98 vertices; the cube asset has 8).
const box = gridBox([600, 400, 300], 4);
const file = { name: "box-600x400x300.obj", mimeType: "text/plain", buffer: Buffer.from(objText(box)) };
// The same name, another mesh (1 cm taller).
const wrong = { name: "box-600x400x300.obj", mimeType: "text/plain", buffer: Buffer.from(objText(gridBox([600, 400, 310], 4))) };

/** What must be the same wherever the link is opened. */
async function view(page) {
  const o = await K(page, "k.object");
  const st = await K(page, "k.state");
  return {
    digest: o.surface_digest,
    vertices: o.n_input_vertices,
    lx: o.source.lx,
    upload: st.upload,
    brushes: st.brushes,
    levels: st.levels,
    shownLevels: (await K(page, "k.shown")).map((f) => f.level),
    camera: st.camera, // as the link has it
    shownCamera: (await K(page, "k.upload")).camera, // the viewport's
  };
}

/** The camera shown is the link's: to its six digits where it was made, to rounding where opened. */
function cameraIs(shown, link, relative, where) {
  for (const k of ["position", "target"])
    shown[k].forEach((x, i) => assert.ok(Math.abs(x - link[k][i]) <= relative * Math.max(1, Math.abs(x)), `${where}: camera ${k} ${shown[k]} vs the link's ${link[k]}`));
}

function sameView(got, want, where) {
  const { shownCamera, ...rest } = got;
  const { shownCamera: _, ...wantRest } = want;
  assert.deepEqual(rest, wantRest, where);
  cameraIs(shownCamera, want.camera, 1e-9, where);
}

test("a link to an upload: the same view on the server holding it; on another, the file named, a wrong file refused, the right one reproducing the view", async () => {
  serverB = await startServer(); // its own, empty data (cache) directory

  // On A: the box uploaded in millimetres, prepared at l_x 0.1 m, two strokes on its +z face.
  const page = await openView(env.browser, env.server, hash({ object: "cube", lx: 0.1, levels: [0, 0.3] }));
  await waitReady(page);
  await field(page, "file unit").locator("select").selectOption("mm");
  await page.setInputFiles("input[data-testid=kelvin-upload]", file);
  await page.waitForFunction(() => window.distlab.kelvin.upload?.id && window.distlab.kelvin.state.object === "upload", null, { timeout: 120000 });
  await type(page, "l_x", "0.1");
  await page.waitForFunction(() => window.distlab.kelvin.ready && window.distlab.kelvin.object?.source?.lx === 0.1, null, { timeout: 300000, polling: 100 });
  const v0 = await K(page, "k.sigma.version");
  await kelvinStroke(page, [-0.2, -0.08, 0.15], [0.2, -0.08, 0.15]);
  await kelvinStroke(page, [-0.15, 0.08, 0.15], [0.1, 0.08, 0.15]);
  await page.waitForFunction((v) => window.distlab.kelvin.sigma.version > v && window.distlab.kelvin.ready, v0, { timeout: 120000, polling: 100 });
  await page.waitForTimeout(400); // the URL is written debounced
  const link = await page.evaluate(() => location.hash);
  const made = await view(page);
  assert.match(made.upload.digest, /^[0-9a-f]{64}$/);
  assert.deepEqual(made.upload, { digest: made.digest, name: file.name, bytes: file.buffer.length, unit: "mm" }, "the link names the file and its mesh");
  assert.equal(made.vertices, box.vertices.length);
  assert.ok(made.brushes.length > 0, "the strokes are in the link");
  assert.deepEqual(made.shownLevels, [0, 0.3]);
  cameraIs(made.shownCamera, made.camera, 5e-6, "where the link was made");
  assert.ok(link.includes(made.digest) || /\?z=/.test(link), "the plain link carries the digest");
  await screenshot(page, "kelvin-link-made");

  // On A, another session: the same view, without a word about uploading.
  const again = await openView(env.browser, env.server, link);
  await waitReady(again);
  sameView(await view(again), made, "reopened on A");
  assert.equal(await K(again, "k.upload.notice"), null);

  // On B: the file named, nothing prepared, the cube never loaded.
  const onB = await openView(env.browser, serverB, link, { setup: (p) => (p.requests = kelvinRequests(p)) });
  await onB.waitForFunction(() => window.distlab.kelvin.upload?.notice, null, { timeout: 60000 });
  const notice = await K(onB, "k.upload.notice");
  for (const part of [file.name, `${file.buffer.length.toLocaleString("en")} bytes`, made.digest, "read in mm"]) assert.ok(notice.includes(part), `the notice names ${part}: "${notice}"`);
  assert.ok(await onB.locator("[data-testid=kelvin-link-notice] button", { hasText: `upload ${file.name}` }).isVisible());
  const nothing = async () => {
    assert.equal(await K(onB, "k.objectId"), null);
    assert.equal(await K(onB, "k.displayTriangles"), 0, "no surface drawn");
    assert.deepEqual(
      onB.requests.filter((r) => r.method === "POST" && (r.path.endsWith("/objects") || r.path.endsWith("/estimate") || r.body.includes('"asset"'))),
      [],
      "no object requested, no estimate, no asset",
    );
    assert.deepEqual((await onB.evaluate(() => window.distlab.api.get("/api/kelvin/objects"))).objects, []);
  };
  await nothing();
  await screenshot(onB, "kelvin-link-missing-upload");

  // A different file: the server's check refuses it, in words; still nothing prepared.
  await onB.setInputFiles("input[data-testid=kelvin-link-upload]", wrong);
  await onB.waitForFunction(() => /not the linked file/.test(window.distlab.kelvin.upload.refusal), null, { timeout: 60000 });
  const refusal = await K(onB, "k.upload.refusal");
  assert.ok(refusal.includes(made.digest), refusal);
  assert.ok(await K(onB, "k.upload.notice"), "the notice stays");
  await nothing();
  await screenshot(onB, "kelvin-link-wrong-file");

  // The right file: the view of the link.
  await onB.setInputFiles("input[data-testid=kelvin-link-upload]", file);
  await waitReady(onB);
  sameView(await view(onB), made, "opened on B after the upload");
  assert.equal(await K(onB, "k.upload.notice"), null);
  await screenshot(onB, "kelvin-link-reproduced");
  for (const p of [page, again, onB]) assert.deepEqual(p.problems.filter((x) => !x.includes("the server responded with a status")), []);
});

test("a link from before links named their uploads shows no other object", async () => {
  const page = await openView(env.browser, env.server, hash({ object: "upload", lx: 0.1, levels: [0], brushes: [] }), { setup: (p) => (p.requests = kelvinRequests(p)) });
  await page.waitForFunction(() => window.distlab.kelvin.upload?.notice, null, { timeout: 60000 });
  assert.match(await K(page, "k.upload.notice"), /does not say which/);
  assert.equal(await K(page, "k.objectId"), null);
  assert.deepEqual(
    page.requests.filter((r) => r.method === "POST" && (r.path.endsWith("/objects") || r.path.endsWith("/estimate") || r.body.includes('"asset"'))),
    [],
  );
});
