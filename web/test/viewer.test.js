// Browser test of `shrad view`: headless Debian chromium (WebGL on SwiftShader) driven by
// playwright-core. It starts the server, loads the page, checks that the scene is lit, drags
// an object with real mouse events and watches the pixels where its shadow and colour
// bleeding fall change and settle, switches the solver, shows the channels and the probes,
// saves screenshots and measures GI updates per second and drag latency, with where the
// light's latency goes (written to web/test-output/perf-*.json and printed; no figure of
// speed is asserted: the machine may be shared).
//
// SHRAD_VIEW_CMD: the server command (JSON array; default: the release shrad-view binary).
// SHRAD_VIEW_PERF=1 also measures the 77k-patch room; SHRAD_VIEW_PATCHES sets the Cornell
// box's patch count (default 20000). SHRAD_VIEW_SHOTS: the screenshots' folder (default
// target/viewer-shots, so that a test run leaves the work tree as it was;
// scripts/refresh-viewer-images points it at docs/images/viewer).

import { test } from 'node:test';
import assert from 'node:assert/strict';
import { writeFileSync, mkdirSync } from 'node:fs';
import path from 'node:path';
import { dragBy, launch, openPage, output, settled, shot, shrad, sleep, startServer, stopServer } from './harness.js';

/** Canvas rects (8x8 px) around world points. */
async function rectsAt(page, points) {
  return shrad(page, (pts) => pts.map((p) => {
    const s = window.__shrad.screenOf(p);
    return [Math.round(s.x) - 4, Math.round(s.y) - 4, 8, 8];
  }), points);
}

/** Floor points around an object's box: beside each side, at the height of its base. */
function around(box, reach = 0.35) {
  const [lo, hi] = box;
  const cx = (lo[0] + hi[0]) / 2, cz = (lo[2] + hi[2]) / 2;
  const dx = (hi[0] - lo[0]) * (0.5 + reach), dz = (hi[2] - lo[2]) * (0.5 + reach);
  const y = lo[1] + 1e-3 * (hi[1] - lo[1]);
  return [[cx - dx, y, cz], [cx + dx, y, cz], [cx, y, cz - dz], [cx, y, cz + dz]];
}

const luminance = (c) => 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2];
const maxDiff = (a, b) => Math.max(...a.flatMap((c, i) => c.map((x, k) => Math.abs(x - b[i][k]))));

/** Pointer moves dispatched by the page itself at `hz` for `seconds` (after a real mouse
 * down): their rate does not depend on how fast playwright's round trips are on a loaded
 * machine, so they can outpace the engine, as a person's hand does. */
async function inPageMoves(page, from, seconds, pixels, hz) {
  await shrad(page, ([x, y, secs, px, rate]) => new Promise((resolve) => {
    const el = window.__shrad.renderer.domElement;
    const n = Math.round(secs * rate);
    let i = 0;
    const timer = setInterval(() => {
      i++;
      const phase = Math.sin((i / n) * 2 * Math.PI * Math.max(1, secs / 2));
      el.dispatchEvent(new PointerEvent('pointermove', { clientX: x + px * phase, clientY: y, bubbles: true, pointerId: 1, isPrimary: true, buttons: 1 }));
      if (i >= n) { clearInterval(timer); resolve(); }
    }, 1000 / rate);
  }), [from.x, from.y, seconds, pixels, hz]);
}

/** GI updates per second and drag latency while an object is dragged back and forth: with
 * real mouse moves at 30 per second (as fast as playwright manages), or with `hz` pointer
 * moves per second dispatched in the page. */
