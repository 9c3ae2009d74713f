// Steering by mouse and keys: select an interior object, drag it over the surface it rests
// on, rotate it (shift-drag, Q / E, the buttons), paint it (`set_reflectance`); drag a point
// or spot light's ball (gizmos.js). The page shows a move at once and the engine's frames take over once they
// have it.

import * as THREE from 'three';
import { send } from './connection.js';
import { dragLight, pickLight, startLightDrag } from './gizmos.js';
import { $, state } from './state.js';
import { camera, controls, placeMesh, renderer, requestDraw } from './view.js';

const raycaster = new THREE.Raycaster();
const pointer = new THREE.Vector2();
// state.drag while dragging: { object, plane, start (Vector3), startMatrix (world from object), normal, rotate, x0 }

function ndc(e) {
  const r = renderer.domElement.getBoundingClientRect();
  pointer.set(((e.clientX - r.left) / r.width) * 2 - 1, -((e.clientY - r.top) / r.height) * 2 + 1);
  raycaster.setFromCamera(pointer, camera);
}

function pick(e) {
  ndc(e);
  const hits = raycaster.intersectObjects(state.objects.map((o) => o.mesh), false);
  return hits.length ? hits[0] : null;
}

/** World from object of object `o` now. */
function worldFromObject(o) {
  const ob = state.objects[o];
  return new THREE.Matrix4().multiplyMatrices(ob.worldFromLocal, ob.localFromObject);
}

/** World box centre of object `o`. */
export function centreOf(o) {
  const ob = state.objects[o];
  const box = ob.mesh.geometry.boundingBox.clone().applyMatrix4(ob.worldFromLocal);
  return box.getCenter(new THREE.Vector3());
}

/** The surface object `o` rests on: the first other surface below its centre (its normal),
 * else the world's up. */
function supportNormal(o) {
  const ob = state.objects[o];
  const box = ob.mesh.geometry.boundingBox.clone().applyMatrix4(ob.worldFromLocal);
  const from = box.getCenter(new THREE.Vector3());
  const down = new THREE.Raycaster(from, new THREE.Vector3(0, -1, 0));
  const others = state.objects.filter((_, i) => i !== o).map((x) => x.mesh);
  const hit = down.intersectObjects(others, false)[0];
  if (hit && hit.face) {
    const n = hit.face.normal.clone().transformDirection(hit.object.matrixWorld);
    if (n.y > 0.3) return n.normalize();
  }
  return new THREE.Vector3(0, 1, 0);
}

function select(o) {
  state.selected = o;
  const name = o >= 0 ? state.objects[o].meta.name : null;
  $('selection').textContent = name ? `selected: ${name}` : 'click an interior object, then drag it; Q / E or shift-drag rotates it';
  $('rot-left').disabled = $('rot-right').disabled = $('paint').disabled = o < 0;
  if (o >= 0) {
    const rho = state.objects[o].meta.reflectance;
    const c = new THREE.Color().setRGB(rho[0], rho[1], rho[2], THREE.LinearSRGBColorSpace);
    $('paint').value = '#' + c.getHexString(THREE.SRGBColorSpace);
  }
  for (const [i, ob] of state.objects.entries()) {
    ob.overlay.visible = $('roles').checked || i === o;
    ob.overlay.material.opacity = i === o ? 0.25 : 0.35;
  }
  requestDraw();
}

/** Move object `o` to `matrix` (world from object) for the mouse event at time `t`: the page
 * shows it there at once, with the colours it has, and the engine's frames take over once
 * one of them has the move (its light then follows within a few frames). */
function steer(o, matrix, t) {
  const id = send('set_transform', { object: o, matrix: Array.from(matrix.elements) }, true);
  if (id === undefined) return;
  state.dispatchLatencies.push(performance.now() - t);
  state.pendingSteer.set(id, [t]);
  const ob = state.objects[o];
  const worldFromLocal = matrix.clone().multiply(ob.localFromObject.clone().invert());
  ob.local = { id, worldFromLocal, untilFrame: undefined };
  ob.worldFromLocal.copy(worldFromLocal);
  placeMesh(ob);
  state.awaitingMove.push(t);
  requestDraw();
}

