// The soak: strandcastd under a mixed, partly hostile load for a long run (not part of the test
// command; BENCHMARKS.md records its figures). 20 clients: well-behaved ones that read every
// frame and send motion and parameter changes, one that floods requests, one that never reads,
// and some that join and leave all the time. Every 10 s it prints the daemon's RSS; at the end
// the RSS trend after warm-up, frames per well-behaved client and their longest gap between
// frames, and the NaN events the daemon counted.
//
// usage: node tests/soak/soak.mjs [--minutes M] [--daemon PATH] [--json] [-- extra daemon flags]
// (defaults: 10 minutes, build/strandcastd). Exit status 0 when RSS stayed flat after warm-up
// (the last third within 10% of the middle third), every well-behaved client kept receiving
// (no gap over --max-gap-ms, default 100), and no NaN event happened; 1 otherwise.
import { spawn } from 'node:child_process';
import fs from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import { createRequire } from 'node:module';

const here = path.dirname(fileURLToPath(import.meta.url));
const require = createRequire(path.join(here, '..', 'package.json'));
const WebSocket = require('ws');
const SUBPROTOCOL = 'strandcast.v3';

const argv = process.argv.slice(2);
const dashes = argv.indexOf('--');
const own = dashes >= 0 ? argv.slice(0, dashes) : argv;
const extra = dashes >= 0 ? argv.slice(dashes + 1) : [];
const opt = (name, def) => { const i = own.indexOf(name); return i >= 0 && i + 1 < own.length ? own[i + 1] : def; };
const minutes = Number(opt('--minutes', '10'));
const maxGapMs = Number(opt('--max-gap-ms', '100'));
const daemonPath = opt('--daemon', path.join(here, '..', '..', 'build', 'strandcastd'));
const json = own.includes('--json');
if (!(minutes > 0) || !(maxGapMs > 0) || !fs.existsSync(daemonPath)) {
  console.error('usage: node tests/soak/soak.mjs [--minutes M] [--max-gap-ms MS] [--daemon PATH] [--json] [-- daemon flags]');
  process.exit(2);
}
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

function startDaemon() {
  const child = spawn(daemonPath, ['--port', '0', ...extra], { stdio: ['ignore', 'pipe', 'pipe'] });
  return new Promise((resolve, reject) => {
    let text = '';
    const onData = (d) => {
      text += d.toString();
      const m = /open https?:\/\/[^:\s]+:(\d+)\//.exec(text);
      if (m) resolve({ child, port: Number(m[1]) });
    };
    child.stdout.on('data', onData);
    child.stderr.on('data', onData);
    child.once('exit', (code) => reject(new Error(`strandcastd exited with ${code}:\n${text}`)));
  });
}

function rssMiB(pid) {
  const m = /VmRSS:\s+(\d+) kB/.exec(fs.readFileSync(`/proc/${pid}/status`, 'utf8'));
  return m ? Number(m[1]) / 1024 : NaN;
}

async function metric(port, name) {
  const body = await (await fetch(`http://127.0.0.1:${port}/metrics`)).text();
  const m = new RegExp(`^${name.replace(/[{}"]/g, '\\$&')} ([0-9.e+]+)$`, 'm').exec(body);
  return m ? Number(m[1]) : NaN;
}

// A client that reads every frame; records frame arrival gaps once warm; optionally sends
// motion at 60 Hz and a parameter change every 2 s.
function reader(port, { active = false, name }) {
  const ws = new WebSocket(`ws://127.0.0.1:${port}/`, SUBPROTOCOL);
  const r = { name, frames: 0, maxGapMs: 0, last: 0, closed: null, errors: 0, timers: [] };
  ws.on('message', (data, isBinary) => {
    const t = performance.now();
    if (isBinary) {
      if (r.last && r.counting) r.maxGapMs = Math.max(r.maxGapMs, t - r.last);
      r.last = t;
      r.frames++;
    } else {
      const m = JSON.parse(data.toString());
      if (m.type === 'error' && m.code !== 'rate_limited') r.errors++;
    }
  });
  ws.on('close', (code) => { r.closed = code; r.timers.forEach(clearInterval); });
  ws.on('open', () => {
    if (!active) return;
    let a = 0;
    r.timers.push(setInterval(() => {
      a += 0.02;
      ws.send(JSON.stringify({ type: 'motion', position: [0, 0.01 * Math.sin(a), 0], orientation: [0, Math.sin(a / 4), 0, Math.cos(a / 4)] }));
    }, 16));
    let k = 0;
    r.timers.push(setInterval(() => ws.send(JSON.stringify({ type: 'set_params', values: { wind_x: (k++ % 5) * 0.5 } })), 2000));
  });
  r.ws = ws;
  return r;
}

