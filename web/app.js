// The viewer application: wires the stream worker (connection and decoding), the renderer, the
// panel and input; owns the scene state (groom, colliders, head pose, view settings) and the
// render loop.
import { OrbitCamera } from './camera.js';
import { buildLayout } from './interp.js';
import { rendererName, softwareWebGL } from './gl_util.js';
import { Input } from './input.js';
import { dragRotate, dragTranslate, motionMessage } from './motion.js';
import { defaultUrl, takeToken } from './net.js';
import { ProtocolError } from './client.js';
import { Banner, statsText } from './overlay.js';
import { Panel } from './panel.js';
import { pickColliders } from './pick.js';
import { ColliderMeshLoader, blobUrl, httpBase } from './collider_mesh.js';
import { GroomDataLoader } from './groom_data.js';
import { meshStrands, strandParams } from './hairmesh.js';
import { parseHairmeshData } from './hairmesh_data.js';
import { Renderer } from './renderer.js';
import { StreamClient } from './stream_client.js';
import { Ema, LatencyEstimator, RateMeter } from './stats.js';
import { VIEW_SPECS, applySetting, defaultSettings } from './view_settings.js';

// The protocol accepts head positions within +-5 m per axis (PROTOCOL.md, motion).
const MAX_HEAD_POSITION = 5;

function finiteArray(a, n) {
  return Array.isArray(a) && (n === undefined || a.length === n) && a.every(Number.isFinite);
}

