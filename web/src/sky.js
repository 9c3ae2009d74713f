// The sky behind the scene: the `scene` message's uniform radiance, or the equirectangular
// map the server sends once (binary kind 3), drawn where no surface is, under the same
// exposure and tone mapping as the surfaces. The map is looked up as shrad's `Sky::radiance`
// does (crates/shrad/src/sky.rs: `uv`, the nearest texel): top row +Y, turned by
// `rotate_deg` about +Y.

import * as THREE from 'three';
import { world } from './view.js';

const material = new THREE.ShaderMaterial({
  uniforms: {
    radiance: { value: new THREE.Vector3() },
    map: { value: null },
    useMap: { value: 0 },
    mapScale: { value: 1 },
    rot: { value: new THREE.Vector2(0, 1) }, // (sin, cos) of the map's turn about +Y
  },
  vertexShader: /* glsl */ `
    varying vec3 vDir;
    void main() {
      // A triangle over the whole screen; each pixel's world direction from the camera.
      vec4 view = inverse(projectionMatrix) * vec4(position.xy, 1.0, 1.0);
      vDir = transpose(mat3(viewMatrix)) * (view.xyz / view.w);
      gl_Position = vec4(position.xy, 0.9999, 1.0);
    }`,
  fragmentShader: /* glsl */ `
    uniform vec3 radiance;
    uniform sampler2D map;
    uniform float useMap;
    uniform float mapScale;
    uniform vec2 rot;
    varying vec3 vDir;
    void main() {
      vec3 d = normalize(vDir);
      vec3 L = radiance;
      if (useMap > 0.5) {
        float lx = rot.y * d.x - rot.x * d.z;
        float lz = rot.x * d.x + rot.y * d.z;
        float u = atan(lx, -lz) / 6.283185307179586;
        if (u < 0.0) u += 1.0;
        float v = acos(clamp(d.y, -1.0, 1.0)) / 3.141592653589793;
        L = texture2D(map, vec2(u, v)).rgb * mapScale;
      }
      gl_FragColor = vec4(L, 1.0);
      #include <tonemapping_fragment>
      #include <colorspace_fragment>
    }`,
  depthTest: false,
  depthWrite: false,
});
const triangle = new THREE.BufferGeometry();
triangle.setAttribute('position', new THREE.Float32BufferAttribute([-1, -1, 0, 3, -1, 0, -1, 3, 0], 3));
const background = new THREE.Mesh(triangle, material);
background.frustumCulled = false;
background.renderOrder = -1; // before the surfaces, which draw over it
background.visible = false;
world.add(background);

/** The `scene` message's `sky`: null (none: black), uniform, or a map (which follows). */
export function showSky(sky) {
  background.visible = !!sky;
  if (!sky) return;
  const r = sky.kind === 'uniform' ? sky.radiance : [0, 0, 0];
  material.uniforms.radiance.value.set(r[0], r[1], r[2]);
  const turn = THREE.MathUtils.degToRad(sky.rotate_deg ?? 0);
  material.uniforms.rot.value.set(Math.sin(turn), Math.cos(turn));
}

/** The sky's map (protocol.js `decodeSky`): RGB halves, rows from the top. */
export function onSkyMap(s) {
  const rgba = new Uint16Array(4 * s.width * s.height);
  const one = THREE.DataUtils.toHalfFloat(1);
  for (let i = 0, n = s.width * s.height; i < n; i++) {
    rgba[4 * i] = s.halves[3 * i];
    rgba[4 * i + 1] = s.halves[3 * i + 1];
    rgba[4 * i + 2] = s.halves[3 * i + 2];
    rgba[4 * i + 3] = one;
  }
  const texture = new THREE.DataTexture(rgba, s.width, s.height, THREE.RGBAFormat, THREE.HalfFloatType);
  // The nearest texel, as the engine's `Sky::radiance` (a large map comes averaged down).
  texture.magFilter = texture.minFilter = THREE.NearestFilter;
  texture.colorSpace = THREE.LinearSRGBColorSpace;
  texture.needsUpdate = true;
  material.uniforms.map.value?.dispose();
  material.uniforms.map.value = texture;
  material.uniforms.mapScale.value = s.scale;
  const turn = THREE.MathUtils.degToRad(s.rotateDeg);
  material.uniforms.rot.value.set(Math.sin(turn), Math.cos(turn));
  material.uniforms.useMap.value = 1;
  background.visible = true;
}

/** The radiance the page shows the sky with (uniform), for the test hooks. */
export function skyRadiance() {
  return background.visible ? material.uniforms.radiance.value.toArray() : null;
}
