// The server's messages, each to its handler: the scene, geometry and frames (scene.js),
// probes (panels.js), replies to requests, this client's role, errors.

import { note, send } from './connection.js';
import { onLightReply } from './gizmos.js';
import { onProbes, showStats } from './panels.js';
import { decodeColours, decodeGeometry, decodeSky, header, KIND_COLOURS, KIND_GEOMETRY, KIND_SKY } from './protocol.js';
import { onColours, onFrame, onGeometry, onScene } from './scene.js';
import { onSkyMap } from './sky.js';
import { $, state } from './state.js';
import { requestDraw } from './view.js';

export function onText(m) {
  switch (m.type) {
    case 'scene': return onScene(m);
    case 'frame': return onFrame(m);
    case 'probes': return onProbes(m);
    case 'ok': return onOk(m);
    case 'pong': return;
    case 'role': return onRole(m);
    case 'refused': return note(`refused: ${m.message}`, true);
    case 'error': {
      // A refused move: show the engine's place again.
      const moved = localMoveOf(m.id);
      if (moved) { moved.local = null; requestDraw(); }
      onLightReply(m);
      state.pendingSteer.delete(m.id);
      return note(m.message, true);
    }
    default: return note(`unknown message type '${m.type}'`, true);
  }
}

/** Whether this page steers or watches (one client steers; `--watch-only`: nobody). */
function onRole(m) {
  state.role = m.role;
  const who = m.role === 'steer' ? 'you steer'
    : m.watch_only ? 'you watch (this server is watch-only)'
      : m.steering_free ? 'you watch; steering is free' : 'you watch (another client steers)';
  $('role').textContent = `${who} · ${m.clients} of ${m.max_clients} clients`;
  $('role').className = m.role === 'steer' ? 'steer' : 'watch';
  $('take-steering').hidden = !(m.role !== 'steer' && m.steering_free);
  $('release-steering').hidden = m.role !== 'steer' || m.clients < 2;
}

$('take-steering').onclick = () => send('take_steering');
$('release-steering').onclick = () => send('release_steering');

export function onBinary(buffer) {
  const h = header(buffer);
  if (h.kind === KIND_GEOMETRY) return onGeometry(decodeGeometry(buffer));
  if (h.kind === KIND_COLOURS) return onColours(decodeColours(buffer));
  if (h.kind === KIND_SKY) return onSkyMap(decodeSky(buffer));
  note(`unknown binary kind ${h.kind}`, true);
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
  if (m.request === 'set_light_transform') onLightReply(m);
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
