// Browser test of the lights in `shrad view`: the courtyard of scenes/courtyard.toml (a
// uniform sky, a sun, a lamp and a spot light). The lights panel lists every light with its
// kind and unit; the sky is drawn behind the scene in its radiance; the lamp's intensity,
// changed in the panel, changes the picture as radiosity is linear in a light's intensity;
// the lamp's ball, dragged with the mouse, moves the lamp in the engine. Saves the
// screenshot of the panel that docs/viewer.md shows (SHRAD_VIEW_SHOTS, as viewer.test.js).

import { test } from 'node:test';
import assert from 'node:assert/strict';
import { mkdtempSync, rmSync, writeFileSync } from 'node:fs';
import { tmpdir } from 'node:os';
import path from 'node:path';
import { dragBy, launch, openPage, repo, settled, shot, shrad, startServer, stopServer } from './harness.js';

/** The sRGB encoding of a linear value in [0, 1], as 0..255. */
const srgb = (x) => 255 * (x <= 0.0031308 ? 12.92 * x : 1.055 * x ** (1 / 2.4) - 0.055);

/** Set the lamp's intensity in the panel to `cd`, then wait for a converged frame with it
 * drawn; the sum of the radiance the page draws, and the mean colour of `rects`. */
async function lampAt(page, cd, rects) {
  await page.fill('#lights .light[data-light="0"] input.intensity', String(cd));
  await page.waitForFunction((want) => {
    const f = window.__shrad.state.lastFrame;
    return f && f.lights && Math.abs(f.lights[0].intensity - want) <= 1e-3 * Math.max(want, 1);
  }, cd, { timeout: 30_000 });
  await settled(page, 120_000);
  return { sum: await shrad(page, () => window.__shrad.radianceSum()), pixels: await shrad(page, (r) => window.__shrad.sample(r), rects) };
}

test('lights and sky in the page: listed, drawn, steered, a block painted', { timeout: 600_000 }, async () => {
  const server = await startServer([path.join(repo, 'scenes/courtyard.toml'), '--patches', '3000']);
  const browser = await launch();
  try {
    const { page, errors } = await openPage(browser.context, server.url);
    await settled(page, 120_000);

    // The panel lists each punctual light with its kind and unit, then the sky.
    const rows = await page.$$eval('#lights .light', (els) => els.map((e) => e.innerText.replace(/\s+/g, ' ')));
    assert.equal(rows.length, 4, rows.join(' | '));
    assert.match(rows[0], /^lamp point.* cd = .* W\/sr/);
    assert.match(rows[1], /^spot spot, cone 15–30°.* cd/);
    assert.match(rows[2], /^sun directional.* lx = 1\.500 W\/m\^2/);
    assert.match(rows[3], /^sky: uniform radiance 0\.350, 0\.500, 0\.900/);

    // The sky at the top of the picture: with linear tone mapping at 0 EV a pixel there is
    // the sRGB encoding of the sky's radiance.
    await page.selectOption('#tonemap', 'linear');
    const [w] = await shrad(page, () => window.__shrad.canvasSize());
    const box = await shrad(page, () => { const r = window.__shrad.renderer.domElement.getBoundingClientRect(); return [r.left, r.top]; });
    const [sky] = await shrad(page, (r) => window.__shrad.sample(r), [[box[0] + w / 2 - 4, box[1] + 4, 8, 8]]);
    const want = [0.35, 0.5, 0.9].map(srgb);
    for (let k = 0; k < 3; k++) assert.ok(Math.abs(sky[k] - want[k]) <= 3, `sky pixel ${sky} is not the sky's radiance ${want}`);
    await page.selectOption('#tonemap', 'aces');

    // The lamp's intensity: the floor under it brightens, and what the page draws is linear
    // in it (radiosity is): B(2I) - B(I) = B(I) - B(0), within the engine's convergence.
    const cd = await shrad(page, () => window.__shrad.state.lights[0].meta.intensity);
    const under = await shrad(page, () => { const p = window.__shrad.state.lights[0].meta.position; const s = window.__shrad.screenOf([p[0], 0.001, p[2]]); return [[s.x - 4, s.y - 4, 8, 8]]; });
    const one = await lampAt(page, Number(cd.toPrecision(6)), under);
    await shot(page, 'courtyard-lights.png');
    const off = await lampAt(page, 0, under);
    const two = await lampAt(page, 2 * Number(cd.toPrecision(6)), under);
    console.log('lamp off / once / twice, radiance drawn:', JSON.stringify({ off: off.sum, one: one.sum, two: two.sum }),
      'residual of linearity / lamp part:', [0, 1, 2].map((k) => (two.sum[k] - 2 * one.sum[k] + off.sum[k]) / (two.sum[k] - off.sum[k])));
    for (let k = 0; k < 3; k++) {
      const [b0, b1, b2] = [off.sum[k], one.sum[k], two.sum[k]];
      assert.ok(b2 - b0 > 0.05 * b1, `channel ${k}: the lamp changes the picture by ${b2 - b0} of ${b1} only`);
      assert.ok(Math.abs(b2 - 2 * b1 + b0) <= 0.03 * (b2 - b0), `channel ${k}: off ${b0}, once ${b1}, twice ${b2}: not linear in the intensity`);
    }
    const lum = (c) => 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2];
    assert.ok(lum(two.pixels[0]) > lum(off.pixels[0]) + 10, `the floor under the lamp: ${off.pixels[0]} off, ${two.pixels[0]} at twice`);

    // Drag the lamp's ball 100 px to the right: the engine moves the lamp.
    const before = await shrad(page, () => window.__shrad.state.lastFrame.lights[0].position);
    const from = await shrad(page, () => window.__shrad.screenOfLight('lamp'));
    await dragBy(page, from, 100, 0, 10, 500);
    await page.waitForFunction((x) => window.__shrad.state.lastFrame.lights[0].position[0] > x + 0.2, before[0], { timeout: 30_000 });
    const after = await shrad(page, () => window.__shrad.state.lastFrame.lights[0].position);
    assert.ok(Math.abs(after[1] - before[1]) < 1e-4, `the lamp left its height: ${before} -> ${after}`);

    // Paint the grey block blue (select it, pick a colour: `set_reflectance`): the page draws
    // it blue once the engine's frames have it.
    const at = await shrad(page, () => window.__shrad.screenOf('block'));
    const blockPixel = async () => (await shrad(page, (r) => window.__shrad.sample(r), [[at.x - 3, at.y - 3, 6, 6]]))[0];
    const grey = await blockPixel();
    await page.mouse.click(at.x, at.y);
    await page.waitForFunction(() => !document.getElementById('paint').disabled, null, { timeout: 10_000 });
    await page.$eval('#paint', (el) => { el.value = '#2040ff'; el.dispatchEvent(new Event('input')); });
    const deadline = Date.now() + 60_000;
    let blue = await blockPixel();
    while (!(blue[2] > 1.5 * blue[0]) && Date.now() < deadline) {
      await page.waitForTimeout(250);
      blue = await blockPixel();
    }
    assert.ok(blue[2] > 1.5 * blue[0], `the painted block is drawn ${blue} (it was ${grey})`);
    assert.ok(Math.abs(grey[2] - grey[0]) < 0.2 * grey[2], `the block was not grey before: ${grey}`);
    assert.deepEqual(errors, [], `the page reported errors: ${errors.join('; ')}`);
  } finally {
    await browser.close();
    await stopServer(server);
  }
});

