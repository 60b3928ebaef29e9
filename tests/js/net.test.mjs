// Tests web/net.js with a fake WebSocket: hello, version mismatch, reconnects with backoff,
// refused handshakes, ids on requests.
import test from 'node:test';
import assert from 'node:assert/strict';

class FakeSocket {
  static OPEN = 1;
  static all = [];
  constructor(url, protocol) {
    this.url = url;
    this.requested = protocol;
    this.protocol = '';
    this.readyState = 0;
    this.sent = [];
    this.listeners = { open: [] };
    FakeSocket.all.push(this);
  }
  addEventListener(type, fn) { (this.listeners[type] ||= []).push(fn); }
  send(text) { this.sent.push(text); }
  close() { this.readyState = 3; }
  // test helpers
  accept(protocol = this.requested) {
    this.protocol = protocol;
    this.readyState = 1;
    for (const fn of this.listeners.open) fn();
    if (this.onopen) this.onopen();
  }
  text(obj) { this.onmessage({ data: JSON.stringify(obj) }); }
  drop(code = 1006, reason = '') { this.readyState = 3; this.onclose({ code, reason }); }
}
globalThis.WebSocket = FakeSocket;
let fetchStatus = 200;
globalThis.fetch = async () => ({ status: fetchStatus });

const { Connection, SUBPROTOCOL, PROTOCOL_VERSION, defaultUrl, takeToken } = await import('../../web/net.js');
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));
const HELLO = { type: 'hello', protocol: PROTOCOL_VERSION, server: 'strandcastd', version: '0.1.0' };

function make(extra = {}, token = null) {
  FakeSocket.all = [];
  const log = { hello: [], msgs: [], bin: [], status: [] };
  const c = new Connection('ws://h:1/', {
    onHello: (h) => log.hello.push(h),
    onMessage: (m) => log.msgs.push(m),
    onBinary: (b) => log.bin.push(b),
    onStatus: (s) => log.status.push(s),
  }, { baseMs: 5, factor: 2, maxMs: 40, jitter: 0, ...extra }, token);
  return { c, log };
}

test('defaultUrl follows the page scheme and host', () => {
  assert.equal(defaultUrl({ protocol: 'http:', host: 'a:7681' }), 'ws://a:7681/');
  assert.equal(defaultUrl({ protocol: 'https:', host: 'b' }), 'wss://b/');
  assert.equal(defaultUrl({ protocol: 'http:', host: 'a', pathname: '/rooms/studio-2' }), 'ws://a/rooms/studio-2');
  assert.equal(defaultUrl({ protocol: 'http:', host: 'a', pathname: '/index.html' }), 'ws://a/');
});

test('a room the server does not serve stops the connection (no reconnects)', async () => {
  for (const code of [4404, 4400]) {
    const { c, log } = make();
    c.start();
    FakeSocket.all[0].accept();
    FakeSocket.all[0].text({ type: 'error', code: 'unknown_room', field: 'room', message: 'not here' });
    FakeSocket.all[0].drop(code, 'this server serves room "a", not "b"');
    assert.equal(log.status.at(-1).state, 'no_room');
    assert.match(log.status.at(-1).reason, /serves room "a"/);
    await sleep(30);
    assert.equal(FakeSocket.all.length, 1, 'no reconnect');
  }
});

test('hello opens the session; messages and frames flow only after it', () => {
  const { c, log } = make();
  c.start();
  const ws = FakeSocket.all[0];
  assert.equal(ws.requested, SUBPROTOCOL);
  ws.accept();
  ws.onmessage({ data: new ArrayBuffer(8) });
  ws.text({ type: 'params', values: {} });
  assert.equal(log.bin.length + log.msgs.length, 0);
  assert.equal(c.send({ type: 'get_params' }), null, 'nothing is sent before hello');
  ws.text(HELLO);
  assert.equal(log.hello.length, 1);
  assert.equal(log.status.at(-1).state, 'open');
  ws.onmessage({ data: new ArrayBuffer(8) });
  ws.text({ type: 'params', values: { gravity: 1 } });
  ws.onmessage({ data: 'not json' });
  ws.text({ no: 'type' });
  assert.equal(log.bin.length, 1);
  assert.deepEqual(log.msgs, [{ type: 'params', values: { gravity: 1 } }]);
  const id1 = c.send({ type: 'get_params' }), id2 = c.send({ type: 'reset' });
  assert.ok(id2 > id1);
  assert.equal(c.send({ type: 'motion', position: [0, 0, 0] }), 0);
  assert.deepEqual(ws.sent.map((s) => JSON.parse(s)), [{ type: 'get_params', id: id1 }, { type: 'reset', id: id2 }, { type: 'motion', position: [0, 0, 0] }]);
  c.stop();
});

