// The frame: camera and light set-up, the shadow pass and the shaded pass of head and hair (the
// guides' render strands, or those grown from the hair mesh when the mesh is streamed), and the
// hair mesh's wireframe when asked.
import { HairRenderer } from './hair_renderer.js';
import { HairMeshRenderer } from './hairmesh_renderer.js';
import { HeadRenderer } from './head_renderer.js';
import { ShadowMap } from './shadow_map.js';
import { quatRotate } from './mat4.js';
import { lightDirection } from './view_settings.js';

const BACKGROUND = [0.075, 0.082, 0.1];

export class Renderer {
  constructor(canvas, gl) {
    this.canvas = canvas;
    this.gl = gl;
    this.hair = new HairRenderer(gl);
    this.meshHair = new HairMeshRenderer(gl);
    this.fromMesh = false; // draw the hair grown from the hair mesh (meshHair) instead of hair
    this.head = new HeadRenderer(gl);
    this.shadow = new ShadowMap(gl, 1024);
    this.light = new Float64Array(3);
    this.center = new Float64Array(3);
    this.radius = 0.3;
    this.boundsCenter = new Float64Array(3); // rest bounds centre, head frame
    this.boundsRadius = 0.3;
    this.mainView = { viewProj: null, eye: null, viewDir: new Float32Array(3), ortho: false, fwd: null, pxScale: new Float32Array(2) };
    this.lightView = { viewProj: null, eye: new Float32Array(3), viewDir: new Float32Array(3), ortho: true, fwd: new Float32Array(3), pxScale: new Float32Array(2) };
    this.width = 0;
    this.height = 0;
  }

  // The groom's rest bounds [minx, miny, minz, maxx, maxy, maxz] in the head frame.
  setBounds(b) {
    for (let c = 0; c < 3; c++) this.boundsCenter[c] = 0.5 * (b[c] + b[c + 3]);
    this.boundsRadius = 0.5 * Math.hypot(b[3] - b[0], b[4] - b[1], b[5] - b[2]);
  }

  // Matches the drawing buffer to the canvas' CSS size times the device pixel ratio (max 2).
  resize() {
    const dpr = Math.min(2, window.devicePixelRatio || 1);
    const w = Math.max(1, Math.round(this.canvas.clientWidth * dpr)), h = Math.max(1, Math.round(this.canvas.clientHeight * dpr));
    if (w !== this.canvas.width || h !== this.canvas.height) {
      this.canvas.width = w;
      this.canvas.height = h;
    }
    this.width = w;
    this.height = h;
  }

  // Draws one frame. camera: OrbitCamera; settings: view settings; head: { position,
  // orientation } of the head now. Allocates nothing.
  render(camera, settings, head) {
    const gl = this.gl;
    this.resize();
    camera.update(this.width / this.height);
    lightDirection(this.light, settings.lightAzimuth, settings.lightElevation);
    // shadow frustum around the hair: rest bounds centre under the head transform, with room
    // for hair swinging out
    quatRotate(this.center, head.orientation, this.boundsCenter);
    for (let c = 0; c < 3; c++) this.center[c] += head.position[c];
    this.radius = 1.5 * this.boundsRadius;
    this.shadow.fit(this.center, this.radius, this.light);
    this.head.place(head.position, head.orientation);

    gl.enable(gl.DEPTH_TEST);
    gl.depthFunc(gl.LEQUAL);
    gl.disable(gl.CULL_FACE);
    gl.disable(gl.BLEND);
    if (settings.shadows) {
      const lv = this.lightView;
      lv.viewProj = this.shadow.viewProj;
      for (let c = 0; c < 3; c++) { lv.viewDir[c] = -this.light[c]; lv.fwd[c] = -this.light[c]; }
      lv.pxScale[0] = 0; lv.pxScale[1] = this.shadow.texelWorld;
      this.shadow.begin();
      (this.fromMesh ? this.meshHair : this.hair).drawDepth(lv, settings);
      if (settings.colliders) this.head.drawDepth(this.shadow.viewProj);
    }
    gl.bindFramebuffer(gl.FRAMEBUFFER, null);
    gl.viewport(0, 0, this.width, this.height);
    gl.clearColor(BACKGROUND[0], BACKGROUND[1], BACKGROUND[2], 1);
    gl.clearDepth(1);
    gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
    if (settings.colliders) {
      this.head.draw(camera.viewProj, camera.eye, this.light, settings.headColor, this.shadow, settings.shadows, settings.absorb);
    }
    const mv = this.mainView;
    mv.viewProj = camera.viewProj;
    mv.eye = camera.eye;
    mv.fwd = camera.forward;
    mv.pxScale[0] = camera.pixelSize(1, this.height);
    mv.pxScale[1] = 0;
    (this.fromMesh ? this.meshHair : this.hair).draw(mv, settings, this.light, this.shadow);
    if (this.fromMesh && settings.meshWire) this.meshHair.drawWire(camera.viewProj);
  }
}
