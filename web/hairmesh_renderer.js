// Draws hair grown from a streamed hair mesh: the mesh, face and layer-parameter textures, the
// render-strand instance buffer (hairmesh.js meshStrands), the two hair passes (light-space depth, Kajiya-Kay)
// and the mesh's wireframe overlay.
import { createProgram } from './gl_util.js';
import { setShadeUniforms, setViewUniforms } from './ribbon_uniforms.js';
import { DEPTH_FS, HAIR_FS, HAIRMESH_VS, WIRE_FS, WIRE_VS } from './shaders.js';
import { MESH_INSTANCE_STRIDE, wireframeIndices } from './hairmesh.js';

const WIRE_COLOR = [0.35, 0.85, 1.0];

function makeTexture(gl) {
  const t = gl.createTexture();
  gl.bindTexture(gl.TEXTURE_2D, t);
  gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.NEAREST);
  gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.NEAREST);
  gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_S, gl.CLAMP_TO_EDGE);
  gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_T, gl.CLAMP_TO_EDGE);
  return t;
}

export class HairMeshRenderer {
  constructor(gl) {
    this.gl = gl;
    this.main = createProgram(gl, HAIRMESH_VS, HAIR_FS, 'hair mesh');
    this.depth = createProgram(gl, HAIRMESH_VS, DEPTH_FS, 'hair mesh shadow');
    this.wire = createProgram(gl, WIRE_VS, WIRE_FS, 'hair mesh wireframe');
    this.meshTex = makeTexture(gl);
    this.faceTex = makeTexture(gl);
    this.paramTex = makeTexture(gl);
    this.paramW = 1;
    this.instances = gl.createBuffer();
    this.vao = gl.createVertexArray();
    this.wireVao = gl.createVertexArray();
    this.wireIndices = gl.createBuffer();
    this.wireCount = 0;
    this.count = 0;
    this.nlayers = 0;
    this.meshW = 0;
    this.meshH = 0;
    this.faceW = 0;
    this.pts = 2;
    this.hasFrame = false;
  }

