// The viewer's wire protocol, version 1 (docs/viewer-protocol.md): decoding of the server's
// binary messages, and the control messages the page sends.

export const VERSION = 1;
const MAGIC = 0x56524853; // "SHRV" little-endian
export const KIND_COLOURS = 1;
export const KIND_GEOMETRY = 2;
export const KIND_SKY = 3;

/** The 16-byte header of a binary message, or an Error saying what is wrong. */
export function header(buffer) {
  if (buffer.byteLength < 16) throw new Error(`binary message of ${buffer.byteLength} bytes is shorter than its header`);
  const dv = new DataView(buffer);
  if (dv.getUint32(0, true) !== MAGIC) throw new Error('binary message without the SHRV magic');
  const version = dv.getUint16(4, true);
  if (version !== VERSION) throw new Error(`binary message of protocol ${version}, this page speaks ${VERSION}`);
  return { kind: dv.getUint8(6), channel: dv.getUint8(7), frame: dv.getUint32(8, true), extra: dv.getUint32(12, true) };
}

/** Geometry: per object, its local-frame positions (Float32Array) and triangles (Uint32Array). */
export function decodeGeometry(buffer) {
  const h = header(buffer);
  const n = h.extra;
  const dv = new DataView(buffer);
  const counts = [];
  let off = 16;
  for (let o = 0; o < n; o++) {
    counts.push([dv.getUint32(off, true), dv.getUint32(off + 4, true)]);
    off += 8;
  }
  const objects = counts.map(() => ({}));
  for (let o = 0; o < n; o++) {
    objects[o].positions = new Float32Array(buffer, off, 3 * counts[o][0]);
    off += 12 * counts[o][0];
  }
  for (let o = 0; o < n; o++) {
    objects[o].triangles = new Uint32Array(buffer, off, 3 * counts[o][1]);
    off += 12 * counts[o][1];
  }
  if (off !== buffer.byteLength) throw new Error(`geometry message: ${buffer.byteLength - off} bytes left over`);
  return objects;
}

/** Colours: the frame number, scale, world-from-local matrices and the f16 RGB halves. */
export function decodeColours(buffer) {
  const h = header(buffer);
  const dv = new DataView(buffer);
  const n = h.extra;
  const scale = dv.getFloat32(16, true);
  const vertices = dv.getUint32(20, true);
  const matrices = new Float32Array(buffer, 24, 16 * n);
  const halves = new Uint16Array(buffer, 24 + 64 * n, 3 * vertices);
  return { frame: h.frame, channel: h.channel, scale, matrices, halves };
}

/** The sky's map: its scale, size, turn about +Y (degrees) and RGB halves, rows from the top. */
export function decodeSky(buffer) {
  header(buffer);
  const dv = new DataView(buffer);
  const scale = dv.getFloat32(16, true);
  const width = dv.getUint32(20, true), height = dv.getUint32(24, true);
  const rotateDeg = dv.getFloat32(28, true);
  if (buffer.byteLength !== 32 + 6 * width * height) throw new Error(`sky message of ${buffer.byteLength} bytes for a ${width}x${height} map`);
  return { scale, width, height, rotateDeg, halves: new Uint16Array(buffer, 32, 3 * width * height) };
}

/** A control message as text. */
export function request(type, body = {}, id = undefined) {
  const m = { v: VERSION, type, ...body };
  if (id !== undefined) m.id = id;
  return JSON.stringify(m);
}
