// The page of `shrad view`: draws the engine's frames (per-vertex linear radiance, exposure
// and tone mapping here), steers it (select, drag, rotate, lights, animation, solver) and
// shows its state (stats, plot, probes, channels, roles). Protocol: docs/viewer-protocol.md.

import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
import { decodeColours, decodeGeometry, header, KIND_COLOURS, KIND_GEOMETRY, request } from './protocol.js';
import { Plot } from './plot.js';

const $ = (id) => document.getElementById(id);
const ROLE_COLOURS = { boundary: 0x3b7bff, interior: 0xff8a2b, light: 0xffee55 };
const TONE_MAPS = {
  aces: THREE.ACESFilmicToneMapping, agx: THREE.AgXToneMapping, neutral: THREE.NeutralToneMapping,
  reinhard: THREE.ReinhardToneMapping, linear: THREE.LinearToneMapping,
};

// ---- renderer, camera, controls -------------------------------------------------------
const container = $('view');
// Multisampling is cheap on a GPU but dominates the cost of a software rasteriser
// (SwiftShader, llvmpipe: about 3x per frame), so it is off there; `?aa=1` / `?aa=0` force it.
function softwareRenderer() {
  const gl = document.createElement('canvas').getContext('webgl2');
  const info = gl && gl.getExtension('WEBGL_debug_renderer_info');
  const name = info ? String(gl.getParameter(info.UNMASKED_RENDERER_WEBGL)) : '';
  gl?.getExtension('WEBGL_lose_context')?.loseContext();
  return /swiftshader|llvmpipe|software/i.test(name);
}
const params = new URLSearchParams(location.search);
const software = softwareRenderer();
const antialias = params.has('aa') ? params.get('aa') !== '0' : !software;
// While something changes (a drag, the engine converging, the animation playing) a software
// rasteriser draws at a fraction of the canvas's resolution (its cost grows with the pixels:
// about 4x less at 0.5), and once the scene is still at full resolution, so that an
// interactive frame stays cheap enough to follow the mouse. `?scale=` sets the fraction.
const busyScale = Math.min(1, Math.max(0.125, Number(params.get('scale') ?? (software ? 0.5 : 1)) || 1));
const renderer = new THREE.WebGLRenderer({ antialias });
renderer.setPixelRatio(1);
renderer.outputColorSpace = THREE.SRGBColorSpace;
renderer.toneMapping = THREE.ACESFilmicToneMapping;
container.appendChild(renderer.domElement);
const world = new THREE.Scene();
world.background = new THREE.Color(0x000000);
const camera = new THREE.PerspectiveCamera(40, 1, 0.01, 1000);
const controls = new OrbitControls(camera, renderer.domElement);
controls.enableDamping = false;
controls.addEventListener('change', () => requestDraw());
const probeGroup = new THREE.Group();
world.add(probeGroup);

function resize() {
  const w = container.clientWidth, h = container.clientHeight;
  renderer.setSize(w, h, false);
  camera.aspect = w / Math.max(h, 1);
  camera.updateProjectionMatrix();
  requestDraw();
}
window.addEventListener('resize', resize);

// ---- state ----------------------------------------------------------------------------
const state = {
  scene: null, // the `scene` message
  objects: [], // per object: { mesh, overlay, meta, worldFromLocal (Matrix4), localFromObject (Matrix4) }
  lastFrame: null, // last `frame` message
  framesDrawn: 0,
  drawnTimes: [], // performance.now() of each drawn colour frame in the last second
  lastDrawnFrame: 0,
  selected: -1,
  nextId: 1,
  pendingSteer: new Map(), // id -> mouse-event times of the moves it stands for (its own and those it superseded)
  frameMs: new Map(), // frame -> the engine's ms for it (recent frames)
  received: 0, // frame messages received (acknowledged to the server: flow control)
  steps: [], // per applied move: the breakdown of its latency (see onOk)
  awaitingFrame: [], // [{frame, t}] steering to see drawn
  latencies: [], // ms from the mouse event to the drawn engine frame that shows its GI
  moveLatencies: [], // ms from the mouse event to the drawn frame that shows the object there
  receiveLatencies: [], // ms from the mouse event to the page receiving the first engine frame with it
  dispatchLatencies: [], // ms from the mouse event to its handler running (the browser's input delay)
  replyLatencies: [], // ms from the mouse event to the engine's reply to the move
  awaitingMove: [], // mouse-event times of local moves not drawn yet
  drawMs: [], // ms from queueing each of the last frames to the rasteriser finishing it
  pixelRatio: 1,
  messages: [],
  error: null,
  probes: null,
  connected: false,
};
const plot = new Plot($('plot'));
const fences = []; // frames queued and not yet finished by the rasteriser (see whenFinished)

