// Pointer, wheel and touch input on the canvas: orbit and zoom the camera, or drag the head
// (move, or turn with shift / the right button) when a drag starts on it.

export class Input {
  // handlers: hitHead(ndcX, ndcY) -> bool, headStart(mode: 'move' | 'turn'), headDrag(dxPx,
  // dyPx) with the total drag since the start, headEnd(). camera: OrbitCamera.
  constructor(canvas, camera, handlers) {
    this.canvas = canvas;
    this.camera = camera;
    this.h = handlers;
    this.pointers = new Map(); // id -> { x, y }
    this.mode = null;          // 'orbit' | 'head' | 'pinch'
    this.start = { x: 0, y: 0 };
    this.last = { x: 0, y: 0 };
    this.pinchDist = 0;
    canvas.addEventListener('pointerdown', (e) => this._down(e));
    canvas.addEventListener('pointermove', (e) => this._move(e));
    canvas.addEventListener('pointerup', (e) => this._up(e));
    canvas.addEventListener('pointercancel', (e) => this._up(e));
    canvas.addEventListener('wheel', (e) => {
      e.preventDefault();
      const unit = e.deltaMode === 1 ? 16 : e.deltaMode === 2 ? 400 : 1;
      camera.zoom(Math.exp(Math.max(-200, Math.min(200, e.deltaY * unit)) * 0.0015));
    }, { passive: false });
    canvas.addEventListener('contextmenu', (e) => e.preventDefault());
  }

  _ndc(e) {
    const r = this.canvas.getBoundingClientRect();
    return [((e.clientX - r.left) / r.width) * 2 - 1, 1 - ((e.clientY - r.top) / r.height) * 2];
  }

  _down(e) {
    this.canvas.setPointerCapture(e.pointerId);
    this.pointers.set(e.pointerId, { x: e.clientX, y: e.clientY });
    if (this.pointers.size === 2) {
      // a second finger turns any drag into a pinch
      if (this.mode === 'head') this.h.headEnd();
      const [a, b] = [...this.pointers.values()];
      this.pinchDist = Math.hypot(a.x - b.x, a.y - b.y);
      this.mode = 'pinch';
      return;
    }
    if (this.pointers.size > 2) return;
    this.start.x = this.last.x = e.clientX;
    this.start.y = this.last.y = e.clientY;
    const [x, y] = this._ndc(e);
    if (this.h.hitHead(x, y)) {
      this.mode = 'head';
      this.h.headStart(e.shiftKey || e.button === 2 ? 'turn' : 'move');
    } else {
      this.mode = 'orbit';
    }
  }

  _move(e) {
    const p = this.pointers.get(e.pointerId);
    if (!p) return;
    p.x = e.clientX;
    p.y = e.clientY;
    if (this.mode === 'pinch' && this.pointers.size >= 2) {
      const [a, b] = [...this.pointers.values()];
      const d = Math.hypot(a.x - b.x, a.y - b.y);
      if (this.pinchDist > 0 && d > 0) this.camera.zoom(this.pinchDist / d);
      this.pinchDist = d;
    } else if (this.mode === 'orbit') {
      this.camera.orbit(e.clientX - this.last.x, e.clientY - this.last.y);
    } else if (this.mode === 'head') {
      this.h.headDrag(e.clientX - this.start.x, e.clientY - this.start.y);
    }
    this.last.x = e.clientX;
    this.last.y = e.clientY;
  }

  _up(e) {
    if (!this.pointers.delete(e.pointerId)) return;
    if (this.mode === 'head') this.h.headEnd();
    if (this.pointers.size === 0) this.mode = null;
    else if (this.mode === 'pinch' && this.pointers.size === 1) {
      // continue orbiting with the remaining finger
      const [q] = [...this.pointers.values()];
      this.last.x = q.x;
      this.last.y = q.y;
      this.mode = 'orbit';
    } else if (this.mode === 'head') this.mode = null;
  }
}
