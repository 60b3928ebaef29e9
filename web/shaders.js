// GLSL ES 3.00 sources: hair ribbons (main and shadow passes) and the collider meshes.

// Hair vertex shader. Each instance is one render strand; vertex 2 i and 2 i + 1 are the two
// edges of the ribbon at smoothed point i. The worker's Catmull-Rom smoothed guides come in two
// RGBA32F textures, point k of guide g at texel g * uPts + k: (position, a) and (tangent, b),
// where the guide's normal is a b1 + b b2 with (b1, b2) the tangent's basis (frames.js
// tangentBasis, rebuilt here from the same float32 tangent). The render strand is
// sum_j w_j guide_j (multi-strand interpolation, w1, w2 = barycentric weights times uMulti)
// plus an offset in guide 0's (normal, binormal) frame that grows from root to tip
// (single-strand interpolation); it takes guide 0's tangent. The ribbon is expanded sideways,
// perpendicular to the tangent and the view direction, to uWidthPx pixels tapering to
// uTipWidth at the tip.
export const HAIR_VS = `#version 300 es
precision highp float;
precision highp int;
precision highp sampler2D;
uniform sampler2D uPos;
uniform sampler2D uTan;
uniform int uTexW;
uniform int uPts;
uniform mat4 uViewProj;
uniform vec3 uEye;
uniform vec3 uViewDir;
uniform int uOrtho;
uniform vec3 uFwd;
uniform vec2 uPxScale;
uniform float uWidthPx;
uniform float uTipWidth;
uniform float uMulti;
uniform float uSpread;
uniform float uTipSpread;
layout(location = 0) in uvec3 aGuides;
layout(location = 1) in vec2 aBary;
layout(location = 2) in vec2 aOffset;
layout(location = 3) in vec2 aRand;
out vec3 vPos;
out vec3 vTan;
out float vT;
out float vShade;

ivec2 texel(uint g, int i) {
  int k = int(g) * uPts + i;
  return ivec2(k % uTexW, k / uTexW);
}

void main() {
  int last = max(1, int(float(uPts - 1) * aRand.x + 0.5));
  int i = min(gl_VertexID >> 1, last);
  float side = (gl_VertexID & 1) == 0 ? -0.5 : 0.5;
  float w1 = aBary.x * uMulti;
  float w2 = aBary.y * uMulti;
  vec4 A = texelFetch(uPos, texel(aGuides.x, i), 0);
  vec4 D = texelFetch(uTan, texel(aGuides.x, i), 0);
  vec3 p = (1.0 - w1 - w2) * A.xyz;
  if (w1 > 0.0) p += w1 * texelFetch(uPos, texel(aGuides.y, i), 0).xyz;
  if (w2 > 0.0) p += w2 * texelFetch(uPos, texel(aGuides.z, i), 0).xyz;
  vec3 T = D.xyz;
  float sg = T.z >= 0.0 ? 1.0 : -1.0;
  float ba = -1.0 / (sg + T.z);
  float bb = T.x * T.y * ba;
  vec3 N = A.w * vec3(1.0 + sg * T.x * T.x * ba, sg * bb, -sg * T.x) + D.w * vec3(bb, sg + T.y * T.y * ba, -T.y);
  vec3 B = cross(T, N);
  float t = float(i) / float(uPts - 1);
  p += (aOffset.x * N + aOffset.y * B) * (uSpread * mix(1.0, uTipSpread, t));
  vec3 view = uOrtho == 1 ? uViewDir : p - uEye;
  vec3 s = cross(T, view);
  float sl = length(s);
  s = sl > 1e-12 ? s / sl : N;
  float depth = uOrtho == 1 ? 0.0 : dot(p - uEye, uFwd);
  float width = uWidthPx * (uPxScale.x * depth + uPxScale.y) * mix(1.0, uTipWidth, t);
  vec3 q = p + s * (side * width);
  vPos = q;
  vTan = T;
  vT = t;
  vShade = aRand.y;
  gl_Position = uViewProj * vec4(q, 1.0);
}
`;