/** A Radiance .hdr of `width` x `height` linear RGB texels (rows from the top), flat
 * scanlines (a width under 8 is never run-length encoded). */
function hdr(width, height, texels) {
  const head = Buffer.from(`#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y ${height} +X ${width}\n`, 'ascii');
  const body = Buffer.alloc(4 * width * height);
  texels.forEach((c, i) => {
    const max = Math.max(...c);
    if (max <= 0) return;
    const e = Math.floor(Math.log2(max)) + 1; // max = m 2^e, m in [0.5, 1)
    const k = 256 / 2 ** e;
    body.set([Math.floor(c[0] * k), Math.floor(c[1] * k), Math.floor(c[2] * k), e + 128], 4 * i);
  });
  return Buffer.concat([head, body]);
}

test('a sky map is sent once and drawn behind the scene', { timeout: 300_000 }, async () => {
  // A map whose upper half is one colour and lower half another, behind a lone floor.
  const dir = mkdtempSync(path.join(tmpdir(), 'shrad-sky-'));
  const [up, down] = [[0.25, 0.5, 0.75], [0.75, 0.375, 0.125]];
  writeFileSync(path.join(dir, 'sky.hdr'), hdr(4, 2, [up, up, up, up, down, down, down, down]));
  writeFileSync(path.join(dir, 'scene.toml'), [
    '[camera]', 'eye = [0, 1.5, 6]', 'target = [0, 1, 0]', 'yfov_deg = 50',
    '[environment]', 'file = "sky.hdr"', 'scale = 2.0',
    '[[object]]', 'name = "floor"', 'role = "boundary"', 'shape = "quad"',
    'corners = [[-3, 0, -3], [-3, 0, 3], [3, 0, 3], [3, 0, -3]]', 'reflectance = [0.5, 0.5, 0.5]',
  ].join('\n'));
  const server = await startServer([path.join(dir, 'scene.toml'), '--patches', '500']);
  const browser = await launch();
  try {
    const { page, errors } = await openPage(browser.context, server.url);
    await settled(page, 120_000);
    await page.selectOption('#tonemap', 'linear');
    const [w] = await shrad(page, () => window.__shrad.canvasSize());
    const box = await shrad(page, () => { const r = window.__shrad.renderer.domElement.getBoundingClientRect(); return [r.left, r.top]; });
    // The top of the picture looks above the horizon: the upper half's colour times 2.
    const [top] = await shrad(page, (r) => window.__shrad.sample(r), [[box[0] + w / 2 - 4, box[1] + 4, 8, 8]]);
    const want = up.map((x) => srgb(Math.min(1, 2 * x)));
    for (let k = 0; k < 3; k++) assert.ok(Math.abs(top[k] - want[k]) <= 3, `sky pixel ${top}, not the map's upper half ${want}`);
    assert.match(await page.innerText('#lights'), /sky: map .*sky\.hdr \(4×2, drawn at 4×2\)/);
    assert.deepEqual(errors, [], `the page reported errors: ${errors.join('; ')}`);
  } finally {
    await browser.close();
    await stopServer(server);
    rmSync(dir, { recursive: true, force: true });
  }
});
