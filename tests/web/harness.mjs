// Browser-test harness: starts the real `distlab serve` on a free port with the built front end
// (web/dist), launches Debian's chromium headless through playwright-core, and keeps screenshots
// as artifacts. Environment (set by tests/web/CMakeLists.txt): DISTLAB_EXE, DISTLAB_SOURCE_DIR,
// DISTLAB_ARTIFACTS, CHROMIUM.
import { spawn } from "node:child_process";
import { after, before } from "node:test";
import { mkdirSync, mkdtempSync, rmSync, existsSync } from "node:fs";
import { createRequire } from "node:module";
import { tmpdir } from "node:os";
import path from "node:path";

const source = process.env.DISTLAB_SOURCE_DIR ?? path.resolve(import.meta.dirname, "../..");
const require = createRequire(path.join(source, "web", "package.json"));
const { chromium } = require("playwright-core");
/** msgpack bytes → value (the server's binary WebSocket frames). */
export const decodeMsgpack = require("@msgpack/msgpack").decode;

export const artifacts = process.env.DISTLAB_ARTIFACTS ?? path.join(source, "build", "web-artifacts");
mkdirSync(artifacts, { recursive: true });

/** Starts `distlab serve --port 0` and resolves once it prints the port it listens on. stop()
 *  removes the cache directory if this made it, or if removeCache (a restart taking it over). */
export async function startServer({ extra = [], cacheDir, port: wanted = 0, removeCache = !cacheDir } = {}) {
  const exe = process.env.DISTLAB_EXE ?? path.join(source, "build", "backend", "app", "distlab");
  const web = process.env.DISTLAB_WEB_DIST ?? path.join(source, "web", "dist"); // another front-end build (A/B)
  if (!existsSync(path.join(web, "index.html"))) throw new Error(`no front-end build at ${web} (run npm run build in web/)`);
  const cache = cacheDir ?? mkdtempSync(path.join(tmpdir(), "distlab-web-cache-"));
  const args = ["serve", "--host", "127.0.0.1", "--port", String(wanted), "--assets", path.join(source, "assets"), "--web", web, "--cache-dir", cache, ...extra];
  const proc = spawn(exe, args, { stdio: ["ignore", "pipe", "pipe"] });
  let log = "";
  const port = await new Promise((resolve, reject) => {
    const timer = setTimeout(() => reject(new Error("server did not start in 120 s:\n" + log)), 120000);
    const onData = (d) => {
      log += d.toString();
      const m = /listening on http:\/\/[^:]+:(\d+)\//.exec(log);
      if (m) {
        clearTimeout(timer);
        resolve(Number(m[1]));
      }
    };
    proc.stdout.on("data", onData);
    proc.stderr.on("data", onData);
    proc.on("exit", (code) => reject(new Error(`server exited (${code}):\n${log}`)));
  });
  return {
    port,
    url: `http://127.0.0.1:${port}/`,
    cacheDir: cache,
    log: () => log,
    async stop({ keepCache = false } = {}) {
      if (proc.exitCode === null) {
        proc.kill("SIGTERM");
        await new Promise((r) => proc.once("exit", r));
      }
      if (removeCache && !keepCache) rmSync(cache, { recursive: true, force: true });
    },
  };
}

/** A fresh directory under the system's temporary one, removed after the test `t` whatever its outcome. */
export function tempDir(t, prefix) {
  const dir = mkdtempSync(path.join(tmpdir(), prefix));
  t.after(() => rmSync(dir, { recursive: true, force: true }));
  return dir;
}

export async function launchBrowser() {
  return chromium.launch({
    executablePath: process.env.CHROMIUM ?? "/usr/bin/chromium",
    headless: true,
    args: [
      "--no-sandbox",
      ...(process.env.GPU_COMPOSITING === "1" ? [] : ["--disable-gpu"]),
      "--disable-background-networking",
      "--disable-component-update",
      "--enable-unsafe-swiftshader", // WebGL on the CPU (no GPU here)
      "--use-angle=swiftshader",
    ],
  });
}

/** The server and browser a test file shares: registers node:test hooks that start both before its
 *  tests and close both after them. A test may replace `.server` (a restart); the current one is stopped. */