export class App {
  // antialias: multisampling on or off; undefined = on unless WebGL runs on a CPU rasterizer.
  constructor({ canvas, panelEl, statsEl, bannerEl, url, antialias }) {
    this.canvas = canvas;
    this.statsEl = statsEl;
    this.banner = new Banner(bannerEl);
    this.antialias = antialias === undefined ? !softwareWebGL() : !!antialias;
    const gl = canvas.getContext('webgl2', { antialias: this.antialias, alpha: false, powerPreference: 'high-performance' });
    if (!gl) throw new Error('This browser has no WebGL2: strandcast cannot draw the hair.');
    this.gl = gl;
    this.rendererName = rendererName(gl);
    this.settings = defaultSettings();
    this.camera = new OrbitCamera({ yaw: 0.5, pitch: 0.2, distance: 0.8, target: [0, 0.05, 0] });
    this.renderer = new Renderer(canvas, gl);
    this.maxTexW = Math.min(4096, gl.getParameter(gl.MAX_TEXTURE_SIZE));
    // scene
    this.groom = null;          // hello.groom (applied: its data arrived)
    this.groomData = null;      // its /groom.bin (groom_data.js)
    this.cameraFramed = false;  // the camera was framed on the first hello's groom
    this.colliders = [];
    this.roots = null;          // Float32Array, rest roots (head frame)
    this.head = { position: new Float64Array(3), orientation: new Float64Array([0, 0, 0, 1]) };
    this.drag = null;           // { mode, pos, q, worldPerPx } while dragging the head
    this.dragHead = { position: new Float64Array(3), orientation: new Float64Array([0, 0, 0, 1]) };
    this.motionDirty = false;
    this.guideConfig = null;    // { mode, pts, texW, texH, tanOffset } from the worker
    this.hairmesh = null;       // the groom's hair mesh topology (hairmesh_data.js), or null
    this.hairmeshEtag = null;   // the version of it held or being fetched
    this.meshStream = false;    // subscribed to the hair mesh (frames are hair mesh frames)
    this.layoutPerGuide = 0;
    this.paused = false;
    // statistics
    this.fps = new RateMeter(2000, 512);
    this.frames = new RateMeter(2000, 512);
    this.latency = new LatencyEstimator(10000, 1024);
    this.decodeMs = new Ema(0.1);
    this.prepareMs = new Ema(0.1);
    this.uploadMs = new Ema(0.1);
    this.seq = null;
    this.serverStats = null;
    this.framesRendered = 0;
    this.framesUploaded = 0;
    this.totals = { frames: 0, bytes: 0, decodeMs: 0, prepareMs: 0, uploads: 0, uploadMs: 0, draws: 0, drawMs: 0 }; // for benchmarks
    // Benchmark mode: wait for the GPU before and after each upload and draw, so that their
    // times are their own and not the wait for earlier work (slower overall; tests only).
    this.benchmarkTiming = false;
    this.syncPixel = new Uint8Array(4);
    this.clientId = null;
    this.lastOverlay = 0;
    this.captureWaiters = [];
    this.contextLost = false;
    this.dirty = true;                  // something changed since the last drawn frame
    this.viewKey = new Float64Array(8); // camera and canvas size at the last drawn frame
    this.refused = null;

    this.panel = new Panel(panelEl, {
      setParams: (values) => this.request({ type: 'set_params', values }),
      animate: (preset, speed) => this.request({ type: 'animate', preset, speed }),
      reset: () => this.request({ type: 'reset' }),
      pause: () => this.request({ type: 'pause' }),
      resume: () => this.request({ type: 'resume' }),
      step: () => this.request({ type: 'step', count: 1 }),
      setGroom: (spec) => this.request({ type: 'set_groom', ...spec }),
      setView: (name, value) => this.setView(name, value),
    });
    this.panel.buildView(VIEW_SPECS, this.settings);

    this.url = url || defaultUrl(location);
    this.colliderMesh = null;   // the parsed collision mesh drawn now (head frame), or null
    this.meshLoader = new ColliderMeshLoader(httpBase(this.url), (m) => {
      this.colliderMesh = m;
      if (!this.contextLost) this.renderer.head.setMesh(m);
      this.dirty = true;
    }, (message) => this.panel.showStatus(`collision mesh not drawn: ${message}`, true));
    // the groom is applied once its per-strand data (GET groom.url) is at hand
    this.groomLoader = new GroomDataLoader(httpBase(this.url), (g, data, colliders) => this._applyGroom(g, colliders, data),
      (message) => this.panel.showStatus(`groom not drawn: ${message}`, true));
    this.stream = new StreamClient({
      onHello: (h) => this._onHello(h),
      onMessage: (m) => this._onMessage(m),
      onStatus: (s) => this._onStatus(s),
      onConfigured: (cfg) => this._onConfigured(cfg),
      onDecoded: (m) => this._onDecoded(m),
      onError: (message) => this.panel.showStatus(message, true),
    });

    this.input = new Input(canvas, this.camera, {
      hitHead: (x, y) => this._hitHead(x, y),
      headStart: (mode) => this._headStart(mode),
      headDrag: (dx, dy) => this._headDrag(dx, dy),
      headEnd: () => { this.drag = null; this.dirty = true; },
    });

    canvas.addEventListener('webglcontextlost', (e) => {
      e.preventDefault();
      this.contextLost = true;
      this.banner.show('The WebGL context was lost; waiting for the browser to restore it…', true);
    });
    canvas.addEventListener('webglcontextrestored', () => {
      this.contextLost = false;
      this.renderer = new Renderer(canvas, gl);
      this.layoutPerGuide = 0;
      this.dirty = true;
      this.hairmeshEtag = null;
      if (this.groom) this._applyGroom(this.groom, this.colliders, this.groomData);
      this.renderer.head.setMesh(this.colliderMesh);
      this.banner.hide();
    });

    this._loop = this._loop.bind(this);
  }

  start() {
    this.token = takeToken(location, history);
    this.stream.start(this.url, undefined, this.token);
    requestAnimationFrame(this._loop);
  }

  // Sends a request (stream_client.js request()); an error reply is shown in the panel (and a
  // refused parameter's control goes back to the server's value). Returns the promise of the
  // reply, or null when not connected.
  request(msg) {
    const reply = this.stream.request(msg);
    if (reply === null) {
      this.panel.showStatus('not connected: the change was not sent', true);
      return null;
    }
    reply.catch((e) => this._refused(e));
    return reply;
  }

  _refused(e) {
    if (!(e instanceof ProtocolError)) {
      this.panel.showStatus(`no reply: ${e.message}`, true);
      return;
    }
    this.panel.showStatus(`server refused: ${e.message}`, true);
    if (e.field.startsWith('values.')) this.panel.revertParam(e.field.slice(7));
  }