  // Takes a mesh's topology (faces: Uint32Array of 4 column indices per face) and sizes the mesh
  // texture for ncols x nlayers vertices in rows of at most maxTexW texels (texel c * nlayers + l).
  // Forgets the current frame.
  setTopology(faces, nfaces, ncols, nlayers, maxTexW) {
    const gl = this.gl, n = ncols * nlayers;
    this.nlayers = nlayers;
    this.meshW = Math.max(1, Math.min(maxTexW, n));
    this.meshH = Math.ceil(n / this.meshW);
    gl.bindTexture(gl.TEXTURE_2D, this.meshTex);
    gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA32F, this.meshW, this.meshH, 0, gl.RGBA, gl.FLOAT, null);
    this.faceW = Math.max(1, Math.min(maxTexW, nfaces));
    const faceH = Math.ceil(nfaces / this.faceW), texels = new Uint32Array(4 * this.faceW * faceH);
    texels.set(faces.subarray(0, 4 * nfaces));
    gl.bindTexture(gl.TEXTURE_2D, this.faceTex);
    gl.pixelStorei(gl.UNPACK_ALIGNMENT, 4);
    gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA32UI, this.faceW, faceH, 0, gl.RGBA_INTEGER, gl.UNSIGNED_INT, texels);
    const idx = wireframeIndices(faces, nfaces, ncols, nlayers);
    gl.bindVertexArray(this.wireVao);
    gl.bindBuffer(gl.ELEMENT_ARRAY_BUFFER, this.wireIndices);
    gl.bufferData(gl.ELEMENT_ARRAY_BUFFER, idx, gl.STATIC_DRAW);
    gl.bindVertexArray(null);
    this.wireCount = idx.length;
    this.hasFrame = false;
  }

  // Replaces the render strands (hairmesh.js meshStrands) drawn with pts points each, point i
  // of strand k at layer parameter params[k pts + i] (hairmesh.js strandParams; an R32F texture
  // in rows of at most maxTexW texels).
  setStrands(strands, pts, params, maxTexW) {
    const gl = this.gl, st = MESH_INSTANCE_STRIDE, n = params.length;
    this.paramW = Math.max(1, Math.min(maxTexW, n));
    const rows = Math.max(1, Math.ceil(n / this.paramW)), texels = new Float32Array(this.paramW * rows);
    texels.set(params);
    gl.bindTexture(gl.TEXTURE_2D, this.paramTex);
    gl.pixelStorei(gl.UNPACK_ALIGNMENT, 4);
    gl.texImage2D(gl.TEXTURE_2D, 0, gl.R32F, this.paramW, rows, 0, gl.RED, gl.FLOAT, texels);
    gl.bindVertexArray(this.vao);
    gl.bindBuffer(gl.ARRAY_BUFFER, this.instances);
    gl.bufferData(gl.ARRAY_BUFFER, strands.data, gl.STATIC_DRAW);
    gl.enableVertexAttribArray(0);
    gl.vertexAttribIPointer(0, 1, gl.UNSIGNED_INT, st, 0);
    gl.enableVertexAttribArray(1);
    gl.vertexAttribPointer(1, 2, gl.FLOAT, false, st, 4);
    gl.enableVertexAttribArray(2);
    gl.vertexAttribPointer(2, 4, gl.FLOAT, false, st, 12);
    gl.enableVertexAttribArray(3);
    gl.vertexAttribPointer(3, 1, gl.FLOAT, false, st, 28);
    for (let k = 0; k < 4; k++) gl.vertexAttribDivisor(k, 1);
    gl.bindVertexArray(null);
    this.count = strands.count;
    this.pts = Math.max(2, pts);
  }

  // Uploads one frame of mesh vertices: buf holds meshW * meshH RGBA texels (xyz, unused w).
  upload(buf) {
    const gl = this.gl;
    gl.pixelStorei(gl.UNPACK_ALIGNMENT, 4);
    gl.bindTexture(gl.TEXTURE_2D, this.meshTex);
    gl.texSubImage2D(gl.TEXTURE_2D, 0, 0, 0, this.meshW, this.meshH, gl.RGBA, gl.FLOAT, buf, 0);
    this.hasFrame = true;
  }

  _common(prog, v, s, widthPx) {
    const gl = this.gl, u = prog.u;
    gl.useProgram(prog.program);
    gl.activeTexture(gl.TEXTURE0);
    gl.bindTexture(gl.TEXTURE_2D, this.meshTex);
    gl.uniform1i(u.uMesh, 0);
    gl.activeTexture(gl.TEXTURE1);
    gl.bindTexture(gl.TEXTURE_2D, this.faceTex);
    gl.uniform1i(u.uFaces, 1);
    gl.activeTexture(gl.TEXTURE3); // unit 2 is the shadow map's (ribbon_uniforms.js)
    gl.bindTexture(gl.TEXTURE_2D, this.paramTex);
    gl.uniform1i(u.uParams, 3);
    gl.uniform1i(u.uParamW, this.paramW);
    gl.uniform1i(u.uMeshW, this.meshW);
    gl.uniform1i(u.uFaceW, this.faceW);
    gl.uniform1i(u.uNLayers, this.nlayers);
    gl.uniform1i(u.uPts, this.pts);
    setViewUniforms(gl, u, v, widthPx, s.tipWidth);
    gl.uniform1f(u.uOffset, s.meshOffset);
    gl.uniform1f(u.uTipSpread, s.tipSpread);
    gl.uniform1f(u.uCurl, s.curl);
    gl.uniform1f(u.uCurlTurns, s.curlTurns);
    gl.uniform1f(u.uFrizz, s.frizz);
  }

  // Light-space depth of every render strand into the bound shadow map (view v: the light).
  drawDepth(v, s) {
    if (!this.hasFrame || !this.count) return;
    const gl = this.gl;
    this._common(this.depth, v, s, 3);
    gl.bindVertexArray(this.vao);
    gl.drawArraysInstanced(gl.TRIANGLE_STRIP, 0, 2 * this.pts, this.count);
    gl.bindVertexArray(null);
  }

  // Shaded ribbons of every render strand (view v: the camera; light direction; shadow map).
  draw(v, s, light, shadow) {
    if (!this.hasFrame || !this.count) return;
    const gl = this.gl, u = this.main.u;
    this._common(this.main, v, s, s.widthPx);
    setShadeUniforms(gl, u, s, light, shadow);
    gl.bindVertexArray(this.vao);
    gl.drawArraysInstanced(gl.TRIANGLE_STRIP, 0, 2 * this.pts, this.count);
    gl.bindVertexArray(null);
  }

  // The mesh's layer and column edges as lines over the scene (view projection viewProj).
  drawWire(viewProj) {
    if (!this.hasFrame || !this.wireCount) return;
    const gl = this.gl, u = this.wire.u;
    gl.useProgram(this.wire.program);
    gl.activeTexture(gl.TEXTURE0);
    gl.bindTexture(gl.TEXTURE_2D, this.meshTex);
    gl.uniform1i(u.uMesh, 0);
    gl.uniform1i(u.uMeshW, this.meshW);
    gl.uniformMatrix4fv(u.uViewProj, false, viewProj);
    gl.uniform3f(u.uColor, WIRE_COLOR[0], WIRE_COLOR[1], WIRE_COLOR[2]);
    gl.bindVertexArray(this.wireVao);
    gl.drawElements(gl.LINES, this.wireCount, gl.UNSIGNED_INT, 0);
    gl.bindVertexArray(null);
  }
}