async function measure(page, name, seconds, pixels, hz = 0) {
  await shrad(page, () => { const s = window.__shrad.state; s.latencies.length = 0; s.moveLatencies.length = 0; s.receiveLatencies.length = 0; s.dispatchLatencies.length = 0; s.replyLatencies.length = 0; if (s.steps) s.steps.length = 0; });
  const from = await shrad(page, (n) => window.__shrad.screenOf(n), name);
  const f0 = await shrad(page, () => ({ drawn: window.__shrad.state.framesDrawn, engine: window.__shrad.state.lastFrame.frame, t: performance.now() }));
  const engineRates = [];
  const engineMs = [];
  const backlog = [];
  await page.mouse.move(from.x, from.y);
  await page.mouse.down();
  const moving = hz > 0 ? inPageMoves(page, from, seconds, pixels, hz) : null;
  const steps = Math.round(seconds * 30);
  for (let i = 1; i <= steps && !moving; i++) {
    const phase = Math.sin((i / steps) * 2 * Math.PI * Math.max(1, seconds / 2));
    await page.mouse.move(from.x + pixels * phase, from.y);
    await sleep(1000 / 30);
    if (i % 15 === 0) {
      const f = await shrad(page, () => { const m = window.__shrad.state.lastFrame; return { rate: m.gi_updates_per_s, ms: m.stats?.frame_ms, backlog: m.steering?.backlog }; });
      engineRates.push(f.rate);
      engineMs.push(f.ms);
      backlog.push(f.backlog);
    }
  }
  if (moving) {
    // Sample the engine while the page moves the object.
    let done = false;
    moving.then(() => { done = true; });
    while (!done) {
      await sleep(500);
      const f = await shrad(page, () => { const m = window.__shrad.state.lastFrame; return { rate: m.gi_updates_per_s, ms: m.stats?.frame_ms, backlog: m.steering?.backlog }; });
      engineRates.push(f.rate);
      engineMs.push(f.ms);
      backlog.push(f.backlog);
    }
  }
  await page.mouse.up();
  // The last moves' frames, drawn (bounded wait: they are counted when they are drawn).
  await page.waitForFunction(() => window.__shrad.state.awaitingFrame.length === 0 && window.__shrad.state.pendingSteer.size === 0, null, { timeout: 60_000, polling: 50 }).catch(() => {});
  const undrawn = await shrad(page, () => window.__shrad.state.awaitingFrame.length + window.__shrad.state.pendingSteer.size);
  const f1 = await shrad(page, () => ({ drawn: window.__shrad.state.framesDrawn, engine: window.__shrad.state.lastFrame.frame, t: performance.now(), latencies: window.__shrad.state.latencies.slice(), moves: window.__shrad.state.moveLatencies.slice(), received: window.__shrad.state.receiveLatencies.slice(), dispatched: window.__shrad.state.dispatchLatencies.slice(), replied: window.__shrad.state.replyLatencies.slice(), drawMs: window.__shrad.state.drawMs.slice(), steps: (window.__shrad.state.steps || []).filter((x) => x.drawn !== undefined), sent: window.__shrad.state.dispatchLatencies.length }));
  const secs = (f1.t - f0.t) / 1000;
  const quantiles = (xs) => {
    const v = xs.slice().sort((a, b) => a - b);
    const q = (p) => (v.length ? v[Math.min(v.length - 1, Math.floor(p * v.length))] : NaN);
    return { samples: v.length, median: q(0.5), p90: q(0.9), max: v[v.length - 1] };
  };
  return {
    seconds: secs,
    moves_sent: f1.sent,
    // Moves whose light the page had not drawn 60 s after the drag (0: every one was).
    undrawn,
    drawn_per_s: (f1.drawn - f0.drawn) / secs,
    engine_frames_per_s: (f1.engine - f0.engine) / secs,
    engine_reported_per_s: engineRates,
    // Mouse event to the page drawing the object at the new place (the page moves it at once).
    object_latency_ms: quantiles(f1.moves),
    // Mouse event to the page drawing the first engine frame computed with the object there.
    latency_ms: quantiles(f1.latencies),
    // Mouse event to the page receiving that engine frame (the engine's and the network's
    // share of the light's latency, before the rasteriser's).
    received_latency_ms: quantiles(f1.received),
    // The parts before that: the browser's input delay (event to its handler), and the
    // engine's reply to the move (it replies between frames, before stepping the one with
    // the move).
    dispatch_latency_ms: quantiles(f1.dispatched),
    reply_latency_ms: quantiles(f1.replied),
    page_draw_ms: quantiles(f1.drawMs),
    // The light's latency, move by move, split where it goes (medians of each part, ms):
    // mouse event -> engine applied (its reply; of which waiting for the frame to start:
    // queued), applied -> frame received (the engine computing it, then publishing and
    // sending; of which computing: compute), received -> drawn (the page and the rasteriser).
    breakdown_ms: {
      to_applied: quantiles(f1.steps.map((x) => x.replied)).median,
      queued_in_server: quantiles(f1.steps.map((x) => x.queued)).median,
      applied_to_received: quantiles(f1.steps.map((x) => x.received - x.replied)).median,
      engine_compute: quantiles(f1.steps.filter((x) => x.computeMs !== undefined).map((x) => x.computeMs)).median,
      received_to_drawn: quantiles(f1.steps.map((x) => x.drawn - x.received)).median,
    },
    engine_frame_ms_while_dragging: quantiles(engineMs.filter((x) => x !== undefined)),
    // The steering backlog the engine reported while dragging (0 when nothing queued).
    backlog_max: backlog.some((x) => x !== undefined) ? Math.max(...backlog.filter((x) => x !== undefined)) : null,
  };
}