test('a hello with another protocol version stops with a mismatch', async () => {
  const { c, log } = make();
  c.start();
  FakeSocket.all[0].accept();
  FakeSocket.all[0].text({ ...HELLO, protocol: 1 });
  assert.equal(log.status.at(-1).state, 'mismatch');
  assert.match(log.status.at(-1).reason, /protocol 1.*protocol 3/);
  assert.equal(log.hello.length, 0);
  await sleep(60);
  assert.equal(FakeSocket.all.length, 1, 'no reconnect after a mismatch');
});

test('a server that picks no subprotocol is a mismatch', () => {
  const { c, log } = make();
  c.start();
  FakeSocket.all[0].accept('');
  assert.equal(log.status.at(-1).state, 'mismatch');
  c.stop();
});

test('lost connections reconnect with growing delays, reset after a hello', async () => {
  const { c, log } = make();
  c.start();
  FakeSocket.all[0].accept();
  FakeSocket.all[0].text(HELLO);
  for (let k = 0; k < 3; k++) {
    FakeSocket.all.at(-1).accept();
    FakeSocket.all.at(-1).drop(1001, 'going away');
    await sleep(60);
  }
  const lost = log.status.filter((s) => s.state === 'lost');
  assert.deepEqual(lost.map((s) => s.delayMs), [5, 10, 20]);
  assert.match(lost[0].reason, /going away \(code 1001\)/);
  assert.equal(FakeSocket.all.length, 4);
  FakeSocket.all.at(-1).accept();
  FakeSocket.all.at(-1).text(HELLO);
  FakeSocket.all.at(-1).drop();
  assert.equal(log.status.filter((s) => s.state === 'lost').at(-1).delayMs, 5, 'backoff reset by the hello');
  c.stop();
});

test('handshakes refused while HTTP answers are reported as a likely version mismatch', async () => {
  fetchStatus = 200;
  const { c, log } = make();
  c.start();
  FakeSocket.all[0].drop();
  await sleep(30);
  FakeSocket.all.at(-1).drop();
  await sleep(30);
  const refused = log.status.find((s) => s.state === 'refused');
  assert.ok(refused, JSON.stringify(log.status));
  assert.match(refused.reason, /protocol version mismatch/);
  assert.ok(FakeSocket.all.length >= 3, 'still retrying');
  c.stop();
  // a server that is down (HTTP fails too) is just lost
  globalThis.fetch = async () => { throw new Error('refused'); };
  const second = make();
  second.c.start();
  FakeSocket.all[0].drop();
  await sleep(30);
  FakeSocket.all.at(-1).drop();
  await sleep(30);
  assert.ok(!second.log.status.some((s) => s.state === 'refused'));
  second.c.stop();
});

test('takeToken reads #token= and removes it from the address bar', () => {
  const calls = [];
  const history = { replaceState: (...a) => calls.push(a) };
  assert.equal(takeToken({ hash: '#token=ab%2Bc-9', pathname: '/', search: '?x=1' }, history), 'ab+c-9');
  assert.deepEqual(calls, [[null, '', '/?x=1']]);
  assert.equal(takeToken({ hash: '#view=1&token=t0k', pathname: '/p', search: '' }, history), 't0k');
  assert.equal(takeToken({ hash: '', pathname: '/', search: '' }, history), null);
  assert.equal(takeToken({ hash: '#token=%E0%A4%A', pathname: '/', search: '' }, history), null);
  assert.equal(calls.length, 3); /* a malformed token is removed too */
});

test('a token is sent as auth after every hello that asks for one, and only then', async () => {
  const { c } = make({}, 'secret-token-123456');
  c.start();
  let ws = FakeSocket.all[0];
  ws.accept();
  ws.text({ ...HELLO, access: 'open' });
  assert.equal(ws.sent.length, 0);
  ws.drop();
  await sleep(20);
  ws = FakeSocket.all[1];
  ws.accept();
  ws.text({ ...HELLO, access: 'token' });
  assert.equal(ws.sent.length, 1);
  const auth = JSON.parse(ws.sent[0]);
  assert.equal(auth.type, 'auth');
  assert.equal(auth.token, 'secret-token-123456');
  c.stop();
  const { c: c2 } = make();
  c2.start();
  FakeSocket.all[0].accept();
  FakeSocket.all[0].text({ ...HELLO, access: 'token' });
  assert.equal(FakeSocket.all[0].sent.length, 0); /* no token: read-only, nothing sent */
  c2.stop();
});
