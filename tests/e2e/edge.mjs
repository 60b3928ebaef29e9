// Browser end-to-end test of a room through an edge relay: nats-server, strandcastd as the
// simulation node of room "e2e", strandcastd --relay, and headless Chromium (SwiftShader WebGL2,
// playwright-core) on the edge's http://EDGE/rooms/e2e. The page must connect to its room through
// the edge, get the room's groom data binary from the edge (it draws nothing without it), draw
// shaded hair, name the room in its title, and have a parameter change acknowledged by the node.
// Usage: node tests/e2e/edge.mjs --daemon PATH/strandcastd --out DIR [--web DIR] [--nats-server PATH]
import fs from 'node:fs';
import path from 'node:path';
import { arg, capture, harness } from './harness.mjs';
import { pixelStats } from './pixels.mjs';

const h = harness('edge e2e');
const { check, die, outDir, webDir, daemonPath } = h;
const natsPath = arg('--nats-server', '/usr/sbin/nats-server');
if (!fs.existsSync(natsPath)) die(`${natsPath} not found; install the Debian package nats-server (.ci/deps)`);

async function main() {
  const natsAddr = await h.start('nats-server', natsPath, ['-a', '127.0.0.1', '-p', '-1'], /client connections on ([0-9.]+:\d+)/);
  const nats = `nats://${natsAddr}`;
  await h.start('strandcastd-node', daemonPath, ['--port', '0', '--web', webDir, '--min-step-rate', '0', '--strands', '1024',
    '--verts', '16', '--nats', nats, '--room', 'e2e'], /(http:\/\/[0-9.:]+\/)/);
  const edge = await h.start('strandcastd-edge', daemonPath, ['--relay', '--port', '0', '--web', webDir, '--nats', nats],
    /(http:\/\/[0-9.:]+\/)/);
  console.log(`edge e2e: nats ${nats}, edge ${edge}`);
  const context = await h.launch({ width: 900, height: 640 });
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
  const ps = pixelStats((await capture(page)).rgba);
  check(ps.hairShare >= 0.02, `canvas shows hair: ${(100 * ps.hairShare).toFixed(1)}% hair-coloured pixels (need 2%)`);
  await page.screenshot({ path: path.join(outDir, 'edge-room.png'), timeout: 180000 });
  const reply = await page.evaluate(() => window.strandcast.request({ type: 'set_params', values: { gravity: 4 } }));
  check(reply && reply.type === 'ok', `a parameter change through the edge is acknowledged by the node (${JSON.stringify(reply)})`);
  check(errors.length === 0, `no page errors ${errors.join('; ')}`);
}

main()
  .catch((e) => { if (!process.exitCode) { console.error(`edge e2e: FAIL: ${e.stack || e.message}`); process.exitCode = 1; } })
  .finally(() => h.cleanup());