/** Steady stepping of a static scene for `seconds` (the engine kept stepping). */
async function steady(page, seconds) {
  await shrad(page, () => window.__shrad.send('run', { continuous: true }));
  await sleep(1500);
  const a = await shrad(page, () => ({ drawn: window.__shrad.state.framesDrawn, engine: window.__shrad.state.lastFrame.frame, t: performance.now() }));
  await sleep(seconds * 1000);
  const b = await shrad(page, () => ({ drawn: window.__shrad.state.framesDrawn, engine: window.__shrad.state.lastFrame.frame, t: performance.now(), ms: window.__shrad.state.lastFrame.stats.frame_ms }));
  await shrad(page, () => window.__shrad.send('run', { continuous: false }));
  const secs = (b.t - a.t) / 1000;
  return { seconds: secs, drawn_per_s: (b.drawn - a.drawn) / secs, engine_frames_per_s: (b.engine - a.engine) / secs, last_step_ms: b.ms };
}

test('shrad view in a real browser: lit, drag, solver, channels, probes, performance', { timeout: 900_000 }, async () => {
  mkdirSync(output, { recursive: true });
  const patches = process.env.SHRAD_VIEW_PATCHES || '20000';
  const server = await startServer(['cornell', '--patches', patches]);
  const browser = await launch();
  try {
    const { page, errors } = await openPage(browser.context, server.url);
    await settled(page);
    await sleep(300);
    // The canvas shows the lit scene, not black.
    const [w, h] = await shrad(page, () => window.__shrad.canvasSize());
    const grid = [];
    for (let i = 1; i < 8; i++) for (let j = 1; j < 6; j++) grid.push([Math.round((i * w) / 8) - 4, Math.round((j * h) / 6) - 4, 8, 8]);
    const lit = await shrad(page, (r) => window.__shrad.sample(r), grid);
    const mean = lit.reduce((s, c) => s + luminance(c), 0) / lit.length;
    assert.ok(mean > 20, `the canvas is dark: mean luminance ${mean.toFixed(1)} of 255`);
    assert.ok(Math.max(...lit.map(luminance)) - Math.min(...lit.map(luminance)) > 20, 'the canvas is flat: no lit scene');
    await shot(page, 'cornell-before.png');

    // Drag the short block with real mouse events; watch the floor around where it lands.
    const name = 'short_block';
    const boxBefore = await shrad(page, (n) => window.__shrad.boxOf(n), name);
    const from = await shrad(page, (n) => window.__shrad.screenOf(n), name);
    const frameBefore = await shrad(page, () => window.__shrad.state.lastFrame.frame);
    await dragBy(page, from, -120, 30, 20, 800);
    await page.waitForFunction((f) => window.__shrad.state.lastDrawnFrame > f, frameBefore);
    const boxAfter = await shrad(page, (n) => window.__shrad.boxOf(n), name);
    const moved = Math.hypot(boxAfter[0][0] - boxBefore[0][0], boxAfter[0][2] - boxBefore[0][2]);
    assert.ok(moved > 0.05 * (boxBefore[1][0] - boxBefore[0][0]), `the block did not move (${moved})`);
    assert.ok(Math.abs(boxAfter[0][1] - boxBefore[0][1]) < 1e-3 * (boxBefore[1][1] - boxBefore[0][1]) + 1e-4, 'the block left the floor');
    // The floor next to the block's new place, as it looked before the drag (block away) ...
    const rects = await rectsAt(page, around(boxAfter));
    // (sampled under the camera of now, from the first frame after the move, until the engine
    // says it converged and six samples in a row agree; the time it took is reported, not
    // asserted, and the wait is bounded by a generous 120 s)
    const t0 = Date.now();
    const series = [await shrad(page, (r) => window.__shrad.sample(r), rects)];
    let settledAt = null;
    while (Date.now() - t0 < 120_000) {
      await sleep(100);
      series.push(await shrad(page, (r) => window.__shrad.sample(r), rects));
      const last = series.slice(-6);
      const conv = await shrad(page, () => window.__shrad.state.lastFrame.converged);
      if (last.length === 6 && last.every((s) => maxDiff(s, last[0]) < 1.0) && conv) { settledAt = (Date.now() - t0) / 1000; break; }
    }
    assert.ok(settledAt !== null, 'the floor around the moved block did not settle (converged, six equal samples) within 120 s');
    const after = series[series.length - 1];
    // Before the drag the block stood elsewhere: compare with the same pixels with the block
    // put back (the GI of the old state, rendered under the same camera).
    await shot(page, 'cornell-after-drag.png');
    const changeFirstToLast = maxDiff(series[0], after);
    const idleFrame = await shrad(page, () => window.__shrad.state.lastFrame.frame);
    const backId = await shrad(page, ([n, m]) => {
      const s = window.__shrad.state;
      const o = s.objects.findIndex((x) => x.meta.name === n);
      return window.__shrad.send('set_transform', { object: o, matrix: m }, true);
    }, [name, await shrad(page, ([n, dx, dz]) => {
      const s = window.__shrad.state;
      const o = s.objects.findIndex((x) => x.meta.name === n);
      const ob = s.objects[o];
      const m = ob.worldFromLocal.clone().multiply(ob.localFromObject);
      m.elements[12] += dx; m.elements[14] += dz;
      return Array.from(m.elements);
    }, [name, boxBefore[0][0] - boxAfter[0][0], boxBefore[0][2] - boxAfter[0][2]])]);
    assert.equal(typeof backId, 'number', 'the move back was not sent (the socket is not open)');
    // The engine was idle (converged): the next frame it steps is the one with the block back,
    // and the page places the block from the engine's matrices (this move was not shown ahead).
    await page.waitForFunction((f) => window.__shrad.state.lastDrawnFrame > f, idleFrame, { timeout: 30_000 });
    const boxBack = await shrad(page, (n) => window.__shrad.boxOf(n), name);
    assert.ok(Math.abs(boxBack[0][0] - boxBefore[0][0]) < 1e-3 && Math.abs(boxBack[0][2] - boxBefore[0][2]) < 1e-3,
      `the block is not back where it stood (x ${boxBack[0][0]} vs ${boxBefore[0][0]}, z ${boxBack[0][2]} vs ${boxBefore[0][2]})`);
    await settled(page);
    const restored = await shrad(page, (r) => window.__shrad.sample(r), rects);
    const gi = maxDiff(restored, after);
    assert.ok(gi > 3, `the pixels where the block's shadow and colour bleeding fall did not change (max ${gi.toFixed(1)} of 255)`);
    const result = { drag: { moved_world: moved, settled_s: settledAt, pixel_change_vs_block_away: gi, change_while_settling: changeFirstToLast } };

    // Switch the solver: the stats panel moves.
    const statsText = async () => shrad(page, () => document.getElementById('stats').innerText);
    const before = await statsText();
    await page.selectOption('#solver', 'grid');
    await page.click('#apply-solver');
    await page.waitForFunction(() => window.__shrad.state.lastFrame.solver === 'grid', null, { timeout: 60_000 });
    await page.waitForFunction(() => window.__shrad.state.lastDrawnFrame >= window.__shrad.state.lastFrame.frame);
    // The panel repaints five times a second, not per frame; and the switch now precomputes
    // beside the frames, so the grid's first frame may come just after a repaint.
    await page.waitForFunction(() => /grid/.test(document.getElementById('stats').innerText), null, { timeout: 10_000 });
    const gridText = await statsText();
    assert.notEqual(gridText, before);
    assert.match(gridText, /grid/);
    await page.selectOption('#solver', 'dispersive');
    await page.click('#apply-solver');
    await page.waitForFunction(() => window.__shrad.state.lastFrame.solver === 'dispersive', null, { timeout: 60_000 });
    await settled(page);

    // Error against the reference.
    await page.click('#error-btn');
    await page.waitForFunction(() => window.__shrad.state.error && window.__shrad.state.error.overall >= 0, null, { timeout: 120_000 });
    result.error_vs_reference = await shrad(page, () => window.__shrad.state.error);
    // Against a fresh reference solve of the same state: the converged dispersive default is
    // a few per cent off (measured here 4.75 %; README: 4.5 %), the paper's method 34 %.
    const err = result.error_vs_reference;
    assert.equal(err.solver, 'dispersive');
    assert.ok(err.overall > 0 && err.overall < 0.10, `the dispersive default is ${(100 * err.overall).toFixed(2)} % from the reference`);

    // Channels: what the page draws for each adds up to the total (the scene is converged,
    // so the three frames are of one state): direct + indirect = total, within the half
    // floats' rounding and the clamp of the indirect part at 0, and each a real part of it.
    const sums = { total: await shrad(page, () => window.__shrad.radianceSum()) };
    for (const c of ['direct', 'indirect']) {
      await page.selectOption('#channel', c);
      await page.waitForFunction((k) => window.__shrad.state.lastChannel === k, c === 'direct' ? 1 : 2);
      sums[c] = await shrad(page, () => window.__shrad.radianceSum());
      await sleep(200);
      await shot(page, `cornell-${c}.png`);
    }
    await page.selectOption('#channel', 'total');
    await page.waitForFunction(() => window.__shrad.state.lastChannel === 0);
    for (let k = 0; k < 3; k++) {
      const [t, d, i] = [sums.total[k], sums.direct[k], sums.indirect[k]];
      assert.ok(d > 0.05 * t && d < t, `channel ${k}: direct ${d} is not a part of the total ${t}`);
      assert.ok(i > 0.05 * t && i < t, `channel ${k}: indirect ${i} is not a part of the total ${t}`);
      assert.ok(Math.abs(d + i - t) <= 0.01 * t, `channel ${k}: direct ${d} + indirect ${i} = ${d + i}, not the total ${t}`);
    }
    result.channels = sums;

    // Probes: 8 per interior object, shaded, repaired/invalid marked.
    await page.check('#probes');
    await page.waitForFunction(() => window.__shrad.state.probes && window.__shrad.state.probes.probes.length > 0, null, { timeout: 30_000 });
    const probes = await shrad(page, () => window.__shrad.state.probes.probes.map((p) => ({ object: p.object, state: p.state, bright: Math.max(...p.radiance) })));
    assert.equal(probes.length, 16);
    assert.ok(probes.some((p) => p.bright > 0), 'every probe is black');
    await page.check('#roles');
    await sleep(300);
    await shot(page, 'cornell-probes.png');
    await page.uncheck('#roles');
    await page.uncheck('#probes');
    result.probes = { count: probes.length, states: probes.reduce((m, p) => ({ ...m, [p.state]: (m[p.state] || 0) + 1 }), {}) };

    // Performance at 20k patches: steady stepping, then a sustained drag.
    result.steady = await steady(page, 5);
    result.dragging = await measure(page, 'tall_block', 4, 60);
    result.dragging_fast = await measure(page, 'tall_block', 4, 60, 30);
    result.errors = errors;
    writeFileSync(path.join(output, `perf-cornell-${patches}.json`), JSON.stringify(result, null, 2));
    console.log('cornell 20k:', JSON.stringify(result));
    // The light followed the object: every move's frame was drawn, in both drags.
    for (const k of ['dragging', 'dragging_fast']) {
      assert.equal(result[k].undrawn, 0, `${k}: the light of ${result[k].undrawn} moves was never drawn`);
      assert.ok(result[k].latency_ms.samples > 0, `${k}: no move's light was drawn`);
    }
    assert.deepEqual(errors, [], `the page reported errors: ${errors.join('; ')}`);
  } finally {
    await browser.close();
    const r = await stopServer(server);
    assert.ok(r && (r.code === 0), `the server did not exit cleanly on SIGINT: ${JSON.stringify(r)}\n${server.stderr()}`);
  }
});

