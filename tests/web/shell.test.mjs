// The shell loads from the real server, talks to it, routes between views, and reconnects after
// a server restart.
import { test } from "node:test";
import assert from "node:assert/strict";
import { openView, screenshot, serverAndBrowser, startServer } from "./harness.mjs";
import { gridBox, objText } from "./grid_box.mjs";

const env = serverAndBrowser();

test("the shell loads, has WebGL, and routes between the three views", async () => {
  const page = await openView(env.browser, env.server, "#/gap");
  const gl = await page.evaluate(() => !!document.createElement("canvas").getContext("webgl2"));
  assert.ok(gl, "WebGL2 is available in headless chromium");
  for (const [id, title] of [["gap", "GAP explorer"], ["kelvin", "Semantic distance"], ["cbf", "CBF rollouts"]]) {
    await page.click(`#tabs a[data-view=${id}]`);
    await page.waitForFunction((t) => document.title.endsWith(t), title);
    assert.equal(await page.locator("#tabs a.active").getAttribute("data-view"), id);
    await page.waitForSelector("canvas.viewport-canvas");
    assert.equal(await page.locator("canvas.viewport-canvas").count(), 1, "exactly one viewport after switching");
  }
  await screenshot(page, "shell");
  assert.deepEqual(page.problems, []);
});

test("an unknown route falls back to the first view; keyboard 2 opens the second", async () => {
  const page = await openView(env.browser, env.server, "#/nonsense?s=%7Bbroken");
  await page.waitForFunction(() => location.hash.startsWith("#/gap"));
  await page.keyboard.press("2");
  await page.waitForFunction(() => location.hash.startsWith("#/kelvin"));
  assert.deepEqual(page.problems, []);
});

// Tab links carried no state (issue 37 leftover): leaving a view by a tab and coming back by its tab
// (or its key) mounted it with its defaults, so a moved GAP shape or an uploaded Kelvin object was
// gone until Back. Each view comes back as it was left, its tab links to its full state, and the
// address bar shows that state once it is back.
test("a view left by its tab comes back as it was: the GAP shape moved, the Kelvin upload, both in their links", async () => {
  const route = (page) => page.evaluate(() => location.hash);
  const stateOf = (hash) => JSON.parse(decodeURIComponent(/\?s=(.*)$/.exec(hash)?.[1] ?? "%7B%7D"));
  const settled = (page, view) => page.waitForFunction((v) => location.hash.startsWith(`#/${v}?s=`) && window.distlab?.[v] !== undefined, view);
  const page = await openView(env.browser, env.server, "#/gap");
  await page.keyboard.press("ArrowRight"); // B 1 cm along +x
  await page.waitForFunction(() => location.hash.includes("%22b%22"));
  await page.waitForTimeout(400); // the link is written 150 ms after the change
  const gapLink = await route(page);
  const moved = stateOf(gapLink);
  assert.ok(Math.abs(moved.b.position[0] - 0.56) < 1e-9, gapLink); // from 0.55

  await page.click("#tabs a[data-view=kelvin]");
  await page.waitForFunction(() => window.distlab?.kelvin?.ready === true, null, { polling: 100 });
  assert.equal(await page.locator("#tabs a[data-view=gap]").getAttribute("href"), gapLink, "the GAP tab links to GAP's state");
  const box = gridBox([0.3, 0.2, 0.2], 2);
  await page.setInputFiles("input[data-testid=kelvin-upload]", {
    name: "tab-box.obj",
    mimeType: "text/plain",
    buffer: Buffer.from(objText(box)),
  });
  // state.object turns "upload" before the cube's status is replaced: wait for the uploaded mesh's
  // own object (its surface digest is the upload's digest) and read it in the same evaluation.
  const uploaded = () => {
    const k = window.distlab.kelvin;
    const d = k.upload.ref?.digest;
    return k.ready && k.state.object === "upload" && d !== undefined && k.object?.surface_digest === d ? d : false;
  };
  const digest = await (await page.waitForFunction(uploaded, null, { polling: 100 })).jsonValue();
  await page.waitForFunction((d) => location.hash.includes(d), digest);

  await page.click("#tabs a[data-view=gap]");
  await settled(page, "gap");
  assert.deepEqual(stateOf(await route(page)), moved, "GAP comes back with B moved, and its link says so");
  assert.ok((await page.locator("#tabs a[data-view=kelvin]").getAttribute("href")).includes(digest), "the Kelvin tab links to the upload");

  await page.keyboard.press("2"); // the Kelvin view's key
  await page.waitForFunction(() => window.distlab?.kelvin?.ready === true && window.distlab.kelvin.object, null, { polling: 100 });
  assert.equal(await page.evaluate(() => window.distlab.kelvin.state.object), "upload");
  assert.equal(await page.evaluate(() => window.distlab.kelvin.object.surface_digest), digest, "the same uploaded mesh, not the cube");
  assert.equal(await page.evaluate(() => window.distlab.kelvin.object.n_input_vertices), box.vertices.length);
  await page.waitForFunction((d) => location.hash.startsWith("#/kelvin?s=") && location.hash.includes(d), digest);
  assert.deepEqual(page.problems, []);
  await page.context().close();
});

test("the page reconnects after the server restarts on the same port", async () => {
  const page = await openView(env.browser, env.server, "#/gap");
  const port = env.server.port;
  await env.server.stop({ keepCache: true });
  await page.waitForFunction(() => document.getElementById("connection")?.textContent?.startsWith("offline"), null, { timeout: 60000 });
  env.server = await startServer({ cacheDir: env.server.cacheDir, port, removeCache: true });
  // A restart on another port cannot be followed by the page; the test restarts on the same one.
  await page.waitForFunction(() => document.getElementById("connection")?.textContent === "connected", null, { timeout: 120000 });
});
