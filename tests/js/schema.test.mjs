// Protocol schema test: every JSON Schema in proto/schema compiles, accepts and refuses sample
// client messages, and every text message the real strandcastd sends validates against the
// schema of its type. usage: STRANDCASTD=path node --test tests/js/schema.test.mjs
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { spawn } from 'node:child_process';
import { mkdtempSync, readdirSync, readFileSync, rmSync, writeFileSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { dirname, join } from 'node:path';
import { fileURLToPath } from 'node:url';
import { createRequire } from 'node:module';
import { parseGroomData } from '../../web/groom_data.js';

const require = createRequire(import.meta.url);
const Ajv2020 = require('ajv/dist/2020').default;
const WebSocket = require('ws');

const here = dirname(fileURLToPath(import.meta.url));
const schemaDir = join(here, '..', '..', 'proto', 'schema');

function loadSchemas() {
  const ajv = new Ajv2020({ strict: true, strictRequired: false, allErrors: true });
  const names = readdirSync(schemaDir).filter((f) => f.endsWith('.json')).sort();
  for (const f of names) ajv.addSchema(JSON.parse(readFileSync(join(schemaDir, f), 'utf8')));
  const get = (name) => {
    const v = ajv.getSchema(`https://strandcast.invalid/schema/${name}.json`);
    assert.ok(v, `no schema ${name}`);
    return v;
  };
  return { names, get };
}

function check(validate, msg, want) {
  const ok = validate(msg);
  assert.equal(ok, want, `${JSON.stringify(msg)}: ${JSON.stringify(validate.errors)}`);
}

const CLIENT_OK = [
  { type: 'get_params', id: 1 },
  { type: 'set_params', id: 'a', values: { gravity: 0, sph: false, substeps: 2 } },
  { type: 'set_params', values: { solver: 'pbd', pbd_iterations: 6 } },
  { type: 'set_params', values: { solver: 'dftl' } },
  { type: 'motion', t: 12.5, position: [0, 0.05, 0], orientation: [0, 0.3826834, 0, 0.9238795] },
  { type: 'animate', preset: 'nod', speed: 2 },
  { type: 'reset' }, { type: 'pause' }, { type: 'resume' }, { type: 'step', count: 3 },
  { type: 'set_groom', style: 'wavy', strands: 32, verts: 6 },
  { type: 'set_groom', file: 'tiny.hair', verts: 5 },
  { type: 'set_groom', file: 'tiny.hair', verts: 5, collider: 'tet.obj' },
  { type: 'set_groom', style: 'wavy', collider: null },
  { type: 'subscribe', stride: 2, max_error: 0.001, max_rate: 30 },
  { type: 'keyframe', id: 9 },
  { type: 'auth', id: 10, token: 'k3Jq9-Vx2Lm7Tz8Wb4Np6Rs1Yd5Hf0Gc' },
];
const CLIENT_BAD = [
  { type: 'auth' },
  { type: 'auth', token: 5 },
  { type: 'set_params', values: {} },
  { type: 'set_params', values: { gravity: null } },
  { type: 'set_params', values: { solver: ['pbd'] } },
  { type: 'motion', position: [0, 0], orientation: [0, 0, 0, 1] },
  { type: 'motion', position: [0, 0, 9], orientation: [0, 0, 0, 1] },
  { type: 'step', count: 0 },
  { type: 'step', count: 1.5 },
  { type: 'set_groom', style: 'wavy', file: 'a.tfx' },
  { type: 'set_groom', file: '../etc/passwd' },
  { type: 'set_groom', file: 'a//b.tfx' },
  { type: 'set_groom', file: 'a.tfx', strands: 3 },
  { type: 'set_groom', style: 'wavy', collider: '../x.obj' },
  { type: 'set_groom', style: 'wavy', collider: 7 },
  { type: 'set_groom', style: 'wavy', collider: '' },
  { type: 'subscribe', max_error: 0 },
  { type: 'reset', extra: 1 },
  { type: 'pause', id: { no: 1 } },
];

test('schemas compile and sort client messages', () => {
  const { names, get } = loadSchemas();
  assert.ok(names.length >= 20);
  for (const m of CLIENT_OK) check(get(`client.${m.type}`), m, true);
  for (const m of CLIENT_BAD) check(get(`client.${m.type}`), m, false);
});

/* A tiny Cem Yuksel .hair file: 16 strands of 8 points. */
function tinyHair() {
  const buf = Buffer.alloc(128 + 16 * 8 * 12);
  buf.write('HAIR', 0, 'latin1');
  buf.writeUInt32LE(16, 4);
  buf.writeUInt32LE(128, 8);
  buf.writeUInt32LE(2, 12);
  buf.writeUInt32LE(7, 16);
  for (let s = 0; s < 16; s++) {
    for (let k = 0; k < 8; k++) {
      const a = (2 * Math.PI * s) / 16, o = 128 + 12 * (s * 8 + k);
      buf.writeFloatLE(0.07 * Math.cos(a), o);
      buf.writeFloatLE(0.05 - 0.02 * k, o + 4);
      buf.writeFloatLE(0.07 * Math.sin(a), o + 8);
    }
  }
  return buf;
}

function startDaemon(assets) {
  const exe = process.env.STRANDCASTD;
  assert.ok(exe, 'set STRANDCASTD to the strandcastd binary');
  const child = spawn(exe, ['--port', '0', '--strands', '64', '--verts', '8', '--threads', '1', '--assets', assets, '--min-step-rate', '0'],
                      { stdio: ['ignore', 'pipe', 'inherit'] });
  return new Promise((resolve, reject) => {
    let out = '';
    const timer = setTimeout(() => reject(new Error('strandcastd printed no URL')), 20000);
    child.stdout.on('data', (d) => {
      out += d;
      const m = /http:\/\/[^:]+:(\d+)\//.exec(out);
      if (m) { clearTimeout(timer); resolve({ child, port: Number(m[1]) }); }
    });
    child.on('exit', (code) => reject(new Error(`strandcastd exited early (${code})`)));
  });
}

function open(port, path = '/') {
  const ws = new WebSocket(`ws://127.0.0.1:${port}${path}`, 'strandcast.v3');
  const texts = [];
  let waiters = [];
  ws.on('message', (data, isBinary) => {
    if (isBinary) return;
    texts.push(JSON.parse(data.toString('utf8')));
    waiters = waiters.filter((w) => !w());
  });
  const until = (pred, what) => new Promise((resolve, reject) => {
    const timer = setTimeout(() => reject(new Error(`timed out waiting for ${what}`)), 15000);
    const w = () => { const m = texts.find(pred); if (m) { clearTimeout(timer); resolve(m); return true; } return false; };
    if (!w()) waiters.push(w);
  });
  return new Promise((resolve, reject) => {
    ws.on('open', () => resolve({ ws, texts, until }));
    ws.on('error', reject);
  });
}

test('every server message validates against its schema', async () => {
  const { get } = loadSchemas();
  const dir = mkdtempSync(join(tmpdir(), 'strandcast-schema-'));
  writeFileSync(join(dir, 'tiny.hair'), tinyHair());
  // a closed tetrahedron (counter-clockwise seen from outside) around the tiny groom's roots
  // a layered hair mesh: one quad over the tiny groom's roots and the same quad 5 cm further out
  writeFileSync(join(dir, 'cap.hairmesh.obj'), 'v 0 0 0\nv 0.01 0 0\nv 0.01 0 0.01\nv 0 0 0.01\nv 0 -0.05 0\nv 0.01 -0.05 0\nv 0.01 -0.05 0.01\nv 0 -0.05 0.01\nf 1 4 3 2\n');
  writeFileSync(join(dir, 'tet.obj'), 'v -0.2 -0.2 -0.2\nv 0.3 -0.2 -0.2\nv -0.2 0.3 -0.2\nv -0.2 -0.2 0.3\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n');
  const { child, port } = await startDaemon(dir);
  try {
    const a = await open(port), b = await open(port, '/rooms/default');
    await a.until((m) => m.type === 'hello', 'hello');
    await b.until((m) => m.type === 'hello', 'hello');
    // a room this server does not serve, and a name that is no room name: an error, then a close
    const elsewhere = await open(port, '/rooms/elsewhere'), badRoom = await open(port, '/rooms/no.dots');
    await elsewhere.until((m) => m.type === 'error' && m.code === 'unknown_room', 'unknown_room');
    await badRoom.until((m) => m.type === 'error' && m.code === 'bad_room', 'bad_room');
    const send = (c, m) => c.ws.send(JSON.stringify(m));
    let id = 100;
    for (const m of CLIENT_OK) {
      const msg = { ...m, id: ++id };
      if (msg.type === 'step') send(a, { type: 'pause', id: ++id });
      send(a, msg);
      const want = ++id - 1;
      await a.until((r) => r.id === want, `reply to ${m.type}`);
    }
    const bad = [{ type: 'fly' }, { type: 'set_params', values: { nope: 1 } }, { type: 'step' },
                 { type: 'set_groom', file: 'missing.tfx' }, { type: 'set_params', values: { solver: 'verlet' } },
                 { type: 'set_params', values: { solver: 'hairmesh' } }];
    send(a, { type: 'resume', id: ++id });
    const ids = [];
    for (const m of bad) { ids.push(++id); send(a, { ...m, id }); }
    a.ws.send('{"type":');
    ids.push(++id);
    a.ws.send(`{"type":"set_params","id":${id},"values":{"gravity":1e999}}`);
    // replies are matched by id: errors found while reading (bad JSON, ranges) are answered at
    // once, the rest at the next step boundary, so the last reply may come before earlier ones
    for (const want of ids) await a.until((r) => r.id === want, `the error for id ${want}`);
    await b.until((m) => m.type === 'stats', 'stats');
    await b.until((m) => m.type === 'groom', 'groom');
    const seen = new Set();
    for (const m of [...a.texts, ...b.texts, ...elsewhere.texts, ...badRoom.texts]) {
      check(get(`server.${m.type}`), m, true);
      seen.add(m.type);
    }
    for (const t of ['hello', 'params', 'ok', 'error', 'state', 'groom', 'subscribed', 'stats']) assert.ok(seen.has(t), `no ${t} seen`);
    // the replies to requests that change the simulation say from which step it shows, the others not
    const oks = a.texts.filter((m) => m.type === 'ok');
    for (const r of ['set_params', 'animate', 'reset', 'pause', 'resume', 'step']) {
      assert.ok(oks.some((m) => m.request === r && Number.isInteger(m.step)), `ok of ${r} without step`);
    }
    assert.ok(oks.filter((m) => m.request === 'keyframe').every((m) => m.step === undefined), 'ok of keyframe with a step');
    assert.ok(oks.some((m) => m.request === 'reset' && m.step === 0), 'reset does not show at step 0');
    // the stiffnesses span many decades: their schema entries ask for log sliders, the rest not
    const hello = a.texts.find((m) => m.type === 'hello');
    const logs = hello.params.schema.filter((e) => e.scale !== undefined).map((e) => `${e.name}:${e.scale}`);
    assert.deepEqual(logs, ['global_stiffness:log', 'local_stiffness:log', 'hm_stretch_stiffness:log', 'hm_shear_stiffness:log',
                            'hm_bend_stiffness:log', 'hm_volume_stiffness:log', 'hm_cg_tolerance:log']);
    const withEntry = (patch) => {
      const h = structuredClone(hello);
      Object.assign(h.params.schema.find((e) => e.name === 'local_stiffness'), patch);
      return h;
    };
    check(get('server.hello'), withEntry({ scale: 'linear' }), false);
    check(get('server.hello'), withEntry({ type: 'int' }), false);
    check(get('server.hello'), withEntry({ min: -1 }), false);
    // the solver is an enum: its choices, a string default; each solver's own parameters say so
    const solver = hello.params.schema.find((e) => e.name === 'solver');
    assert.equal(solver.type, 'enum');
    assert.deepEqual(solver.choices, ['dftl', 'hairmesh', 'pbd']);
    assert.equal(solver.default, 'dftl');
    assert.equal(hello.params.values.solver, 'dftl');
    assert.deepEqual(hello.params.schema.find((e) => e.name === 'pbd_iterations').solvers, ['pbd']);
    assert.deepEqual(hello.params.schema.find((e) => e.name === 'dftl_correction').solvers, ['dftl', 'pbd']);
    assert.deepEqual(hello.params.schema.find((e) => e.name === 'repulsion').solvers, ['dftl']);
    assert.equal(hello.params.schema.find((e) => e.name === 'gravity').solvers, undefined);
    // the hair-mesh solver's own parameters: hm_ names, for hairmesh only, with ranges and units
    const hm = hello.params.schema.filter((e) => e.name.startsWith('hm_'));
    assert.deepEqual(hm.map((e) => e.name), ['hm_stretch_stiffness', 'hm_shear_stiffness', 'hm_bend_stiffness', 'hm_volume_stiffness',
                                             'hm_damping', 'hm_cg_iterations', 'hm_cg_tolerance', 'hm_deform_min']);
    for (const e of hm) assert.deepEqual(e.solvers, ['hairmesh'], e.name);
    assert.equal(hm.find((e) => e.name === 'hm_bend_stiffness').unit, '1/s^2');
    assert.equal(hm.find((e) => e.name === 'hm_damping').max, 8);
    assert.deepEqual(hello.grooms.styles, ['straight', 'wavy', 'curly', 'hairmesh:straight', 'hairmesh:wavy', 'hairmesh:curly']);
    check(get('server.hello'), withEntry({ choices: ['a'] }), false); // choices only on an enum
    const enumEntry = (patch) => {
      const h = structuredClone(hello);
      Object.assign(h.params.schema.find((e) => e.name === 'solver'), patch);
      return h;
    };
    check(get('server.hello'), enumEntry({ choices: undefined }), false);
    check(get('server.hello'), enumEntry({ default: 0 }), false);
    check(get('server.hello'), enumEntry({ solvers: [] }), false);
    // the switch was announced to every client with the solver's name
    for (const c of [a, b]) {
      const named = c.texts.filter((m) => m.type === 'params' && Array.isArray(m.changed) && m.changed.includes('solver')).map((m) => m.values.solver);
      assert.deepEqual(named.slice(-2), ['pbd', 'dftl']);
    }
    const refused = a.texts.filter((m) => m.type === 'error' && String(m.field).startsWith('values')).map((m) => m.message);
    assert.ok(refused.some((t) => t.includes('one of: dftl, hairmesh, pbd')), `no refusal of an unknown solver: ${refused}`);
    assert.ok(refused.some((t) => t.includes('hair-mesh groom')), `no refusal of hairmesh on strands: ${refused}`);
    assert.ok(b.texts.some((m) => m.type === 'groom' && m.collider_mesh && m.collider_mesh.source === 'tet.obj'), 'no groom with the mesh');
    assert.deepEqual(b.texts.find((m) => m.type === 'hello').grooms.colliders, ['tet.obj']);
    // the groom's data binary the hello names, read by the viewer's parser (the groom may have
    // changed since: then the server's bytes carry the newest groom message's tag)
    const groomMsgs = [hello.groom, ...b.texts.filter((m) => m.type === 'groom').map((m) => m.groom)];
    const r = await fetch(`http://127.0.0.1:${port}${hello.groom.url}`);
    assert.equal(r.status, 200);
    const tag = r.headers.get('etag').replace(/"/g, '');
    const described = groomMsgs.filter((g) => g.etag === tag).pop();
    assert.ok(described, `the ETag ${tag} is no groom's etag`);
    const data = parseGroomData(await r.arrayBuffer());
    assert.equal(data.strands, described.strands);
    assert.equal(data.verts, described.verts);
    assert.equal(16 + 16 * data.strands, described.bytes);
    // a .hairmesh.obj is a groom file, not a collision mesh; set_groom loads it as a hair mesh
    assert.ok(hello.grooms.files.includes('cap.hairmesh.obj') && !hello.grooms.colliders.includes('cap.hairmesh.obj'));
    // (its 4,096 guides share one 1 cm face: SPH off, or the crowd slows every step)
    send(a, { type: 'set_params', id: 'nosph', values: { sph: false } });
    await a.until((m) => m.id === 'nosph', 'the reply to set_params sph false');
    send(a, { type: 'set_groom', id: 'hm', file: 'cap.hairmesh.obj', verts: 6, collider: null });
    const hmReply = await a.until((m) => m.id === 'hm', 'the reply to the hair-mesh set_groom');
    assert.equal(hmReply.type, 'ok', JSON.stringify(hmReply));
    const hmGroom = await b.until((m) => m.type === 'groom' && m.groom.source === 'file:cap.hairmesh.obj', 'the hair-mesh groom');
    assert.ok(hmGroom.groom.hairmesh, 'the hair-mesh groom names its hair mesh');
    assert.equal(hmGroom.groom.verts, 6);
    check(get('server.groom'), hmGroom, true);
    const codes = new Set(a.texts.filter((m) => m.type === 'error').map((m) => m.code));
    for (const c of ['unknown_type', 'unknown_param', 'bad_state', 'not_found', 'not_finite', 'bad_json']) assert.ok(codes.has(c), `no ${c}`);
    a.ws.close();
    b.ws.close();
  } finally {
    const exited = new Promise((resolve) => child.on('exit', (code, sig) => resolve({ code, sig })));
    child.kill('SIGTERM');
    const { code } = await exited;
    rmSync(dir, { recursive: true, force: true });
    assert.equal(code, 0, 'strandcastd exits 0 on SIGTERM');
  }
});