test('sharing: the token from the page address into its socket, one steerer and a watcher that takes over', { timeout: 300_000 }, async () => {
  const token = 'browser-test-token-0123456789';
  const server = await startServer(['cornell', '--patches', '2000', '--token', token]);
  const browser = await launch();
  try {
    // Without the token (or with a wrong one) the page itself is refused.
    assert.equal((await fetch(server.url)).status, 401);
    assert.equal((await fetch(`${server.url}?token=wrong-token-0123456789`)).status, 401);
    // With it, the page loads its modules (the cookie) and its socket (the URL), and steers.
    const { page, errors } = await openPage(browser.context, `${server.url}?token=${token}`);
    await page.waitForFunction(() => document.getElementById('role').textContent.startsWith('you steer'));
    // A second page watches; once the first hands over, it takes steering.
    const second = await browser.context.newPage();
    await second.goto(`${server.url}?token=${token}`);
    await second.waitForFunction(() => window.__shrad && window.__shrad.state.framesDrawn > 0, null, { timeout: 120_000 });
    await second.waitForFunction(() => document.getElementById('role').textContent.startsWith('you watch (another'));
    assert.equal(await second.isHidden('#take-steering'), true, 'take steering offered while another steers');
    await page.click('#release-steering');
    await second.waitForSelector('#take-steering', { state: 'visible' });
    await second.click('#take-steering');
    await second.waitForFunction(() => document.getElementById('role').textContent.startsWith('you steer'));
    await page.waitForFunction(() => document.getElementById('role').textContent.startsWith('you watch'));
    assert.deepEqual(errors, []);
  } finally {
    await browser.close();
    await stopServer(server);
  }
});

