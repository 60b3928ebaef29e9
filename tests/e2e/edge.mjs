// Browser end-to-end test of a room through an edge relay: nats-server, strandcastd as the
// simulation node of room "e2e", strandcastd --relay, and headless Chromium (SwiftShader WebGL2,
// playwright-core) on the edge's http://EDGE/rooms/e2e. The page must connect to its room through
// the edge, get the room's groom data binary from the edge (it draws nothing without it), draw
// shaded hair, name the room in its title, and have a parameter change acknowledged by the node.
// Usage: node tests/e2e/edge.mjs --daemon PATH/strandcastd --out DIR [--web DIR] [--nats-server PATH]
import { spawn } from 'node:child_process';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import { createRequire } from 'node:module';
import { pixelStats } from './pixels.mjs';

const here = path.dirname(fileURLToPath(import.meta.url));
const require = createRequire(path.join(here, '..', 'package.json'));
const arg = (name, def) => { const i = process.argv.indexOf(name); return i > 0 && i + 1 < process.argv.length ? process.argv[i + 1] : def; };
const daemonPath = arg('--daemon');
const outDir = path.resolve(arg('--out', 'e2e-out'));
const webDir = path.resolve(arg('--web', path.join(here, '..', '..', 'web')));
const chromiumPath = arg('--chromium', '/usr/bin/chromium');
const natsPath = arg('--nats-server', '/usr/sbin/nats-server');

function die(msg) {
  console.error(`edge e2e: FAIL: ${msg}`);
  process.exitCode = 1;
  throw new Error(msg);
}
function check(cond, msg) {
  if (!cond) die(msg);
  console.log(`edge e2e: ok: ${msg}`);
}

const playwright = require('playwright-core');
if (!daemonPath || !fs.existsSync(daemonPath)) die(`--daemon ${daemonPath} does not exist`);
if (!fs.existsSync(chromiumPath)) die(`${chromiumPath} not found; install the Debian package chromium (.ci/deps)`);
if (!fs.existsSync(natsPath)) die(`${natsPath} not found; install the Debian package nats-server (.ci/deps)`);
fs.mkdirSync(outDir, { recursive: true });
const cleanups = [];

// Starts exe with args (logged to outDir/name.log); resolves with the first match of re in its output.
function start(name, exe, args, re) {
  const log = fs.openSync(path.join(outDir, `${name}.log`), 'w');
  const child = fs.existsSync('/usr/bin/setpriv')
    ? spawn('/usr/bin/setpriv', ['--pdeathsig', 'TERM', '--', exe, ...args], { stdio: ['ignore', 'pipe', 'pipe'] })
    : spawn(exe, args, { stdio: ['ignore', 'pipe', 'pipe'] });
  const exited = new Promise((r) => child.once('exit', r));
  cleanups.push(async () => { if (child.exitCode === null) { child.kill('SIGTERM'); await exited; } fs.closeSync(log); });
  return new Promise((resolve, reject) => {
    let text = '';
    const timer = setTimeout(() => reject(new Error(`${name} printed no address in 60 s:\n${text}`)), 60000);
    const onData = (d) => {
      fs.writeSync(log, d);
      text += d.toString();
      const m = re.exec(text);
      if (m) { clearTimeout(timer); resolve(m[1]); }
    };
    child.stdout.on('data', onData);
    child.stderr.on('data', onData);
  });
}

async function main() {
  const natsAddr = await start('nats-server', natsPath, ['-a', '127.0.0.1', '-p', '-1'], /client connections on ([0-9.]+:\d+)/);
  const nats = `nats://${natsAddr}`;
  await start('strandcastd-node', daemonPath, ['--port', '0', '--web', webDir, '--min-step-rate', '0', '--strands', '1024',
    '--verts', '16', '--nats', nats, '--room', 'e2e'], /(http:\/\/[0-9.:]+\/)/);
  const edge = await start('strandcastd-edge', daemonPath, ['--relay', '--port', '0', '--web', webDir, '--nats', nats],
    /(http:\/\/[0-9.:]+\/)/);
  console.log(`edge e2e: nats ${nats}, edge ${edge}`);
  const profile = fs.mkdtempSync(path.join(os.tmpdir(), 'strandcast-edge-e2e-'));
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
  await page.goto(`${edge}rooms/e2e`);
  await page.waitForFunction(() => window.strandcast && window.strandcast.framesUploaded >= 3, null, { timeout: 120000, polling: 200 })
    .catch(async (e) => {
      const status = await page.evaluate(() => (document.querySelector('.status') || {}).textContent).catch(() => '');
      die(`no frames drawn through the edge: ${e.message}; status ${status}; ${errors.join('; ')}`);
    });
  check(errors.length === 0, `the room's page drew frames through the edge ${errors.join('; ')}`);
  check((await page.title()) === 'strandcast: e2e', `the page title names the room ("${await page.title()}")`);
  const c = await page.evaluate(async () => {
    const f = await window.strandcast.capture();
    let s = '';
    for (let i = 0; i < f.rgba.length; i += 0x8000) s += String.fromCharCode.apply(null, f.rgba.subarray(i, i + 0x8000));
    return btoa(s);
  });
  const ps = pixelStats(Buffer.from(c, 'base64'));
  check(ps.hairShare >= 0.02, `canvas shows hair: ${(100 * ps.hairShare).toFixed(1)}% hair-coloured pixels (need 2%)`);
  await page.screenshot({ path: path.join(outDir, 'edge-room.png'), timeout: 180000 });
  const reply = await page.evaluate(() => window.strandcast.request({ type: 'set_params', values: { gravity: 4 } }));
  check(reply && reply.type === 'ok', `a parameter change through the edge is acknowledged by the node (${JSON.stringify(reply)})`);
  check(errors.length === 0, `no page errors ${errors.join('; ')}`);
}

main()
  .catch((e) => { if (!process.exitCode) { console.error(`edge e2e: FAIL: ${e.stack || e.message}`); process.exitCode = 1; } })
  .finally(async () => { for (const c of cleanups.reverse()) await c().catch(() => {}); });
