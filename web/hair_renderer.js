// Draws the hair: guide-point textures, the render-strand instance buffer and the two passes
// (light-space depth for shadows, Kajiya-Kay shaded ribbons).
import { createProgram } from './gl_util.js';
import { setShadeUniforms, setViewUniforms } from './ribbon_uniforms.js';
import { DEPTH_FS, HAIR_FS, HAIR_VS } from './shaders.js';
import { INSTANCE_STRIDE } from './interp.js';

function makeTexture(gl) {
  const t = gl.createTexture();
  gl.bindTexture(gl.TEXTURE_2D, t);
  gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.NEAREST);
  gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.NEAREST);
  gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_S, gl.CLAMP_TO_EDGE);
  gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_T, gl.CLAMP_TO_EDGE);
  return t;
}

export class HairRenderer {
  constructor(gl) {
    this.gl = gl;
    this.main = createProgram(gl, HAIR_VS, HAIR_FS, 'hair');
    this.depth = createProgram(gl, HAIR_VS, DEPTH_FS, 'hair shadow');
    this.posTex = makeTexture(gl);
    this.tanTex = makeTexture(gl);
    this.instances = gl.createBuffer();      // every render strand
    this.guideInstances = gl.createBuffer(); // render strand 0 of each guide (shadow pass)
    this.vao = gl.createVertexArray();
    this.guideVao = gl.createVertexArray();
    this.count = 0;
    this.nguides = 0;
    this.pts = 0;
    this.texW = 0;
    this.texH = 0;
    this.hasFrame = false;
  }

  // Sizes the two RGBA32F guide textures for nguides smoothed guides of pts points in a
  // texW x texH layout (texel k = guide * pts + point, row-major). Forgets the current frame.
  setGuides(nguides, pts, texW, texH) {
    const gl = this.gl;
    this.nguides = nguides; this.pts = pts; this.texW = texW; this.texH = texH;
    for (const t of [this.posTex, this.tanTex]) {
      gl.bindTexture(gl.TEXTURE_2D, t);
      gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA32F, texW, texH, 0, gl.RGBA, gl.FLOAT, null);
    }
    this.hasFrame = false;
  }

  // Replaces the render strands (a layout from interp.js buildLayout).
  setLayout(layout) {
    const gl = this.gl;
    gl.bindBuffer(gl.ARRAY_BUFFER, this.instances);
    gl.bufferData(gl.ARRAY_BUFFER, layout.data, gl.STATIC_DRAW);
    gl.bindBuffer(gl.ARRAY_BUFFER, this.guideInstances);
    gl.bufferData(gl.ARRAY_BUFFER, layout.guideData, gl.STATIC_DRAW);
    this._attribs(this.vao, this.instances, INSTANCE_STRIDE);
    this._attribs(this.guideVao, this.guideInstances, INSTANCE_STRIDE);
    gl.bindVertexArray(null);
    this.count = layout.count;
  }

  _attribs(vao, buffer, stride) {
    const gl = this.gl;
    gl.bindVertexArray(vao);
    gl.bindBuffer(gl.ARRAY_BUFFER, buffer);
    gl.enableVertexAttribArray(0);
    gl.vertexAttribIPointer(0, 3, gl.UNSIGNED_INT, stride, 0);
    gl.vertexAttribDivisor(0, 1);
    for (let k = 0; k < 3; k++) {
      gl.enableVertexAttribArray(1 + k);
      gl.vertexAttribPointer(1 + k, 2, gl.FLOAT, false, stride, 12 + 8 * k);
      gl.vertexAttribDivisor(1 + k, 1);
    }
  }

  // Uploads one smoothed frame from the worker: the (position, a) image at float 0 and the
  // (tangent, b) image at float tanOffset of buf, each texW * texH * 4 floats. Allocates nothing.
  upload(buf, tanOffset) {
    const gl = this.gl;
    gl.pixelStorei(gl.UNPACK_ALIGNMENT, 4);
    gl.bindTexture(gl.TEXTURE_2D, this.posTex);
    gl.texSubImage2D(gl.TEXTURE_2D, 0, 0, 0, this.texW, this.texH, gl.RGBA, gl.FLOAT, buf, 0);
    gl.bindTexture(gl.TEXTURE_2D, this.tanTex);
    gl.texSubImage2D(gl.TEXTURE_2D, 0, 0, 0, this.texW, this.texH, gl.RGBA, gl.FLOAT, buf, tanOffset);
    this.hasFrame = true;
  }

  _common(prog, v, s, widthPx) {
    const gl = this.gl, u = prog.u;
    gl.useProgram(prog.program);
    gl.activeTexture(gl.TEXTURE0);
    gl.bindTexture(gl.TEXTURE_2D, this.posTex);
    gl.uniform1i(u.uPos, 0);
    gl.activeTexture(gl.TEXTURE1);
    gl.bindTexture(gl.TEXTURE_2D, this.tanTex);
    gl.uniform1i(u.uTan, 1);
    gl.uniform1i(u.uTexW, this.texW);
    gl.uniform1i(u.uPts, this.pts);
    setViewUniforms(gl, u, v, widthPx, s.tipWidth);
    gl.uniform1f(u.uMulti, s.multi);
    gl.uniform1f(u.uSpread, s.spread);
    gl.uniform1f(u.uTipSpread, s.tipSpread);
  }

  // Light-space depth of the guides' strands into the bound shadow map (view v: the light).
  drawDepth(v, s) {
    if (!this.hasFrame || !this.count) return;
    const gl = this.gl;
    this._common(this.depth, v, s, 3);
    gl.bindVertexArray(this.guideVao);
    gl.drawArraysInstanced(gl.TRIANGLE_STRIP, 0, 2 * this.pts, this.nguides);
    gl.bindVertexArray(null);
  }

  // Shaded ribbons of every render strand (view v: the camera; light: { dir, shadow }).
  draw(v, s, light, shadow) {
    if (!this.hasFrame || !this.count) return;
    const gl = this.gl, u = this.main.u;
    this._common(this.main, v, s, s.widthPx);
    setShadeUniforms(gl, u, s, light, shadow);
    gl.bindVertexArray(this.vao);
    gl.drawArraysInstanced(gl.TRIANGLE_STRIP, 0, 2 * this.pts, this.count);
    gl.bindVertexArray(null);
  }
}
