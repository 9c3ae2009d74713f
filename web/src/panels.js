// The side panels: stats and the frame-time plot, the solver's and the display's controls,
// the probes and the animation (the lights: lights.js).

import * as THREE from 'three';
import { note, send } from './connection.js';
import { Plot } from './plot.js';
import { $, state } from './state.js';
import { probeGroup, renderer, requestDraw } from './view.js';

const TONE_MAPS = {
  aces: THREE.ACESFilmicToneMapping, agx: THREE.AgXToneMapping, neutral: THREE.NeutralToneMapping,
  reinhard: THREE.ReinhardToneMapping, linear: THREE.LinearToneMapping,
};
export const plot = new Plot($('plot'));

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

export function showStats(m) {
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
export function fillSolverControls(m) {
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

export function syncLive(m) {
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
export function onProbes(m) {
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

// ---- animation ------------------------------------------------------------------------
$('play').onclick = () => send('play', { playing: !(state.lastFrame && state.lastFrame.playing) });
$('time').oninput = () => {
  const t = Number($('time').value);
  $('time-value').textContent = `${t.toFixed(2)} s`;
  send('set_time', { t });
};