function rotated(o, start, angle, normal) {
  const pivot = centreOf(o);
  const r = new THREE.Matrix4().makeRotationAxis(normal, angle);
  const to = new THREE.Matrix4().makeTranslation(pivot.x, pivot.y, pivot.z);
  const from = new THREE.Matrix4().makeTranslation(-pivot.x, -pivot.y, -pivot.z);
  return to.multiply(r).multiply(from).multiply(start);
}

renderer.domElement.addEventListener('pointerdown', (e) => {
  if (e.button !== 0 || !state.objects.length) return;
  // A watcher orbits and looks; only the client that steers moves objects.
  if (state.role === 'watch') return;
  ndc(e);
  const light = pickLight(raycaster);
  if (light >= 0) {
    state.drag = { ...startLightDrag(light, raycaster, e.shiftKey), isLight: true };
    controls.enabled = false;
    renderer.domElement.setPointerCapture(e.pointerId);
    e.preventDefault();
    return;
  }
  const hit = pick(e);
  const o = hit ? hit.object.userData.object : -1;
  if (o < 0 || state.objects[o].meta.role !== 'interior') {
    if (!hit) select(-1);
    return;
  }
  select(o);
  const normal = supportNormal(o);
  state.drag = {
    object: o, normal, rotate: e.shiftKey, x0: e.clientX,
    plane: new THREE.Plane().setFromNormalAndCoplanarPoint(normal, hit.point),
    start: hit.point.clone(), startMatrix: worldFromObject(o),
  };
  controls.enabled = false;
  renderer.domElement.setPointerCapture(e.pointerId);
  e.preventDefault();
});

renderer.domElement.addEventListener('pointermove', (e) => {
  if (!state.drag) return;
  if (state.drag.isLight) { ndc(e); dragLight(state.drag, raycaster); return; }
  if (state.drag.rotate) {
    const angle = (e.clientX - state.drag.x0) * 0.01;
    steer(state.drag.object, rotated(state.drag.object, state.drag.startMatrix, angle, state.drag.normal), e.timeStamp);
    return;
  }
  ndc(e);
  const p = new THREE.Vector3();
  if (!raycaster.ray.intersectPlane(state.drag.plane, p)) return;
  const d = p.sub(state.drag.start);
  const m = new THREE.Matrix4().makeTranslation(d.x, d.y, d.z).multiply(state.drag.startMatrix);
  steer(state.drag.object, m, e.timeStamp);
});

function endDrag(e) {
  if (!state.drag) return;
  state.drag = null;
  controls.enabled = true;
  try { renderer.domElement.releasePointerCapture(e.pointerId); } catch { /* already released */ }
}
renderer.domElement.addEventListener('pointerup', endDrag);
renderer.domElement.addEventListener('pointercancel', endDrag);

function rotateSelected(angle) {
  const o = state.selected;
  if (o < 0) return;
  steer(o, rotated(o, worldFromObject(o), angle, supportNormal(o)), performance.now());
}
$('paint').oninput = () => {
  const o = state.selected;
  if (o < 0) return;
  const c = new THREE.Color().setStyle($('paint').value, THREE.SRGBColorSpace);
  state.objects[o].meta.reflectance = [c.r, c.g, c.b];
  send('set_reflectance', { object: o, reflectance: [c.r, c.g, c.b] });
};
$('rot-left').onclick = () => rotateSelected(Math.PI / 12);
$('rot-right').onclick = () => rotateSelected(-Math.PI / 12);
window.addEventListener('keydown', (e) => {
  if (e.target instanceof HTMLInputElement || e.target instanceof HTMLSelectElement) return;
  if (e.key === 'q' || e.key === 'Q') rotateSelected(Math.PI / 12);
  if (e.key === 'e' || e.key === 'E') rotateSelected(-Math.PI / 12);
});
