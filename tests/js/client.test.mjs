// Tests web/client.js: request ids and replies, errors as rejected promises carrying the code and
// field, pending requests rejected on close (a fake socket); then against a real strandcastd
// (STRANDCASTD, default build/strandcastd; 128 x 8 CPU groom): hello, a set_params round trip, an
// error reply, frames decoded to finite Float32Arrays, the groom data binary, and the README's
// example (tests/client_example.mjs, which README.md must hold verbatim) run as written.
import test from 'node:test';
import assert from 'node:assert/strict';
import { spawn, execFile } from 'node:child_process';
import fs from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import { createRequire } from 'node:module';
import { connect, ProtocolError, Requests, SUBPROTOCOL } from '../../web/client.js';

const here = path.dirname(fileURLToPath(import.meta.url));
const root = path.join(here, '..', '..');
const WebSocket = createRequire(path.join(here, '..', 'package.json'))('ws');
const daemonPath = process.env.STRANDCASTD || path.join(root, 'build', 'strandcastd');
const STRANDS = 128, VERTS = 8;

class FakeSocket {
  static last = null;
  constructor(url, protocol) {
    this.url = url;
    this.protocol = protocol;
    this.sent = [];
    this.handlers = {};
    FakeSocket.last = this;
    setTimeout(() => { this.emit('open', {}); this.text(this.hello()); });
  }
  hello() { return { type: 'hello', protocol: 3, server: 'fake', groom: { strands: 1, verts: 2 } }; }
  addEventListener(type, fn) { (this.handlers[type] ||= []).push(fn); }
  emit(type, ev) { for (const fn of this.handlers[type] || []) fn(ev); }
  text(obj) { this.emit('message', { data: JSON.stringify(obj) }); }
  send(text) { this.sent.push(JSON.parse(text)); }
  close(code, reason) { this.emit('close', { code, reason }); }
}

test('requests get fresh ids; replies settle them, error replies reject with code and field', async () => {
  const c = await connect('ws://fake/', { WebSocket: FakeSocket });
  const ws = FakeSocket.last;
  assert.equal(ws.protocol, SUBPROTOCOL);
  assert.equal(c.hello.server, 'fake');
  const a = c.request({ type: 'get_params' }), b = c.request({ type: 'set_params', values: { gravity: -3 } });
  assert.deepEqual(ws.sent.map((m) => m.id), [1, 2]);
  const params = [];
  c.on('params', (m) => params.push(m));
  ws.text({ type: 'params', values: { gravity: 1 } });          // an announcement, no id
  ws.text({ type: 'error', id: 2, code: 'out_of_range', field: 'values.gravity', message: 'outside [0, 50]' });
  ws.text({ type: 'params', id: 1, values: { gravity: 2 } });
  assert.deepEqual((await a).values, { gravity: 2 });
  await assert.rejects(b, (e) => e instanceof ProtocolError && e.code === 'out_of_range' && e.field === 'values.gravity' && e.id === 2);
  assert.deepEqual(params, [{ type: 'params', values: { gravity: 1 } }]);
  const pending = c.request({ type: 'reset' });
  c.close();
  await assert.rejects(pending, /connection closed before the reply came/);
  await assert.rejects(c.request({ type: 'reset' }), /connection is closed/);
});

test('Requests: a motion without id gets none; an id still waiting is refused', async () => {
  const r = new Requests();
  assert.equal(await r.track({ type: 'motion', position: [0, 0, 0] }), null);
  const p = r.track({ type: 'reset', id: 'x' });
  await assert.rejects(r.track({ type: 'pause', id: 'x' }), /already waiting/);
  assert.equal(r.settle({ type: 'ok', id: 'y' }), false);
  assert.equal(r.settle({ type: 'ok', id: 'x', step: 3 }), true);
  assert.equal((await p).step, 3);
  assert.equal(r.size, 0);
  const w = new Requests('w');
  assert.deepEqual([w.assign({ type: 'reset' }), w.assign({ type: 'pause' })], ['w1', 'w2']);
});

test('connect refuses a hello of another protocol version and a missing WebSocket', async () => {
  class Old extends FakeSocket {
    hello() { return { type: 'hello', protocol: 1, server: 'old' }; }
  }
  await assert.rejects(connect('ws://fake/', { WebSocket: Old }), /speaks protocol 1/);
  await assert.rejects(connect('ws://fake/', { WebSocket: 0 }), /no WebSocket/);
});

test('connect to a room the server does not serve rejects with its error code', async () => {
  class Elsewhere extends FakeSocket {
    hello() { return { type: 'error', code: 'unknown_room', field: 'room', message: 'this server serves room "default", not "b"' }; }
  }
  await assert.rejects(connect('ws://fake/rooms/b', { WebSocket: Elsewhere }),
                       (e) => e instanceof ProtocolError && e.code === 'unknown_room' && e.field === 'room');
});

