// The runtime in headless Chromium: serves the repository, opens the viewer with ?test=golden,
// and checks
//   1. the hash lines the page computes through the wasm runtime (every golden rig and the
//      capture, positions and normals, and the packed take decoded and played) equal
//      fixtures/golden/hashes.txt, hashes_planar.txt, hashes_normals.txt and hashes_take.txt,
//      line for line, as .ci/ffi.sh checks the C examples;
//   2. the viewer draws the face: a screenshot at rest and one at JawMoCap's frame 388 (mouth
//      open) each cover the canvas with more than the background, and differ from each other
//      around the mouth (the face deforms).
//   3. the take the viewer plays, read from the TRC and from the same numbers as CSV
//      (out/browser/JawMoCap.csv), is the baker's input to the golden capture, to the bit.
// Writes out/browser/{screenshot.png,screenshot_rest.png,hashes.txt,summary.json}.
//
//   node web/test/browser-test.mjs      (CHROMIUM=/path/to/chromium to use another binary)
//
// The wasm module must be at web/build/facebake_ffi.wasm (.ci/browser.sh builds it).

import { mkdirSync, readFileSync, writeFileSync } from 'node:fs';
import { join, resolve } from 'node:path';
import { fileURLToPath } from 'node:url';
import { chromium } from 'playwright-core';
import { serve } from '../serve.mjs';

const ROOT = resolve(fileURLToPath(new URL('../..', import.meta.url)));
const OUT = join(ROOT, 'out', 'browser');
const MOUTH_OPEN = 388; // JawMoCap's widest mouth (README)
const failures = [];

function fail(message) {
  failures.push(message);
  console.error(`FAIL: ${message}`);
}

/** The golden lines, in the format ffi/examples/c/play_golden.c prints (and the page too). */
function expectedLines() {
  const golden = (name) => readFileSync(join(ROOT, 'fixtures', 'golden', name), 'utf8').split('\n');
  const pattern = /^(coefficients|weights|coefficients_k4|product|planar|capture) (frame \d+|sequence) [0-9a-f]{16}$/;
  const positions = [...golden('hashes.txt'), ...golden('hashes_planar.txt')].filter((l) => pattern.test(l));
  const normals = golden('hashes_normals.txt')
    .filter((l) => pattern.test(l))
    .map((l) => `normals ${l}`);
  const take = golden('hashes_take.txt').filter((l) => /^take (frame \d+|sequence) [0-9a-f]{16}$/.test(l));
  return [...positions, ...normals, ...take];
}

/** Compare by key (the line without its hash): counts of equal, different, missing, extra. */
function compare(expected, got) {
  const key = (l) => l.slice(0, l.lastIndexOf(' '));
  const have = new Map(got.map((l) => [key(l), l]));
  let equal = 0;
  const wrong = [];
  for (const line of expected) {
    const g = have.get(key(line));
    if (g === line) {
      equal++;
    } else {
      wrong.push(`want ${line}, got ${g ?? 'nothing'}`);
    }
    have.delete(key(line));
  }
  return { equal, wrong, extra: [...have.values()] };
}

/** Pixel statistics of a PNG, decoded by the page itself. */
function pixelStats(page, png, reference) {
  return page.evaluate(
    async ([a, b]) => {
      async function pixels(base64) {
        const img = new Image();
        img.src = `data:image/png;base64,${base64}`;
        await img.decode();
        const c = document.createElement('canvas');
        c.width = img.width;
        c.height = img.height;
        const ctx = c.getContext('2d');
        ctx.drawImage(img, 0, 0);
        return ctx.getImageData(0, 0, c.width, c.height);
      }
      const p = await pixels(a);
      const d = p.data;
      const bg = [d[0], d[1], d[2]]; // a corner: the background
      let covered = 0;
      let sum = 0;
      let sum2 = 0;
      const n = p.width * p.height;
      for (let i = 0; i < n; i++) {
        const [r, g, bl] = [d[4 * i], d[4 * i + 1], d[4 * i + 2]];
        if (Math.max(Math.abs(r - bg[0]), Math.abs(g - bg[1]), Math.abs(bl - bg[2])) > 24) {
          covered++;
        }
        const y = 0.299 * r + 0.587 * g + 0.114 * bl;
        sum += y;
        sum2 += y * y;
      }
      let changed = null;
      if (b) {
        const q = (await pixels(b)).data;
        changed = 0;
        for (let i = 0; i < n; i++) {
          const delta = Math.max(...[0, 1, 2].map((c) => Math.abs(d[4 * i + c] - q[4 * i + c])));
          if (delta > 24) {
            changed++;
          }
        }
        changed /= n;
      }
      const mean = sum / n;
      return { width: p.width, height: p.height, covered: covered / n, lumaStd: Math.sqrt(Math.max(0, sum2 / n - mean * mean)), changed };
    },
    [png.toString('base64'), reference?.toString('base64') ?? null],
  );
}