// ---- connection -----------------------------------------------------------------------
const ws = new WebSocket(`ws://${location.host}/ws`);
ws.binaryType = 'arraybuffer';
ws.onopen = () => setStatus('connected', true);
ws.onclose = (e) => { state.connected = false; setStatus(`disconnected (${e.code}${e.reason ? ': ' + e.reason : ''})`, false); };
ws.onmessage = (e) => {
  try {
    if (typeof e.data === 'string') {
      const m = JSON.parse(e.data);
      if (m.type === 'frame' || m.type === 'probes') acknowledge();
      onText(m);
    } else {
      if (header(e.data).kind === KIND_COLOURS) acknowledge();
      onBinary(e.data);
    }
  } catch (err) {
    note(`bad message from the server: ${err.message}`, true);
  }
};

/** Tell the server one more frame message has arrived: it keeps a bounded number of bytes
 * unacknowledged, so frames never queue up in the socket ahead of newer ones. */
function acknowledge() {
  state.received++;
  send('ack', { received: state.received });
}

function send(type, body = {}, withId = false) {
  if (ws.readyState !== WebSocket.OPEN) return undefined;
  const id = withId ? state.nextId++ : undefined;
  ws.send(request(type, body, id));
  return id;
}

function setStatus(text, ok) {
  const s = $('status');
  s.textContent = text;
  s.className = ok ? 'status ok' : 'status';
  state.connected = ok;
}

function note(text, isError = false) {
  const div = document.createElement('div');
  div.textContent = text;
  if (isError) div.className = 'err';
  const box = $('messages');
  box.prepend(div);
  while (box.childNodes.length > 6) box.removeChild(box.lastChild);
  state.messages.push({ text, isError });
}

function onText(m) {
  switch (m.type) {
    case 'scene': return onScene(m);
    case 'frame': return onFrame(m);
    case 'probes': return onProbes(m);
    case 'ok': return onOk(m);
    case 'pong': return;
    case 'error': {
      // A refused move: show the engine's place again.
      const moved = localMoveOf(m.id);
      if (moved) { moved.local = null; requestDraw(); }
      state.pendingSteer.delete(m.id);
      return note(m.message, true);
    }
    default: return note(`unknown message type '${m.type}'`, true);
  }
}

function onBinary(buffer) {
  const h = header(buffer);
  if (h.kind === KIND_GEOMETRY) return onGeometry(decodeGeometry(buffer));
  if (h.kind === KIND_COLOURS) return onColours(decodeColours(buffer));
  note(`unknown binary kind ${h.kind}`, true);
}

// ---- scene and geometry ---------------------------------------------------------------
function onScene(m) {
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
  $('anim-section').style.display = m.duration > 0 ? '' : 'none';
  $('time').max = String(m.duration);
}

