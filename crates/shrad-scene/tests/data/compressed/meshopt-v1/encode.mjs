// Test vectors for shrad's version 1 attribute decoder (KHR_meshopt_compression), made by
// meshoptimizer's own encoder (npm meshoptimizer 1.3.0, level 3, version 1) from data whose
// channels it codes as 32-bit XOR deltas (channel modes 0x02 and 0x42), which gltfpack's files
// do not use; each round trip through meshoptimizer's decoder is checked. Writes NAME.bin (the
// stream) and NAME.raw (the data) next to this script:
//     npm install meshoptimizer@1.3.0 && node encode.mjs
import { MeshoptEncoder, MeshoptDecoder } from 'meshoptimizer';
import fs from 'fs';
await MeshoptEncoder.ready; await MeshoptDecoder.ready;
const count = 700, size = 8;
let seed = 12345; const rnd = () => (seed = (seed * 1103515245 + 12345) % 2147483648) / 2147483648;
const gens = {
  noise: (i,c) => 1.0 + rnd() * 1e-3,
  bitsrand: (i,c) => null,
};
for (const [name, g] of Object.entries(gens)) {
  const u = new Uint32Array(count * 2);
  const f = new Float32Array(u.buffer);
  for (let i = 0; i < count; i++) for (let c = 0; c < 2; c++) {
    if (name === 'bitsrand') u[2*i+c] = (0x3f800000 | ((rnd()*0x7fffff)|0)) ^ ((i & 3) << 28);
    else f[2*i+c] = g(i,c);
  }
  const src = new Uint8Array(u.buffer);
  const enc = MeshoptEncoder.encodeVertexBufferLevel(src, count, size, 3, 1);
  const modes = Array.from(enc.slice(enc.length - 2)).map(x=>x.toString(16));
  const dec = new Uint8Array(count * size); MeshoptDecoder.decodeVertexBuffer(dec, count, size, enc);
  console.log(name, enc.length, modes, dec.every((x, i) => x === src[i]));
  const here = new URL('.', import.meta.url).pathname;
  fs.writeFileSync(`${here}${name}.bin`, enc); fs.writeFileSync(`${here}${name}.raw`, src);
}
