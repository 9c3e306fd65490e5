// The README's screenshot (docs/images/kelvin-wrench.png): the Kelvin view on the paper's wrench
// with σ case (a) of eq. 24 and three iso-surfaces, taken from the real server in headless
// Chromium. Not a test; run after building the server and the front end:
//   node tests/web/readme_screenshot.mjs [out.png]
import path from "node:path";
import { launchBrowser, openView, startServer } from "./harness.mjs";

const out = path.resolve(
  process.argv[2] ??
    path.join(import.meta.dirname, "../../docs/images/kelvin-wrench.png"),
);
const state = {
  object: "wrench",
  lx: 0.004,
  preset: "a",
  levels: [-0.25, 0, 0.25],
  opacity: 0.3,
  camera: { position: [0.07, -0.13, 0.11], target: [0, 0, 0] },
};
const server = await startServer();
const browser = await launchBrowser();
try {
  const page = await openView(
    browser,
    server,
    `#/kelvin?s=${encodeURIComponent(JSON.stringify(state))}`,
    { width: 1280, height: 720 },
  );
  await page.waitForFunction(
    () => window.distlab?.kelvin?.ready === true,
    null,
    { timeout: 300000, polling: 200 },
  );
  await page.waitForTimeout(1500); // the iso-surfaces' frames and one more render
  await page.screenshot({ path: out });
  console.log(`wrote ${out}`);
} finally {
  await browser.close();
  await server.stop();
}
