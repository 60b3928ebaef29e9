// Worker: decodes strand frames with codec.js, smooths the guides (Catmull-Rom), computes their
// normals and the head pose, and posts the result back in transferable Float32Arrays that the
// page returns for reuse (at most POOL buffers exist per configuration).
import { StrandDecoder } from './codec.js';
import { catmullWeights, smoothedCount, smoothStrands } from './catmull.js';
import { strandNormals } from './frames.js';
import { fitRigid, rigidScratch } from './rigid.js';

const POOL = 3;

const st = {
  gen: 0,
  nstrands: 0,
  nverts: 0,
  segs: 2,
  pts: 0,
  texW: 0,
  texH: 0,
  block: 0,           // floats per texture block (texW * texH * 3)
  restRoots: null,
  free: [],
  allocated: 0,
  weights: null,
  rootState: null,
  head: { q: [0, 0, 0, 1], t: [0, 0, 0] },
  rigid: rigidScratch(),
  decoder: null,
};

// { type: 'config', gen, nstrands, nverts, segs, maxTexW, restRoots: Float32Array }
function configure(m) {
  st.gen = m.gen;
  st.nstrands = m.nstrands;
  st.nverts = m.nverts;
  st.segs = m.segs;
  st.pts = smoothedCount(m.nverts, m.segs);
  const texels = st.nstrands * st.pts;
  st.texW = Math.max(1, Math.min(m.maxTexW, texels));
  st.texH = Math.max(1, Math.ceil(texels / st.texW));
  st.block = st.texW * st.texH * 3;
  st.restRoots = m.restRoots;
  st.free = [];
  st.allocated = 0;
  st.weights = catmullWeights(m.segs);
  st.rootState = new Float32Array(3 * st.nstrands);
  st.head = { q: [0, 0, 0, 1], t: [0, 0, 0] };
  postMessage({ type: 'configured', gen: st.gen, pts: st.pts, texW: st.texW, texH: st.texH, nrmOffset: st.block });
}

function takeBuffer() {
  if (st.free.length) return st.free.pop();
  if (st.allocated < POOL) {
    st.allocated++;
    return new Float32Array(2 * st.block);
  }
  return null;
}

function onFrame(data, arrival) {
  if (!st.decoder) st.decoder = new StrandDecoder();
  const bytes = new Uint8Array(data);
  const t0 = performance.now();
  let info;
  try {
    info = st.decoder.decode(bytes);
  } catch (e) {
    postMessage({ type: 'error', message: e.message, needKeyframe: /needs keyframe/.test(e.message) });
    return;
  }
  const decoded = info.positions;
  const t1 = performance.now();
  if (info.nstrandsSent !== st.nstrands || info.nverts !== st.nverts) {
    postMessage({ type: 'skipped', gen: st.gen, strands: info.nstrandsSent, verts: info.nverts, seq: info.seq });
    return;
  }
  const buf = takeBuffer();
  if (!buf) {
    postMessage({ type: 'dropped', seq: info.seq });
    return;
  }
  smoothStrands(buf, 0, decoded, 0, st.nstrands, st.nverts, st.segs, st.weights);
  strandNormals(buf, st.block, buf, 0, st.nstrands, st.pts, st.rootState);
  const headOk = st.restRoots && st.restRoots.length === 3 * st.nstrands &&
    fitRigid(st.head, st.restRoots, decoded, 0, 3 * st.nverts, st.nstrands, Math.max(1, Math.floor(st.nstrands / 256)), st.rigid);
  const t2 = performance.now();
  postMessage({
    type: 'frame', gen: st.gen, buf, arrival,
    seq: info.seq, simTime: info.simTime, keyframe: info.keyframe, bytes: data.byteLength,
    head: headOk ? { position: st.head.t.slice(), orientation: st.head.q.slice() } : null,
    decodeMs: t1 - t0, prepareMs: t2 - t1,
  }, [buf.buffer]);
}

self.onmessage = (ev) => {
  const m = ev.data;
  if (m.type === 'config') configure(m);
  else if (m.type === 'frame') onFrame(m.data, m.arrival);
  else if (m.type === 'recycle') { if (m.gen === st.gen && m.buf.length === 2 * st.block && st.free.length < POOL) st.free.push(m.buf); }
  else if (m.type === 'reset') { if (st.decoder) st.decoder.reset(); }
};
