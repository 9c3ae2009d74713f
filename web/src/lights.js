// The lights panel: every light of the scene with its controls. Surfaces that emit (objects
// of role `light`) get a colour, a power factor and an off switch (`set_emission`); punctual
// lights (point, spot, directional: the `scene` message's `lights`) a colour and their
// intensity in the file's unit, candela or lux (`set_light_intensity`), and point and spot
// lights a gizmo in the view to drag (gizmos.js). The sky is named last.

import * as THREE from 'three';
import { send } from './connection.js';
import { makeGizmos, syncGizmos } from './gizmos.js';
import { $, state } from './state.js';

const LUMENS_PER_WATT = 683; // as shrad converts (docs/scene-format.md)

function linearToHex(rgb) {
  const max = Math.max(...rgb, 1e-9);
  const c = new THREE.Color().setRGB(rgb[0] / max, rgb[1] / max, rgb[2] / max, THREE.LinearSRGBColorSpace);
  return '#' + c.getHexString(THREE.SRGBColorSpace);
}

/** Linear RGB of a colour input's value, brought to the brightest channel `base`. */
function hexToLinear(hex, base) {
  const c = new THREE.Color().setStyle(hex, THREE.SRGBColorSpace);
  return [c.r * base, c.g * base, c.b * base];
}

/** A photometric intensity as the panel shows it (six significant digits). */
const shown = (x) => String(Number(x.toPrecision(6)));
const fmt = (x) => (Math.abs(x) >= 1000 || (x !== 0 && Math.abs(x) < 0.01) ? x.toExponential(3) : x.toFixed(3));

/** `W/sr` or `W/m^2` of a punctual light of linear `color` and photometric `intensity`. */
function radiometricText(l, color, intensity) {
  return `${fmt((Math.max(...color) * intensity) / LUMENS_PER_WATT)} ${l.meta.radiometric_unit}`;
}

function surfaceLight(l) {
  const base = Math.max(...l.emission);
  const div = document.createElement('div');
  div.className = 'light';
  div.innerHTML = `<div>${l.name} <span class="small">surface</span></div>
    <input type="color" value="${linearToHex(l.emission)}">
    power <input type="range" min="0" max="4" step="0.05" value="1"> <span>1.00×</span>
    <label style="display:inline"><input type="checkbox"> off</label>`;
  const [colour, power, off] = div.querySelectorAll('input');
  const label = div.querySelector('span:last-of-type');
  const update = () => {
    const k = off.checked ? 0 : Number(power.value);
    label.textContent = `${Number(power.value).toFixed(2)}×`;
    send('set_emission', { object: l.index, radiance: hexToLinear(colour.value, k * base) });
  };
  colour.oninput = update; power.oninput = update; off.onchange = update;
  return div;
}

function punctualLight(l, i) {
  const div = document.createElement('div');
  div.className = 'light';
  div.dataset.light = String(i);
  const cone = l.meta.cone ? `, cone ${THREE.MathUtils.radToDeg(l.meta.cone.inner).toFixed(0)}–${THREE.MathUtils.radToDeg(l.meta.cone.outer).toFixed(0)}°` : '';
  const where = l.meta.kind === 'directional' ? '' : ' · drag its ball in the view';
  div.innerHTML = `<div>${l.meta.name} <span class="small">${l.meta.kind}${cone}${where}</span></div>
    <input type="color" value="${linearToHex(l.meta.color)}">
    intensity <input type="number" class="intensity" min="0" step="any" value="${shown(l.meta.intensity)}"> ${l.meta.unit}
    <span class="small radiometric"></span>`;
  const [colour, intensity] = div.querySelectorAll('input');
  const watts = div.querySelector('.radiometric');
  l.colour = l.meta.color.slice();
  l.inputs = { colour, intensity, watts };
  watts.textContent = `= ${radiometricText(l, l.colour, l.meta.intensity)}`;
  const update = () => {
    const value = Number(intensity.value);
    if (!(value >= 0)) return; // the input shows it is not a number yet; nothing is sent
    watts.textContent = `= ${radiometricText(l, l.colour, value)}`;
    send('set_light_intensity', { light: i, color: l.colour, intensity: value });
  };
  colour.oninput = () => { l.colour = hexToLinear(colour.value, Math.max(...l.meta.color, 1e-9)); update(); };
  intensity.oninput = update;
  return div;
}

function skyLine(sky) {
  const div = document.createElement('div');
  div.className = 'light small';
  div.textContent = sky.kind === 'uniform'
    ? `sky: uniform radiance ${sky.radiance.map((x) => x.toFixed(3)).join(', ')} W/(m²·sr)`
    : `sky: map ${sky.file} (${sky.source_width}×${sky.source_height}, drawn at ${sky.width}×${sky.height}), turned ${sky.rotate_deg}°, ×${sky.scale}`;
  return div;
}

/** The panel for the `scene` message `m`. */
export function fillLights(m) {
  const surfaces = m.objects.map((o, i) => ({ ...o, index: i })).filter((o) => o.role === 'light' && Math.max(...o.emission) > 0);
  state.lights = (m.lights || []).map((meta) => ({ meta, now: meta, gizmo: null, local: null }));
  const rows = [...surfaces.map(surfaceLight), ...state.lights.map(punctualLight)];
  if (m.sky) rows.push(skyLine(m.sky));
  $('lights').replaceChildren(...rows);
  $('lights-section').style.display = rows.length ? '' : 'none';
  makeGizmos();
}

/** A `frame` message: the lights as the engine has them (another client may steer them). */
export function syncLights(m) {
  syncGizmos(m);
  for (const l of state.lights) {
    const { colour, intensity, watts } = l.inputs || {};
    if (!intensity) continue;
    if (document.activeElement !== colour) { l.colour = l.now.color.slice(); colour.value = linearToHex(l.colour); }
    if (document.activeElement === intensity) continue;
    if (intensity.value !== shown(l.now.intensity)) intensity.value = shown(l.now.intensity);
    watts.textContent = `= ${radiometricText(l, l.now.color, l.now.intensity)}`;
  }
}
