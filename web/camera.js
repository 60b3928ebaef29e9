// Orbit camera: yaw/pitch/distance around a target, with matrices kept in preallocated arrays.
import { mat4Invert, mat4LookAt, mat4Multiply, mat4Perspective, mat4TransformPoint } from './mat4.js';

const UP = [0, 1, 0];
const PITCH_LIMIT = (89 * Math.PI) / 180;

export class OrbitCamera {
  constructor({ yaw = 0, pitch = 0.15, distance = 0.6, target = [0, 0, 0], fovy = (40 * Math.PI) / 180 } = {}) {
    this.yaw = yaw;
    this.pitch = pitch;
    this.distance = distance;
    this.target = Float64Array.from(target);
    this.fovy = fovy;
    this.minDistance = 0.05;
    this.maxDistance = 20;
    this.eye = new Float64Array(3);
    this.forward = new Float64Array(3);
    this.right = new Float64Array(3);
    this.up = new Float64Array(3);
    this.view = new Float32Array(16);
    this.proj = new Float32Array(16);
    this.viewProj = new Float32Array(16);
    this.invViewProj = new Float32Array(16);
    this.near = 0.01;
    this.far = 100;
    this.aspect = 1;
    this._p = new Float64Array(3);
  }

  // Rotates by screen-pixel deltas (rad per pixel = speed); pitch is clamped short of the poles.
  orbit(dxPx, dyPx, speed = 0.008) {
    this.yaw -= dxPx * speed;
    this.pitch = Math.max(-PITCH_LIMIT, Math.min(PITCH_LIMIT, this.pitch + dyPx * speed));
  }

  // Multiplies the distance by factor, within [minDistance, maxDistance].
  zoom(factor) {
    if (!(factor > 0)) return;
    this.distance = Math.max(this.minDistance, Math.min(this.maxDistance, this.distance * factor));
  }

  // Aims at the centre of an axis-aligned box [minx, miny, minz, maxx, maxy, maxz] from a
  // distance that fits it in view.
  frame(bounds) {
    for (let c = 0; c < 3; c++) this.target[c] = 0.5 * (bounds[c] + bounds[c + 3]);
    const r = 0.5 * Math.hypot(bounds[3] - bounds[0], bounds[4] - bounds[1], bounds[5] - bounds[2]);
    if (r > 0 && Number.isFinite(r)) {
      this.distance = Math.max(this.minDistance, (1.15 * r) / Math.sin(this.fovy / 2));
      this.maxDistance = Math.max(this.maxDistance, 10 * this.distance);
    }
  }

  // Recomputes eye, basis vectors and matrices for a viewport aspect ratio.
  update(aspect) {
    this.aspect = aspect > 0 ? aspect : 1;
    const cp = Math.cos(this.pitch), sp = Math.sin(this.pitch), cy = Math.cos(this.yaw), sy = Math.sin(this.yaw);
    const f = this.forward, e = this.eye, t = this.target;
    f[0] = -cp * sy; f[1] = -sp; f[2] = -cp * cy;
    e[0] = t[0] - this.distance * f[0]; e[1] = t[1] - this.distance * f[1]; e[2] = t[2] - this.distance * f[2];
    // right = forward x up, up = right x forward
    const r = this.right, u = this.up;
    r[0] = -f[2]; r[1] = 0; r[2] = f[0];
    const rl = Math.hypot(r[0], r[2]) || 1;
    r[0] /= rl; r[2] /= rl;
    u[0] = r[1] * f[2] - r[2] * f[1]; u[1] = r[2] * f[0] - r[0] * f[2]; u[2] = r[0] * f[1] - r[1] * f[0];
    this.near = Math.max(1e-3, this.distance * 0.02);
    this.far = this.distance * 20 + 1;
    mat4LookAt(this.view, e, t, UP);
    mat4Perspective(this.proj, this.fovy, this.aspect, this.near, this.far);
    mat4Multiply(this.viewProj, this.proj, this.view);
    mat4Invert(this.invViewProj, this.viewProj);
  }

  // World-space size of one pixel at distance depth along the view direction for a viewport
  // of heightPx pixels.
  pixelSize(depth, heightPx) {
    return (2 * Math.tan(this.fovy / 2) * depth) / Math.max(1, heightPx);
  }

  // Ray through normalised device coordinates (x, y in [-1, 1]) after update(): writes the
  // origin (the eye) and a unit direction.
  ray(ndcX, ndcY, outOrigin, outDir) {
    const p = this._p;
    p[0] = ndcX; p[1] = ndcY; p[2] = 1;
    mat4TransformPoint(p, this.invViewProj, p);
    outOrigin[0] = this.eye[0]; outOrigin[1] = this.eye[1]; outOrigin[2] = this.eye[2];
    const dx = p[0] - this.eye[0], dy = p[1] - this.eye[1], dz = p[2] - this.eye[2];
    const l = Math.hypot(dx, dy, dz) || 1;
    outDir[0] = dx / l; outDir[1] = dy / l; outDir[2] = dz / l;
  }
}