/** The TRC's numbers, as text unchanged, in the baker's CSV format. */
function trcAsCsv(trc) {
  const lines = trc.split(/\r?\n/);
  const keys = lines[1].split('\t');
  const values = lines[2].split('\t');
  const value = (k) => values[keys.indexOf(k)];
  const names = lines[3].split('\t').slice(2).filter((n) => n !== '');
  const header = ['frame', 'time', ...names.flatMap((n) => [`${n}_x`, `${n}_y`, `${n}_z`])];
  const rows = lines.slice(5).filter((l) => l.trim() !== '').map((l) => l.split('\t').slice(0, header.length).join(','));
  return [`# rate=${value('DataRate')}`, `# units=${value('Units')}`, header.join(','), ...rows, ''].join('\n');
}

/** Every golden actor sample present in jawmocap_actor.bin against the page's take input. */
async function checkTakeInput(page, what) {
  const bin = readFileSync(join(ROOT, 'fixtures', 'golden', 'jawmocap_actor.bin'));
  const m = (await page.evaluate(() => window.viewer.actorFrame(0))).present.length;
  const record = 1 + 12;
  let same = 0;
  const differ = [];
  for (let i = 0; i < 80; i++) {
    const { actor, present } = await page.evaluate((f) => window.viewer.actorFrame(f), 20 * i);
    for (let j = 0; j < m; j++) {
      const at = (i * m + j) * record;
      if (bin[at] !== 1) {
        continue;
      }
      const want = [0, 1, 2].map((c) => bin.readInt32LE(at + 1 + 4 * c));
      if (present[j] === 1 && want.every((w, c) => w === actor[3 * j + c])) {
        same++;
      } else {
        differ.push(`frame ${20 * i} marker ${j}: ${actor.slice(3 * j, 3 * j + 3)}, want ${want}`);
      }
    }
  }
  summary[`takeInput${what}`] = { same, differ: differ.length };
  console.log(`browser: the viewer's ${what} input equals the baker's for ${same} of ${same + differ.length} golden actor samples`);
  if (differ.length || same === 0) {
    fail(`the viewer's ${what} input differs from the golden actor frames:\n  ${differ.slice(0, 10).join('\n  ')}`);
  }
}

