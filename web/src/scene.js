// The scene the server sent: the camera and bounds (`scene`), the objects' meshes
// (geometry), and every frame's stats and colours.

import * as THREE from 'three';
import { note } from './connection.js';
import { fillLights, syncLights } from './lights.js';
import { fillSolverControls, plot, showStats, syncLive } from './panels.js';
import { showSky } from './sky.js';
import { $, state } from './state.js';
import { camera, controls, placeMesh, requestDraw, resize, world } from './view.js';

const ROLE_COLOURS = { boundary: 0x3b7bff, interior: 0xff8a2b, light: 0xffee55 };

export function onScene(m) {
  state.scene = m;
  $('source').textContent = `${m.source} · ${m.patches} patches · ${m.objects.length} objects`;
  const cam = m.camera;
  const wfc = new THREE.Matrix4().fromArray(cam.world_from_camera);
  const pos = new THREE.Vector3(), quat = new THREE.Quaternion(), scl = new THREE.Vector3();
  wfc.decompose(pos, quat, scl);
  camera.position.copy(pos);
  camera.quaternion.copy(quat);
  camera.fov = THREE.MathUtils.radToDeg(cam.yfov);
  const [lo, hi] = m.bounds;
  const centre = new THREE.Vector3((lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, (lo[2] + hi[2]) / 2);
  const forward = new THREE.Vector3(0, 0, -1).applyQuaternion(quat);
  const along = Math.max(centre.clone().sub(pos).dot(forward), 1e-3);
  controls.target.copy(pos.clone().addScaledVector(forward, along));
  const diag = new THREE.Vector3(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]).length();
  camera.near = diag * 1e-3;
  camera.far = diag * 20;
  state.diagonal = diag;
  controls.update();
  resize();
  fillSolverControls(m);
  fillLights(m);
  showSky(m.sky);
  $('anim-section').style.display = m.duration > 0 ? '' : 'none';
  $('time').max = String(m.duration);
}

export function onGeometry(objects) {
  const m = state.scene;
  if (!m || objects.length !== m.objects.length) return note('geometry does not match the scene message', true);
  for (const o of state.objects) { world.remove(o.mesh); world.remove(o.overlay); }
  state.objects = objects.map((g, i) => {
    const meta = m.objects[i];
    const geometry = new THREE.BufferGeometry();
    geometry.setAttribute('position', new THREE.BufferAttribute(g.positions, 3));
    geometry.setIndex(new THREE.BufferAttribute(g.triangles, 1));
    const colours = new THREE.Float16BufferAttribute(new Uint16Array(g.positions.length), 3);
    colours.setUsage(THREE.DynamicDrawUsage);
    geometry.setAttribute('color', colours);
    geometry.computeBoundingSphere();
    geometry.computeBoundingBox();
    const material = new THREE.MeshBasicMaterial({ vertexColors: true, side: THREE.FrontSide });
    material.color.setScalar(0);
    const mesh = new THREE.Mesh(geometry, material);
    mesh.matrixAutoUpdate = false;
    mesh.userData.object = i;
    const overlay = new THREE.Mesh(geometry, new THREE.MeshBasicMaterial({
      color: ROLE_COLOURS[meta.role], transparent: true, opacity: 0.35, depthWrite: false,
      polygonOffset: true, polygonOffsetFactor: -1, polygonOffsetUnits: -1, toneMapped: false,
    }));
    overlay.matrixAutoUpdate = false;
    overlay.visible = $('roles').checked;
    world.add(mesh);
    world.add(overlay);
    return {
      mesh, overlay, meta, vertices: g.positions.length / 3,
      worldFromLocal: new THREE.Matrix4(),
      localFromObject: new THREE.Matrix4().fromArray(meta.local_from_object),
    };
  });
  requestDraw();
}

export function onFrame(m) {
  state.lastFrame = m;
  if (m.error) state.error = m.error;
  if (m.stats) {
    plot.push(m.stats.frame_ms ?? 0, m.gi_updates_per_s);
    state.frameMs.set(m.frame, m.stats.frame_ms);
    if (state.frameMs.size > 300) state.frameMs.delete(state.frameMs.keys().next().value);
  }
  // The panel is redrawn a few times a second, not per frame: with software compositing
  // its layout and paint cost the engine and the canvas CPU time.
  const now = performance.now();
  if (!(now - (state.statsShownAt ?? -1e9) < 200)) { state.statsShownAt = now; showStats(m); plot.draw(); }
  if (m.playing) { $('time').value = String(m.time); $('time-value').textContent = `${m.time.toFixed(2)} s`; }
  $('play').textContent = m.playing ? 'pause' : 'play';
  $('continuous').checked = m.continuous;
  syncLive(m);
  syncLights(m);
}

export function onColours(c) {
  if (!state.objects.length) return;
  const n = state.objects.length;
  if (c.matrices.length !== 16 * n) return note('colour frame does not match the geometry', true);
  for (let o = 0; o < n; o++) {
    const ob = state.objects[o];
    // A move the page showed ahead of the engine stays until a frame that has it arrives.
    if (ob.local && ob.local.untilFrame !== undefined && c.frame >= ob.local.untilFrame) ob.local = null;
    if (ob.local) ob.worldFromLocal.copy(ob.local.worldFromLocal);
    else ob.worldFromLocal.fromArray(c.matrices, 16 * o);
    placeMesh(ob);
    const first = ob.meta.first_vertex;
    const attr = ob.mesh.geometry.getAttribute('color');
    attr.array.set(c.halves.subarray(3 * first, 3 * (first + ob.vertices)));
    attr.needsUpdate = true;
    ob.mesh.material.color.setScalar(c.scale);
  }
  state.pendingColours = c.frame;
  state.lastChannel = c.channel;
  // What the engine and the network take, before the page draws.
  const now = performance.now();
  for (const a of state.awaitingFrame) {
    if (c.frame >= a.frame && !a.received) {
      a.received = true;
      state.receiveLatencies.push(now - a.t);
      a.step.received = now - a.t;
      a.step.computeMs = state.frameMs.get(a.frame);
    }
  }
  requestDraw();
}