function onGeometry(objects) {
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

// ---- frames ---------------------------------------------------------------------------
function onFrame(m) {
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
}

function onColours(c) {
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

function placeMesh(ob) {
  ob.mesh.matrix.copy(ob.worldFromLocal);
  ob.mesh.matrixWorldNeedsUpdate = true;
  ob.overlay.matrix.copy(ob.worldFromLocal);
  ob.overlay.matrixWorldNeedsUpdate = true;
}

// At most one frame in flight: a new frame is queued only once the rasteriser has finished
// the last one, so that it shows the newest colours and moves rather than waiting behind
// older frames (with a software rasteriser slower than the engine, queued frames add their
// draw times to the latency).
let drawQueued = false;
let drawWanted = false;
function requestDraw() {
  if (fences.length) { drawWanted = true; return; }
  if (drawQueued) return;
  drawQueued = true;
  requestAnimationFrame(draw);
}

/** Wait (without blocking) for the frame queued at `done.start` to be rasterised, then note
 * its draw time and the latencies of the mouse events it shows. */
function whenFinished(done) {
  const gl = renderer.getContext();
  done.sync = typeof gl.fenceSync === 'function' ? gl.fenceSync(gl.SYNC_GPU_COMMANDS_COMPLETE, 0) : null;
  gl.flush();
  fences.push(done);
  if (fences.length === 1) setTimeout(pollFences, 2);
}
function pollFences() {
  const gl = renderer.getContext();
  while (fences.length) {
    const f = fences[0];
    if (f.sync && gl.getSyncParameter(f.sync, gl.SYNC_STATUS) !== gl.SIGNALED) break;
    fences.shift();
    if (f.sync) gl.deleteSync(f.sync);
    const now = performance.now();
    state.drawMs.push(now - f.start);
    if (state.drawMs.length > 60) state.drawMs.shift();
    for (const t of f.moves) state.moveLatencies.push(now - t);
    for (const a of f.gi) { state.latencies.push(now - a.t); a.step.drawn = now - a.t; }
  }
  if (fences.length) setTimeout(pollFences, 2);
  else if (drawWanted) { drawWanted = false; requestDraw(); }
}

/** Is anything changing on screen (so that a cheap, lower-resolution frame is enough)? */
function busy() {
  const f = state.lastFrame;
  return drag !== null || (f && (!f.converged || f.playing || f.continuous)) || state.objects.some((o) => o.local);
}

function draw() {
  drawQueued = false;
  const ratio = busy() ? busyScale : 1;
  if (ratio !== state.pixelRatio) {
    state.pixelRatio = ratio;
    renderer.setPixelRatio(ratio); // resizes the drawing buffer; the canvas keeps its CSS size
  }
  const start = performance.now();
  renderer.render(world, camera);
  const now = performance.now();
  // render() only queues the frame; a fence says when the rasteriser has finished it (what
  // the drag latencies and the draw time measure).
  const done = { start, moves: state.awaitingMove.splice(0), gi: [] };
  // Once still, draw again at full resolution.
  if (ratio !== 1 && !busy()) requestDraw();
  if (state.pendingColours !== undefined) {
    const f = state.pendingColours;
    state.pendingColours = undefined;
    state.framesDrawn++;
    state.lastDrawnFrame = f;
    state.drawnTimes.push(now);
    // Steering that this frame shows: the latency from its mouse event.
    state.awaitingFrame = state.awaitingFrame.filter((a) => {
      if (f >= a.frame) { done.gi.push(a); return false; }
      return true;
    });
  }
  whenFinished(done);
  while (state.drawnTimes.length && now - state.drawnTimes[0] > 1000) state.drawnTimes.shift();
}

/** The object whose move `id` the page shows ahead of the engine, if any. */
function localMoveOf(id) {
  return id === undefined ? undefined : state.objects.find((ob) => ob.local && ob.local.id === id);
}

function onOk(m) {
  if (m.superseded) {
    // A newer move of the same object replaced this one before the engine applied it: its
    // mouse events are shown by the frame that has the newer one.
    const times = state.pendingSteer.get(m.id);
    state.pendingSteer.delete(m.id);
    const newer = state.pendingSteer.get(m.superseded_by);
    if (times && newer) newer.push(...times);
    return;
  }
  const moved = localMoveOf(m.id);
  if (moved) moved.local.untilFrame = m.frame;
  if (m.id !== undefined && state.pendingSteer.has(m.id)) {
    const now = performance.now();
    for (const t of state.pendingSteer.get(m.id)) {
      state.replyLatencies.push(now - t);
      // Where the time goes, from the mouse event (ms): the reply is sent when the engine
      // applies the move, before it steps the frame that has it.
      const step = { t, replied: now - t, queued: m.queued_ms, frame: m.frame };
      state.steps.push(step);
      if (state.steps.length > 4000) state.steps.splice(0, 1000);
      state.awaitingFrame.push({ frame: m.frame, t, step });
    }
    state.pendingSteer.delete(m.id);
  }
  if (m.request === 'compute_error') { state.error = m; showStats(state.lastFrame); }
  if (m.request === 'set_option') note(`${m.key} = ${m.value}${m.precompute_ms ? ` (precomputed in ${m.precompute_ms.toFixed(0)} ms)` : ''}`);
  if (m.request === 'set_solver') note(`solver switched (precomputed in ${m.precompute_ms.toFixed(0)} ms)`);
}

// ---- stats ----------------------------------------------------------------------------
const median = (xs) => { if (!xs.length) return undefined; const v = xs.slice().sort((a, b) => a - b); return v[Math.floor(v.length / 2)]; };
const fmt = (x, d = 1) => (x === undefined || x === null || Number.isNaN(x) ? '–' : Number(x).toFixed(d));

/** The engine's steering backlog: requests that waited more than the one frame they must
 * (0 when all is well), what waits now, and how long the last ones waited. */
function steeringText(st) {
  if (!st) return '–';
  return `${st.backlog} · ${st.pending} waiting · last applied after ${st.waited_frames} frame${st.waited_frames === 1 ? '' : 's'} (${fmt(st.queued_ms, 0)} ms)`;
}

/** How much of the dispersive solver sleeps (its light stopped changing: no work). */
function sleepText(solver) {
  if (!solver || solver.kind !== 'dispersive') return '–';
  if (solver.asleep) return `everything (${solver.objects_asleep} objects): the frame costs nothing`;
  const pending = solver.wall_rows_pending ? ` · ${solver.wall_rows_pending} wall rows still building` : '';
  return `${solver.objects_asleep} object${solver.objects_asleep === 1 ? '' : 's'}${pending}`;
}

function showStats(m) {
  if (!m) return;
  const s = m.stats || {};
  const energy = s.energy || {};
  const updated = s.objects_updated || [];
  const names = updated.map((o) => (state.scene ? state.scene.objects[o]?.name : o)).join(', ');
  const pageRate = state.drawnTimes.length;
  const e = state.error;
  const rows = [
    ['solver', `${m.solver} (${m.preset})`],
    ['frame', `${m.frame}${m.converged ? ' · converged' : ''}`],
    ['ms per step', `${fmt(s.frame_ms, 2)} (server loop ${fmt(m.loop_ms, 1)}, publish ${fmt(m.publish_ms, 1)})`],
    ['backlog', steeringText(m.steering)],
    ['objects updated', `${updated.length}${names ? ' (' + names + ')' : ''}`],
    ['stalest', `${s.stalest ?? '–'} frames`],
    ['asleep', sleepText(s.solver)],
    ['energy', energy.emitted ? `absorbed/emitted ${fmt(energy.absorbed / energy.emitted, 3)} · reflected/bound ${fmt(energy.reflected / energy.reflected_bound, 3)}` : '–'],
    ['GI updates/s', `${m.gi_updates_per_s} engine · ${pageRate} drawn`],
    ['page draw', `${fmt(median(state.drawMs), 1)} ms at ${Math.round(100 * state.pixelRatio)} % resolution`],
    ['error', e ? `${fmt(100 * e.overall, 2)} % (boundary ${fmt(100 * e.boundary, 2)}, interior ${fmt(100 * e.interior, 2)}) at frame ${e.at_frame}, ${e.solver}` : 'not computed'],
  ];
  if (state.moveLatencies.length) rows.push(['drag to screen', `${fmt(median(state.moveLatencies.slice(-20)), 0)} ms (object) · ${fmt(median(state.latencies.slice(-20)), 0)} ms (its light)`]);
  if (s.diverged) rows.push(['diverged', s.diverged.message]);
  const table = $('stats');
  table.replaceChildren(...rows.map(([k, v]) => {
    const tr = document.createElement('tr');
    const a = document.createElement('td'); a.textContent = k;
    const b = document.createElement('td'); b.textContent = v;
    tr.append(a, b);
    return tr;
  }));
}

// ---- solver controls ------------------------------------------------------------------
function fillSolverControls(m) {
  $('solver').replaceChildren(...m.solvers.map((s) => new Option(s, s)));
  fillPresets();
}
function fillPresets() {
  const list = state.scene.presets[$('solver').value] || [];
  $('preset').replaceChildren(...list.map((s) => new Option(s, s)));
}
$('solver').onchange = fillPresets;
$('apply-solver').onclick = () => { send('set_solver', { solver: $('solver').value, preset: $('preset').value }); };
for (const key of ['per_frame', 'budget_ms', 'max_staleness']) {
  $(key).onchange = () => send('set_option', { key, value: $(key).value });
}
$('schedule').onchange = () => send('set_option', { key: 'schedule', value: $('schedule').value });
$('set-key').onchange = () => {
  const [key, ...rest] = $('set-key').value.split('=');
  if (!key || !rest.length) return note('type key=value (e.g. cube_res=64)', true);
  send('set_option', { key: key.trim(), value: rest.join('=').trim() });
};
$('continuous').onchange = () => send('run', { continuous: $('continuous').checked });
$('error-btn').onclick = () => { note('computing the reference…'); send('compute_error'); };

function syncLive(m) {
  const live = m.settings || {};
  $('live').style.display = m.solver === 'dispersive' ? '' : 'none';
  if (document.activeElement?.closest?.('#live')) return;
  for (const key of ['schedule', 'per_frame', 'budget_ms', 'max_staleness']) {
    const v = live[key];
    $(key).disabled = v === '-';
    if (v !== undefined && v !== '-' && $(key).value !== String(v)) $(key).value = String(v);
  }
  if (document.activeElement !== $('solver') && document.activeElement !== $('preset') && $('solver').value !== m.solver) {
    $('solver').value = m.solver;
    fillPresets();
    $('preset').value = m.preset;
  }
}

// ---- display controls -----------------------------------------------------------------
$('channel').onchange = () => send('set_channel', { channel: $('channel').value });
$('exposure').oninput = () => {
  const ev = Number($('exposure').value);
  renderer.toneMappingExposure = 2 ** ev;
  $('exposure-value').textContent = `${ev.toFixed(1)} EV`;
  requestDraw();
};
$('tonemap').onchange = () => {
  renderer.toneMapping = TONE_MAPS[$('tonemap').value];
  for (const o of state.objects) o.mesh.material.needsUpdate = true;
  for (const p of probeGroup.children) if (p.material) p.material.needsUpdate = true;
  requestDraw();
};
$('roles').onchange = () => {
  for (const o of state.objects) o.overlay.visible = $('roles').checked;
  requestDraw();
};
$('probes').onchange = () => {
  send('probes', { on: $('probes').checked });
  probeGroup.visible = $('probes').checked;
  requestDraw();
};

// ---- probes ---------------------------------------------------------------------------
let sphere = null;
function onProbes(m) {
  state.probes = m;
  if (!state.scene) return;
  if (!sphere) {
    const ps = state.scene.probe_sphere;
    sphere = new THREE.BufferGeometry();
    sphere.setAttribute('position', new THREE.Float32BufferAttribute(ps.directions.flat(), 3));
    sphere.setIndex(ps.triangles.flat());
  }
  const radius = 0.012 * (state.diagonal || 1);
  while (probeGroup.children.length > m.probes.length * 2) probeGroup.remove(probeGroup.children[probeGroup.children.length - 1]);
  m.probes.forEach((p, k) => {
    let ball = probeGroup.children[2 * k];
    let ring = probeGroup.children[2 * k + 1];
    if (!ball) {
      const g = sphere.clone();
      g.setAttribute('color', new THREE.Float32BufferAttribute(new Float32Array(sphere.getAttribute('position').count * 3), 3));
      ball = new THREE.Mesh(g, new THREE.MeshBasicMaterial({ vertexColors: true }));
      ring = new THREE.Mesh(sphere, new THREE.MeshBasicMaterial({ wireframe: true, toneMapped: false }));
      probeGroup.add(ball, ring);
    }
    ball.position.fromArray(p.position);
    ball.scale.setScalar(radius);
    const c = ball.geometry.getAttribute('color');
    c.array.set(p.radiance);
    c.needsUpdate = true;
    ring.position.fromArray(p.position);
    ring.scale.setScalar(radius * 1.35);
    ring.visible = p.state !== 'valid';
    ring.material.color.set(p.state === 'invalid' ? 0xff3333 : 0xffdd33);
  });
  requestDraw();
}

// ---- lights ---------------------------------------------------------------------------
function linearToHex(rgb) {
  const max = Math.max(...rgb, 1e-9);
  const c = new THREE.Color().setRGB(rgb[0] / max, rgb[1] / max, rgb[2] / max, THREE.LinearSRGBColorSpace);
  return '#' + c.getHexString(THREE.SRGBColorSpace);
}

function fillLights(m) {
  const box = $('lights');
  box.replaceChildren();
  const lights = m.objects.map((o, i) => ({ ...o, index: i })).filter((o) => o.role === 'light' && Math.max(...o.emission) > 0);
  $('lights-section').style.display = lights.length ? '' : 'none';
  for (const l of lights) {
    const base = Math.max(...l.emission);
    const div = document.createElement('div');
    div.className = 'light';
    div.innerHTML = `<div>${l.name}</div>
      <input type="color" value="${linearToHex(l.emission)}">
      power <input type="range" min="0" max="4" step="0.05" value="1"> <span>1.00×</span>
      <label style="display:inline"><input type="checkbox"> off</label>`;
    const [colour, power, off] = div.querySelectorAll('input');
    const label = div.querySelector('span');
    const update = () => {
      const c = new THREE.Color();
      c.setStyle(colour.value, THREE.SRGBColorSpace);
      const k = off.checked ? 0 : Number(power.value) * base;
      label.textContent = `${Number(power.value).toFixed(2)}×`;
      send('set_emission', { object: l.index, radiance: [c.r * k, c.g * k, c.b * k] });
    };
    colour.oninput = update; power.oninput = update; off.onchange = update;
    box.appendChild(div);
  }
}

// ---- animation ------------------------------------------------------------------------
$('play').onclick = () => send('play', { playing: !(state.lastFrame && state.lastFrame.playing) });
$('time').oninput = () => {
  const t = Number($('time').value);
  $('time-value').textContent = `${t.toFixed(2)} s`;
  send('set_time', { t });
};

// ---- selection, drag, rotation --------------------------------------------------------
const raycaster = new THREE.Raycaster();
const pointer = new THREE.Vector2();
let drag = null; // { object, plane, start (Vector3), startMatrix (world from object), pivot, normal, rotate, x0 }

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
function centreOf(o) {
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
  $('rot-left').disabled = $('rot-right').disabled = o < 0;
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
  const hit = pick(e);
  const o = hit ? hit.object.userData.object : -1;
  if (o < 0 || state.objects[o].meta.role !== 'interior') {
    if (!hit) select(-1);
    return;
  }
  select(o);
  const normal = supportNormal(o);
  drag = {
    object: o, normal, rotate: e.shiftKey, x0: e.clientX,
    plane: new THREE.Plane().setFromNormalAndCoplanarPoint(normal, hit.point),
    start: hit.point.clone(), startMatrix: worldFromObject(o),
  };
  controls.enabled = false;
  renderer.domElement.setPointerCapture(e.pointerId);
  e.preventDefault();
});

renderer.domElement.addEventListener('pointermove', (e) => {
  if (!drag) return;
  if (drag.rotate) {
    const angle = (e.clientX - drag.x0) * 0.01;
    steer(drag.object, rotated(drag.object, drag.startMatrix, angle, drag.normal), e.timeStamp);
    return;
  }
  ndc(e);
  const p = new THREE.Vector3();
  if (!raycaster.ray.intersectPlane(drag.plane, p)) return;
  const d = p.sub(drag.start);
  const m = new THREE.Matrix4().makeTranslation(d.x, d.y, d.z).multiply(drag.startMatrix);
  steer(drag.object, m, e.timeStamp);
});

function endDrag(e) {
  if (!drag) return;
  drag = null;
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
$('rot-left').onclick = () => rotateSelected(Math.PI / 12);
$('rot-right').onclick = () => rotateSelected(-Math.PI / 12);
window.addEventListener('keydown', (e) => {
  if (e.target instanceof HTMLInputElement || e.target instanceof HTMLSelectElement) return;
  if (e.key === 'q' || e.key === 'Q') rotateSelected(Math.PI / 12);
  if (e.key === 'e' || e.key === 'E') rotateSelected(-Math.PI / 12);
});

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