  // Changes a viewer setting (also the hook tests use); returns false for a bad name or value.
  setView(name, value) {
    const rebuild = applySetting(this.settings, name, value);
    if (rebuild === null) return false;
    this.dirty = true;
    if (rebuild === 'layout') this._buildLayout();
    if (rebuild === 'smoothing') { this._buildMeshStrands(); this._configureWorker(); }
    if (rebuild === 'meshLayout') this._buildMeshStrands();
    if (rebuild === 'source') this._chooseSource();
    return true;
  }

  // ---- connection ----------------------------------------------------------------------

  _onStatus(s) {
    if (s.state !== 'connecting') console.info(`strandcast: connection ${s.state}${s.reason ? `: ${s.reason}` : ''}`);
    if (s.state === 'open') {
      this.refused = null;
      this.banner.hide();
    } else if (s.state === 'refused') {
      this.refused = s.reason;
      this.banner.show(`Protocol version mismatch? ${s.reason}. Still retrying…`, true);
    } else if (this.refused && (s.state === 'lost' || s.state === 'connecting')) {
      this.banner.show(`Protocol version mismatch? ${this.refused}. Retrying (attempt ${s.attempt})…`, true);
    } else if (s.state === 'lost') {
      this.banner.show(`Connection to strandcastd lost (${s.reason}). Reconnecting in ${(s.delayMs / 1000).toFixed(1)} s (attempt ${s.attempt})…`, false);
    } else if (s.state === 'connecting' && s.attempt > 0) {
      this.banner.show(`Reconnecting to strandcastd (attempt ${s.attempt})…`, false);
    } else if (s.state === 'no_room') {
      this.banner.show(`No such room here: ${s.reason}. Open / or a room this server serves (/rooms/NAME).`, true);
    } else if (s.state === 'mismatch') {
      this.banner.show(`Protocol version mismatch: ${s.reason}. This page cannot talk to this server; reload the page from the server you want to use.`, true);
    }
  }

  _onHello(h) {
    if (!h.groom || !Number.isInteger(h.groom.strands) || !Number.isInteger(h.groom.verts) || h.groom.strands < 1 || h.groom.verts < 2) {
      this.banner.show('The server sent a hello without a usable groom description.', true);
      return;
    }
    this.limits = h.limits || {};
    this.clientId = Number.isInteger(h.client) ? h.client : null;
    document.title = typeof h.room === 'string' && h.room !== 'default' ? `strandcast: ${h.room}` : 'strandcast';
    this.panel.buildParams(h.params || {});
    this.panel.buildMotion(h.presets, h.animation, this.limits);
    this.panel.buildGrooms(h.grooms, h.groom, this.limits);
    this.panel.updateState(h.state);
    this.paused = !!(h.state && h.state.paused);
    if (h.head && finiteArray(h.head.position, 3) && finiteArray(h.head.orientation, 4)) {
      this.head.position.set(h.head.position);
      this.head.orientation.set(h.head.orientation);
    }
    const first = !this.cameraFramed;
    this.cameraFramed = true;
    this.groomLoader.update(h.groom, h.colliders);
    this.meshLoader.update(h.collider_mesh);
    if (first && finiteArray(h.groom.bounds, 6)) this.camera.frame(h.groom.bounds);
    if (h.access === 'token' && !this.token) {
      this.panel.showStatus('read-only: this server needs its token to take changes (open the page as .../#token=TOKEN)', true);
    } else {
      this.panel.showStatus(`connected to ${h.server || 'server'} ${h.version || ''} as client ${h.client ?? '?'}`, false);
    }
  }

  _onMessage(m) {
    switch (m.type) {
      case 'params': this.panel.updateParams(m.values); break;
      case 'state':
        this.panel.updateState(m);
        if (typeof m.paused === 'boolean') this.paused = m.paused;
        this.latency.reset();
        break;
      case 'groom':
        this.groomLoader.update(m.groom, m.colliders);
        this.meshLoader.update(m.collider_mesh);
        break;
      case 'stats': this.serverStats = m; break;
      case 'subscribed': // without an id: the server moved this client (its hair mesh went away)
        if (m.stream && m.stream.codec === 'strand' && this.meshStream) {
          this._setMeshStream(false);
          this.panel.showStatus('the solver has no hair mesh any more: drawing the strands', true);
        }
        break;
      case 'error': this._refused(new ProtocolError(m)); break; // one without an id (a stream's)
      default: break;
    }
  }

