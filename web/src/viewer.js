// The 3D view: renderer, scene, lights, camera and orbit navigation about a fixed up axis
// (+z, as in most CAE decks), standard views, framing, the axes triad in the lower-left
// corner and the render loop. Other modules add their objects to `viewer.scene` and
// per-frame work to `viewer.beforeRender`.
import * as THREE from "three";
import { OrbitControls } from "three/addons/controls/OrbitControls.js";

export const UP = new THREE.Vector3(0, 0, 1);

/** View directions: from the target towards the camera. */
export const VIEWS = {
  front: new THREE.Vector3(0, -1, 0),
  back: new THREE.Vector3(0, 1, 0),
  side: new THREE.Vector3(1, 0, 0),
  top: new THREE.Vector3(0, -1e-4, 1).normalize(), // a hair off the pole: screen-up is +y
  bottom: new THREE.Vector3(0, -1e-4, -1).normalize(),
  iso: new THREE.Vector3(1, -1, 1).normalize(),
};

const TRIAD_PX = 96;

export class Viewer {
  constructor(canvas) {
    this.canvas = canvas;
    this.renderer = new THREE.WebGLRenderer({ canvas, antialias: true, preserveDrawingBuffer: true });
    this.renderer.localClippingEnabled = true;
    this.scene = new THREE.Scene();
    this.scene.background = new THREE.Color(0xf4f5f7);
    this.camera = new THREE.PerspectiveCamera(40, 1, 0.001, 1e6);
    // the orbit axis is camera.up as OrbitControls finds it when constructed: set it first
    this.camera.up.copy(UP);
    this.scene.add(new THREE.HemisphereLight(0xffffff, 0x667788, 1.6));
    this.sun = new THREE.DirectionalLight(0xffffff, 1.6);
    this.scene.add(this.sun);
    this.orbit = new OrbitControls(this.camera, canvas);
    this.radius = 1;
    this.beforeRender = [];
    this.triad = makeTriad();
    const loop = () => {
      this.draw();
      requestAnimationFrame(loop);
    };
    requestAnimationFrame(loop);
  }

  draw() {
    this.resize();
    for (const fn of this.beforeRender) fn();
    this.sun.position.copy(this.camera.position);
    this.renderer.render(this.scene, this.camera);
    this.drawTriad();
  }

  resize() {
    const c = this.canvas, w = c.clientWidth, h = c.clientHeight;
    if (w && h && (c.width !== w || c.height !== h)) {
      this.renderer.setSize(w, h, false);
      this.camera.aspect = w / Math.max(h, 1);
      this.camera.updateProjectionMatrix();
    }
  }

  drawTriad() {
    const r = this.renderer, t = this.triad;
    t.camera.position.set(0, 0, 4).applyQuaternion(this.camera.quaternion);
    t.camera.quaternion.copy(this.camera.quaternion);
    const h = this.canvas.height;
    r.autoClear = false;
    r.setScissorTest(true);
    r.setViewport(0, 0, TRIAD_PX, TRIAD_PX);
    r.setScissor(0, 0, TRIAD_PX, TRIAD_PX);
    r.clearDepth();
    r.render(t.scene, t.camera);
    r.setScissorTest(false);
    r.setViewport(0, 0, this.canvas.width, h);
    r.autoClear = true;
  }

  /** Screen directions (x right, y down, unit length in 2D) of the world axes as the triad draws them. */
  triadAxes() {
    const out = {};
    for (const [name, v] of [["x", [1, 0, 0]], ["y", [0, 1, 0]], ["z", [0, 0, 1]]]) {
      const d = new THREE.Vector3(...v).applyQuaternion(this.camera.quaternion.clone().invert());
      const n = Math.hypot(d.x, d.y) || 1;
      out[name] = { x: d.x / n, y: -d.y / n, depth: d.z };
    }
    return out;
  }

