// Head dragging: screen-space drags turned into head translations/rotations and motion messages.
import { quatAxisAngle, quatMultiply, quatNormalize } from './mat4.js';

// Moves start by a drag of (dxPx, dyPx) screen pixels in the camera plane (right, up unit
// vectors; screen y grows downwards) with worldPerPx metres per pixel at the head's depth.
export function dragTranslate(out, start, right, up, dxPx, dyPx, worldPerPx) {
  for (let c = 0; c < 3; c++) out[c] = start[c] + (right[c] * dxPx - up[c] * dyPx) * worldPerPx;
  return out;
}

// Rotates start (unit quaternion [x, y, z, w]) by a drag: horizontal pixels turn about the
// camera's up axis, vertical pixels about its right axis, radPerPx radians per pixel.
export function dragRotate(out, start, right, up, dxPx, dyPx, radPerPx) {
  const yaw = quatAxisAngle([0, 0, 0, 1], up, dxPx * radPerPx);
  const pitch = quatAxisAngle([0, 0, 0, 1], right, dyPx * radPerPx);
  const q = quatMultiply([0, 0, 0, 1], yaw, pitch);
  return quatNormalize(out, quatMultiply(out, q, start));
}

// The protocol's motion message for a head transform at client time tMs.
export function motionMessage(tMs, position, orientation) {
  return {
    type: 'motion',
    t: tMs,
    position: [position[0], position[1], position[2]],
    orientation: [orientation[0], orientation[1], orientation[2], orientation[3]],
  };
}
