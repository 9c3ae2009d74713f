// What the browser tests of `shrad view` share: starting the server (SHRAD_VIEW_CMD, a JSON
// array; default the release shrad-view binary) on a free port and stopping it, headless
// Debian chromium (WebGL on SwiftShader) through playwright-core, a page that has drawn its
// first frame, waiting for the engine to converge, and screenshots into SHRAD_VIEW_SHOTS
// (default target/viewer-shots, so that a test run leaves the work tree as it was;
// scripts/refresh-viewer-images points it at docs/images/viewer). Not a test file itself.

import { spawn } from 'node:child_process';
import { mkdtempSync, mkdirSync, rmSync } from 'node:fs';
import { tmpdir } from 'node:os';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import { chromium } from 'playwright-core';

export const here = path.dirname(fileURLToPath(import.meta.url));
export const repo = path.resolve(here, '../..');
const target = process.env.CARGO_TARGET_DIR || path.join(repo, 'target');
const shots = path.resolve(process.env.SHRAD_VIEW_SHOTS || path.join(target, 'viewer-shots'));
export const output = path.join(repo, 'web/test-output');
const command = process.env.SHRAD_VIEW_CMD
  ? JSON.parse(process.env.SHRAD_VIEW_CMD)
  : [path.join(target, 'release/shrad-view')];
export const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

/** Start the server on a free port; resolves with its URL and process. */
export function startServer(args) {
  return new Promise((resolve, reject) => {
    const child = spawn(command[0], [...command.slice(1), ...args, '--port', '0'], { stdio: ['ignore', 'pipe', 'pipe'] });
    let out = '', err = '';
    const timer = setTimeout(() => reject(new Error(`server did not print its URL within 180 s\n${err}`)), 180_000);
    child.stdout.on('data', (d) => {
      out += d;
      const m = out.match(/(http:\/\/127\.0\.0\.1:\d+\/)/);
      if (m) { clearTimeout(timer); resolve({ url: m[1], child, stderr: () => err }); }
    });
    child.stderr.on('data', (d) => { err += d; });
    child.on('exit', (code) => { clearTimeout(timer); reject(new Error(`server exited with ${code}\n${err}`)); });
  });
}

export async function stopServer(server) {
  const exited = new Promise((r) => server.child.once('exit', (code, signal) => r({ code, signal })));
  server.child.kill('SIGINT');
  const r = await Promise.race([exited, sleep(10_000).then(() => null)]);
  if (!r) server.child.kill('SIGKILL');
  return r;
}

export async function launch() {
  const profile = mkdtempSync(path.join(tmpdir(), 'shrad-view-chromium-'));
  const context = await chromium.launchPersistentContext(profile, {
    executablePath: '/usr/bin/chromium',
    headless: true,
    viewport: { width: 1200, height: 700 },
    args: [
      '--headless', '--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run',
      '--disable-background-networking', '--disable-component-update', '--disable-sync',
      '--use-angle=swiftshader', '--enable-unsafe-swiftshader',
    ],
  });
  return { context, close: async () => { await context.close(); rmSync(profile, { recursive: true, force: true }); } };
}

export async function openPage(context, url) {
  const page = context.pages()[0] || (await context.newPage());
  const errors = [];
  page.on('pageerror', (e) => errors.push(e.message));
  page.on('console', (m) => { if (m.type() === 'error') errors.push(m.text()); });
  await page.goto(url);
  await page.waitForFunction(() => window.__shrad && window.__shrad.state.framesDrawn > 0, null, { timeout: 120_000 });
  return { page, errors };
}

export const shrad = (page, fn, arg) => page.evaluate(fn, arg);

/** Wait until the engine says it has converged and the page drew that frame. */
export async function settled(page, timeout = 30_000) {
  await page.waitForFunction(() => {
    const s = window.__shrad.state;
    return s.lastFrame && s.lastFrame.converged && s.lastDrawnFrame >= s.lastFrame.frame;
  }, null, { timeout });
}

export async function shot(page, name) {
  mkdirSync(shots, { recursive: true });
  await page.screenshot({ path: path.join(shots, name) });
}

/** Drag from canvas point `from` by (dx, dy) pixels in `steps` real mouse moves over `ms`. */
export async function dragBy(page, from, dx, dy, steps, ms) {
  await page.mouse.move(from.x, from.y);
  await page.mouse.down();
  for (let i = 1; i <= steps; i++) {
    await page.mouse.move(from.x + (dx * i) / steps, from.y + (dy * i) / steps);
    await sleep(ms / steps);
  }
  await page.mouse.up();
}
