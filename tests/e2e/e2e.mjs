// Browser end-to-end test: the real strandcastd serving web/, headless Chromium (SwiftShader
// WebGL2) driven by playwright-core, and a second WebSocket client checking the server side.
// Usage: node tests/e2e/e2e.mjs --daemon PATH/strandcastd --out DIR [--web DIR] [--no-bench]
// Prints one JSON line per benchmark case ({"bench":"web_e2e",...}); exits 1 on any failure.
import { spawn } from 'node:child_process';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import { createRequire } from 'node:module';
import { diffShare, pixelStats } from './pixels.mjs';

const here = path.dirname(fileURLToPath(import.meta.url));
const require = createRequire(path.join(here, '..', 'package.json'));

function arg(name, def) {
  const i = process.argv.indexOf(name);
  return i > 0 && i + 1 < process.argv.length ? process.argv[i + 1] : def;
}

const daemonPath = arg('--daemon');
const outDir = path.resolve(arg('--out', 'e2e-out'));
const webDir = path.resolve(arg('--web', path.join(here, '..', '..', 'web')));
const bench = !process.argv.includes('--no-bench');
const chromiumPath = arg('--chromium', '/usr/bin/chromium');

function die(msg) {
  console.error(`e2e: FAIL: ${msg}`);
  process.exitCode = 1;
  throw new Error(msg);
}

function check(cond, msg) {
  if (!cond) die(msg);
  console.log(`e2e: ok: ${msg}`);
}

let playwright, WebSocket;
try {
  playwright = require('playwright-core');
  WebSocket = require('ws');
} catch (e) {
  console.error(`e2e: FAIL: npm packages missing (${e.message}); run .ci/deps (npm install in tests/)`);
  process.exit(1);
}
if (!daemonPath || !fs.existsSync(daemonPath)) {
  console.error(`e2e: FAIL: --daemon ${daemonPath} does not exist`);
  process.exit(1);
}
if (!fs.existsSync(chromiumPath)) {
  console.error(`e2e: FAIL: ${chromiumPath} not found; install the Debian package chromium (.ci/deps)`);
  process.exit(1);
}
fs.mkdirSync(outDir, { recursive: true });

const cleanups = [];
async function cleanup() {
  while (cleanups.length) {
    try { await cleanups.pop()(); } catch (e) { console.error(`e2e: cleanup: ${e.message}`); }
  }
}

// Starts the daemon on a free port; resolves with its URL once it prints it.
function startDaemon() {
  const log = fs.openSync(path.join(outDir, 'strandcastd.log'), 'w');
  const child = spawn(daemonPath, ['--port', '0', '--web', webDir], { stdio: ['ignore', 'pipe', 'pipe'] });
  cleanups.push(async () => {
    if (child.exitCode === null) {
      child.kill('SIGTERM');
      await new Promise((r) => { const t = setTimeout(() => { child.kill('SIGKILL'); r(); }, 5000); child.once('exit', () => { clearTimeout(t); r(); }); });
    }
    fs.closeSync(log);
  });
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
    child.once('exit', (code) => { clearTimeout(timer); reject(new Error(`strandcastd exited with ${code} before printing its URL:\n${text}`)); });
  });
}

// A second protocol client: resolves once its hello arrived; collects every text message.
function secondClient(wsUrl) {
  return new Promise((resolve, reject) => {
    const ws = new WebSocket(wsUrl, 'strandcast.v1');
    const client = { ws, hello: null, messages: [], waiters: [] };
    ws.on('message', (data, isBinary) => {
      if (isBinary) return;
      const m = JSON.parse(data.toString());
      if (m.type === 'hello') { client.hello = m; resolve(client); }
      client.messages.push(m);
      client.waiters = client.waiters.filter((w) => !w(m));
    });
    ws.on('error', reject);
    cleanups.push(async () => ws.close());
  });
}