const { child, port } = await startDaemon();
const pid = child.pid;
const readers = [];
for (let i = 0; i < 14; i++) readers.push(reader(port, { active: i < 6, name: `reader${i}` }));
// the flooder: requests far past its budget, as fast as the socket takes them
const flooder = new WebSocket(`ws://127.0.0.1:${port}/`, SUBPROTOCOL);
let flooding = null;
flooder.on('open', () => {
  flooding = setInterval(() => {
    for (let i = 0; i < 200; i++) flooder.send('{"type":"set_params","values":{"gravity":9.81}}');
  }, 50);
});
flooder.on('close', () => clearInterval(flooding));
flooder.on('error', () => {});
// the reader that never reads: pauses its socket at once
const deaf = new WebSocket(`ws://127.0.0.1:${port}/`, SUBPROTOCOL);
deaf.on('open', () => deaf._socket.pause());
deaf.on('error', () => {});
// churn: 4 slots whose clients come and go every 1-3 s
let churned = 0;
const churn = setInterval(() => {
  const w = new WebSocket(`ws://127.0.0.1:${port}/`, SUBPROTOCOL);
  w.on('error', () => {});
  w.on('open', () => { churned++; setTimeout(() => w.close(), 1000 + Math.random() * 2000); });
}, 500);

const start = performance.now(), total = minutes * 60000, warm = Math.min(60000, total / 3);
const samples = [];
const nan0 = await metric(port, 'strandcast_nan_resets_total');
await sleep(Math.min(5000, warm));
for (const r of readers) r.counting = true;
for (let left = total - (performance.now() - start); left > 1; left = total - (performance.now() - start)) {
  await sleep(Math.min(10000, left));
  const t = (performance.now() - start) / 1000;
  const rss = rssMiB(pid);
  samples.push({ t, rss });
  if (!json) console.log(`soak: ${t.toFixed(0)} s  RSS ${rss.toFixed(1)} MiB  frames/reader ${(readers.reduce((s, r) => s + r.frames, 0) / readers.length).toFixed(0)}`);
}
clearInterval(churn);
const nan = (await metric(port, 'strandcast_nan_resets_total')) - nan0;
const coalesced = await metric(port, 'strandcast_text_coalesced_total');
const rejected = await metric(port, 'strandcast_control_messages_total{result="rejected"}');
const after = samples.filter((s) => s.t * 1000 >= warm);
const third = Math.max(1, Math.floor(after.length / 3));
const mean = (a) => a.reduce((s, x) => s + x.rss, 0) / a.length;
const mid = mean(after.slice(third, 2 * third)), last = mean(after.slice(-third));
const rssFlat = after.length >= 3 ? Math.abs(last - mid) <= 0.1 * mid : true;
const seconds = (performance.now() - start) / 1000;
const open = readers.filter((r) => r.closed === null);
const worstGap = Math.max(...readers.map((r) => r.maxGapMs));
const minFps = Math.min(...readers.map((r) => r.frames / seconds));
const ok = rssFlat && open.length === readers.length && worstGap <= maxGapMs && nan === 0;
const result = {
  bench: 'soak', minutes, readers: readers.length, churned, rss_mib_first: samples[0]?.rss, rss_mib_mid: mid, rss_mib_last: last,
  rss_flat: rssFlat, readers_open: open.length, min_frames_per_reader_per_s: minFps, max_gap_ms: worstGap,
  nan_events: nan, announcements_coalesced: coalesced, requests_rejected: rejected, ok,
};
console.log(json ? JSON.stringify(result) : `soak: ${JSON.stringify(result, null, 1)}`);
for (const r of readers) r.ws.close();
flooder.close();
deaf.terminate();
child.kill('SIGTERM');
await new Promise((r) => child.once('exit', r));
process.exit(ok ? 0 : 1);
