// The 3D view: renderer, scene, lights, camera and orbit navigation, the render loop and
// framing. Other modules add their objects to `viewer.scene`.
import * as THREE from "three";
import { OrbitControls } from "three/addons/controls/OrbitControls.js";

export class Viewer {
  constructor(canvas) {
    this.canvas = canvas;
    this.renderer = new THREE.WebGLRenderer({ canvas, antialias: true, preserveDrawingBuffer: true });
    this.renderer.localClippingEnabled = true;
    this.scene = new THREE.Scene();
    this.scene.background = new THREE.Color(0xf4f5f7);
    this.camera = new THREE.PerspectiveCamera(40, 1, 0.001, 1e6);
    this.scene.add(new THREE.HemisphereLight(0xffffff, 0x667788, 1.6));
    this.sun = new THREE.DirectionalLight(0xffffff, 1.6);
    this.scene.add(this.sun);
    this.orbit = new OrbitControls(this.camera, canvas);
    this.beforeRender = [];
    const loop = () => {
      this.resize();
      for (const fn of this.beforeRender) fn();
      this.sun.position.copy(this.camera.position);
      this.renderer.render(this.scene, this.camera);
      requestAnimationFrame(loop);
    };
    requestAnimationFrame(loop);
  }

  resize() {
    const c = this.canvas, w = c.clientWidth, h = c.clientHeight;
    if (c.width !== w || c.height !== h) {
      this.renderer.setSize(w, h, false);
      this.camera.aspect = w / Math.max(h, 1);
      this.camera.updateProjectionMatrix();
    }
  }

  /** Frame a bounding box (THREE.Box3). */
  fit(box) {
    this.resize();
    const camera = this.camera;
    const c = box.getCenter(new THREE.Vector3());
    const r = box.getSize(new THREE.Vector3()).length() / 2 || 1;
    this.orbit.target.copy(c);
    // distance at which the bounding sphere fits the narrower of the two fields of view
    const vfov = THREE.MathUtils.degToRad(camera.fov);
    const hfov = 2 * Math.atan(Math.tan(vfov / 2) * camera.aspect);
    const dist = 1.1 * r / Math.sin(Math.min(vfov, hfov) / 2);
    camera.position.copy(c).add(new THREE.Vector3(0.6, -1.2, 0.8).normalize().multiplyScalar(dist));
    camera.near = r / 1000; camera.far = r * 100;
    camera.up.set(0, 0, 1);
    camera.updateProjectionMatrix();
    this.orbit.update();
  }

  /** Page coordinates of a world point. */
  toPage(p) {
    const v = p.clone().project(this.camera);
    return this.ndcToPage(v);
  }

  ndcToPage(v) {
    const rect = this.canvas.getBoundingClientRect();
    return { x: rect.left + (v.x + 1) / 2 * rect.width, y: rect.top + (1 - v.y) / 2 * rect.height };
  }
}