// Resolves with the first message (already received or later) that pred accepts.
function waitMessage(client, pred, ms, what) {
  const seen = client.messages.find(pred);
  if (seen) return Promise.resolve(seen);
  return new Promise((resolve, reject) => {
    const t = setTimeout(() => reject(new Error(`no ${what} within ${ms / 1000} s`)), ms);
    client.waiters.push((m) => { if (pred(m)) { clearTimeout(t); resolve(m); return true; } return false; });
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

async function measure(page, perGuide, seconds) {
  await page.evaluate((n) => window.strandcast.setView('perGuide', n), perGuide);
  await waitUploads(page, 2, 120000);
  const take = () => page.evaluate(() => ({ t: performance.now(), r: window.strandcast.framesRendered, tot: { ...window.strandcast.totals }, s: window.strandcast.snapshot() }));
  const a = await take();
  // at least `seconds` and at least 3 rendered frames (SwiftShader can be slow)
  await page.waitForTimeout(seconds * 1000);
  await page.waitForFunction((r) => window.strandcast.framesRendered >= r + 3, a.r, { timeout: 120000, polling: 100 });
  const b = await take();
  const dt = (b.t - a.t) / 1000, nf = b.tot.frames - a.tot.frames, nu = b.tot.uploads - a.tot.uploads;
  const decode = nf ? (b.tot.decodeMs - a.tot.decodeMs) / nf : NaN;
  const smooth = nf ? (b.tot.prepareMs - a.tot.prepareMs) / nf : NaN;
  const upload = nu ? (b.tot.uploadMs - a.tot.uploadMs) / nu : NaN;
  const round = (x, d = 2) => (Number.isFinite(x) ? +x.toFixed(d) : null);
  return {
    bench: 'web_e2e',
    guides: b.s.guides,
    verts: b.s.verts,
    per_guide: b.s.perGuide,
    render_strands: b.s.renderStrands,
    render_fps: round((b.r - a.r) / dt),
    frames_decoded_per_s: round(nf / dt),
    decode_ms: round(decode),
    smooth_ms: round(smooth),
    upload_ms: round(upload),
    decode_upload_ms: round(decode + smooth + upload),
    kbit_per_s: round(b.s.kbitPerSec, 0),
    bytes_per_vertex: round(b.s.bytesPerVertex, 3),
    server_steps_per_s: round(b.s.serverStepsPerSec, 1),
    seconds: round(dt, 1),
  };
}

async function main() {
  const url = await startDaemon();
  console.log(`e2e: strandcastd at ${url}`);
  const wsUrl = url.replace(/^http/, 'ws');
  const profile = fs.mkdtempSync(path.join(os.tmpdir(), 'strandcast-e2e-'));
  cleanups.push(async () => fs.rmSync(profile, { recursive: true, force: true }));
  const context = await playwright.chromium.launchPersistentContext(profile, {
    executablePath: chromiumPath,
    headless: true,
    viewport: { width: 1000, height: 640 },
    args: ['--no-sandbox', '--use-angle=swiftshader', '--enable-unsafe-swiftshader', '--ignore-gpu-blocklist',
      '--no-first-run', '--disable-background-networking', '--disable-component-update', '--disable-sync'],
  });
  cleanups.push(async () => context.close());
  const page = context.pages()[0] || (await context.newPage());
  const errors = [];
  page.on('pageerror', (e) => errors.push(`page error: ${e.message}`));
  page.on('console', (m) => { if (m.type() === 'error') errors.push(`console error: ${m.text()}`); });
  page.on('crash', () => errors.push('page crashed'));

  await page.goto(url);
  await page.waitForFunction(() => window.strandcast && window.strandcast.framesUploaded >= 2, null, { timeout: 120000, polling: 200 });
  check(errors.length === 0, `page loaded and drew streamed frames without errors ${errors.join('; ')}`);

  const gl = await page.evaluate(() => {
    const g = window.strandcast.gl;
    const info = g.getExtension('WEBGL_debug_renderer_info');
    return { webgl2: g instanceof WebGL2RenderingContext, lost: g.isContextLost(), renderer: g.getParameter(info ? info.UNMASKED_RENDERER_WEBGL : g.RENDERER) };
  });
  check(gl.webgl2 && !gl.lost, `WebGL2 context alive (${gl.renderer})`);

  const still = await capture(page);
  const ps = pixelStats(still.rgba);
  check(ps.hairShare >= 0.02, `canvas shows hair: ${(100 * ps.hairShare).toFixed(1)}% hair-coloured pixels (need 2%)`);
  check(ps.hairLumaSpread >= 25, `hair is shaded, not flat: luminance p95-p5 ${ps.hairLumaSpread.toFixed(0)} over hair pixels (need 25)`);
  check(ps.lumaStd >= 8, `canvas is not blank: luminance std dev ${ps.lumaStd.toFixed(1)} (need 8)`);

  // the head moves: a preset animation through the panel's button
  await page.click('button[data-preset="shake"]');
  await waitUploads(page, 3, 60000);
  const a = await capture(page);
  await page.waitForTimeout(400);
  await waitUploads(page, 3, 60000);
  const b = await capture(page);
  const changed = diffShare(a.rgba, b.rgba, 24);
  check(changed >= 0.002, `the picture changes while the head moves: ${(100 * changed).toFixed(2)}% of pixels changed (need 0.2%)`);

  // a panel slider changes the parameter on the server (seen by another client)
  const other = await secondClient(wsUrl);
  const pageClient = await page.evaluate(() => window.strandcast.clientId);
  const slider = page.locator('input[type=range][data-param="gravity"]');
  const box = await slider.boundingBox();
  check(!!box, 'the panel has a gravity slider');
  await page.mouse.click(box.x + box.width * 0.25, box.y + box.height / 2);
  const seen = await waitMessage(other, (m) => m.type === 'params' && m.values && typeof m.values.gravity === 'number' && Math.abs(m.values.gravity - 9.81) > 0.5, 20000, 'gravity change broadcast');
  check(seen.values.gravity > 5 && seen.values.gravity < 20 && seen.by === pageClient,
    `moving the gravity slider set gravity = ${seen.values.gravity.toFixed(2)} on the server (by client ${seen.by}, the page is ${pageClient})`);

  // a parameter set by the other client shows up in the panel
  other.ws.send(JSON.stringify({ type: 'set_params', id: 'e2e', values: { wind_x: 3.25 } }));
  await waitMessage(other, (m) => m.id === 'e2e', 20000, 'reply to set_params');
  await page.waitForFunction(() => {
    const r = document.querySelector('input[type=range][data-param="wind_x"]');
    return r && Math.abs(Number(r.value) - 3.25) < 1e-6 && Math.abs(Number(r.parentElement.querySelector('.num').value) - 3.25) < 1e-6;
  }, null, { timeout: 20000, polling: 100 });
  check(true, 'wind_x = 3.25 set by another client shows in the panel');

  await page.screenshot({ path: path.join(outDir, 'e2e-screenshot.png') });
  console.log(`e2e: screenshot ${path.join(outDir, 'e2e-screenshot.png')}`);

  if (bench) {
    await page.click('button[data-preset="none"]');
    const cpu = (os.cpus()[0] || {}).model || 'unknown';
    for (const per of [4, 16]) {
      const r = await measure(page, per, 6);
      console.log(JSON.stringify({ ...r, renderer: gl.renderer, nproc: os.cpus().length, cpu, date: new Date().toISOString().slice(0, 10) }));
    }
  }
  check(errors.length === 0, `no page errors ${errors.join('; ')}`);
  const lost = await page.evaluate(() => window.strandcast.gl.isContextLost());
  check(!lost, 'WebGL2 context still alive at the end');
}

try {
  await main();
  console.log('e2e: all checks passed');
} catch (e) {
  if (!process.exitCode) console.error(`e2e: FAIL: ${e.stack || e.message}`);
  process.exitCode = 1;
} finally {
  await cleanup();
}
