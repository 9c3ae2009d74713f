// Checks glTF files two ways and prints one JSON line per file:
//   - the Khronos glTF-Validator (npm gltf-validator): its counts of errors, warnings, infos;
//   - three.js's GLTFLoader (npm three), in node: the meshes it makes, their vertex colour
//     and _RADIOSITY attributes, and their materials (KHR_materials_unlit gives a
//     MeshBasicMaterial, which draws the vertex colours as they are).
// Exit status 1 when any file has a validator error or does not load in three.js.
// Usage: node validate.mjs FILE.glb [FILE.gltf ...]
import { readFile } from 'node:fs/promises';
import path from 'node:path';
import validator from 'gltf-validator';
import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';

async function validate(file, bytes) {
  const report = await validator.validateBytes(new Uint8Array(bytes), {
    uri: path.basename(file),
    externalResourceFunction: async (uri) =>
      new Uint8Array(await readFile(path.join(path.dirname(file), decodeURIComponent(uri)))),
  });
  const issues = report.issues;
  return {
    errors: issues.numErrors,
    warnings: issues.numWarnings,
    infos: issues.numInfos,
    messages: issues.messages.slice(0, 10).map((m) => `${m.severity} ${m.code} ${m.pointer ?? ''}: ${m.message}`),
  };
}

async function loadInThree(file, bytes) {
  // node's fetch reads no file: URLs; a .gltf's .bin is handed over as a data: URL.
  const dir = path.dirname(file);
  const manager = new THREE.LoadingManager();
  const binaries = new Map();
  if (file.endsWith('.gltf')) {
    for (const b of JSON.parse(bytes.toString('utf8')).buffers ?? []) {
      if (b.uri && !b.uri.startsWith('data:')) {
        const data = await readFile(path.join(dir, decodeURIComponent(b.uri)));
        binaries.set(b.uri, `data:application/octet-stream;base64,${data.toString('base64')}`);
      }
    }
  }
  manager.setURLModifier((url) => binaries.get(url) ?? url);
  const loader = new GLTFLoader(manager);
  const data = file.endsWith('.glb') ? bytes.buffer.slice(bytes.byteOffset, bytes.byteOffset + bytes.byteLength) : bytes.toString('utf8');
  const gltf = await loader.parseAsync(data, '');
  const meshes = [];
  gltf.scene.traverse((o) => {
    if (o.isMesh) {
      const g = o.geometry;
      const colour = g.getAttribute('color');
      const radiosity = g.getAttribute('_radiosity');
      let maxColour = 0;
      let maxRadiosity = 0;
      for (let i = 0; colour && i < colour.count * colour.itemSize; i++) maxColour = Math.max(maxColour, colour.array[i]);
      for (let i = 0; radiosity && i < radiosity.count * radiosity.itemSize; i++) maxRadiosity = Math.max(maxRadiosity, radiosity.array[i]);
      g.computeBoundingBox();
      meshes.push({
        name: o.name,
        bounds: [g.boundingBox.min.toArray(), g.boundingBox.max.toArray()],
        vertices: g.getAttribute('position').count,
        triangles: g.index ? g.index.count / 3 : 0,
        color: colour ? colour.itemSize : 0,
        radiosity: radiosity ? radiosity.itemSize : 0,
        maxColour,
        maxRadiosity,
        material: o.material.type,
        vertexColors: o.material.vertexColors,
        uv1: g.getAttribute('uv1') ? g.getAttribute('uv1').itemSize : 0,
        mapChannel: o.material.map ? o.material.map.channel : null,
      });
    }
  });
  return { meshes };
}

// Images in node: GLTFLoader decodes them with createImageBitmap (a browser's); a stub that
// gives a 1x1 bitmap lets it build the textures (their pixels are checked in the browser test,
// web/test/lightmap-example.test.js), so the meshes, their uv1 and their maps are checked here.
globalThis.self ??= globalThis;
globalThis.createImageBitmap ??= async () => ({ width: 1, height: 1, close() {} });

// three's FileLoader reports progress with the browser's ProgressEvent, which node lacks.
globalThis.ProgressEvent ??= class ProgressEvent extends Event {
  constructor(type, init = {}) {
    super(type);
    Object.assign(this, init);
  }
};

let failed = false;
for (const file of process.argv.slice(2)) {
  const bytes = await readFile(file);
  const out = { file, validator: await validate(file, bytes) };
  try {
    out.three = await loadInThree(file, bytes);
  } catch (e) {
    out.three = { error: String(e) };
  }
  if (out.validator.errors > 0 || out.three.error || out.three.meshes.length === 0) failed = true;
  console.log(JSON.stringify(out));
}
process.exit(failed ? 1 : 0);
