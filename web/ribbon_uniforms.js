// The uniforms both hair ribbon programs share (hair_renderer.js: strands streamed as strands;
// hairmesh_renderer.js: strands grown from a streamed hair mesh): the camera's (or light's)
// view, the ribbon width, and the Kajiya-Kay shading of the main pass. The caller has bound the
// program whose uniform locations are u.

// The view v ({ viewProj, eye, viewDir, ortho, fwd, pxScale }) and the ribbon width in pixels
// at the root, tipWidth its share at the tip.
export function setViewUniforms(gl, u, v, widthPx, tipWidth) {
  gl.uniformMatrix4fv(u.uViewProj, false, v.viewProj);
  gl.uniform3f(u.uEye, v.eye[0], v.eye[1], v.eye[2]);
  gl.uniform3f(u.uViewDir, v.viewDir[0], v.viewDir[1], v.viewDir[2]);
  gl.uniform1i(u.uOrtho, v.ortho ? 1 : 0);
  gl.uniform3f(u.uFwd, v.fwd[0], v.fwd[1], v.fwd[2]);
  gl.uniform2f(u.uPxScale, v.pxScale[0], v.pxScale[1]);
  gl.uniform1f(u.uWidthPx, widthPx);
  gl.uniform1f(u.uTipWidth, tipWidth);
}

// The main pass's shading: light direction, the view settings s (colours, the two specular
// lobes, ambient, root occlusion) and the shadow map (texture unit 2).
export function setShadeUniforms(gl, u, s, light, shadow) {
  gl.uniform3f(u.uLightDir, light[0], light[1], light[2]);
  gl.uniform3f(u.uHairColor, s.hairColorLinear[0], s.hairColorLinear[1], s.hairColorLinear[2]);
  gl.uniform3f(u.uSpecColor, s.specColor[0], s.specColor[1], s.specColor[2]);
  gl.uniform1f(u.uShift1, s.shift1);
  gl.uniform1f(u.uShift2, s.shift2);
  gl.uniform1f(u.uExp1, s.exp1);
  gl.uniform1f(u.uExp2, s.exp2);
  gl.uniform1f(u.uSpec1, s.spec1);
  gl.uniform1f(u.uSpec2, s.spec2);
  gl.uniform1f(u.uAmbient, s.ambient);
  gl.uniform1f(u.uRootAO, s.rootAO);
  shadow.bindUniforms(u, 2, s.shadows, s.absorb);
}
