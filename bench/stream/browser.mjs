// The web viewer's half of bench/stream/clients.py: drives server/www in headless Chromium
// (playwright-core, /usr/bin/chromium) through the given cameras of each scene in each mode,
// reads the page's own per-frame times (window.vismapViewer.timings: decode and draw measured
// in the page with performance.now(), the canvas draw ended by reading one pixel back:
// ?timing=1), takes a screenshot of the last frame per mode and compares the compact and delta
// screenshots with svg mode's. Prints one JSON object on stdout; progress on stderr.
//   node bench/stream/browser.mjs --port P --plan PLAN.json --out DIR [--modes svg,compact,delta]
//                                 [--query draw=2d]   (more of the viewer's URL parameters)
// PLAN.json: [{scene, library, width, height, cameras: [camera fields, ...]}, ...].
// Exits 77 without chromium or playwright-core (npm install --no-save playwright-core@1).
import { createRequire } from 'node:module';
import fs from 'node:fs';
import path from 'node:path';

const PIXEL_TOLERANCE = 48;  // of 255, in any channel: as tests/server/test_viewer.mjs
const BAR_PX = 54;           // server/www/index.html: #view is the window less the bar (two rows)

const args = Object.fromEntries(process.argv.slice(2).reduce((a, v, i, all) =>
  (v.startsWith('--') ? a.concat([[v.slice(2), all[i + 1]]]) : a), []));
const modes = (args.modes || 'svg,compact,delta').split(',');
const frameTimeoutMs = 1000 * Number(args['frame-timeout'] || 300);
const chromium = process.env.CHROMIUM || '/usr/bin/chromium';
const require = createRequire(import.meta.url);
let pw;
try {
  pw = require('playwright-core');
} catch {
  console.log(JSON.stringify({ skipped: 'playwright-core is not installed' }));
  process.exit(77);
}
if (!fs.existsSync(chromium)) {
  console.log(JSON.stringify({ skipped: `no ${chromium}` }));
  process.exit(77);
}
const plan = JSON.parse(fs.readFileSync(args.plan, 'utf8'));
fs.mkdirSync(args.out, { recursive: true });
const log = (...a) => console.error('browser:', ...a);

// Pixels of two PNG screenshots of the same size, compared in a page (Chromium decodes PNG):
// of the pixels either shows as object (not white), the fraction that differ by more than tol.
async function compare(page, a, b) {
  return page.evaluate(async ([a, b, tol]) => {
    const pixels = async (b64) => {
      const img = new Image();
      img.src = 'data:image/png;base64,' + b64;
      await img.decode();
      const c = document.createElement('canvas');
      c.width = img.width; c.height = img.height;
      const ctx = c.getContext('2d');
      ctx.drawImage(img, 0, 0);
      return ctx.getImageData(0, 0, c.width, c.height);
    };
    const [p, q] = [await pixels(a), await pixels(b)];
    if (p.width !== q.width || p.height !== q.height) return { error: `sizes ${p.width}x${p.height} and ${q.width}x${q.height}` };
    let object = 0, differ = 0, objectA = 0, objectB = 0;
    const isObject = (d, i) => d[i] < 250 || d[i + 1] < 250 || d[i + 2] < 250;
    for (let i = 0; i < p.data.length; i += 4) {
      const oa = isObject(p.data, i), ob = isObject(q.data, i);
      objectA += oa; objectB += ob;
      if (!oa && !ob) continue;
      ++object;
      let m = 0;
      for (let k = 0; k < 3; ++k) m = Math.max(m, Math.abs(p.data[i + k] - q.data[i + k]));
      if (m > tol) ++differ;
    }
    return { object, objectA, objectB, differ, fraction: differ / Math.max(object, 1) };
  }, [a.toString('base64'), b.toString('base64'), PIXEL_TOLERANCE]);
}

async function runMode(browser, s, mode) {
  const page = await browser.newPage({ viewport: { width: s.width, height: s.height + BAR_PX } });
  const errors = [];
  page.on('pageerror', (e) => errors.push(String(e)));
  const r = { scene: s.scene, mode, frames: s.cameras.length, ok: 0, timings: [], errors };
  try {
    await page.goto(`http://127.0.0.1:${args.port}/?scene=${encodeURIComponent(s.library)}` +
                    `&format=${mode}&viewport=${s.width}x${s.height}&timing=1${args.query ? '&' + args.query : ''}`);
    // The viewer shows the framing camera's frame first; the cameras follow one at a time.
    await page.waitForFunction(() => window.vismapViewer && window.vismapViewer.timings.length > 0,
                               null, { timeout: frameTimeoutMs });
    for (const cam of s.cameras) {
      const seq = await page.evaluate((c) => window.vismapViewer.camera(c), cam);
      const t = await page.waitForFunction((q) => window.vismapViewer.timings.find((e) => e.seq === q),
                                           seq, { timeout: frameTimeoutMs, polling: 20 });
      const e = await t.jsonValue();
      r.timings.push(e);
      if (e.error) errors.push(`frame ${seq}: ${e.error}`);
      else ++r.ok;
    }
    const shot = await page.locator(mode === 'svg' ? '#view svg' : '#view canvas').screenshot();
    r.screenshot = path.join(args.out, `${s.scene}_${mode}.png`);
    fs.writeFileSync(r.screenshot, shot);
    r.stats = await page.$eval('#stats', (e) => e.textContent);
    if (mode !== 'svg') r.draw = await page.$eval('#view canvas', (c) => c.dataset.draw);
  } catch (e) {
    errors.push(String(e.message || e).split('\n')[0]);
  }
  return { r, page };
}

const browser = await pw.chromium.launch({ executablePath: chromium, args: ['--no-sandbox', '--headless=new'] });
const out = { chromium: browser.version(), runs: [], compare: [] };
try {
  for (const s of plan) {
    const pages = {};
    for (const mode of modes) {
      const t0 = Date.now();
      const { r, page } = await runMode(browser, s, mode);
      log(`${s.scene} ${mode}: ${r.ok}/${r.frames} frames in ${((Date.now() - t0) / 1000).toFixed(1)} s` +
          (r.errors.length ? `; ${r.errors.join('; ')}` : ''));
      out.runs.push(r);
      pages[mode] = { r, page };
    }
    const ref = pages.svg;
    for (const mode of modes.filter((m) => m !== 'svg')) {
      const p = pages[mode];
      if (!ref || !ref.r.screenshot || !p.r.screenshot) {
        out.compare.push({ scene: s.scene, mode, error: 'a screenshot is missing' });
        continue;
      }
      const d = await compare(ref.page, fs.readFileSync(ref.r.screenshot), fs.readFileSync(p.r.screenshot));
      out.compare.push(Object.assign({ scene: s.scene, mode, against: 'svg', tolerance: PIXEL_TOLERANCE }, d));
    }
    for (const { page } of Object.values(pages)) await page.close();
  }
} finally {
  await browser.close();
}
console.log(JSON.stringify(out));