  // ---- groom, layout and worker configuration -------------------------------------------

  // groom: a hello's or groom message's description; data: its parsed /groom.bin (groom_data.js)
  _applyGroom(groom, colliders, data) {
    if (!groom || !(groom.strands >= 1) || !(groom.verts >= 2) || !data) return;
    this.groom = groom;
    this.groomData = data;
    this.colliders = Array.isArray(colliders) ? colliders : [];
    this.roots = data.roots;
    this.renderer.head.setColliders(this.colliders);
    if (finiteArray(groom.bounds, 6)) this.renderer.setBounds(groom.bounds);
    this.guideConfig = null;
    this.renderer.hair.hasFrame = false;
    this.dirty = true;
    this._buildLayout();
    if (this.meshStream) this._setMeshStream(false); // a new groom starts on the strands
    this._loadHairmesh(groom.hairmesh);
    this._configureWorker();
  }

  // ---- hair mesh: topology, render strands, the stream's source ------------------------

  // Fetches the hair mesh topology a groom description names (null: the groom has none).
  _loadHairmesh(desc) {
    if (!desc || typeof desc.url !== 'string') {
      this.hairmesh = null;
      this.hairmeshEtag = null;
      return;
    }
    if (desc.etag === this.hairmeshEtag && this.hairmesh) { this._chooseSource(); return; }
    const etag = this.hairmeshEtag = desc.etag;
    this.hairmesh = null;
    fetch(blobUrl(desc.url, httpBase(this.url)), { cache: 'no-cache' })
      .then((r) => { if (!r.ok) throw new Error(`GET ${desc.url}: HTTP ${r.status}`); return r.arrayBuffer(); })
      .then((buf) => {
        if (this.hairmeshEtag !== etag) return; // superseded by a newer groom
        const m = parseHairmeshData(buf);
        if (m.ncols !== desc.ncols || m.nlayers !== desc.nlayers || m.nfaces !== desc.nfaces) throw new Error('hair mesh binary: its counts are not the groom\'s');
        this.hairmesh = m;
        if (!this.contextLost) this.renderer.meshHair.setTopology(m.faces, m.nfaces, m.ncols, m.nlayers, this.maxTexW);
        this._buildMeshStrands();
        this._chooseSource();
      })
      .catch((e) => { if (this.hairmeshEtag === etag) this.panel.showStatus(`hair mesh not drawn: ${e.message}`, true); });
  }

  // Render points per grown strand: segs per layer span.
  _meshPts() { return this.hairmesh ? (this.hairmesh.nlayers - 1) * this.settings.segs + 1 : 2; }

  _buildMeshStrands() {
    if (!this.hairmesh || this.contextLost) return;
    const m = this.hairmesh, pts = this._meshPts(), strands = meshStrands(m.faces, m.nfaces, this.settings.perFace);
    this.renderer.meshHair.setStrands(strands, pts, strandParams(m, m.rest, strands, pts), this.maxTexW);
    this.dirty = true;
  }

  // Subscribes to the hair mesh when the view setting asks for it and the groom has one, to the
  // strands otherwise; a refusal (the solver has no hair mesh) keeps the strands.
  _chooseSource() {
    const want = !!(this.settings.hairmesh && this.hairmesh);
    if (want === this.meshStream) return;
    const reply = this.stream.request({ type: 'subscribe', source: want ? 'hairmesh' : 'strands' });
    if (!reply) return;
    reply.then((m) => this._setMeshStream(m.stream && m.stream.codec === 'hairmesh'))
      .catch((e) => this.panel.showStatus(`${want ? 'hair mesh' : 'strands'} not streamed: ${e.message}`, true));
  }

  _setMeshStream(on) {
    this.meshStream = on;
    this.renderer.fromMesh = on;
    this.renderer.meshHair.hasFrame = false;
    this.dirty = true;
    this._configureWorker();
  }

  _buildLayout() {
    if (!this.groom || this.contextLost) return;
    const per = this.settings.perGuide;
    const layout = buildLayout(this.roots, this.groom.strands, per);
    this.renderer.hair.setLayout(layout);
    this.layoutPerGuide = per;
  }

