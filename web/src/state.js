// The page's state, shared by its modules: what the server sent, what the page shows and
// the latencies it measures. Nothing here draws or sends.

export const $ = (id) => document.getElementById(id);
export const params = new URLSearchParams(location.search);

export const state = {
  scene: null, // the `scene` message
  lights: [], // per punctual light: { meta (the scene message's), now (the last frame's), gizmo, local (a move shown ahead), inputs }
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
  role: null, // 'steer' or 'watch' (the server's `role` message)
  drag: null, // the drag in progress (controls.js), or null
};
