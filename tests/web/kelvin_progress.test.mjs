// A preparation's bar and time left follow its stages' real shares (issue 38 goal 3): the bar is
// the job's overall fraction (the server weighs each stage by its predicted seconds), so it never
// goes back from one stage to the next, and the label counts the time left down. Today's bar
// showed each stage's own fraction (full at the end of build, empty again at decomp) and no time.
import { test } from "node:test";
import assert from "node:assert/strict";
import { openView, serverAndBrowser } from "./harness.mjs";

const env = serverAndBrowser();
const hash = (state) =>
  `#/kelvin?s=${encodeURIComponent(JSON.stringify(state))}`;

test("the preparation's bar never goes back and its label says the time left", async () => {
  const page = await openView(
    env.browser,
    env.server,
    hash({ object: "wrench", lx: 0.005, levels: [0] }),
    {
      setup: (p) =>
        // Every frame's bar and label while the progress box is shown.
        p.addInitScript(() => {
          window.__bar = [];
          const look = () => {
            const box = document.getElementById("progress");
            const bar = document.getElementById("progress-bar");
            if (box && bar && !box.hidden) {
              const label =
                document.getElementById("progress-label")?.textContent ?? "";
              const value = bar.hasAttribute("value") ? bar.value : null;
              const last = window.__bar.at(-1);
              if (!last || last.label !== label || last.value !== value)
                window.__bar.push({ label, value });
            }
            requestAnimationFrame(look);
          };
          requestAnimationFrame(look);
        }),
    },
  );
  await page.waitForFunction(() => window.distlab.kelvin.ready === true, null, {
    timeout: 300000,
    polling: 100,
  });
  const seen = (await page.evaluate(() => window.__bar)).filter((r) =>
    r.label.startsWith("preparing wrench"),
  );
  const stages = new Set(
    seen.map((r) => /: (\w+)/.exec(r.label)?.[1]).filter(Boolean),
  );
  assert.ok(
    stages.size >= 3,
    `the bar was seen through several stages: ${JSON.stringify(seen)}`,
  );
  let last = 0;
  for (const r of seen.filter((r) => r.value !== null)) {
    assert.ok(
      r.value >= last,
      `the bar went back from ${last} to ${r.value} at "${r.label}": ${JSON.stringify(seen)}`,
    );
    last = r.value;
  }
  assert.ok(
    seen.some((r) =>
      /· (≈ [\d.]+ s left|longer than predicted)$/.test(r.label),
    ),
    `the label says the time left: ${JSON.stringify(seen.map((r) => r.label))}`,
  );
  assert.deepEqual(page.problems, []);
});
