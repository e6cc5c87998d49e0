// The web viewer (server/www) in headless Chromium, driven by playwright-core: it connects,
// loads a library scene, shows the live SVG stream and orbits on a mouse drag.
//   node tests/server/test_viewer.mjs PATH/TO/vismapd
// Exits 77 (skipped) without /usr/bin/chromium or playwright-core (npm install --no-save playwright-core@1).
import { spawn } from 'node:child_process';
import { createRequire } from 'node:module';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import readline from 'node:readline';

const require = createRequire(import.meta.url);
const chromium = process.env.CHROMIUM || '/usr/bin/chromium';
let pw;
try {
  pw = require('playwright-core');
} catch {
  console.log('skipped: playwright-core is not installed');
  process.exit(77);
}
if (!fs.existsSync(chromium)) {
  console.log(`skipped: no ${chromium}`);
  process.exit(77);
}

const lib = fs.mkdtempSync(path.join(os.tmpdir(), 'vismap-viewer-'));
fs.writeFileSync(path.join(lib, 'tet.obj'),
  'v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n');
const server = spawn(process.argv[2], ['--port', '0', '--library', lib], { stdio: ['ignore', 'ignore', 'pipe'] });
const guard = setTimeout(() => { console.error('timed out'); server.kill('SIGKILL'); process.exit(1); }, 90000);
const port = await new Promise((resolve, reject) => {
  readline.createInterface({ input: server.stderr }).on('line', (l) => {
    const e = JSON.parse(l);
    if (e.event === 'listening') resolve(e.port);
  });
  server.on('exit', () => reject(new Error('vismapd exited')));
});

let browser;
let failed = false;
try {
  browser = await pw.chromium.launch({ executablePath: chromium, args: ['--no-sandbox', '--headless=new'] });
  const page = await browser.newPage({ viewport: { width: 800, height: 600 } });
  await page.goto(`http://127.0.0.1:${port}/?scene=tet.obj`);
  await page.waitForSelector('#view svg path', { timeout: 30000 });
  const first = await page.$eval('#view', (v) => v.innerHTML);
  const stats = await page.$eval('#stats', (s) => s.textContent);
  if (!/fps/.test(stats)) throw new Error(`no frame stats shown: ${stats}`);
  const box = await page.$eval('#view', (v) => { const r = v.getBoundingClientRect(); return [r.x + r.width / 2, r.y + r.height / 2]; });
  await page.mouse.move(box[0], box[1]);
  await page.mouse.down();
  for (let i = 1; i <= 10; ++i) await page.mouse.move(box[0] + 15 * i, box[1] + 3 * i);
  await page.mouse.up();
  await page.waitForFunction((f) => document.querySelector('#view').innerHTML !== f, first, { timeout: 30000 });
  console.log('ok: viewer streamed frames and orbited on drag');
} catch (e) {
  console.error(e);
  failed = true;
} finally {
  if (browser) await browser.close();
  server.kill('SIGTERM');
  await new Promise((r) => server.on('exit', r));
  clearTimeout(guard);
  fs.rmSync(lib, { recursive: true, force: true });
}
process.exit(failed ? 1 : 0);