  _configureWorker() {
    if (!this.groom) return;
    this.guideConfig = null;
    if (this.meshStream && this.hairmesh) {
      this.stream.configure(this.hairmesh.ncols, this.hairmesh.nlayers, this.settings.segs, this.maxTexW, 'hairmesh');
    } else {
      this.stream.configure(this.groom.strands, this.groom.verts, this.settings.segs, this.maxTexW);
    }
  }

  _onConfigured(cfg) {
    this.guideConfig = cfg;
    if (cfg.mode === 'hairmesh' || this.contextLost) return; // the mesh texture is sized with the topology
    this.renderer.hair.setGuides(this.groom.strands, cfg.pts, cfg.texW, cfg.texH);
  }

  _onDecoded(m) {
    this.frames.add(m.arrival, m.bytes);
    this.latency.add(m.arrival, m.simTime);
    this.decodeMs.add(m.decodeMs);
    this.prepareMs.add(m.prepareMs);
    this.totals.frames++;
    this.totals.bytes += m.bytes;
    this.totals.decodeMs += m.decodeMs;
    this.totals.prepareMs += m.prepareMs;
    this.seq = m.seq;
  }

  // ---- head dragging --------------------------------------------------------------------

  _hitHead(x, y) {
    if (!this.colliders.length || !this.settings.colliders) return false;
    this.camera.update(this.canvas.clientWidth / Math.max(1, this.canvas.clientHeight));
    const o = [0, 0, 0], d = [0, 0, 0];
    this.camera.ray(x, y, o, d);
    return pickColliders(o, d, this.colliders, this.head) >= 0;
  }

  _headStart(mode) {
    const p = this.head.position, e = this.camera.eye, f = this.camera.forward;
    const depth = Math.max(0.01, (p[0] - e[0]) * f[0] + (p[1] - e[1]) * f[1] + (p[2] - e[2]) * f[2]);
    this.drag = {
      mode,
      pos: Float64Array.from(p),
      q: Float64Array.from(this.head.orientation),
      worldPerPx: this.camera.pixelSize(depth, this.canvas.clientHeight),
    };
    this.dragHead.position.set(p);
    this.dragHead.orientation.set(this.head.orientation);
  }

  _headDrag(dx, dy) {
    const d = this.drag;
    if (!d) return;
    if (d.mode === 'move') {
      const p = dragTranslate(this.dragHead.position, d.pos, this.camera.right, this.camera.up, dx, dy, d.worldPerPx);
      for (let c = 0; c < 3; c++) p[c] = Math.max(-MAX_HEAD_POSITION, Math.min(MAX_HEAD_POSITION, p[c]));
    } else dragRotate(this.dragHead.orientation, d.q, this.camera.right, this.camera.up, dx, dy, 0.01);
    this.motionDirty = true;
  }

  // ---- the render loop ------------------------------------------------------------------

