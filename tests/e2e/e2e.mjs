// Browser end-to-end test: the real strandcastd serving web/, headless Chromium (SwiftShader
// WebGL2) driven by playwright-core, and a second WebSocket client checking the server side.
// Usage: node tests/e2e/e2e.mjs --daemon PATH/strandcastd --out DIR [--web DIR] [--no-bench]
//        [-- extra strandcastd flags, e.g. --strands 1024]
// Prints one JSON line per benchmark case ({"bench":"web_e2e",...}); exits 1 on any failure.
import { spawn } from 'node:child_process';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { capture, harness, require } from './harness.mjs';
import { diffShare, pixelStats } from './pixels.mjs';
import { StrandDecoder } from '../../web/codec.js';
import { parseGroomData } from '../../web/groom_data.js';

let WebSocket;
try {
  require('playwright-core');
  WebSocket = require('ws');
} catch (e) {
  console.error(`e2e: FAIL: npm packages missing (${e.message}); run .ci/deps (npm install in tests/)`);
  process.exit(1);
}
const h = harness('e2e');
const { check, die, cleanups, daemonPath, outDir, webDir } = h;
const bench = !process.argv.includes('--no-bench');
const dashes = process.argv.indexOf('--');
const daemonExtra = dashes > 0 ? process.argv.slice(dashes + 1) : [];

// Starts the daemon on port (0: a free one), logging to logName in the output folder; resolves
// with { url, stop } once it prints its URL. stop() ends it (SIGTERM) and waits for its exit.
function startDaemon(port, logName) {
  let log = fs.openSync(path.join(outDir, logName), 'w');
  // setpriv --pdeathsig: the daemon gets SIGTERM if this process dies (e.g. killed by ctest)
  // no groom budget: its start-up measurement would compete with the browser on a busy machine
  const args = ['--port', String(port), '--web', webDir, '--min-step-rate', '0', ...daemonExtra];
  const child = fs.existsSync('/usr/bin/setpriv')
    ? spawn('/usr/bin/setpriv', ['--pdeathsig', 'TERM', '--', daemonPath, ...args], { stdio: ['ignore', 'pipe', 'pipe'] })
    : spawn(daemonPath, args, { stdio: ['ignore', 'pipe', 'pipe'] });
  const exited = new Promise((r) => child.once('exit', r));
  const stop = async () => {
    if (child.exitCode === null && child.signalCode === null) {
      child.kill('SIGTERM');
      const t = setTimeout(() => child.kill('SIGKILL'), 5000);
      await exited;
      clearTimeout(t);
    }
  };
  cleanups.push(async () => { await stop(); fs.closeSync(log); log = null; });
  return new Promise((resolve, reject) => {
    let text = '';
    const timer = setTimeout(() => reject(new Error(`strandcastd printed no URL in 60 s:\n${text}`)), 60000);
    const onData = (d) => {
      if (log !== null) fs.writeSync(log, d);
      text += d.toString();
      const m = /(http:\/\/[0-9.:]+\/)/.exec(text);
      if (m) { clearTimeout(timer); resolve({ url: m[1], stop }); }
    };
    child.stdout.on('data', onData);
    child.stderr.on('data', onData);
    child.once('exit', (code) => { clearTimeout(timer); reject(new Error(`strandcastd exited with ${code} before printing its URL:\n${text}`)); });
  });
}

