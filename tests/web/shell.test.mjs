// The shell loads from the real server, talks to it, routes between views, and reconnects after
// a server restart.
import { test } from "node:test";
import assert from "node:assert/strict";
import { openView, screenshot, serverAndBrowser, startServer } from "./harness.mjs";

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

test("the page reconnects after the server restarts on the same port", async () => {
  const page = await openView(env.browser, env.server, "#/gap");
  const port = env.server.port;
  await env.server.stop({ keepCache: true });
  await page.waitForFunction(() => document.getElementById("connection")?.textContent?.startsWith("offline"), null, { timeout: 60000 });
  env.server = await startServer({ cacheDir: env.server.cacheDir, port });
  // A restart on another port cannot be followed by the page; the test restarts on the same one.
  await page.waitForFunction(() => document.getElementById("connection")?.textContent === "connected", null, { timeout: 120000 });
});
