// Light-space depth map for hair self-shadowing: a depth texture, its framebuffer and the
// orthographic light matrices fitted around the hair each frame.
import { mat4LookAt, mat4Multiply, mat4Ortho } from './mat4.js';

export class ShadowMap {
  constructor(gl, size = 1024) {
    this.gl = gl;
    this.size = size;
    this.tex = gl.createTexture();
    gl.bindTexture(gl.TEXTURE_2D, this.tex);
    gl.texStorage2D(gl.TEXTURE_2D, 1, gl.DEPTH_COMPONENT32F, size, size);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.NEAREST);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.NEAREST);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_S, gl.CLAMP_TO_EDGE);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_T, gl.CLAMP_TO_EDGE);
    this.fbo = gl.createFramebuffer();
    gl.bindFramebuffer(gl.FRAMEBUFFER, this.fbo);
    gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.DEPTH_ATTACHMENT, gl.TEXTURE_2D, this.tex, 0);
    gl.drawBuffers([gl.NONE]);
    gl.readBuffer(gl.NONE);
    const status = gl.checkFramebufferStatus(gl.FRAMEBUFFER);
    gl.bindFramebuffer(gl.FRAMEBUFFER, null);
    if (status !== gl.FRAMEBUFFER_COMPLETE && !gl.isContextLost()) throw new Error(`shadow map framebuffer incomplete (0x${status.toString(16)})`);
    this.view = new Float32Array(16);
    this.proj = new Float32Array(16);
    this.viewProj = new Float32Array(16);
    this.depthRange = 1;
    this.texelWorld = 1;
    this._eye = new Float64Array(3);
    this._up = new Float64Array(3);
  }

  // Fits the light frustum (light travelling opposite to the unit vector toLight) around the
  // sphere (center, radius). Allocates nothing.
  fit(center, radius, toLight) {
    const r = Math.max(radius, 1e-3), e = this._eye, up = this._up;
    for (let c = 0; c < 3; c++) e[c] = center[c] + toLight[c] * 2 * r;
    if (Math.abs(toLight[1]) < 0.95) { up[0] = 0; up[1] = 1; up[2] = 0; } else { up[0] = 1; up[1] = 0; up[2] = 0; }
    mat4LookAt(this.view, e, center, up);
    mat4Ortho(this.proj, -r, r, -r, r, r, 3 * r);
    mat4Multiply(this.viewProj, this.proj, this.view);
    this.depthRange = 2 * r;
    this.texelWorld = (2 * r) / this.size;
  }

  // Binds the map as the render target, cleared to the far plane.
  begin() {
    const gl = this.gl;
    gl.bindFramebuffer(gl.FRAMEBUFFER, this.fbo);
    gl.viewport(0, 0, this.size, this.size);
    gl.clearDepth(1);
    gl.clear(gl.DEPTH_BUFFER_BIT);
  }

  // Sets the lightTransmit() uniforms of a program (table u from createProgram) with the map
  // on texture unit `unit`.
  bindUniforms(u, unit, on, absorb) {
    const gl = this.gl;
    gl.activeTexture(gl.TEXTURE0 + unit);
    gl.bindTexture(gl.TEXTURE_2D, this.tex);
    gl.uniform1i(u.uShadow, unit);
    gl.uniformMatrix4fv(u.uLightViewProj, false, this.viewProj);
    gl.uniform1f(u.uShadowDepth, this.depthRange);
    gl.uniform1f(u.uShadowBias, 2 * this.texelWorld);
    gl.uniform1f(u.uAbsorb, absorb);
    gl.uniform2f(u.uShadowTexel, 1 / this.size, 1 / this.size);
    gl.uniform1i(u.uShadowOn, on ? 1 : 0);
  }
}
