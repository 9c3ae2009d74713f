// KTX2 / Basis Universal fixtures for tests/gltf_ktx2.rs, made by Binomial's own encoder
// (basis_encoder.wasm, as npm ktx2-encoder 0.6.0 bundles it): a 64 x 64 checker of 8-texel
// squares, (230, 50, 25) where (x / 8 + y / 8) is odd, else (25, 75, 230), sRGB, opaque,
// as ETC1S (BasisLZ, 7 mip levels), UASTC (zstd, 7 levels) and UASTC (zstd, 1 level).
//     npm install ktx2-encoder@0.6.0 && node encode.mjs
import { encodeToKTX2 } from 'ktx2-encoder';
import fs from 'fs';
const W = 64, H = 64;
const px = new Uint8Array(W * H * 4);
for (let y = 0; y < H; y++) for (let x = 0; x < W; x++) {
  const i = 4 * (y * W + x); const c = ((x >> 3) + (y >> 3)) & 1;
  const col = c ? [230, 50, 25] : [25, 75, 230];
  px.set([...col, 255], i);
}
const dec = async () => ({ data: px, width: W, height: H });
for (const [name, opts] of Object.entries({
  etc1s: { isUASTC: false, generateMipmap: true, qualityLevel: 255 },
  uastc: { isUASTC: true, generateMipmap: true },
  uastc_zstd: { isUASTC: true, generateMipmap: false, needSupercompression: true },
})) {
  const out = await encodeToKTX2(new Uint8Array(4), { ...opts, imageDecoder: dec, isSetKTX2SRGBTransferFunc: true });
  fs.writeFileSync(new URL(`${name}.ktx2`, import.meta.url), out);
  console.log(name, out.length);
}
