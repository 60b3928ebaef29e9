// Browser end-to-end test of the hair grown from a streamed hair mesh: strandcastd running the
// hair-mesh solver on a groom traced through a procedural hair mesh, headless Chromium
// (SwiftShader WebGL2) driven by playwright-core. The viewer's "grow from hair mesh" setting
// subscribes to the mesh (source hairmesh); the test checks the frames are hair mesh frames of
// kilobytes, that the canvas shows shaded hair grown on the GPU, that the wireframe overlay draws,
// and that the page falls back to the strands when the solver changes. Screenshots go to --out.
// Usage: node tests/e2e/hairmesh.mjs --daemon PATH/strandcastd --out DIR [--web DIR]
import { spawn } from 'node:child_process';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import { createRequire } from 'node:module';
import { diffShare, pixelStats } from './pixels.mjs';

const here = path.dirname(fileURLToPath(import.meta.url));
const require = createRequire(path.join(here, '..', 'package.json'));
const arg = (name, def) => { const i = process.argv.indexOf(name); return i > 0 && i + 1 < process.argv.length ? process.argv[i + 1] : def; };
const daemonPath = arg('--daemon');
const outDir = path.resolve(arg('--out', 'e2e-out'));
const webDir = path.resolve(arg('--web', path.join(here, '..', '..', 'web')));
const chromiumPath = arg('--chromium', '/usr/bin/chromium');

function die(msg) {
  console.error(`hairmesh e2e: FAIL: ${msg}`);
  process.exitCode = 1;
  throw new Error(msg);
}
function check(cond, msg) {
  if (!cond) die(msg);
  console.log(`hairmesh e2e: ok: ${msg}`);
}

const playwright = require('playwright-core');
if (!daemonPath || !fs.existsSync(daemonPath)) die(`--daemon ${daemonPath} does not exist`);
if (!fs.existsSync(chromiumPath)) die(`${chromiumPath} not found; install the Debian package chromium (.ci/deps)`);
fs.mkdirSync(outDir, { recursive: true });
const cleanups = [];

// strandcastd with the hair-mesh solver on a hair-mesh groom; resolves with its URL.
function startDaemon() {
  const log = fs.openSync(path.join(outDir, 'strandcastd-hairmesh.log'), 'w');
  const args = ['--port', '0', '--web', webDir, '--min-step-rate', '0', '--groom', 'hairmesh:straight', '--strands', '1024',
    '--verts', '24', '--solver', 'hairmesh'];
  const child = fs.existsSync('/usr/bin/setpriv')
    ? spawn('/usr/bin/setpriv', ['--pdeathsig', 'TERM', '--', daemonPath, ...args], { stdio: ['ignore', 'pipe', 'pipe'] })
    : spawn(daemonPath, args, { stdio: ['ignore', 'pipe', 'pipe'] });
  const exited = new Promise((r) => child.once('exit', r));
  cleanups.push(async () => { if (child.exitCode === null) { child.kill('SIGTERM'); await exited; } fs.closeSync(log); });
  return new Promise((resolve, reject) => {
    let text = '';
    const timer = setTimeout(() => reject(new Error(`strandcastd printed no URL in 60 s:\n${text}`)), 60000);
    const onData = (d) => {
      fs.writeSync(log, d);
      text += d.toString();
      const m = /(http:\/\/[0-9.:]+\/)/.exec(text);
      if (m) { clearTimeout(timer); resolve(m[1]); }
    };
    child.stdout.on('data', onData);
    child.stderr.on('data', onData);
  });
}

async function capture(page) {
  const c = await page.evaluate(async () => {
    const f = await window.strandcast.capture();
    let s = '';
    for (let i = 0; i < f.rgba.length; i += 0x8000) s += String.fromCharCode.apply(null, f.rgba.subarray(i, i + 0x8000));
    return { width: f.width, height: f.height, b64: btoa(s) };
  });
  return { width: c.width, height: c.height, rgba: Buffer.from(c.b64, 'base64') };
}

async function waitUploads(page, n, ms) {
  const start = await page.evaluate(() => window.strandcast.framesUploaded);
  await page.waitForFunction((target) => window.strandcast.framesUploaded >= target, start + n, { timeout: ms, polling: 100 });
}