  // Waits until the GPU has carried out every command so far: a one-pixel read is a full sync
  // point in every WebGL implementation (gl.finish() is not, in Chromium). Benchmark mode only.
  _sync() {
    const gl = this.gl;
    gl.bindFramebuffer(gl.FRAMEBUFFER, null);
    gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, this.syncPixel);
  }

  // True when the camera or the canvas size changed since the last call. Allocates nothing.
  _viewChanged() {
    const k = this.viewKey, c = this.camera;
    const v0 = c.yaw, v1 = c.pitch, v2 = c.distance, v3 = c.target[0], v4 = c.target[1], v5 = c.target[2];
    const v6 = this.canvas.clientWidth, v7 = this.canvas.clientHeight;
    const changed = k[0] !== v0 || k[1] !== v1 || k[2] !== v2 || k[3] !== v3 || k[4] !== v4 || k[5] !== v5 || k[6] !== v6 || k[7] !== v7;
    k[0] = v0; k[1] = v1; k[2] = v2; k[3] = v3; k[4] = v4; k[5] = v5; k[6] = v6; k[7] = v7;
    return changed;
  }

  // One animation frame: upload the newest decoded frame, send pending head motion, and draw
  // when anything changed (every frame with the "redraw every frame" setting).
  _loop(now) {
    requestAnimationFrame(this._loop);
    if (this.contextLost) return;
    const moved = this._viewChanged();
    let draw = moved || this.dirty || this.settings.continuous || this.captureWaiters.length > 0;
    this.dirty = false;
    const f = this.stream.take();
    if (f) {
      const cfg = this.guideConfig, mesh = cfg && cfg.mode === 'hairmesh';
      const fits = cfg && (mesh ? this.renderer.meshHair.meshW === cfg.texW && this.renderer.meshHair.meshH === cfg.texH
        : this.renderer.hair.texW === cfg.texW);
      if (fits && f.gen === this.stream.gen) {
        if (this.benchmarkTiming) this._sync();
        const t0 = performance.now();
        if (mesh) this.renderer.meshHair.upload(f.buf);
        else this.renderer.hair.upload(f.buf, cfg.tanOffset);
        if (this.benchmarkTiming) this._sync();
        const dt = performance.now() - t0;
        this.uploadMs.add(dt);
        this.totals.uploads++;
        this.totals.uploadMs += dt;
        this.framesUploaded++;
        draw = true;
        this.head.position.set(f.head.position); // where the simulation had the head (frame header)
        this.head.orientation.set(f.head.orientation);
      }
      this.stream.recycle(f);
    }
    if (this.motionDirty && this.drag) {
      this.motionDirty = false;
      draw = true;
      this.stream.send(motionMessage(now, this.dragHead.position, this.dragHead.orientation));
    }
    if (draw) {
      this.fps.add(now);
      const t0 = performance.now();
      this.renderer.render(this.camera, this.settings, this.drag ? this.dragHead : this.head);
      if (this.benchmarkTiming) {
        this._sync();
        this.totals.draws++;
        this.totals.drawMs += performance.now() - t0;
      }
      this.framesRendered++;
      if (this.captureWaiters.length) this._capture();
    }
    if (now - this.lastOverlay > 250) {
      this.lastOverlay = now;
      this.statsEl.textContent = statsText(this.snapshot(now));
    }
  }

  // Current statistics (also read by the end-to-end test).
  snapshot(now = performance.now()) {
    const fps = this.frames.perSecond(now), bps = this.frames.bytesPerSecond(now);
    const hm = this.meshStream && this.hairmesh;
    const verts = hm ? this.hairmesh.ncols * this.hairmesh.nlayers : this.groom ? this.groom.strands * this.groom.verts : 0;
    const s = this.serverStats || {};
    return {
      renderFps: this.fps.perSecond(now),
      framesPerSec: fps,
      kbitPerSec: (bps * 8) / 1000,
      bytesPerVertex: fps > 0 && verts > 0 ? bps / fps / verts : NaN,
      latencyMs: this.latency.value,
      decodeMs: this.decodeMs.value,
      prepareMs: this.prepareMs.value,
      uploadMs: this.uploadMs.value,
      serverStepsPerSec: s.steps_per_s,
      serverStepMs: s.step_ms,
      clients: s.clients,
      seq: this.seq,
      guides: this.groom ? this.groom.strands : 0,
      verts: this.groom ? this.groom.verts : 0,
      renderStrands: this.meshStream ? this.renderer.meshHair.count : this.renderer.hair.count,
      source: this.meshStream ? 'hairmesh' : 'strands',
      meshFrames: this.renderer.meshHair.hasFrame,
      perGuide: this.layoutPerGuide,
      framesRendered: this.framesRendered,
      framesUploaded: this.framesUploaded,
      paused: this.paused,
      renderer: this.rendererName,
      antialias: this.antialias,
    };
  }

  // Resolves with the pixels of the next rendered frame: { width, height, rgba: Uint8Array }
  // (bottom row first, as GL reads them).
  capture() {
    return new Promise((resolve) => this.captureWaiters.push(resolve));
  }

  _capture() {
    const gl = this.gl, w = this.renderer.width, h = this.renderer.height;
    const rgba = new Uint8Array(w * h * 4);
    gl.readPixels(0, 0, w, h, gl.RGBA, gl.UNSIGNED_BYTE, rgba);
    const waiters = this.captureWaiters;
    this.captureWaiters = [];
    for (const r of waiters) r({ width: w, height: h, rgba });
  }
}
