// Tests web/stream_client.js's requests with a fake worker: replies settle the page's requests
// (client.js Requests), error replies reject with the code and field, a lost connection rejects
// what is pending, and messages that answer nothing of the page's (the worker's own requests,
// announcements) go to onMessage.
import test from 'node:test';
import assert from 'node:assert/strict';

class FakeWorker {
  static last = null;
  constructor() { this.posted = []; FakeWorker.last = this; }
  postMessage(m) { this.posted.push(m); }
}
globalThis.Worker = FakeWorker;
const { StreamClient } = await import('../../web/stream_client.js');
const { ProtocolError } = await import('../../web/client.js');

test('requests settle with their replies; a lost connection rejects the pending ones', async () => {
  const msgs = [];
  const sc = new StreamClient({ onHello: () => {}, onMessage: (m) => msgs.push(m), onStatus: () => {} });
  const w = FakeWorker.last;
  assert.equal(sc.request({ type: 'reset' }), null, 'nothing is sent before hello');
  w.onmessage({ data: { type: 'hello', hello: {} } });
  const a = sc.request({ type: 'set_params', values: { gravity: 1 } });
  const b = sc.request({ type: 'set_params', values: { gravity: -1 } });
  const [ida, idb] = w.posted.map((p) => p.message.id);
  assert.notEqual(ida, idb);
  w.onmessage({ data: { type: 'message', message: { type: 'ok', id: 'w1' } } });
  w.onmessage({ data: { type: 'message', message: { type: 'error', id: idb, code: 'out_of_range', field: 'values.gravity', message: 'no' } } });
  w.onmessage({ data: { type: 'message', message: { type: 'ok', id: ida, step: 7 } } });
  assert.equal((await a).step, 7);
  await assert.rejects(b, (e) => e instanceof ProtocolError && e.code === 'out_of_range' && e.field === 'values.gravity');
  assert.deepEqual(msgs, [{ type: 'ok', id: 'w1' }]);
  const c = sc.request({ type: 'pause' });
  w.onmessage({ data: { type: 'status', status: { state: 'lost', reason: 'gone' } } });
  await assert.rejects(c, /the connection was lost before the reply came/);
  assert.equal(sc.request({ type: 'pause' }), null);
});