test('the 77k-patch room (SHRAD_VIEW_PERF=1)', { timeout: 900_000, skip: process.env.SHRAD_VIEW_PERF !== '1' }, async () => {
  const server = await startServer(['room', '--patches', '77375']);
  const browser = await launch();
  try {
    const { page, errors } = await openPage(browser.context, server.url);
    await settled(page, 120_000);
    const name = await shrad(page, () => {
      const s = window.__shrad.state;
      const [w, h] = window.__shrad.canvasSize();
      const inside = s.objects.filter((o) => o.meta.role === 'interior').map((o) => o.meta.name)
        .filter((n) => { const p = window.__shrad.screenOf(n); return p.x > 50 && p.x < w - 50 && p.y > 50 && p.y < h - 50; });
      return inside[0];
    });
    assert.ok(name, 'no interior object of the room is on screen');
    const result = { object: name, patches: await shrad(page, () => window.__shrad.state.scene.patches) };
    await shot(page, 'room-77k.png');
    result.steady = await steady(page, 5);
    result.dragging = await measure(page, name, 4, 40);
    result.dragging_fast = await measure(page, name, 4, 40, 30);
    result.errors = errors;
    writeFileSync(path.join(output, 'perf-room-77k.json'), JSON.stringify(result, null, 2));
    console.log('room 77k:', JSON.stringify(result));
    // The light followed the object: every move's frame was drawn, in both drags.
    for (const k of ['dragging', 'dragging_fast']) {
      assert.equal(result[k].undrawn, 0, `${k}: the light of ${result[k].undrawn} moves was never drawn`);
      assert.ok(result[k].latency_ms.samples > 0, `${k}: no move's light was drawn`);
    }
  } finally {
    await browser.close();
    await stopServer(server);
  }
});
