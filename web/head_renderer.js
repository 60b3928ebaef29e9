// Draws the character's colliders (the head and any spheres/capsules from the hello message,
// and the collision mesh), moved by the head transform, shaded with the hair's shadow.
import { createProgram } from './gl_util.js';
import { colliderParts, unitCylinder, unitSphere } from './geometry.js';
import { mat3NormalFromMat4, mat4FromTRS, mat4Multiply } from './mat4.js';
import { DEPTH_FS, HEAD_FS, HEAD_VS } from './shaders.js';

const UNIT_SCALE = [1, 1, 1];

function upload(gl, mesh, indexType) {
  const vao = gl.createVertexArray();
  gl.bindVertexArray(vao);
  const pb = gl.createBuffer();
  gl.bindBuffer(gl.ARRAY_BUFFER, pb);
  gl.bufferData(gl.ARRAY_BUFFER, mesh.positions, gl.STATIC_DRAW);
  gl.enableVertexAttribArray(0);
  gl.vertexAttribPointer(0, 3, gl.FLOAT, false, 0, 0);
  const nb = gl.createBuffer();
  gl.bindBuffer(gl.ARRAY_BUFFER, nb);
  gl.bufferData(gl.ARRAY_BUFFER, mesh.normals, gl.STATIC_DRAW);
  gl.enableVertexAttribArray(1);
  gl.vertexAttribPointer(1, 3, gl.FLOAT, false, 0, 0);
  const ib = gl.createBuffer();
  gl.bindBuffer(gl.ELEMENT_ARRAY_BUFFER, ib);
  gl.bufferData(gl.ELEMENT_ARRAY_BUFFER, mesh.indices, gl.STATIC_DRAW);
  gl.bindVertexArray(null);
  return { vao, count: mesh.indices.length, type: indexType || gl.UNSIGNED_SHORT, buffers: [pb, nb, ib] };
}

export class HeadRenderer {
  constructor(gl) {
    this.gl = gl;
    this.main = createProgram(gl, HEAD_VS, HEAD_FS, 'head');
    this.depth = createProgram(gl, HEAD_VS, DEPTH_FS, 'head shadow');
    this.meshes = { sphere: upload(gl, unitSphere()), cylinder: upload(gl, unitCylinder()) };
    this.parts = [];
    this.head = new Float32Array(16);
    this.mesh = null; // the collision mesh's part (identity placement under the head)
  }

  // Replaces the collision mesh ({ positions, normals, indices: Uint32Array } in the head
  // frame, or null for none).
  setMesh(m) {
    const gl = this.gl;
    if (this.mesh) {
      gl.deleteVertexArray(this.mesh.mesh.vao);
      for (const b of this.mesh.mesh.buffers) gl.deleteBuffer(b);
      this.mesh = null;
    }
    if (!m) return;
    const local = mat4FromTRS(new Float32Array(16), [0, 0, 0], [0, 0, 0, 1], UNIT_SCALE);
    this.mesh = { mesh: upload(gl, m, gl.UNSIGNED_INT), local, model: new Float32Array(16), normal: new Float32Array(9) };
  }

  // Replaces the colliders (array from the hello/groom message); unknown kinds are skipped.
  setColliders(colliders) {
    this.parts = [];
    for (const c of Array.isArray(colliders) ? colliders : []) {
      for (const p of colliderParts(c)) {
        this.parts.push({
          mesh: this.meshes[p.mesh],
          local: mat4FromTRS(new Float32Array(16), p.t, p.q, p.s),
          model: new Float32Array(16),
          normal: new Float32Array(9),
        });
      }
    }
  }

  // Places every part under the head transform (position, orientation [x, y, z, w]).
  place(position, orientation) {
    mat4FromTRS(this.head, position, orientation, UNIT_SCALE);
    for (let i = 0; i <= this.parts.length; i++) {
      const p = i < this.parts.length ? this.parts[i] : this.mesh;
      if (!p) continue;
      mat4Multiply(p.model, this.head, p.local);
      mat3NormalFromMat4(p.normal, p.model);
    }
  }

  _draw(prog) {
    const gl = this.gl, u = prog.u;
    for (let i = 0; i <= this.parts.length; i++) {
      const p = i < this.parts.length ? this.parts[i] : this.mesh;
      if (!p) continue;
      gl.uniformMatrix4fv(u.uModel, false, p.model);
      gl.uniformMatrix3fv(u.uNormalMat, false, p.normal);
      gl.bindVertexArray(p.mesh.vao);
      gl.drawElements(gl.TRIANGLES, p.mesh.count, p.mesh.type, 0);
    }
    gl.bindVertexArray(null);
  }

  drawDepth(viewProj) {
    const gl = this.gl;
    gl.useProgram(this.depth.program);
    gl.uniformMatrix4fv(this.depth.u.uViewProj, false, viewProj);
    this._draw(this.depth);
  }

  draw(viewProj, eye, light, color, shadow, shadowsOn, absorb) {
    const gl = this.gl, u = this.main.u;
    gl.useProgram(this.main.program);
    gl.uniformMatrix4fv(u.uViewProj, false, viewProj);
    gl.uniform3f(u.uEye, eye[0], eye[1], eye[2]);
    gl.uniform3f(u.uLightDir, light[0], light[1], light[2]);
    gl.uniform3f(u.uColor, color[0], color[1], color[2]);
    shadow.bindUniforms(u, 2, shadowsOn, absorb);
    this._draw(this.main);
  }
}
