// The user's scene items (Client.scene) in the page: they arrive over the WebSocket, stay through
// view switches, show only in the view they name, move and go away as the session's client says.
import { test } from "node:test";
import assert from "node:assert/strict";
import { createRequire } from "node:module";
import path from "node:path";
import { openView, screenshot, serverAndBrowser } from "./harness.mjs";

const source =
  process.env.DISTLAB_SOURCE_DIR ?? path.resolve(import.meta.dirname, "../..");
const { encode } = createRequire(path.join(source, "web", "package.json"))(
  "@msgpack/msgpack",
);
const env = serverAndBrowser();

/** The bytes of little-endian float32 / uint32 values (the frame's bin values). */
const f32 = (a) => new Uint8Array(new Float32Array(a).buffer);
const u32 = (a) => new Uint8Array(new Uint32Array(a).buffer);

async function call(session, method, route, body, type = "application/json") {
  const r = await fetch(env.server.url + route.slice(1), {
    method,
    headers: { "X-Distlab-Session": session, "Content-Type": type },
    body: type === "application/json" ? JSON.stringify(body) : body,
  });
  assert.ok(r.ok, `${method} ${route}: ${r.status} ${await r.text()}`);
}

const shown = (page) =>
  page.evaluate(() =>
    Object.fromEntries(window.distlab.scene().map((i) => [i.name, i.visible])),
  );

test("scene items survive view switches and show in the view they name", async () => {
  const page = await openView(env.browser, env.server, "#/gap");
  const session = await page.evaluate(() => window.distlab.api.sessionId());
  const tri = {
    kind: "mesh",
    positions: f32([0, 0, 0, 1, 0, 0, 0, 1, 0]),
    indices: u32([0, 1, 2]),
    color: [1, 0, 0],
  };
  await call(
    session,
    "PUT",
    "/api/scene/items/everywhere",
    encode(tri),
    "application/msgpack",
  );
  await call(
    session,
    "PUT",
    "/api/scene/items/kelvin_only",
    encode({ ...tri, view: "kelvin" }),
    "application/msgpack",
  );
  await page.waitForFunction(() => window.distlab.scene().length === 2);
  assert.deepEqual(await shown(page), { everywhere: true, kelvin_only: false });
  for (const [view, expected] of [
    ["kelvin", { everywhere: true, kelvin_only: true }],
    ["cbf", { everywhere: true, kelvin_only: false }],
  ]) {
    await page.click(`#tabs a[data-view=${view}]`);
    // The view's own test hook (not the hash: a view leaving may still write its state there).
    await page.waitForFunction((v) => window.distlab[v] !== undefined, view);
    assert.deepEqual(await shown(page), expected, view);
  }
  await call(session, "PUT", "/api/scene/items/everywhere/pose", {
    pose: { position: [0.25, 0.5, 1] },
  });
  await page.waitForFunction(
    () =>
      window.distlab.scene().find((i) => i.name === "everywhere")
        .position[2] === 1,
  );
  await call(session, "DELETE", "/api/scene/items/kelvin_only");
  await page.waitForFunction(() => window.distlab.scene().length === 1);
  await screenshot(page, "scene-items");
  await call(session, "DELETE", "/api/scene/items");
  await page.waitForFunction(() => window.distlab.scene().length === 0);
  assert.deepEqual(page.problems, []);
});

test("a page of another session gets none of them", async () => {
  const mine = await openView(env.browser, env.server, "#/gap");
  const other = await openView(env.browser, env.server, "#/gap");
  const session = await mine.evaluate(() => window.distlab.api.sessionId());
  assert.notEqual(
    session,
    await other.evaluate(() => window.distlab.api.sessionId()),
  );
  const dots = { kind: "points", positions: f32([0, 0, 0, 0, 0, 1]) };
  await call(
    session,
    "PUT",
    "/api/scene/items/dots",
    encode(dots),
    "application/msgpack",
  );
  await mine.waitForFunction(() => window.distlab.scene().length === 1);
  // The other page's socket answers a ping after anything queued for it before: still nothing.
  await other.evaluate(
    () =>
      new Promise((resolve) => {
        const off = window.distlab.socket.on("pong", () => resolve(off()));
        window.distlab.socket.send({ type: "ping" });
      }),
  );
  assert.deepEqual(await shown(other), {});
});