async function main() {
  const url = await startDaemon();
  console.log(`hairmesh e2e: strandcastd at ${url}`);
  const profile = fs.mkdtempSync(path.join(os.tmpdir(), 'strandcast-hm-e2e-'));
  cleanups.push(async () => fs.rmSync(profile, { recursive: true, force: true }));
  const context = await playwright.chromium.launchPersistentContext(profile, {
    executablePath: chromiumPath,
    headless: true,
    viewport: { width: 900, height: 640 },
    args: ['--no-sandbox', '--use-angle=swiftshader', '--enable-unsafe-swiftshader', '--ignore-gpu-blocklist',
      '--no-first-run', '--disable-background-networking', '--disable-component-update', '--disable-sync'],
  });
  cleanups.push(async () => context.close());
  const page = context.pages()[0] || (await context.newPage());
  const errors = [];
  page.on('pageerror', (e) => errors.push(`page error: ${e.message}`));
  page.on('console', (m) => { if (m.type() === 'error') errors.push(`console error: ${m.text()}`); });
  await page.goto(url);
  await page.waitForFunction(() => window.strandcast && window.strandcast.framesUploaded >= 2, null, { timeout: 120000, polling: 200 });
  check(errors.length === 0, `the page drew the strands first ${errors.join('; ')}`);

  // grow from the hair mesh: the page subscribes to it and fetches its topology
  await page.evaluate(() => window.strandcast.setView('hairmesh', true));
  await page.waitForFunction(() => {
    const s = window.strandcast.snapshot();
    return s.source === 'hairmesh' && s.meshFrames;
  }, null, { timeout: 120000, polling: 200 }).catch(async (e) => {
    const state = await page.evaluate(() => ({ status: (document.querySelector('.status') || {}).textContent, s: window.strandcast.snapshot() }));
    die(`no hair mesh frames drawn: ${e.message}; ${JSON.stringify(state)}; ${errors.join('; ')}`);
  });
  await waitUploads(page, 3, 120000);
  const t0 = await page.evaluate(() => ({ ...window.strandcast.totals }));
  await waitUploads(page, 10, 120000);
  const t1 = await page.evaluate(() => ({ ...window.strandcast.totals, s: window.strandcast.snapshot() }));
  const perFrame = (t1.bytes - t0.bytes) / (t1.frames - t0.frames);
  check(perFrame > 0 && perFrame < 8000, `hair mesh frames of ${perFrame.toFixed(0)} bytes (a full hairstyle in kilobytes)`);
  check(t1.s.renderStrands >= 10000, `${t1.s.renderStrands} render strands grown from the mesh on the GPU`);

  const grown = await capture(page);
  const ps = pixelStats(grown.rgba);
  check(ps.hairShare >= 0.02, `canvas shows hair grown from the mesh: ${(100 * ps.hairShare).toFixed(1)}% hair-coloured pixels (need 2%)`);
  check(ps.hairLumaSpread >= 25, `the grown hair is shaded: luminance p95-p5 ${ps.hairLumaSpread.toFixed(0)} (need 25)`);
  await page.screenshot({ path: path.join(outDir, 'hairmesh-grown.png'), timeout: 180000 });
  console.log(`hairmesh e2e: screenshot ${path.join(outDir, 'hairmesh-grown.png')}`);

  // styling is a view setting: curls change the picture
  await page.evaluate(() => window.strandcast.setView('curl', 0.006) && window.strandcast.setView('curlTurns', 6));
  await waitUploads(page, 2, 120000);
  const curled = await capture(page);
  check(diffShare(grown.rgba, curled.rgba, 24) >= 0.01, 'curling the grown strands changes the picture');
  await page.screenshot({ path: path.join(outDir, 'hairmesh-curled.png'), timeout: 180000 });
  await page.evaluate(() => window.strandcast.setView('curl', 0));

  // the wireframe overlay
  await page.evaluate(() => window.strandcast.setView('meshWire', true));
  await waitUploads(page, 2, 120000);
  const wired = await capture(page);
  let wire = 0;
  for (let i = 0; i < wired.rgba.length; i += 4) if (wired.rgba[i + 2] > 200 && wired.rgba[i + 1] > 170 && wired.rgba[i] < 140) wire++;
  check(wire / (wired.rgba.length / 4) >= 0.002, `the hair mesh wireframe is drawn: ${(100 * wire / (wired.rgba.length / 4)).toFixed(2)}% wire-coloured pixels`);
  await page.screenshot({ path: path.join(outDir, 'hairmesh-wireframe.png'), timeout: 180000 });

  // the solver changes away from the hair mesh: the server moves the page back to the strands
  await page.evaluate(() => window.strandcast.request({ type: 'set_params', values: { solver: 'dftl' } }));
  await page.waitForFunction(() => window.strandcast.snapshot().source === 'strands', null, { timeout: 60000, polling: 200 });
  await waitUploads(page, 3, 120000);
  const back = await capture(page);
  check(pixelStats(back.rgba).hairShare >= 0.02, 'after the solver change the page draws the streamed strands again');
  check(errors.length === 0, `no page errors ${errors.join('; ')}`);
}

main()
  .catch((e) => { if (!process.exitCode) { console.error(`hairmesh e2e: FAIL: ${e.stack || e.message}`); process.exitCode = 1; } })
  .finally(async () => { while (cleanups.length) { try { await cleanups.pop()(); } catch { /* already gone */ } } });