export function serverAndBrowser() {
  const env = { server: null, browser: null };
  before(async () => {
    env.server = await startServer();
    env.browser = await launchBrowser();
  });
  after(async () => {
    await env.browser?.close();
    await env.server?.stop();
  });
  return env;
}

/** openView's size for tests that paint many strokes: each stroke's frames are drawn in software
 *  (SwiftShader), so fewer pixels is less time (the 200-stroke test: 123 s at 1280 × 800, 98 s). */
export const PAINTING_WINDOW = { width: 1280, height: 520 };

/** A page on the given hash; console errors and failed requests are collected in page.problems.
 *  `setup(page)` runs before the page loads (to listen to its requests and sockets from the start). */
export async function openView(browser, server, hash, { width = 1280, height = 800, setup } = {}) {
  const context = await browser.newContext({ viewport: { width, height }, acceptDownloads: true });
  // Generous waits: CI's 2 cores render WebGL in software while other tests run (waits, not timings).
  context.setDefaultTimeout(120000);
  const page = await context.newPage();
  page.problems = [];
  page.on("pageerror", (e) => page.problems.push(`pageerror: ${e.message}`));
  page.on("console", (m) => {
    if (m.type() === "error") page.problems.push(`console: ${m.text()}`);
  });
  await setup?.(page);
  await page.goto(server.url + hash);
  await page.waitForFunction(() => document.getElementById("connection")?.textContent === "connected", null, { timeout: 120000 });
  // Views load lazily: wait until the routed view has mounted its test hooks (window.distlab.<view>).
  const view = /^#\/(gap|kelvin|cbf)\b/.exec(hash)?.[1];
  if (view) await page.waitForFunction((v) => window.distlab?.[v] !== undefined, view, { timeout: 120000 });
  return page;
}

export async function screenshot(page, name) {
  const file = path.join(artifacts, `${name}.png`);
  await page.screenshot({ path: file });
  return file;
}

/** Pixels of the 3D canvas (for "the picture changed" checks). */
export async function canvasPixels(page) {
  const buf = await page.locator("canvas.viewport-canvas").first().screenshot();
  return buf;
}

export function differentBytes(a, b) {
  if (a.length !== b.length) return Math.max(a.length, b.length);
  let n = 0;
  for (let i = 0; i < a.length; i++) if (a[i] !== b[i]) n++;
  return n;
}

/** A real mouse stroke across the Kelvin object's visible face, through points given in world space. */
export async function kelvinStroke(page, from, to, steps = 12) {
  const at = (p) => page.evaluate((p) => window.distlab.kelvin.toScreen(p), p);
  await screenStroke(page, await at(from), await at(to), steps);
}

/** A mouse drag from screen position a to b in `steps` moves. */
export async function screenStroke(page, a, b, steps = 12) {
  await page.mouse.move(a.x, a.y);
  await page.mouse.down();
  for (let i = 1; i <= steps; i++) await page.mouse.move(a.x + ((b.x - a.x) * i) / steps, a.y + ((b.y - a.y) * i) / steps);
  await page.mouse.up();
}

/** The page's pixels (sRGB bytes) at page positions, from a screenshot taken now; with `near`, the
 *  pixel of the 3 × 3 around each position closest to that colour (for lines a pixel or two wide). */
export async function pagePixels(page, positions, near = null) {
  const png = (await page.screenshot()).toString("base64");
  return page.evaluate(
    async ({ png, positions, near }) => {
      const img = new Image();
      img.src = `data:image/png;base64,${png}`;
      await img.decode();
      const c = document.createElement("canvas");
      [c.width, c.height] = [img.width, img.height];
      const ctx = c.getContext("2d");
      ctx.drawImage(img, 0, 0);
      const off = (px) => Math.max(...px.map((v, i) => Math.abs(v - near[i])));
      return positions.map((s) => {
        if (!near) return Array.from(ctx.getImageData(Math.round(s.x), Math.round(s.y), 1, 1).data.slice(0, 3));
        const d = ctx.getImageData(Math.round(s.x) - 1, Math.round(s.y) - 1, 3, 3).data;
        const px = Array.from({ length: 9 }, (_, k) => Array.from(d.slice(4 * k, 4 * k + 3)));
        return px.reduce((best, p) => (off(p) < off(best) ? p : best));
      });
    },
    { png, positions, near },
  );
}
