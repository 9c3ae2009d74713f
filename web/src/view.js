// The three.js view: renderer, camera, orbit controls, and the draw loop (at most one frame
// in flight, a lower resolution on a software rasteriser while something changes).

import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
import { $, params, state } from './state.js';

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
const software = softwareRenderer();
const antialias = params.has('aa') ? params.get('aa') !== '0' : !software;
// While something changes (a drag, the engine converging, the animation playing) a software
// rasteriser draws at a fraction of the canvas's resolution (its cost grows with the pixels:
// about 4x less at 0.5), and once the scene is still at full resolution, so that an
// interactive frame stays cheap enough to follow the mouse. `?scale=` sets the fraction.
const busyScale = Math.min(1, Math.max(0.125, Number(params.get('scale') ?? (software ? 0.5 : 1)) || 1));
export const renderer = new THREE.WebGLRenderer({ antialias });
renderer.setPixelRatio(1);
renderer.outputColorSpace = THREE.SRGBColorSpace;
renderer.toneMapping = THREE.ACESFilmicToneMapping;
container.appendChild(renderer.domElement);
export const world = new THREE.Scene();
world.background = new THREE.Color(0x000000);
export const camera = new THREE.PerspectiveCamera(40, 1, 0.01, 1000);
export const controls = new OrbitControls(camera, renderer.domElement);
controls.enableDamping = false;
controls.addEventListener('change', () => requestDraw());
export const probeGroup = new THREE.Group();
world.add(probeGroup);
const fences = []; // frames queued and not yet finished by the rasteriser (see whenFinished)

export function resize() {
  const w = container.clientWidth, h = container.clientHeight;
  renderer.setSize(w, h, false);
  camera.aspect = w / Math.max(h, 1);
  camera.updateProjectionMatrix();
  requestDraw();
}
window.addEventListener('resize', resize);

/** Put object `ob`'s mesh and role overlay at its `worldFromLocal`. */
export function placeMesh(ob) {
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
export function requestDraw() {
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
  return state.drag !== null || (f && (!f.converged || f.playing || f.continuous)) || state.objects.some((o) => o.local);
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
