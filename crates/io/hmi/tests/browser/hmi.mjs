// The HMI page in a real browser (playwright-core driving Debian's chromium), run by
// crates/io/hmi/tests/browser.rs against the mixer PLC:
//
//   node hmi.mjs URL TOKEN OUTDIR
//
// Loads the page, waits until a point value changes and a token moves in the net's SVG,
// checks that a force without the token is refused, enters the token, forces B1 (owned by
// the operator module) to 1 and sees the server hold it there, releases it, and leaves a
// screenshot in OUTDIR. Exits non-zero with the reason on any failure.
// Environment: PETRIPLC_NODE_MODULES (where playwright-core is), PETRIPLC_CHROMIUM.

import { createRequire } from "node:module";
import fs from "node:fs";
import path from "node:path";

const [url, token, outDir] = process.argv.slice(2);
if (!url || !token || !outDir) {
  console.error("usage: node hmi.mjs URL TOKEN OUTDIR");
  process.exit(2);
}
const modules = process.env.PETRIPLC_NODE_MODULES;
const require = createRequire(path.join(modules || process.cwd(), "hmi-test.js"));
const { chromium } = require("playwright-core");

const TIMEOUT = 20000;
const log = (...a) => console.log("hmi.mjs:", ...a);
const problems = [];

const context = await chromium.launchPersistentContext(fs.mkdtempSync(path.join(outDir, "profile-")), {
  executablePath: process.env.PETRIPLC_CHROMIUM || "/usr/bin/chromium",
  headless: true,
  args: [
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
  ],
  viewport: { width: 1280, height: 1000 },
});
context.setDefaultTimeout(TIMEOUT);

async function state(page) {
  const r = await page.request.get(url + "api/state");
  if (!r.ok()) throw new Error("GET api/state: " + r.status());
  return r.json();
}

function pointOf(snapshot, name) {
  const p = snapshot.points.find((p) => p.name === name);
  if (!p) throw new Error("no point " + name + " in api/state");
  return p;
}

let failed = false;
const page = context.pages()[0] || (await context.newPage());
page.on("pageerror", (e) => problems.push("page error: " + e.message));
page.on("console", (m) => {
  // The refused force is a 401 the browser reports; anything else is a problem.
  if (m.type() === "error" && !m.text().includes("status of 401")) problems.push("console error: " + m.text());
});
try {
  await page.goto(url);
  await page.waitForSelector('[data-testid="connection"][data-state="connected"]');
  log("connected");

  // A point value changes on the page.
  await page.waitForSelector('[data-testid="value-B1"]:not(:empty)');
  const shown = () =>
    [...document.querySelectorAll('[data-testid^="value-"]')].map((td) => td.textContent).join(" ");
  const before = await page.evaluate(shown);
  await page.waitForFunction(
    (b) => [...document.querySelectorAll('[data-testid^="value-"]')].map((td) => td.textContent).join(" ") !== b,
    before,
  );
  log("values changed from", before, "to", await page.evaluate(shown));

  // A token moves in the net: the marked places change.
  await page.waitForSelector('[data-testid="net-controller"] svg g.place');
  // Each place's token count and the dots or number drawn for it (the predicates below
  // repeat these functions: Playwright sends a function's text alone, and the page's
  // Content-Security-Policy forbids evaluating strings).
  const drawn = () =>
    JSON.stringify(
      [...document.querySelectorAll('[data-testid="net-controller"] g.place')].map((g) => [
        g.dataset.place,
        Number(g.dataset.tokens),
        g.querySelector(".tokens").innerHTML,
      ]),
    );
  const marking = async () => JSON.parse(await page.evaluate(drawn));
  const m0 = await marking();
  await page.waitForFunction(
    (before) =>
      JSON.stringify(
        [...document.querySelectorAll('[data-testid="net-controller"] g.place')].map((g) => [
          g.dataset.place,
          Number(g.dataset.tokens),
          g.querySelector(".tokens").innerHTML,
        ]),
      ) !== before,
    JSON.stringify(m0),
  );
  const m1 = await marking();
  const marked = (m) => m.filter(([, n, dots]) => n > 0 && dots !== "").map(([p, n]) => p + "=" + n).join(" ");
  log("marked places moved from", marked(m0), "to", marked(m1));

  // The module table shows every module running.
  await page.waitForFunction(() => {
    const rows = [...document.querySelectorAll('[data-testid="modules"] tbody tr')];
    return rows.length === 4 && rows.every((r) => r.children[2].textContent === "running");
  });

  // Without the token the force is refused and nothing is forced.
  await page.getByRole("button", { name: "force B1 to 1", exact: true }).click();
  await page.waitForFunction(() =>
    document.querySelector('[data-testid="force-message"]').textContent.startsWith("Refused"),
  );
  log("without the token:", await page.textContent('[data-testid="force-message"]'));
  if (pointOf(await state(page), "B1").forced) throw new Error("B1 forced without the token");
  if (await page.isVisible('[data-testid="forced-B1"]')) throw new Error("forced badge without the token");

  // With the token: B1 forced to 1, and held there whatever the operator does.
  await page.getByLabel("Forcing token", { exact: true }).fill(token);
  await page.getByRole("button", { name: "Use token" }).click();
  await page.waitForSelector('[data-testid="token-state"][data-has-token="yes"]');
  await page.getByRole("button", { name: "force B1 to 1", exact: true }).click();
  await page.waitForSelector('[data-testid="forced-B1"]', { state: "visible" });
  await page.waitForFunction(() => document.querySelector('[data-testid="value-B1"]').textContent === "1");
  const forced = pointOf(await state(page), "B1");
  if (!forced.forced || forced.value !== 1) throw new Error("api/state after the force: " + JSON.stringify(forced));
  log("forced:", await page.textContent('[data-testid="force-message"]'));
  // The operator releases B1 0.2 s after each press, every 1.4 s: over 1.6 s the page
  // would show 0 at least once if the force did not hold.
  for (let i = 0; i < 16; i++) {
    await page.waitForTimeout(100);
    const v = await page.textContent('[data-testid="value-B1"]');
    if (v !== "1") throw new Error("B1 read " + v + " while forced to 1");
  }
  await page.screenshot({ path: path.join(outDir, "hmi.png"), fullPage: true });

  // Released.
  await page.getByRole("button", { name: "release B1", exact: true }).click();
  await page.waitForSelector('[data-testid="forced-B1"]', { state: "hidden" });
  if (pointOf(await state(page), "B1").forced) throw new Error("B1 still forced after the release");
  log("released");
  if (problems.length > 0) throw new Error(problems.join("; "));
} catch (e) {
  failed = true;
  console.error("hmi.mjs: FAILED:", e && e.stack ? e.stack : e);
  for (const p of problems) console.error("hmi.mjs:", p);
  try {
    await page.screenshot({ path: path.join(outDir, "failure.png"), fullPage: true });
    console.error("hmi.mjs: page text:", (await page.textContent("body")).replace(/\s+/g, " ").slice(0, 3000));
  } catch (err) {
    // The page is gone: nothing more to show.
  }
} finally {
  await context.close();
}
process.exit(failed ? 1 : 0);