// A second protocol client: resolves once its hello arrived; collects every text message.
// A client in Node; with decode, client.frame is the newest frame it decoded: { simStep, head:
// { position, orientation } from its header, roots: [x, y, z] per strand }.
function secondClient(wsUrl, decode = false) {
  return new Promise((resolve, reject) => {
    const ws = new WebSocket(wsUrl, 'strandcast.v3');
    const client = { ws, hello: null, messages: [], waiters: [], frame: null };
    const dec = decode ? new StrandDecoder() : null;
    ws.on('message', (data, isBinary) => {
      if (isBinary) {
        if (!dec) return;
        let f;
        try { f = dec.decode(new Uint8Array(data)); } catch { return; } // before its first keyframe
        const per = 3 * f.nverts;
        client.frame = {
          simStep: f.simStep, head: { position: Array.from(f.headPosition), orientation: Array.from(f.headOrientation) },
          roots: Array.from({ length: f.nstrandsSent }, (_, j) => Array.from(f.positions.subarray(j * per, j * per + 3))),
        };
        return;
      }
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

async function waitUploads(page, n, ms) {
  const start = await page.evaluate(() => window.strandcast.framesUploaded);
  await page.waitForFunction((target) => window.strandcast.framesUploaded >= target, start + n, { timeout: ms, polling: 100 });
}

// Render rate and per-frame costs at perGuide render strands per guide: one pass with the
// page running normally (render fps, worker decode and smoothing times), then one in benchmark
// timing mode (uploads and draws bracketed by gl.finish, so their own cost is measured).
async function measure(page, perGuide, seconds) {
  await page.evaluate((n) => window.strandcast.setView('perGuide', n) && window.strandcast.setView('continuous', true), perGuide);
  await waitUploads(page, 2, 180000);
  const take = () => page.evaluate(() => ({ t: performance.now(), r: window.strandcast.framesRendered, tot: { ...window.strandcast.totals }, s: window.strandcast.snapshot() }));
  const a = await take();
  // at least `seconds` and at least 2 rendered frames (SwiftShader can take tens of seconds)
  await page.waitForTimeout(seconds * 1000);
  await page.waitForFunction((r) => window.strandcast.framesRendered >= r + 2, a.r, { timeout: 600000, polling: 200 });
  const b = await take();
  const dt = (b.t - a.t) / 1000, nf = b.tot.frames - a.tot.frames;
  const decode = nf ? (b.tot.decodeMs - a.tot.decodeMs) / nf : NaN;
  const smooth = nf ? (b.tot.prepareMs - a.tot.prepareMs) / nf : NaN;
  // the timed pass
  await page.evaluate(() => { window.strandcast.benchmarkTiming = true; });
  const c = await take();
  await page.waitForFunction((tot) => window.strandcast.totals.uploads >= tot.uploads + 2 && window.strandcast.totals.draws >= tot.draws + 2, c.tot, { timeout: 600000, polling: 200 });
  const d = await take();
  await page.evaluate(() => { window.strandcast.benchmarkTiming = false; });
  const upload = (d.tot.uploadMs - c.tot.uploadMs) / (d.tot.uploads - c.tot.uploads);
  const draw = (d.tot.drawMs - c.tot.drawMs) / (d.tot.draws - c.tot.draws);
  const round = (x, digits = 2) => (Number.isFinite(x) ? +x.toFixed(digits) : null);
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
    draw_ms: round(draw),
    kbit_per_s: round(((b.tot.bytes - a.tot.bytes) * 8) / 1000 / dt, 0),
    bytes_per_vertex: round(nf ? (b.tot.bytes - a.tot.bytes) / nf / (b.s.guides * b.s.verts) : NaN, 3),
    server_steps_per_s: round(b.s.serverStepsPerSec, 1),
    antialias: b.s.antialias,
    seconds: round(dt, 1),
  };
}

async function main() {
  const daemon = await startDaemon(0, 'strandcastd.log');
  const url = daemon.url;
  console.log(`e2e: strandcastd at ${url}`);
  const wsUrl = url.replace(/^http/, 'ws');
  const context = await h.launch({ width: 1000, height: 640 });
  const page = context.pages()[0] || (await context.newPage());
  const errors = [];
  let browserLog = fs.openSync(path.join(outDir, 'browser.log'), 'w');
  const logLine = (line) => { if (browserLog !== null) fs.writeSync(browserLog, `${new Date().toISOString()} ${line}\n`); };
  cleanups.push(async () => { fs.closeSync(browserLog); browserLog = null; });
  page.on('pageerror', (e) => { errors.push(`page error: ${e.message}`); logLine(`pageerror ${e.message}`); });
  let serverDown = false; // while the test has stopped the server, failed connects are expected
  page.on('console', (m) => {
    logLine(`${m.type()} ${m.text()}`);
    const expected = serverDown && /WebSocket connection to .* failed|ERR_CONNECTION_REFUSED/.test(m.text());
    if (m.type() === 'error' && !expected) errors.push(`console error: ${m.text()}`);
  });
  page.on('crash', () => errors.push('page crashed'));

  await page.goto(url);
  await page.waitForFunction(() => window.strandcast && window.strandcast.framesUploaded >= 2, null, { timeout: 120000, polling: 200 })
    .catch(async (e) => {
      const state = await page.evaluate(() => ({
        banner: document.getElementById('banner').textContent,
        status: (document.querySelector('.status') || {}).textContent,
        snapshot: window.strandcast ? window.strandcast.snapshot() : null,
      }));
      die(`no frames drawn: ${e.message}; page state ${JSON.stringify(state)}; errors ${errors.join('; ')}`);
    });
  check(errors.length === 0, `page loaded and drew streamed frames without errors ${errors.join('; ')}`);

  const gl = await page.evaluate(() => {
    const g = window.strandcast.gl;
    const info = g.getExtension('WEBGL_debug_renderer_info');
    return { webgl2: g instanceof WebGL2RenderingContext, lost: g.isContextLost(), renderer: g.getParameter(info ? info.UNMASKED_RENDERER_WEBGL : g.RENDERER) };
  });
  check(gl.webgl2 && !gl.lost, `WebGL2 context alive (${gl.renderer})`);

  if (daemonExtra.includes('--collider')) { // e.g. -- --groom Ratboy_mohawk.tfx --collider Ratboy_body.tfxmesh
    await page.waitForFunction(() => window.strandcast.colliderMesh, null, { timeout: 120000, polling: 200 });
    const ntris = await page.evaluate(() => window.strandcast.colliderMesh.ntris);
    check(ntris > 0, `the collision mesh from /collider.bin is drawn (${ntris} triangles)`);
    await page.screenshot({ path: path.join(outDir, 'e2e-collider.png'), timeout: 180000 });
    console.log(`e2e: screenshot ${path.join(outDir, 'e2e-collider.png')}`);
  }

  const still = await capture(page);
  const ps = pixelStats(still.rgba);
  check(ps.hairShare >= 0.02, `canvas shows hair: ${(100 * ps.hairShare).toFixed(1)}% hair-coloured pixels (need 2%)`);
  check(ps.hairLumaSpread >= 25, `hair is shaded, not flat: luminance p95-p5 ${ps.hairLumaSpread.toFixed(0)} over hair pixels (need 25)`);
  check(ps.lumaStd >= 8, `canvas is not blank: luminance std dev ${ps.lumaStd.toFixed(1)} (need 8)`);

  // the head moves: a preset animation through the panel's button
  await page.click('button[data-preset="shake"]', { force: true });
  await waitUploads(page, 3, 60000);
  const a = await capture(page);
  await page.waitForTimeout(400);
  await waitUploads(page, 3, 60000);
  const b = await capture(page);
  const changed = diffShare(a.rgba, b.rgba, 24);
  check(changed >= 0.002, `the picture changes while the head moves: ${(100 * changed).toFixed(2)}% of pixels changed (need 0.2%)`);

  // dragging the head sends motion: the server moves the roots, and the head pose the page
  // recovers from the streamed roots follows
  await page.click('button[data-preset="none"]', { force: true });
  await waitUploads(page, 3, 60000);
  const before = await page.evaluate(() => {
    const a = window.strandcast, p = a.head.position, m = a.camera.viewProj, r = a.canvas.getBoundingClientRect();
    const x = m[0] * p[0] + m[4] * p[1] + m[8] * p[2] + m[12], y = m[1] * p[0] + m[5] * p[1] + m[9] * p[2] + m[13];
    const w = m[3] * p[0] + m[7] * p[1] + m[11] * p[2] + m[15];
    return { pos: Array.from(p), sx: r.left + (0.5 + 0.5 * x / w) * r.width, sy: r.top + (0.5 - 0.5 * y / w) * r.height };
  });
  await page.mouse.move(before.sx, before.sy);
  await page.mouse.down();
  await page.mouse.move(before.sx + 60, before.sy - 20, { steps: 8 });
  await page.mouse.up();
  await page.waitForFunction((p0) => {
    const p = window.strandcast.head.position;
    return Math.hypot(p[0] - p0[0], p[1] - p0[1], p[2] - p0[2]) > 0.02;
  }, before.pos, { timeout: 60000, polling: 100 }).catch(async () => {
    const now = await page.evaluate(() => Array.from(window.strandcast.head.position));
    die(`the head did not follow the drag: ${before.pos} -> ${now}`);
  });
  const after = await page.evaluate(() => Array.from(window.strandcast.head.position));
  check(true, `dragging the head moved it (roots streamed back) from [${before.pos.map((v) => v.toFixed(3))}] to [${after.map((v) => v.toFixed(3))}]`);

  // the head (and its collider mesh) is drawn where the frames' headers put it, and the hair's
  // roots sit on that transform: the page and a client decoding the same stream agree
  const viewer = await secondClient(wsUrl, true);
  const t0 = Date.now();
  while (!viewer.frame && Date.now() - t0 < 60000) await new Promise((r) => setTimeout(r, 100));
  check(!!viewer.frame, 'a second client decodes frames');
  // the head comes to rest where the drag left it; the page (slow under SwiftShader) catches up
  // with the newest frames and then draws exactly the header's transform
  let headGap = Infinity, fh = viewer.frame.head;
  for (const end = Date.now() + 60000; headGap >= 1e-6 && Date.now() < end;) {
    await page.waitForTimeout(200);
    fh = viewer.frame.head;
    const pageHead = await page.evaluate(() => ({ p: Array.from(window.strandcast.head.position), q: Array.from(window.strandcast.head.orientation) }));
    headGap = Math.max(...pageHead.p.map((v, i) => Math.abs(v - fh.position[i])), ...pageHead.q.map((v, i) => Math.abs(v - fh.orientation[i])));
  }
  check(headGap < 1e-6, `the page draws the head of the frame header (step ${viewer.frame.simStep}): position [${fh.position.map((v) => v.toFixed(4))}], differs by ${headGap.toExponential(2)}`);
  // the rest roots are in the groom's data binary (GET hello.groom.url), not in the hello
  const groomBin = await fetch(new URL(viewer.hello.groom.url, url));
  check(groomBin.ok, `GET ${viewer.hello.groom.url}: HTTP ${groomBin.status}`);
  const [qx, qy, qz, qw] = fh.orientation, rest = parseGroomData(await groomBin.arrayBuffer()).roots;
  let rootGap = 0;
  viewer.frame.roots.forEach((r, j) => {
    const vx = rest[3 * j], vy = rest[3 * j + 1], vz = rest[3 * j + 2];
    const tx = 2 * (qy * vz - qz * vy), ty = 2 * (qz * vx - qx * vz), tz = 2 * (qx * vy - qy * vx);
    const w = [vx + qw * tx + (qy * tz - qz * ty), vy + qw * ty + (qz * tx - qx * tz), vz + qw * tz + (qx * ty - qy * tx)];
    for (let a = 0; a < 3; a++) rootGap = Math.max(rootGap, Math.abs(r[a] - (w[a] + fh.position[a])));
  });
  check(rootGap < 3e-4, `the streamed roots sit on the header's head transform: within ${(rootGap * 1e3).toFixed(3)} mm (need 0.3)`);
  viewer.ws.close();

  const snap = await page.evaluate(() => ({ s: window.strandcast.snapshot(), text: document.getElementById('stats').textContent }));
  check(snap.s.framesPerSec > 0 && snap.s.kbitPerSec > 0 && Number.isFinite(snap.s.bytesPerVertex) && snap.s.serverStepsPerSec > 0 && /fps/.test(snap.text),
    `stats overlay: ${snap.s.framesPerSec.toFixed(1)} frames/s, ${snap.s.kbitPerSec.toFixed(0)} kbit/s, ${snap.s.bytesPerVertex.toFixed(2)} B/vertex, server ${snap.s.serverStepsPerSec.toFixed(1)} steps/s`);

  // a panel slider changes the parameter on the server (seen by another client)
  const other = await secondClient(wsUrl);
  const pageClient = await page.evaluate(() => window.strandcast.clientId);
  const slider = page.locator('input[type=range][data-param="gravity"]');
  const box = await slider.boundingBox();
  check(!!box, 'the panel has a gravity slider');
  // drag the thumb (about 8 px wide each side of its centre) 24 px to the right
  const g0 = Number(await slider.inputValue());
  const thumbX = box.x + 8 + ((g0 - 0) / 50) * (box.width - 16), cy = box.y + box.height / 2;
  await page.mouse.move(thumbX, cy);
  await page.mouse.down();
  await page.mouse.move(thumbX + 24, cy, { steps: 6 });
  await page.mouse.up();
  const shown = Number(await slider.inputValue());
  check(shown > g0 + 5, `dragging the gravity slider moved it from ${g0} to ${shown}`);
  const seen = await waitMessage(other, (m) => m.type === 'params' && m.values && typeof m.values.gravity === 'number' && Math.abs(m.values.gravity - shown) < 1e-3, 60000, `gravity ${shown} broadcast`)
    .catch(async (e) => {
      const status = await page.evaluate(() => document.querySelector('.status').textContent);
      die(`${e.message}; panel status "${status}"; the other client got ${other.messages.filter((m) => m.type !== 'stats').map((m) => JSON.stringify(m)).join(' ')}`);
    });
  check(seen.by === pageClient, `the server applied gravity = ${seen.values.gravity} from the page (by client ${seen.by}, the page is ${pageClient})`);

  // a parameter set by the other client shows up in the panel
  other.ws.send(JSON.stringify({ type: 'set_params', id: 'e2e', values: { wind_x: 3.25 } }));
  await waitMessage(other, (m) => m.id === 'e2e', 20000, 'reply to set_params');
  await page.waitForFunction(() => {
    const r = document.querySelector('input[type=range][data-param="wind_x"]');
    // the number box shows the exact value, the slider the nearest step
    return r && Math.abs(Number(r.parentElement.querySelector('.num').value) - 3.25) < 1e-9 && Math.abs(Number(r.value) - 3.25) <= Number(r.step);
  }, null, { timeout: 60000, polling: 100 }).catch(async (e) => {
    const shown = await page.evaluate(() => {
      const r = document.querySelector('input[type=range][data-param="wind_x"]');
      return r ? { slider: r.value, step: r.step, box: r.parentElement.querySelector('.num').value } : null;
    });
    die(`wind_x = 3.25 from another client did not show in the panel: ${e.message}; the panel shows ${JSON.stringify(shown)}`);
  });
  check(true, 'wind_x = 3.25 set by another client shows in the panel');

  // local_stiffness spans [0, 1e8] on a log slider (hello scale "log"): its middle position is
  // in the middle decade, and 1,000 set by another client shows as 1000 at its own position
  const stiff = await page.evaluate(() => {
    const r = document.querySelector('input[type=range][data-param="local_stiffness"]');
    if (!r) return null;
    const scale = r.dataset.scale, max = Number(r.max);
    r.value = String(Math.round(max / 2));
    r.dispatchEvent(new Event('input', { bubbles: true }));
    r.dispatchEvent(new Event('change', { bubbles: true }));
    return { scale, max, num: r.parentElement.querySelector('.num').value };
  });
  check(stiff && stiff.scale === 'log', `local_stiffness has a log slider (${JSON.stringify(stiff)})`);
  const ks = await waitMessage(other, (m) => m.type === 'params' && Array.isArray(m.changed) && m.changed.includes('local_stiffness'), 60000, 'local_stiffness broadcast');
  const kv = ks.values.local_stiffness;
  check(ks.by === pageClient && kv >= 3e4 && kv <= 3e5 && Number(stiff.num) === kv,
    `the local_stiffness slider's middle position sent ${kv} 1/s^2 (number box "${stiff.num}")`);
  other.ws.send(JSON.stringify({ type: 'set_params', id: 'e2e-k', values: { local_stiffness: 1000 } }));
  await waitMessage(other, (m) => m.id === 'e2e-k', 20000, 'reply to set_params');
  await page.waitForFunction(() => {
    const r = document.querySelector('input[type=range][data-param="local_stiffness"]');
    return r && r.parentElement.querySelector('.num').value === '1000' && r.value === '101';
  }, null, { timeout: 60000, polling: 100 });
  check(true, 'local_stiffness = 1000 set by another client shows at slider position 101 of 601');

  // the solver is a drop-down: picking pbd switches the server (seen by the other client) and
  // the panel then shows pbd's own parameters and hides dftl's; back to dftl for what follows
  const solverRows = () => page.evaluate(() => {
    // drawn, not only flagged hidden: a stylesheet's display may override the hidden attribute
    const shown = (n) => { const r = document.querySelector(`[data-param="${n}"]`)?.closest('.row'); return !!r && getComputedStyle(r).display !== 'none'; };
    return { pbd: shown('pbd_iterations'), dftl: shown('repulsion') };
  });
  const onDftl = await solverRows();
  check(onDftl.dftl && !onDftl.pbd, `on dftl the panel shows repulsion, not pbd_iterations (${JSON.stringify(onDftl)})`);
  await page.selectOption('select[data-param="solver"]', 'pbd');
  const sw = await waitMessage(other, (m) => m.type === 'params' && Array.isArray(m.changed) && m.changed.includes('solver') && m.values.solver === 'pbd', 60000, 'solver pbd broadcast');
  check(sw.by === pageClient, `the solver drop-down switched the server to pbd (by client ${sw.by})`);
  await page.waitForFunction(() => {
    const shown = (n) => { const r = document.querySelector(`[data-param="${n}"]`)?.closest('.row'); return !!r && getComputedStyle(r).display !== 'none'; };
    return shown('pbd_iterations') && !shown('repulsion');
  }, null, { timeout: 60000, polling: 100 });
  check(true, 'on pbd the panel shows pbd_iterations and hides repulsion');
  other.ws.send(JSON.stringify({ type: 'set_params', id: 'e2e-s', values: { solver: 'dftl' } }));
  await waitMessage(other, (m) => m.id === 'e2e-s', 20000, 'reply to set_params');
  await page.waitForFunction(() => document.querySelector('select[data-param="solver"]').value === 'dftl', null, { timeout: 60000, polling: 100 });
  check(true, 'solver = dftl set by another client shows in the drop-down');

  await page.screenshot({ path: path.join(outDir, 'e2e-screenshot.png'), timeout: 180000 });
  console.log(`e2e: screenshot ${path.join(outDir, 'e2e-screenshot.png')}`);

  if (bench) {
    // the default parameters, and moving hair so that frames carry real motion
    other.ws.send(JSON.stringify({ type: 'set_params', id: 'defaults', values: { gravity: 9.81, wind_x: 0, local_stiffness: 1e6 } }));
    await waitMessage(other, (m) => m.id === 'defaults', 20000, 'reply to set_params');
    await page.click('button[data-preset="shake"]', { force: true });
    const cpu = (os.cpus()[0] || {}).model || 'unknown';
    for (const per of [4, 16]) {
      const r = await measure(page, per, 6);
      console.log(JSON.stringify({ ...r, renderer: gl.renderer, nproc: os.cpus().length, cpu, date: new Date().toISOString().slice(0, 10) }));
    }
  }
  check(errors.length === 0, `no page errors ${errors.join('; ')}`);

  // the server goes away: the page says so, and reconnects once a server is back on the port
  await page.evaluate(() => window.strandcast.setView('perGuide', 1));
  serverDown = true;
  await daemon.stop();
  await page.waitForFunction(() => {
    const b = document.getElementById('banner');
    return !b.classList.contains('hidden') && /lost/.test(b.textContent);
  }, null, { timeout: 60000, polling: 100 });
  const banner = await page.evaluate(() => document.getElementById('banner').textContent);
  check(true, `with the server gone the page shows "${banner}"`);
  const uploaded = await page.evaluate(() => window.strandcast.framesUploaded);
  const again = await startDaemon(Number(new URL(url).port), 'strandcastd-restart.log');
  await page.waitForFunction((n) => document.getElementById('banner').classList.contains('hidden') && window.strandcast.framesUploaded > n,
    uploaded, { timeout: 180000, polling: 200 });
  check(true, `the page reconnected to the restarted server (${again.url}) and draws its frames again`);
  serverDown = false;

  const lost = await page.evaluate(() => window.strandcast.gl.isContextLost());
  check(!lost, 'WebGL2 context still alive at the end');
  check(errors.length === 0, `no page errors after the reconnect ${errors.join('; ')}`);
}

for (const sig of ['SIGINT', 'SIGTERM']) {
  process.on(sig, () => { console.error(`e2e: ${sig}: cleaning up`); h.cleanup().finally(() => process.exit(1)); });
}

try {
  await main();
  console.log('e2e: all checks passed');
} catch (e) {
  if (!process.exitCode) console.error(`e2e: FAIL: ${e.stack || e.message}`);
  process.exitCode = 1;
} finally {
  await h.cleanup();
}