// Hair-mesh vertex shader: render strands grown from a hair mesh (web/hairmesh.js growPoint,
// which this computes for every ribbon point; the tracing rule of server/core/hairmesh_types.h).
// The mesh's vertices are an RGBA32F texture (texel c * uNLayers + l: column c, layer l; xyz),
// its faces an RGBA32UI texture (texel f: the 4 column indices, 0xffffffff for a triangle's
// 4th). Each instance is one render strand: its face, (u, v) in it and random styling values
// [offset angle / 2 pi, offset radius, curl phase / 2 pi, shade], and its length fraction; its
// points' layer parameters (hairmesh.js strandParams, the even parameters of the rest mesh) are
// an R32F texture (texel gl_InstanceID * uPts + i).
// Outputs as HAIR_VS (Kajiya-Kay in HAIR_FS, the shadow pass with DEPTH_FS).
export const HAIRMESH_VS = `#version 300 es
precision highp float;
precision highp int;
precision highp sampler2D;
precision highp usampler2D;
uniform sampler2D uMesh;
uniform usampler2D uFaces;
uniform sampler2D uParams;
uniform int uParamW;
uniform int uMeshW;
uniform int uFaceW;
uniform int uNLayers;
uniform int uPts;
uniform mat4 uViewProj;
uniform vec3 uEye;
uniform vec3 uViewDir;
uniform int uOrtho;
uniform vec3 uFwd;
uniform vec2 uPxScale;
uniform float uWidthPx;
uniform float uTipWidth;
uniform float uOffset;
uniform float uTipSpread;
uniform float uCurl;
uniform float uCurlTurns;
uniform float uFrizz;
layout(location = 0) in uint aFace;
layout(location = 1) in vec2 aUV;
layout(location = 2) in vec4 aRand;
layout(location = 3) in float aLength;
out vec3 vPos;
out vec3 vTan;
out float vT;
out float vShade;
const float TAU = 6.28318530718;

vec3 meshVertex(uint c, int l) {
  int k = int(c) * uNLayers + l;
  return texelFetch(uMesh, ivec2(k % uMeshW, k / uMeshW), 0).xyz;
}

vec3 layerPoint(uvec4 f, vec4 w, int l) {
  vec3 p = w.x * meshVertex(f.x, l) + w.y * meshVertex(f.y, l) + w.z * meshVertex(f.z, l);
  if (f.w != 0xffffffffu) p += w.w * meshVertex(f.w, l);
  return p;
}

float layerParam(int i) {
  int k = gl_InstanceID * uPts + i;
  return texelFetch(uParams, ivec2(k % uParamW, k / uParamW), 0).x;
}

vec3 unitOr(vec3 v, vec3 fallback) {
  float n = length(v);
  return n > 1e-12 ? v / n : fallback;
}

void main() {
  int last = max(1, int(float(uPts - 1) * aLength + 0.5));
  int i = min(gl_VertexID >> 1, last);
  float side = (gl_VertexID & 1) == 0 ? -0.5 : 0.5;
  int fi = int(aFace);
  uvec4 f = texelFetch(uFaces, ivec2(fi % uFaceW, fi / uFaceW), 0);
  float u = aUV.x, v = aUV.y;
  vec4 w = f.w == 0xffffffffu ? vec4(1.0 - u - v, u, v, 0.0)
                               : vec4((1.0 - u) * (1.0 - v), u * (1.0 - v), u * v, (1.0 - u) * v);
  float lt = layerParam(i);
  int l = min(int(floor(lt)), uNLayers - 2);
  float a = lt - float(l);
  vec3 p0 = layerPoint(f, w, l), p1 = layerPoint(f, w, l + 1);
  vec3 e0 = meshVertex(f.y, l) - meshVertex(f.x, l), e1 = meshVertex(f.y, l + 1) - meshVertex(f.x, l + 1);
  vec3 T = unitOr(p1 - p0, vec3(0.0, -1.0, 0.0));
  vec3 e = mix(e0, e1, a);
  vec3 axis = abs(T.x) < 0.9 ? vec3(1.0, 0.0, 0.0) : vec3(0.0, 1.0, 0.0);
  vec3 E = unitOr(e - dot(e, T) * T, unitOr(axis - dot(axis, T) * T, vec3(0.0, 0.0, 1.0)));
  vec3 F = cross(T, E);
  float t = float(i) / float(uPts - 1);
  float sp = uOffset * (1.0 + (uTipSpread - 1.0) * t) * aRand.y;
  float cph = TAU * (uCurlTurns * t + aRand.z);
  float g = uFrizz * t * t;
  float fx = g * (0.6 * sin(TAU * (7.0 * t + aRand.z)) + 0.4 * sin(TAU * (17.0 * t + 2.3 * aRand.z)));
  float fy = g * (0.6 * cos(TAU * (5.0 * t + 1.7 * aRand.z)) + 0.4 * sin(TAU * (13.0 * t + aRand.z)));
  float x = sp * cos(TAU * aRand.x) + uCurl * cos(cph) + fx;
  float y = sp * sin(TAU * aRand.x) + uCurl * sin(cph) + fy;
  vec3 p = mix(p0, p1, a) + x * E + y * F;
  int k = min(i, uPts - 2);
  float span = length(p1 - p0) * (layerParam(k + 1) - layerParam(k)) * float(uPts - 1);
  float dc = TAU * uCurlTurns * uCurl;
  vec3 Tc = unitOr(span * T + dc * (-sin(cph) * E + cos(cph) * F), T);
  vec3 view = uOrtho == 1 ? uViewDir : p - uEye;
  vec3 s = cross(Tc, view);
  float sl = length(s);
  s = sl > 1e-12 ? s / sl : E;
  float depth = uOrtho == 1 ? 0.0 : dot(p - uEye, uFwd);
  float width = uWidthPx * (uPxScale.x * depth + uPxScale.y) * mix(1.0, uTipWidth, t);
  vec3 q = p + s * (side * width);
  vPos = q;
  vTan = Tc;
  vT = t;
  vShade = aRand.w;
  gl_Position = uViewProj * vec4(q, 1.0);
}
`;

