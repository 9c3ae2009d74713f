// The punctual lights in the view: a point or spot light as a small ball in its colour (a
// spot with its outer cone), dragged like an object: over the horizontal plane through it,
// or with shift up and down in the vertical plane facing the camera. The page shows a move
// at once; the engine's frames (`frame` message, `lights`) take over once one has it.

import * as THREE from 'three';
import { send } from './connection.js';
import { state } from './state.js';
import { camera, requestDraw, world } from './view.js';

const group = new THREE.Group();
world.add(group);

/** A display colour for a light's linear RGB (its hue at full brightness). */
function hue(rgb) {
  const max = Math.max(...rgb, 1e-9);
  return new THREE.Color().setRGB(rgb[0] / max, rgb[1] / max, rgb[2] / max, THREE.LinearSRGBColorSpace);
}

/** Build the gizmos of `state.lights` (directional lights have none: they are everywhere). */
export function makeGizmos() {
  group.clear();
  const r = 0.012 * (state.diagonal || 1);
  state.lights.forEach((l, i) => {
    l.gizmo = null;
    if (l.meta.kind === 'directional') return;
    const g = new THREE.Group();
    const material = new THREE.MeshBasicMaterial({ color: hue(l.meta.color), toneMapped: false });
    const ball = new THREE.Mesh(new THREE.SphereGeometry(r, 16, 8), material);
    ball.userData.light = i;
    g.add(ball);
    if (l.meta.kind === 'spot') {
      const h = 5 * r;
      const outer = Math.min(l.meta.cone.outer, THREE.MathUtils.degToRad(80));
      const cone = new THREE.ConeGeometry(h * Math.tan(outer), h, 16, 1, true);
      cone.translate(0, -h / 2, 0); // apex at the light, opening along -Y
      const mesh = new THREE.Mesh(cone, new THREE.MeshBasicMaterial({ color: material.color, wireframe: true, toneMapped: false }));
      mesh.userData.light = i;
      g.add(mesh);
      g.userData.cone = mesh;
    }
    group.add(g);
    l.gizmo = g;
    place(l, l.now);
  });
  requestDraw();
}

/** Put light `l`'s gizmo at `s` (`position`, `direction`, `color`); whether that changed it. */
function place(l, s) {
  if (!l.gizmo) return false;
  const key = JSON.stringify([s.position, s.direction, s.color]);
  if (key === l.gizmo.userData.placed) return false;
  l.gizmo.userData.placed = key;
  l.gizmo.position.fromArray(s.position);
  const cone = l.gizmo.userData.cone;
  if (cone) cone.quaternion.setFromUnitVectors(new THREE.Vector3(0, -1, 0), new THREE.Vector3().fromArray(s.direction).normalize());
  for (const part of l.gizmo.children) part.material.color.copy(hue(s.color));
  return true;
}

/** A `frame` message's lights: where the engine has them now (a move the page shows ahead
 * stays until the frame that has it). Every `frame` message has `lights` (an empty list when
 * the scene has no punctual light), so this asks for a draw only when a gizmo changed: a draw
 * per message kept the software rasteriser busy with frames that showed nothing new, and the
 * colour frames waited behind them. */
export function syncGizmos(m) {
  if (!m.lights) return;
  let moved = false;
  m.lights.forEach((s, i) => {
    const l = state.lights[i];
    if (!l) return;
    l.now = { ...l.meta, ...s };
    if (l.local && l.local.untilFrame !== undefined && m.frame >= l.local.untilFrame) l.local = null;
    if (place(l, l.local ? { ...l.now, position: l.local.position } : l.now)) moved = true;
  });
  if (moved) requestDraw();
}

/** The light whose gizmo `raycaster` meets first, or -1. */
export function pickLight(raycaster) {
  const hit = raycaster.intersectObjects(group.children, true)[0];
  return hit ? hit.object.userData.light : -1;
}

/** Start dragging light `i` from where `raycaster` points; `vertical`: up and down. */
export function startLightDrag(i, raycaster, vertical) {
  const l = state.lights[i];
  const p = new THREE.Vector3().fromArray(l.now.position);
  const normal = vertical ? camera.getWorldDirection(new THREE.Vector3()).setY(0) : new THREE.Vector3(0, 1, 0);
  if (normal.lengthSq() < 1e-12) normal.set(0, 0, 1);
  const plane = new THREE.Plane().setFromNormalAndCoplanarPoint(normal.normalize(), p);
  const start = new THREE.Vector3();
  if (!raycaster.ray.intersectPlane(plane, start)) start.copy(p);
  return { light: i, plane, start, startMatrix: new THREE.Matrix4().fromArray(l.now.world_from_light) };
}

/** Follow the pointer (`raycaster`) in `drag`. */
export function dragLight(drag, raycaster) {
  const p = new THREE.Vector3();
  if (!raycaster.ray.intersectPlane(drag.plane, p)) return;
  const d = p.sub(drag.start);
  moveLight(drag.light, new THREE.Matrix4().makeTranslation(d.x, d.y, d.z).multiply(drag.startMatrix));
}

/** Put light `i` at `matrix` (world from light): asked of the engine, shown at once. */
export function moveLight(i, matrix) {
  const id = send('set_light_transform', { light: i, matrix: Array.from(matrix.elements) }, true);
  if (id === undefined) return;
  const l = state.lights[i];
  l.local = { id, untilFrame: undefined, position: [matrix.elements[12], matrix.elements[13], matrix.elements[14]] };
  place(l, { ...l.now, position: l.local.position });
  requestDraw();
}

/** The engine's reply to a light's move: the frame from which its frames have it (or, on
 * an error, at once). */
export function onLightReply(m) {
  const l = state.lights.find((x) => x.local && x.local.id === m.id);
  if (!l) return;
  if (m.type === 'error') { l.local = null; place(l, l.now); requestDraw(); } else l.local.untilFrame = m.frame;
}