function startDaemon() {
  assert.ok(fs.existsSync(daemonPath), `no daemon at ${daemonPath} (set STRANDCASTD)`);
  const child = spawn(daemonPath, ['--port', '0', '--min-step-rate', '0', '--backend', 'cpu', '--strands', String(STRANDS), '--verts', String(VERTS)],
    { stdio: ['ignore', 'pipe', 'pipe'] });
  return new Promise((resolve, reject) => {
    let text = '';
    const timer = setTimeout(() => reject(new Error(`strandcastd printed no URL in 60 s:\n${text}`)), 60000);
    const onData = (d) => {
      text += d.toString();
      const m = /open https?:\/\/[^:\s]+:(\d+)\//.exec(text);
      if (m) { clearTimeout(timer); resolve({ child, url: `ws://127.0.0.1:${m[1]}/` }); }
    };
    child.stdout.on('data', onData);
    child.stderr.on('data', onData);
    child.once('exit', (code) => { clearTimeout(timer); reject(new Error(`strandcastd exited with ${code}:\n${text}`)); });
  });
}

test('against strandcastd: hello, requests, errors, frames, groom data, the README example', async (t) => {
  const { child, url } = await startDaemon();
  t.after(() => child.kill('SIGTERM'));
  const c = await connect(url, { WebSocket });
  t.after(() => c.close());
  assert.equal(c.hello.type, 'hello');
  assert.equal(c.hello.groom.strands, STRANDS);
  assert.equal(c.hello.groom.verts, VERTS);

  const announced = new Promise((resolve) => c.on('params', (m) => { if (m.values.gravity === 4.5) resolve(m); }));
  const ok = await c.request({ type: 'set_params', values: { gravity: 4.5 } });
  assert.equal(ok.type, 'ok');
  assert.ok(Number.isInteger(ok.step) && ok.step >= 0, `ok carries the step: ${JSON.stringify(ok)}`);
  const params = await c.request({ type: 'get_params' });
  assert.equal(params.type, 'params');
  assert.equal(params.values.gravity, 4.5);
  await announced;

  await assert.rejects(c.request({ type: 'set_params', values: { gravity: -3 } }),
    (e) => e instanceof ProtocolError && e.code === 'out_of_range' && e.field === 'values.gravity');
  await assert.rejects(c.request({ type: 'set_params', values: { no_such_param: 1 } }), (e) => e.code === 'unknown_param');
  await assert.rejects(c.request({ type: 'no_such_type' }), (e) => e.code === 'unknown_type');

  let seen = 0;
  for await (const { header, positions } of c.frames()) {
    assert.ok(positions instanceof Float32Array);
    assert.equal(header.nstrandsSent, STRANDS);
    assert.equal(header.nverts, VERTS);
    assert.equal(positions.length, STRANDS * VERTS * 3);
    assert.ok(positions.every(Number.isFinite), 'every position is finite');
    assert.ok(Number.isInteger(header.simStep) && header.head.orientation.length === 4);
    if (++seen === 5) break;
  }

  const g = await c.groomData();
  assert.equal(g.strands, STRANDS);
  assert.equal(g.verts, VERTS);
  assert.equal(g.restLengths.length, STRANDS);
  assert.equal(g.roots.length, 3 * STRANDS);
  assert.ok(g.restLengths.every((l) => l > 0));

  const example = fs.readFileSync(path.join(root, 'tests', 'client_example.mjs'), 'utf8');
  const readme = fs.readFileSync(path.join(root, 'README.md'), 'utf8');
  const block = /<!-- client_example\.mjs -->\n```js\n([\s\S]*?)```\n<!-- \/client_example\.mjs -->/.exec(readme);
  assert.ok(block, 'README.md holds the example between <!-- client_example.mjs --> markers');
  assert.equal(block[1], example, 'README.md shows tests/client_example.mjs verbatim');
  const out = await new Promise((resolve, reject) => {
    execFile(process.execPath, [path.join(root, 'tests', 'client_example.mjs'), url], { timeout: 60000 }, (err, stdout, stderr) => {
      if (err) reject(new Error(`the example failed: ${err.message}\n${stdout}${stderr}`)); else resolve(stdout);
    });
  });
  assert.match(out, new RegExp(`groom ${STRANDS} x ${VERTS}`));
  assert.match(out, /gravity 4.9 from step \d+/);
  assert.match(out, /refused: out_of_range values\.gravity/);
  assert.match(out, /rest length of strand 0: \d\.\d{4} m/);
  assert.match(out, new RegExp(`step \\d+: ${STRANDS * VERTS} vertices, tip of strand 0 at y = -?\\d+\\.\\d{4} m`));
});

test('with a token, connect resolves once the hello asking for it accepted the auth, and rejects a refusal', async () => {
  class Locked extends FakeSocket {
    hello() { return { type: 'hello', protocol: 3, access: 'token', groom: {} }; }
    send(text) {
      super.send(text);
      const m = this.sent.at(-1);
      setTimeout(() => this.text(m.token === 'good' ? { type: 'ok', id: m.id } : { type: 'error', id: m.id, code: 'forbidden', field: 'token', message: 'wrong token' }));
    }
  }
  const c = await connect('ws://fake/', { WebSocket: Locked, token: 'good' });
  assert.deepEqual(Locked.last.sent, [{ type: 'auth', token: 'good', id: 1 }]);
  c.close();
  await assert.rejects(connect('ws://fake/', { WebSocket: Locked, token: 'bad' }), (e) => e.code === 'forbidden' && e.field === 'token');
});
