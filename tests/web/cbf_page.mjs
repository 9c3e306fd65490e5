// What the CBF view's browser tests share: the view's URL for a state, its test hooks, and the
// wait for a run's end.

export const hash = (state) => `#/cbf?s=${encodeURIComponent(JSON.stringify(state))}`;
/** Evaluates `expr` in the page with c = window.distlab.cbf. */
export const C = (page, expr) => page.evaluate(`(() => { const c = window.distlab.cbf; return ${expr}; })()`);

/** Until the run's n rollouts have all ended and the progress box is gone. */
export async function runEnded(page, n) {
  await page.waitForFunction(
    (n) => {
      const r = window.distlab?.cbf?.rollouts;
      return !!r && r.length === n && r.every((x) => ["finished", "cancelled", "failed"].includes(x.state)) && document.getElementById("progress").hidden;
    },
    n,
    { timeout: 120000, polling: 50 },
  );
}