const server = await serve(0);
const url = `http://127.0.0.1:${server.address().port}/web/?test=golden&frame=0`;
const summary = {};
const browser = await chromium.launch({
  executablePath: process.env.CHROMIUM ?? '/usr/bin/chromium',
  args: [
    '--headless',
    '--no-sandbox',
    '--disable-gpu',
    '--disable-quic',
    '--no-first-run',
    '--disable-background-networking',
    '--disable-component-update',
    '--disable-sync',
    // WebGL through SwiftShader, the software rasteriser, on a machine without a GPU.
    '--use-angle=swiftshader',
    '--enable-unsafe-swiftshader',
  ],
});
try {
  const page = await browser.newPage({ viewport: { width: 800, height: 700 } });
  page.on('console', (m) => console.log(`page: ${m.text()}`));
  page.on('pageerror', (e) => fail(`page error: ${e.message}`));
  page.on('response', (r) => r.status() >= 400 && fail(`${r.url()}: HTTP ${r.status()}`));
  await page.goto(url);
  await page.waitForFunction(() => window.golden !== undefined || window.viewerError, null, { timeout: 300_000 });
  const viewerError = await page.evaluate(() => window.viewerError ?? null);
  if (viewerError) {
    fail(`viewer: ${viewerError}`);
  }
  await page.waitForFunction(() => window.golden !== undefined, null, { timeout: 300_000 });

  // 1. The hashes.
  const golden = await page.evaluate(() => window.golden);
  mkdirSync(OUT, { recursive: true });
  if (golden.error) {
    fail(`golden run: ${golden.error}`);
  } else {
    writeFileSync(join(OUT, 'hashes.txt'), golden.lines.join('\n') + '\n');
    const expected = expectedLines();
    const { equal, wrong, extra } = compare(expected, golden.lines);
    summary.hashes = { expected: expected.length, computed: golden.lines.length, equal, timing: golden.timing };
    console.log(`browser: ${equal} of ${expected.length} golden hash lines equal (${golden.lines.length} computed in the page)`);
    for (const t of golden.timing) {
      const call = t.rig === 'capture' || t.rig === 'take' ? 'fb_play' : 'fb_deform';
      const then = t.decodeMsPerFrame === undefined
        ? `${t.normalsMsPerFrame.toFixed(3)} ms per fb_normals_planned call`
        : `${t.decodeMsPerFrame.toFixed(4)} ms per fb_take_next_frame call`;
      console.log(`browser: ${t.rig}: ${t.frames} frames, ${t.msPerFrame.toFixed(3)} ms per ${call} call, ${then}`);
    }
    if (wrong.length || extra.length) {
      fail(`hashes: ${wrong.length} differ or missing, ${extra.length} extra:\n  ${[...wrong, ...extra].slice(0, 20).join('\n  ')}`);
    }
  }

  // The viewer's live input, the TRC parsed and converted in JavaScript, and the same take as
  // CSV: for every marker present in jawmocap_actor.bin (every 20th JawMoCap frame, converted by
  // the baker), the same Q8.24 actor units.
  if (!viewerError) {
    await checkTakeInput(page, 'TRC');
    writeFileSync(join(OUT, 'JawMoCap.csv'), trcAsCsv(readFileSync(join(ROOT, 'fixtures', 'JawMoCap.trc'), 'utf8')));
    const csvPage = await browser.newPage();
    csvPage.on('pageerror', (e) => fail(`page error (CSV): ${e.message}`));
    await csvPage.goto(`http://127.0.0.1:${server.address().port}/web/?take=../out/browser/JawMoCap.csv&frame=0`);
    await csvPage.waitForFunction(() => window.viewer || window.viewerError, null, { timeout: 120_000 });
    const csvError = await csvPage.evaluate(() => window.viewerError ?? null);
    if (csvError) {
      fail(`viewer (CSV): ${csvError}`);
    } else {
      await checkTakeInput(csvPage, 'CSV');
    }
    await csvPage.close();

    // The packed take in the viewer: decoded through fb_take_next_frame, the samples as they
    // are (it was packed in this rig's actor space), every frame.
    const fbtPage = await browser.newPage();
    fbtPage.on('pageerror', (e) => fail(`page error (packed take): ${e.message}`));
    await fbtPage.goto(`http://127.0.0.1:${server.address().port}/web/?take=../fixtures/golden/jawmocap.fbt&frame=${MOUTH_OPEN}`);
    await fbtPage.waitForFunction(() => window.viewer || window.viewerError, null, { timeout: 120_000 });
    const fbt = await fbtPage.evaluate(() => window.viewerError ?? { frames: window.viewer.frames, label: document.getElementById('label').textContent });
    summary.packedTake = fbt;
    console.log(`browser: the viewer with the packed take: ${JSON.stringify(fbt)}`);
    if (typeof fbt === 'string' || fbt.frames !== 1590 || !fbt.label.startsWith(`frame ${MOUTH_OPEN + 1} / 1590`)) {
      fail(`the viewer does not play the packed take: ${JSON.stringify(fbt)}`);
    }
    await fbtPage.locator('#view').screenshot({ path: join(OUT, 'screenshot_packed.png') });
    await fbtPage.close();
  }

  // 2. The face, drawn.
  if (!viewerError) {
    const webgl = await page.evaluate(() => window.viewer.webgl);
    summary.webgl = webgl;
    if (!webgl) {
      fail('WebGL is unavailable in this Chromium: the face was not drawn');
    }
    // The canvas; without WebGL the whole page, whose status line says why nothing is drawn.
    const canvas = page.locator(webgl ? '#view' : 'body');
    await page.evaluate(() => window.viewer.showFrame(0));
    const rest = await canvas.screenshot({ path: join(OUT, 'screenshot_rest.png') });
    const t0 = await page.evaluate((f) => {
      const before = window.viewer.cost();
      const t = performance.now();
      window.viewer.showFrame(f); // replays frames 1..f from the state after frame 0
      return { ms: performance.now() - t, frames: window.viewer.cost().frames - before.frames };
    }, MOUTH_OPEN);
    const open = await canvas.screenshot({ path: join(OUT, 'screenshot.png') });
    const all = await page.evaluate(() => {
      window.viewer.showFrame(0); // a seek back: a fresh state, frame 0 replayed
      const t = performance.now();
      window.viewer.showFrame(window.viewer.frames - 1); // the whole take, in order
      return { ms: performance.now() - t, cost: window.viewer.cost() };
    });
    summary.viewer = { toMouthOpen: t0, wholeTakeMs: all.ms, playMsPerFrame: all.cost.playMs / all.cost.frames };
    console.log(
      `browser: viewer played ${t0.frames} frames to frame ${MOUTH_OPEN} in ${t0.ms.toFixed(1)} ms, ` +
        `a seek to the last frame (the whole take) ${all.ms.toFixed(1)} ms; ` +
        `fb_play ${summary.viewer.playMsPerFrame.toFixed(3)} ms per frame over ${all.cost.frames} calls`,
    );
    // The controls: about a second of play at the take's rate from frame 0, pause, the slider.
    // The frame reached must be what the rate gives for the time between the two clicks, which
    // lies between the time from the end of the first click to the start of the second and the
    // time from the start of the first to the end of the second.
    await page.evaluate(() => window.viewer.showFrame(0));
    const t1 = performance.now();
    await page.click('#play');
    const t2 = performance.now();
    await page.waitForTimeout(1000);
    const t3 = performance.now();
    await page.click('#play');
    const t4 = performance.now();
    const played = Number(await page.inputValue('#frame'));
    const rate = 60;
    const [low, high] = [1 + Math.floor(((t3 - t2) / 1000) * rate) - 1, 1 + Math.floor(((t4 - t1) / 1000) * rate) + 1];
    summary.viewer.played = { frame: played, low, high };
    console.log(`browser: play, ${((t3 - t2) / 1000).toFixed(2)}–${((t4 - t1) / 1000).toFixed(2)} s, pause: at frame ${played} (${low}–${high} at ${rate} Hz)`);
    if (!(played >= low && played <= high)) {
      fail(`play reached frame ${played}, not ${low}–${high} (the take's rate)`);
    }
    await page.locator('#frame').fill(String(MOUTH_OPEN));
    const label = await page.textContent('#label');
    if (!label.startsWith(`frame ${MOUTH_OPEN + 1} /`)) {
      fail(`the slider set to ${MOUTH_OPEN} shows "${label}"`);
    }
    const stats = await pixelStats(page, open, rest);
    const restStats = await pixelStats(page, rest, null);
    summary.screenshot = { open: stats, rest: restStats };
    console.log(
      `browser: screenshot ${stats.width}x${stats.height}: ${(100 * stats.covered).toFixed(1)} % covered ` +
        `(rest ${(100 * restStats.covered).toFixed(1)} %), luma std ${stats.lumaStd.toFixed(1)}, ` +
        `${(100 * stats.changed).toFixed(2)} % of pixels changed between frame 0 and ${MOUTH_OPEN}`,
    );
    if (webgl && (stats.covered < 0.05 || restStats.covered < 0.05 || stats.lumaStd < 8)) {
      fail('the screenshot is blank: the face covers under 5 % of the canvas');
    }
    if (webgl && stats.changed < 0.002) {
      fail(`the face does not deform: ${(100 * stats.changed).toFixed(3)} % of pixels changed`);
    }
  }
  writeFileSync(join(OUT, 'summary.json'), JSON.stringify(summary, null, 2) + '\n');
} finally {
  await browser.close();
  server.close();
}
if (failures.length) {
  console.error(`browser: ${failures.length} check(s) failed`);
  process.exit(1);
}
console.log(`browser: all checks passed (screenshots in ${OUT})`);