  /** Frame a bounding box (THREE.Box3). The view direction stays unless `dir` is given. */
  fit(box, dir) {
    this.resize();
    const camera = this.camera;
    const c = box.getCenter(new THREE.Vector3());
    const r = box.getSize(new THREE.Vector3()).length() / 2 || 1;
    this.radius = r;
    let d = dir ? dir.clone() : camera.position.clone().sub(this.orbit.target);
    if (!(d.lengthSq() > 0) || !Number.isFinite(d.x)) d = VIEWS.iso.clone();
    d.normalize();
    this.orbit.target.copy(c);
    // distance at which the bounding sphere fits the narrower of the two fields of view
    const vfov = THREE.MathUtils.degToRad(camera.fov);
    const hfov = 2 * Math.atan(Math.tan(vfov / 2) * camera.aspect);
    const dist = 1.1 * r / Math.sin(Math.min(vfov, hfov) / 2);
    camera.position.copy(c).addScaledVector(d, dist);
    camera.near = r / 1000; camera.far = r * 100;
    camera.updateProjectionMatrix();
    this.orbit.update();
  }

  /** A standard view (VIEWS key) of the box. */
  view(name, box) { this.fit(box, VIEWS[name]); }

  /** Page coordinates of a world point. */
  toPage(p) {
    const v = p.clone().project(this.camera);
    return this.ndcToPage(v);
  }

  ndcToPage(v) {
    const rect = this.canvas.getBoundingClientRect();
    return { x: rect.left + (v.x + 1) / 2 * rect.width, y: rect.top + (1 - v.y) / 2 * rect.height };
  }

  /** World-space length that covers `px` pixels at the distance of point p. */
  pixelsToWorld(px, p) {
    const dist = this.camera.position.distanceTo(p);
    const h = 2 * dist * Math.tan(THREE.MathUtils.degToRad(this.camera.fov) / 2);
    return px * h / Math.max(this.canvas.clientHeight, 1);
  }

  /** Median time of n complete frames, for benchmarks: draw, then read one pixel back, which waits
   * until the GPU (or the software renderer) has finished the frame. */
  measureFrames(n) {
    const gl = this.renderer.getContext(), times = [], px = new Uint8Array(4);
    for (let i = 0; i < n; i++) {
      const t0 = performance.now();
      this.draw();
      gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, px);
      times.push(performance.now() - t0);
    }
    times.sort((a, b) => a - b);
    return times[Math.floor(n / 2)];
  }
}

function label(text, color) {
  const c = document.createElement("canvas");
  c.width = c.height = 64;
  const g = c.getContext("2d");
  g.font = "bold 44px sans-serif";
  g.fillStyle = color;
  g.textAlign = "center"; g.textBaseline = "middle";
  g.fillText(text, 32, 34);
  const s = new THREE.Sprite(new THREE.SpriteMaterial({ map: new THREE.CanvasTexture(c), depthTest: false }));
  s.scale.set(0.55, 0.55, 1);
  return s;
}

function makeTriad() {
  const scene = new THREE.Scene();
  const camera = new THREE.OrthographicCamera(-1.7, 1.7, 1.7, -1.7, 0.1, 10);
  const axes = [["X", [1, 0, 0], 0xd62828, "#d62828"], ["Y", [0, 1, 0], 0x2a9d3a, "#2a9d3a"],
    ["Z", [0, 0, 1], 0x1f5fd6, "#1f5fd6"]];
  const shaft = new THREE.CylinderGeometry(0.05, 0.05, 0.72, 12).translate(0, 0.36, 0);
  const head = new THREE.ConeGeometry(0.13, 0.3, 16).translate(0, 0.85, 0);
  for (const [name, v, hex, css] of axes) {
    const dir = new THREE.Vector3(...v);
    const mat = new THREE.MeshBasicMaterial({ color: hex });
    const arrow = new THREE.Group();
    arrow.add(new THREE.Mesh(shaft, mat), new THREE.Mesh(head, mat));
    arrow.quaternion.setFromUnitVectors(new THREE.Vector3(0, 1, 0), dir);
    scene.add(arrow);
    const s = label(name, css);
    s.position.copy(dir).multiplyScalar(1.32);
    scene.add(s);
  }
  return { scene, camera };
}
