// Only the view on screen writes the URL (issue 37 leftover): a view writes its state into the hash
// 150 ms after a change (urlstate.ts, debounced). A change made just before switching views left
// that write pending, and it landed after the switch: the hash read #/kelvin… while the CBF view was
// shown, and a reload opened the Kelvin view. For each pair of views, the first view's state is
// changed (its keyboard shortcut) and its tab left in the same task, so its write is certainly
// pending when the hash changes. Afterwards no write may name the view left (every replaceState of
// the page is logged), the hash must name the view shown, that view must still write its own
// state, and a reload must open it again.
import { test } from "node:test";
import assert from "node:assert/strict";
import { openView, serverAndBrowser } from "./harness.mjs";

const env = serverAndBrowser();

// A shortcut of each view that changes its state (and so writes the hash), and how the state shows it.
const CHANGE = {
  kelvin: { key: "s", changed: (s) => s.slice?.show === true }, // slice plane on (off by default)
  gap: { key: "ArrowRight", changed: (s) => Array.isArray(s.b?.position) && Math.abs(s.b.position[0] - 0.55) > 1e-9 }, // B 1 cm along +x
  cbf: { key: "]", changed: (s) => typeof s.speed === "number" && s.speed > 1 }, // faster playback
};

const viewOf = (hash) => /^#\/([a-z0-9_-]+)/i.exec(hash)?.[1].toLowerCase() ?? "";

/** The view the hash names, and its state. */
async function hashRoute(page) {
  const hash = await page.evaluate(() => location.hash);
  const s = /\?s=(.*)$/.exec(hash)?.[1];
  return { view: viewOf(hash), state: s ? JSON.parse(decodeURIComponent(s)) : {}, hash };
}

/** Lets every write scheduled so far land: the debounce is a 150 ms setTimeout (equal delays run
 *  first in, first out) and its body a few promise turns; then two animation frames. */
async function settle(page) {
  await page.evaluate(async () => {
    await new Promise((r) => setTimeout(r, 600));
    await new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(r)));
  });
}

async function mounted(page, view) {
  await page.waitForFunction((v) => window.distlab?.[v] !== undefined && document.querySelector("#tabs a.active")?.dataset.view === v, view);
}

/** Logs every history.replaceState of the page (window.__writes: the hashes, in order). */
async function logWrites(page) {
  await page.addInitScript(() => {
    window.__writes = [];
    const replace = history.replaceState.bind(history);
    history.replaceState = (data, unused, url) => {
      window.__writes.push(String(url ?? ""));
      return replace(data, unused, url);
    };
  });
}

const pairs = [
  ["kelvin", "cbf"],
  ["gap", "cbf"],
  ["kelvin", "gap"],
  ["gap", "kelvin"],
  ["cbf", "kelvin"],
  ["cbf", "gap"],
];

for (const [from, to] of pairs) {
  test(`a change in ${from} just before opening ${to}: no write names ${from} after, and a reload opens ${to}`, async () => {
    const page = await openView(env.browser, env.server, `#/${from}`, { setup: logWrites });
    // The change and the switch in one task: the change's write is pending when the hash changes.
    const before = await page.evaluate(
      ({ key, to }) => {
        const n = window.__writes.length;
        window.dispatchEvent(new KeyboardEvent("keydown", { key, bubbles: true }));
        document.querySelector(`#tabs a[data-view=${to}]`).click();
        return n;
      },
      { key: CHANGE[from].key, to },
    );
    await mounted(page, to);
    await settle(page);
    const late = (await page.evaluate(() => window.__writes)).slice(before).filter((h) => viewOf(h) !== to);
    assert.deepEqual(late, [], `writes after leaving ${from} for ${to} that name another view`);
    let route = await hashRoute(page);
    assert.equal(route.view, to, `after leaving ${from} for ${to} the hash is ${route.hash}`);

    // The view shown still writes its own state.
    await page.keyboard.press(CHANGE[to].key);
    await page.waitForFunction((v) => location.hash.startsWith(`#/${v}?`), to);
    await settle(page);
    route = await hashRoute(page);
    assert.equal(route.view, to);
    assert.ok(CHANGE[to].changed(route.state), `${to}'s change is in the hash: ${route.hash}`);

    // A reload opens the view that was shown.
    await page.reload();
    await page.waitForFunction(() => ["gap", "kelvin", "cbf"].some((v) => window.distlab?.[v] !== undefined));
    assert.equal(await page.evaluate(() => document.querySelector("#tabs a.active")?.dataset.view), to);
    await mounted(page, to);
    assert.deepEqual(page.problems, []);
    await page.context().close();
  });
}
