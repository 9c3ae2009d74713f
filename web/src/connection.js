// The WebSocket to the server: connecting, sending requests, acknowledging frames (flow
// control), and the status line and message list the page shows. Protocol:
// docs/viewer-protocol.md.

import { header, KIND_COLOURS, request } from './protocol.js';
import { $, params, state } from './state.js';

let ws = null;

/** Open the socket; text messages go to `onText` (parsed), binary ones to `onBinary`. */
export function connect(onText, onBinary) {
  // A server shared beyond loopback wants its token (`?token=...` in this page's address) on
  // the WebSocket too: the page's files carry it in the cookie the server set, the socket in
  // its URL.
  const token = params.get('token');
  ws = new WebSocket(`ws://${location.host}/ws${token ? `?token=${encodeURIComponent(token)}` : ''}`);
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
}

/** Tell the server one more frame message has arrived: it keeps a bounded number of bytes
 * unacknowledged, so frames never queue up in the socket ahead of newer ones. */
function acknowledge() {
  state.received++;
  send('ack', { received: state.received });
}

/** Send request `type`; with `withId`, a fresh id the reply names (returned). */
export function send(type, body = {}, withId = false) {
  if (!ws || ws.readyState !== WebSocket.OPEN) return undefined;
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

/** Show `text` in the message list (the last six). */
export function note(text, isError = false) {
  const div = document.createElement('div');
  div.textContent = text;
  if (isError) div.className = 'err';
  const box = $('messages');
  box.prepend(div);
  while (box.childNodes.length > 6) box.removeChild(box.lastChild);
  state.messages.push({ text, isError });
}
