// Worker: holds the WebSocket to strandcastd (so frames keep being read, and pings answered,
// however busy the page's main thread is drawing), decodes strand frames with codec.js, smooths
// the guides (Catmull-Rom), computes their tangents and normals, and posts the
// newest result back in transferable Float32Arrays that the page returns for reuse (at most
// POOL buffers exist per configuration; frames decoded while none is free are not posted).
// A buffer holds two RGBA32F texture images of texW x texH texels, point k of guide g at texel
// g * pts + k: (position xyz, normal coordinate a), then (tangent xyz, normal coordinate b).
// Each frame carries the head transform the simulation used for it (its header), which goes
// with it to the page. Control messages pass through to the page as parsed objects.
// Configured for a hair mesh instead (config mode 'hairmesh'), it takes the hair mesh frames
// (codec id 2) and posts the mesh's vertices as one RGBA32F image of texW x texH texels (texel
// c * nlayers + l: column c, layer l; xyz, w unused); frames of the other codec are skipped.
import { CODEC_ID_HAIRMESH, CODEC_ID_STRAND, StrandDecoder } from './codec.js';
import { frameHeader } from './client.js';
import { catmullWeights, smoothedCount, smoothStrands } from './catmull.js';
import { strandFrames } from './frames.js';
import { Connection } from './net.js';

const POOL = 3;
const KEYFRAME_REQUEST_MS = 1000;

const st = {
  gen: 0,
  mesh: false,        // configured for hair mesh frames (nstrands = columns, nverts = layers)
  nstrands: 0,
  nverts: 0,
  segs: 2,
  pts: 0,
  texW: 0,
  texH: 0,
  block: 0,           // floats per texture image (texW * texH * 4)
  basis: new Float64Array(6),
  free: [],
  allocated: 0,
  weights: null,
  rootState: null,
  decoder: new StrandDecoder(),
  connection: null,
  lastKeyRequest: -Infinity,
};

// { type: 'config', gen, nstrands, nverts, segs, maxTexW, mode: 'strands' | 'hairmesh' }
function configure(m) {
  st.gen = m.gen;
  st.mesh = m.mode === 'hairmesh';
  st.nstrands = m.nstrands;
  st.nverts = m.nverts;
  st.segs = m.segs;
  st.pts = st.mesh ? m.nverts : smoothedCount(m.nverts, m.segs);
  const texels = st.nstrands * st.pts;
  st.texW = Math.max(1, Math.min(m.maxTexW, texels));
  st.texH = Math.max(1, Math.ceil(texels / st.texW));
  st.block = st.texW * st.texH * 4;
  st.free = [];
  st.allocated = 0;
  st.weights = catmullWeights(m.segs);
  st.rootState = new Float32Array(3 * st.nstrands);
  postMessage({ type: 'configured', gen: st.gen, mode: st.mesh ? 'hairmesh' : 'strands', pts: st.pts, texW: st.texW, texH: st.texH, tanOffset: st.block });
}

function takeBuffer() {
  if (st.free.length) return st.free.pop();
  if (st.allocated < POOL) {
    st.allocated++;
    return new Float32Array(st.mesh ? st.block : 2 * st.block);
  }
  return null;
}

function requestKeyframe() {
  const now = performance.now();
  if (now - st.lastKeyRequest < KEYFRAME_REQUEST_MS) return;
  st.lastKeyRequest = now;
  st.connection.send({ type: 'keyframe' });
}

function onFrame(data) {
  // arrival on the epoch clock: the page's performance.now() has another origin
  const arrival = performance.timeOrigin + performance.now();
  const bytes = new Uint8Array(data);
  const t0 = performance.now();
  let info;
  try {
    info = st.decoder.decode(bytes);
  } catch (e) {
    if (/needs keyframe/.test(e.message)) requestKeyframe();
    else postMessage({ type: 'error', message: e.message });
    return;
  }
  const decoded = info.positions;
  const t1 = performance.now();
  if (info.nstrandsSent !== st.nstrands || info.nverts !== st.nverts) return; // not configured for it (yet)
  if (info.codec !== (st.mesh ? CODEC_ID_HAIRMESH : CODEC_ID_STRAND)) return; // the other source's frames
  const buf = takeBuffer();
  if (!buf) return; // the page has not drawn the previous ones yet: skip this frame
  if (st.mesh) {
    for (let k = 0, n = st.nstrands * st.nverts; k < n; k++) {
      buf[4 * k] = decoded[3 * k]; buf[4 * k + 1] = decoded[3 * k + 1]; buf[4 * k + 2] = decoded[3 * k + 2];
    }
  } else {
    smoothStrands(buf, 0, 4, decoded, 0, st.nstrands, st.nverts, st.segs, st.weights);
    strandFrames(buf, 0, buf, st.block, st.nstrands, st.pts, st.rootState, st.basis);
  }
  const t2 = performance.now();
  // the header as the client module gives it (seq, simTime, simStep, keyframe, head, counts, bytes)
  postMessage({ type: 'frame', gen: st.gen, buf, arrival, ...frameHeader(info), decodeMs: t1 - t0, prepareMs: t2 - t1 }, [buf.buffer]);
}

function start(url, backoff, token) {
  st.connection = new Connection(url, {
    onHello: (h) => { st.decoder.reset(); postMessage({ type: 'hello', hello: h }); },
    onMessage: (m) => {
      if (m.type === 'groom') st.decoder.reset();
      postMessage({ type: 'message', message: m });
    },
    onBinary: onFrame,
    onStatus: (s) => postMessage({ type: 'status', status: s }),
  }, backoff, token);
  st.connection.start();
}

self.onmessage = (ev) => {
  const m = ev.data;
  if (m.type === 'start') start(m.url, m.backoff, m.token);
  else if (m.type === 'send') st.connection.send(m.message);
  else if (m.type === 'config') configure(m);
  else if (m.type === 'recycle') { if (m.gen === st.gen && m.buf.length === (st.mesh ? 1 : 2) * st.block && st.free.length < POOL) st.free.push(m.buf); }
};