// Hair-mesh wireframe: mesh vertices fetched from the mesh texture by index (gl_VertexID of
// the index buffer: vertex c * nlayers + l), one flat colour.
export const WIRE_VS = `#version 300 es
precision highp float;
precision highp int;
precision highp sampler2D;
uniform sampler2D uMesh;
uniform int uMeshW;
uniform mat4 uViewProj;
void main() {
  int k = gl_VertexID;
  gl_Position = uViewProj * vec4(texelFetch(uMesh, ivec2(k % uMeshW, k / uMeshW), 0).xyz, 1.0);
}
`;

export const WIRE_FS = `#version 300 es
precision mediump float;
uniform vec3 uColor;
out vec4 outColor;
void main() { outColor = vec4(uColor, 1.0); }
`;

// Shadow-map passes only write depth.
export const DEPTH_FS = `#version 300 es
precision mediump float;
void main() {}
`;

// Opacity shadow from a light-space depth map of the hair and head: the world distance a point
// lies behind the first occluder along the light, times an absorption per metre, gives the
// transmitted light exp(-uAbsorb * depth) (a deep-opacity style estimate, 4 taps).
const SHADOW_FN = `
uniform highp sampler2D uShadow;
uniform mat4 uLightViewProj;
uniform float uShadowDepth;
uniform float uShadowBias;
uniform float uAbsorb;
uniform vec2 uShadowTexel;
uniform int uShadowOn;

float lightTransmit(vec3 pos) {
  if (uShadowOn == 0) return 1.0;
  vec4 lp = uLightViewProj * vec4(pos, 1.0);
  vec3 s = lp.xyz / lp.w * 0.5 + 0.5;
  if (s.x < 0.0 || s.y < 0.0 || s.x > 1.0 || s.y > 1.0 || s.z > 1.0) return 1.0;
  float sum = 0.0;
  for (int k = 0; k < 4; k++) {
    vec2 o = (vec2(float(k & 1), float(k >> 1)) - 0.5) * uShadowTexel;
    float d = texture(uShadow, s.xy + o).r;
    float behind = max(0.0, (s.z - d) * uShadowDepth - uShadowBias);
    sum += exp(-uAbsorb * behind);
  }
  return 0.25 * sum;
}
`;

