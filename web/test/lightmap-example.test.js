// Browser test of examples/threejs-lightmap: headless Debian chromium (WebGL on SwiftShader)
// opens the example page over a static server of the repository, which loads the committed
// lightmapped bake (examples/threejs-lightmap/cornell.glb, `shrad bake --lightmap`) with
// three.js's GLTFLoader, hooks the lightmap up as `lightMap` on uv1, and draws it. The canvas
// must be lit: most of it not black, the back wall bright (warm white), the red and green
// walls red and green. Also in the page's unlit mode (the glTF's own material, no hook-up).
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { createServer } from 'node:http';
import { readFile, stat } from 'node:fs/promises';
import { mkdtempSync, rmSync } from 'node:fs';
import { tmpdir } from 'node:os';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import { chromium } from 'playwright-core';

const root = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '../..');
const types = { '.html': 'text/html', '.js': 'text/javascript', '.glb': 'model/gltf-binary' };

function serve() {
  const server = createServer(async (req, res) => {
    const url = decodeURIComponent(new URL(req.url, 'http://x').pathname);
    if (url === '/favicon.ico') {
      res.writeHead(204).end();
      return;
    }
    const file = path.join(root, url);
    if (!file.startsWith(root) || !(await stat(file).catch(() => null))?.isFile()) {
      res.writeHead(404).end();
      return;
    }
    res.writeHead(200, { 'content-type': types[path.extname(file)] ?? 'application/octet-stream' });
    res.end(await readFile(file));
  });
  return new Promise((ok) => server.listen(0, '127.0.0.1', () => ok(server)));
}

// The canvas's pixels, read through a 2D canvas (the WebGL one keeps its drawing buffer).
async function pixels(page) {
  return page.evaluate(() => {
    const gl = document.querySelector('canvas');
    const c = document.createElement('canvas');
    [c.width, c.height] = [gl.width, gl.height];
    const ctx = c.getContext('2d');
    ctx.drawImage(gl, 0, 0);
    return { width: c.width, height: c.height, data: Array.from(ctx.getImageData(0, 0, c.width, c.height).data) };
  });
}

// Mean RGB (0..255) over the rectangle of fractions [x0, x1) x [y0, y1) of the picture.
function mean(p, x0, x1, y0, y1) {
  const sum = [0, 0, 0];
  let n = 0;
  for (let y = Math.floor(y0 * p.height); y < y1 * p.height; y++) {
    for (let x = Math.floor(x0 * p.width); x < x1 * p.width; x++) {
      for (let k = 0; k < 3; k++) sum[k] += p.data[4 * (y * p.width + x) + k];
      n++;
    }
  }
  return sum.map((s) => s / n);
}

test('the three.js example shows the lightmap on uv1, lit', { timeout: 180_000 }, async () => {
  const server = await serve();
  const profile = mkdtempSync(path.join(tmpdir(), 'shrad-lightmap-chromium-'));
  const context = await chromium.launchPersistentContext(profile, {
    executablePath: '/usr/bin/chromium',
    headless: true,
    viewport: { width: 480, height: 480 },
    args: ['--headless', '--no-sandbox', '--disable-gpu', '--no-first-run', '--disable-background-networking',
      '--disable-component-update', '--disable-sync', '--use-angle=swiftshader', '--enable-unsafe-swiftshader'],
  });
  try {
    const page = context.pages()[0] || (await context.newPage());
    const errors = [];
    page.on('pageerror', (e) => errors.push(e.message));
    page.on('console', (m) => { if (m.type() === 'error') errors.push(m.text()); });
    const base = `http://127.0.0.1:${server.address().port}/examples/threejs-lightmap/index.html`;
    for (const mode of ['lightmap', 'unlit']) {
      await page.goto(`${base}?mode=${mode}`);
      await page.waitForFunction(() => window.lightmapExample?.drawn, null, { timeout: 120_000 });
      const info = await page.evaluate(() => window.lightmapExample);
      if (mode === 'lightmap') {
        assert.equal(info.meshes.length, 8, JSON.stringify(info));
        assert.ok(info.meshes.every((m) => m.channel === 1 && m.uv1), JSON.stringify(info));
      }
      const p = await pixels(page);
      let lit = 0;
      for (let i = 0; i < p.width * p.height; i++) {
        if (p.data[4 * i] + p.data[4 * i + 1] + p.data[4 * i + 2] > 30) lit++;
      }
      assert.ok(lit > 0.6 * p.width * p.height, `${mode}: only ${lit} lit pixels`);
      if (process.env.SHRAD_LIGHTMAP_SHOTS) {
        await page.screenshot({ path: path.join(process.env.SHRAD_LIGHTMAP_SHOTS, `threejs-lightmap-${mode}.png`) });
      }
      // The back wall: white under the box's warm light (more red than blue), bright.
      const back = mean(p, 0.45, 0.55, 0.2, 0.3);
      assert.ok(back[0] > 90 && back[0] > back[2], `${mode}: back wall ${back}`);
      const left = mean(p, 0.02, 0.08, 0.4, 0.6); // the red wall (x = 556 mm, on the left)
      const right = mean(p, 0.92, 0.98, 0.4, 0.6); // the green one
      assert.ok(left[0] > 1.3 * left[1] && left[0] > 40, `${mode}: left wall ${left}`);
      assert.ok(right[1] > 1.3 * right[0] && right[1] > 40, `${mode}: right wall ${right}`);
    }
    assert.deepEqual(errors, []);
  } finally {
    await context.close();
    rmSync(profile, { recursive: true, force: true });
    server.close();
  }
});
