// The page of `shrad view`: draws the engine's frames (per-vertex linear radiance, exposure
// and tone mapping here), steers it (select, drag, rotate, lights, animation, solver) and
// shows its state (stats, plot, probes, channels, roles). Protocol: docs/viewer-protocol.md.
// By concern: connection.js (the socket), messages.js (each message to its handler),
// scene.js (scene, geometry, frames), view.js (three.js and the draw loop), controls.js
// (selection, drag, rotation), panels.js (stats, settings, probes, animation), lights.js
// (the lights panel), gizmos.js (punctual lights in the view), sky.js (the background),
// plot.js (the frame-time plot), state.js (what they share).

import * as THREE from 'three';
import { connect, send } from './connection.js';
import { centreOf } from './controls.js';
import { onBinary, onText } from './messages.js';
import { state } from './state.js';
import { camera, renderer, resize, world } from './view.js';

connect(onText, onBinary);

// ---- hooks for the browser test (read-only views of the page's state) -----------------
window.__shrad = {
  renderer, camera, world,
  state,
  send,
  /** Canvas-pixel position of object `name`'s world-box centre, or of a world point. */
  screenOf(nameOrPoint) {
    let p;
    if (typeof nameOrPoint === 'string') {
      const o = state.objects.findIndex((x) => x.meta.name === nameOrPoint);
      if (o < 0) return null;
      p = centreOf(o);
    } else {
      p = new THREE.Vector3(...nameOrPoint);
    }
    const v = p.project(camera);
    const r = renderer.domElement.getBoundingClientRect();
    return { x: r.left + (v.x + 1) / 2 * r.width, y: r.top + (1 - v.y) / 2 * r.height };
  },
  /** Canvas-pixel position of punctual light `name` (where the page shows it). */
  screenOfLight(name) {
    const l = state.lights.find((x) => x.meta.name === name);
    return l && l.gizmo ? this.screenOf(l.gizmo.position.toArray()) : null;
  },
  /** World box of object `name` ([lo, hi]). */
  boxOf(name) {
    const o = state.objects.findIndex((x) => x.meta.name === name);
    const ob = state.objects[o];
    const b = ob.mesh.geometry.boundingBox.clone().applyMatrix4(ob.worldFromLocal);
    return [b.min.toArray(), b.max.toArray()];
  },
  /** Render now and read back the mean colour (0..255) of each [x, y, w, h] rect, in CSS
   * pixels of the page (as `screenOf` gives them; the drawing buffer may be smaller). */
  sample(rects) {
    renderer.render(world, camera);
    const gl = renderer.getContext();
    const el = renderer.domElement, box = el.getBoundingClientRect();
    const k = el.width / Math.max(box.width, 1);
    return rects.map(([x0, y0, w0, h0]) => {
      const x = Math.round((x0 - box.left) * k), w = Math.max(1, Math.round(w0 * k));
      const y = Math.round((y0 - box.top) * k), h = Math.max(1, Math.round(h0 * k));
      const px = new Uint8Array(4 * w * h);
      gl.readPixels(x, el.height - y - h, w, h, gl.RGBA, gl.UNSIGNED_BYTE, px);
      let r = 0, g = 0, b = 0;
      for (let i = 0; i < px.length; i += 4) { r += px[i]; g += px[i + 1]; b += px[i + 2]; }
      const n = w * h;
      return [r / n, g / n, b / n];
    });
  },
  /** The canvas's size in CSS pixels. */
  canvasSize() { const r = renderer.domElement.getBoundingClientRect(); return [Math.round(r.width), Math.round(r.height)]; },
  /** Sum over every vertex of the linear radiance (RGB) the page draws now: the halves of the
   * last colour frame of the channel it shows, under that frame's scale. */
  radianceSum() {
    const sum = [0, 0, 0];
    for (const ob of state.objects) {
      const a = ob.mesh.geometry.getAttribute('color').array;
      const scale = ob.mesh.material.color.r;
      for (let i = 0; i < a.length; i++) sum[i % 3] += THREE.DataUtils.fromHalfFloat(a[i]) * scale;
    }
    return sum;
  },
};
resize();