// Kajiya-Kay hair shading: diffuse from sin(T, L); two specular lobes with the tangent shifted
// towards the root (primary, light-coloured) and the tip (secondary, hair-coloured), after
// Scheuermann; root darkening and the opacity shadow for self-shadowing.
export const HAIR_FS = `#version 300 es
precision highp float;
in vec3 vPos;
in vec3 vTan;
in float vT;
in float vShade;
uniform vec3 uEye;
uniform vec3 uLightDir;
uniform vec3 uHairColor;
uniform vec3 uSpecColor;
uniform float uShift1;
uniform float uShift2;
uniform float uExp1;
uniform float uExp2;
uniform float uSpec1;
uniform float uSpec2;
uniform float uAmbient;
uniform float uRootAO;
out vec4 outColor;
${SHADOW_FN}
float kkSpec(vec3 T, vec3 H, float e) {
  float th = dot(T, H);
  float sinTH = sqrt(max(0.0, 1.0 - th * th));
  return smoothstep(-1.0, 0.0, th) * pow(sinTH, e);
}

void main() {
  vec3 T = normalize(vTan);
  vec3 V = normalize(uEye - vPos);
  vec3 L = uLightDir;
  vec3 H = normalize(L + V);
  float tl = dot(T, L);
  float diffuse = sqrt(max(0.0, 1.0 - tl * tl));
  vec3 N = V - dot(V, T) * T;
  float nl = length(N);
  N = nl > 1e-6 ? N / nl : V;
  vec3 T1 = normalize(T + uShift1 * N);
  vec3 T2 = normalize(T + uShift2 * N);
  float light = lightTransmit(vPos);
  float ao = mix(uRootAO, 1.0, smoothstep(0.0, 0.3, vT));
  vec3 base = uHairColor * mix(0.75, 1.2, vShade);
  vec3 c = base * ao * (uAmbient + (1.0 - uAmbient) * diffuse * light);
  c += light * ao * (uSpec1 * kkSpec(T1, H, uExp1) * uSpecColor + uSpec2 * kkSpec(T2, H, uExp2) * base);
  outColor = vec4(pow(clamp(c, 0.0, 1.0), vec3(1.0 / 2.2)), 1.0);
}
`;

export const HEAD_VS = `#version 300 es
precision highp float;
uniform mat4 uViewProj;
uniform mat4 uModel;
uniform mat3 uNormalMat;
layout(location = 0) in vec3 aPos;
layout(location = 1) in vec3 aNormal;
out vec3 vPos;
out vec3 vNormal;
void main() {
  vec4 w = uModel * vec4(aPos, 1.0);
  vPos = w.xyz;
  vNormal = uNormalMat * aNormal;
  gl_Position = uViewProj * w;
}
`;

export const HEAD_FS = `#version 300 es
precision highp float;
in vec3 vPos;
in vec3 vNormal;
uniform vec3 uEye;
uniform vec3 uLightDir;
uniform vec3 uColor;
out vec4 outColor;
${SHADOW_FN}
void main() {
  vec3 N = normalize(vNormal);
  vec3 V = normalize(uEye - vPos);
  if (dot(N, V) < 0.0) N = -N;
  float lambert = max(0.0, dot(N, uLightDir));
  float light = lightTransmit(vPos + N * uShadowBias);
  float rim = pow(1.0 - max(0.0, dot(N, V)), 3.0);
  vec3 c = uColor * (0.25 + 0.75 * lambert * light) + 0.08 * rim;
  outColor = vec4(pow(clamp(c, 0.0, 1.0), vec3(1.0 / 2.2)), 1.0);
}
`;
