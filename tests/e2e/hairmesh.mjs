// Browser end-to-end test of the hair grown from a streamed hair mesh: strandcastd running the
// hair-mesh solver on a groom traced through a procedural hair mesh, headless Chromium
// (SwiftShader WebGL2) driven by playwright-core. The viewer's "grow from hair mesh" setting
// subscribes to the mesh (source hairmesh); the test checks the frames are hair mesh frames of
// kilobytes, that the canvas shows shaded hair grown on the GPU, that the wireframe overlay draws,
// and that the page falls back to the strands when the solver changes. Screenshots go to --out.
// Usage: node tests/e2e/hairmesh.mjs --daemon PATH/strandcastd --out DIR [--web DIR]
import path from 'node:path';
import { capture, harness } from './harness.mjs';
import { diffShare, pixelStats } from './pixels.mjs';

const h = harness('hairmesh e2e');
const { check, die, outDir } = h;

async function waitUploads(page, n, ms) {
  const start = await page.evaluate(() => window.strandcast.framesUploaded);
  await page.waitForFunction((target) => window.strandcast.framesUploaded >= target, start + n, { timeout: ms, polling: 100 });
}

async function main() {
  const url = await h.start('strandcastd-hairmesh', h.daemonPath, ['--port', '0', '--web', h.webDir, '--min-step-rate', '0',
    '--groom', 'hairmesh:straight', '--strands', '1024', '--verts', '24', '--solver', 'hairmesh'], /(http:\/\/[0-9.:]+\/)/);
  console.log(`hairmesh e2e: strandcastd at ${url}`);
  const context = await h.launch({ width: 900, height: 640 });
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
  .finally(() => h.cleanup());
