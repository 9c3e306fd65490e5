#!/usr/bin/env node
// Headless snapshot of a shared view: opens URL in Debian's chromium (playwright-core), waits until
// the view has drawn what the link describes, presses the page's own screenshot button and saves
// the PNG it downloads (the same file as the button in a browser).
//   node web/scripts/snapshot.mjs URL OUT.png [--width 1280] [--height 800] [--timeout 300]
// URL: a link copied from the page (http://HOST:PORT/#/VIEW?s=...); the server must be running.
import { createRequire } from "node:module";
import path from "node:path";

const usage = "usage: node web/scripts/snapshot.mjs URL OUT.png [--width N] [--height N] [--timeout SECONDS]";
const args = process.argv.slice(2);
if (args.includes("--help") || args.length < 2) {
  console.log(usage);
  process.exit(args.includes("--help") ? 0 : 2);
}
const [url, out] = args;
const opt = (name, d) => {
  const i = args.indexOf(`--${name}`);
  const v = i >= 0 ? Number(args[i + 1]) : d;
  if (!(v > 0)) {
    console.error(`--${name} must be a positive number\n${usage}`);
    process.exit(2);
  }
  return v;
};
const width = opt("width", 1280),
  height = opt("height", 800),
  timeout = opt("timeout", 300) * 1000;
const view = /#\/(gap|kelvin|cbf)\b/.exec(url)?.[1];
if (!view) {
  console.error(`${url}: not a view link (#/gap, #/kelvin or #/cbf)\n${usage}`);
  process.exit(2);
}

const require = createRequire(path.join(import.meta.dirname, "..", "package.json"));
const { chromium } = require("playwright-core");
const browser = await chromium.launch({
  executablePath: process.env.CHROMIUM ?? "/usr/bin/chromium",
  headless: true,
  args: ["--no-sandbox", "--disable-gpu", "--disable-background-networking", "--disable-component-update", "--enable-unsafe-swiftshader", "--use-angle=swiftshader"],
});
try {
  const page = await browser.newPage({ viewport: { width, height }, acceptDownloads: true });
  page.setDefaultTimeout(timeout);
  await page.goto(url);
  await page.waitForFunction((v) => window.distlab?.[v] !== undefined, view);
  // Ready: the Kelvin view once its object and iso-surfaces are shown; the others once idle.
  if (view === "kelvin") await page.waitForFunction(() => window.distlab.kelvin.ready === true, null, { polling: 200 });
  else await page.waitForLoadState("networkidle");
  await page.waitForTimeout(500); // the next frame is drawn
  const [download] = await Promise.all([page.waitForEvent("download"), page.click("#screenshot")]);
  await download.saveAs(out);
  console.log(`${out}: snapshot of ${view}`);
} finally {
  await browser.close();
}
