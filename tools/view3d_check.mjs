// Check the interactive 3-D view of a report.html in headless Chromium and
// say, as one JSON line on stdout, whether:
//   - the viewer drew (canvas data-state "drawn") and the canvas shows the
//     valve: enough pixels differ from the white background,
//   - a mouse drag across the canvas redraws it and changes the picture,
//   - the wheel zooms (the picture changes again),
//   - Reset view brings back the first picture (the button's focus ring
//     aside, which lies on the canvas),
//   - the view is not printed,
//   - there is no console error, no uncaught page error and no request to
//     anything but file: and data: URLs.
//
//   node tools/view3d_check.mjs PAGE.html [--out DIR] [--no-webgl]
//
// With --out, DIR receives view3d_initial.png and view3d_rotated.png (the
// canvas before and after the drag). With --no-webgl, Chromium runs without
// WebGL and the check is instead that the view says so in words (canvas
// data-state "unavailable", a visible sentence naming WebGL) without a
// console error. Chromium runs WebGL on SwiftShader (the
// CPU), so no GPU is needed. Environment as for browser_check.mjs:
// COAPT_NODE_MODULES (playwright-core), COAPT_CHROMIUM (default
// /usr/bin/chromium). Exit status: 0 all checks pass, 1 a check fails,
// 2 the check could not run.

import { mkdirSync, mkdtempSync, rmSync, writeFileSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join, resolve } from 'node:path';
import { pathToFileURL } from 'node:url';
import { decodePng, out, preflight } from './browser_check.mjs';

// The valve must cover at least this share of the canvas, and a drag or a
// zoom must change at least this share of its pixels.
const MIN_DRAWN_FRACTION = 0.02;
const MIN_CHANGED_FRACTION = 0.02;
// Reset must restore the first picture up to this share of pixels.
const MAX_RESET_DIFFERENCE = 0.001;
// A channel this far from the background (white) counts as drawn.
const INK_THRESHOLD = 12;
const DEADLINE_MS = 120_000;

function drawnFraction(img) {
  const { width, height, channels, pixels } = img;
  let n = 0;
  for (let p = 0; p < width * height; p++) {
    for (let c = 0; c < Math.min(3, channels); c++) {
      if (255 - pixels[p * channels + c] > INK_THRESHOLD) {
        n += 1;
        break;
      }
    }
  }
  return n / (width * height);
}

function changedFraction(a, b) {
  if (a.width !== b.width || a.height !== b.height || a.channels !== b.channels) return 1;
  let n = 0;
  for (let p = 0; p < a.width * a.height; p++) {
    for (let c = 0; c < Math.min(3, a.channels); c++) {
      if (Math.abs(a.pixels[p * a.channels + c] - b.pixels[p * b.channels + c]) > INK_THRESHOLD) {
        n += 1;
        break;
      }
    }
  }
  return n / (a.width * a.height);
}

async function main() {
  const args = process.argv.slice(2);
  const outAt = args.indexOf('--out');
  const outDir = outAt >= 0 ? args[outAt + 1] : null;
  const pagePath = args.find((a, i) => !a.startsWith('--') && (outAt < 0 || i !== outAt + 1));
  const noWebgl = args.includes('--no-webgl');
  const verdict = {
    ok: false, page: pagePath || null, console_errors: [], page_errors: [], external_requests: [],
    state: null, drawn_fraction: null, drag_changed_fraction: null, zoom_changed_fraction: null,
    reset_difference_fraction: null, frames: null, screenshots: [], error: null,
  };
  const { playwright, executablePath, timer } = preflight(verdict, pagePath, DEADLINE_MS);

  const profile = mkdtempSync(join(tmpdir(), 'coapt-chromium-'));
  let context = null;
  let opened = false;
  try {
    context = await playwright.chromium.launchPersistentContext(profile, {
      executablePath,
      headless: true,
      viewport: { width: 1200, height: 900 },
      deviceScaleFactor: 1,
      args: [
        '--headless', '--no-sandbox', '--disable-quic', '--no-first-run',
        '--disable-background-networking', '--disable-component-update', '--disable-sync',
        '--disable-default-apps', '--disable-extensions', '--no-default-browser-check',
        // WebGL on the CPU: the check must not depend on a GPU.
        ...(noWebgl ? ['--disable-webgl', '--disable-3d-apis'] : ['--use-angle=swiftshader', '--enable-unsafe-swiftshader']),
        '--host-resolver-rules=MAP * ~NOTFOUND',
      ],
    });
    const external = (url) => !(url.startsWith('file:') || url.startsWith('data:'));
    context.on('request', (req) => {
      if (external(req.url())) verdict.external_requests.push(req.url());
    });
    await context.route('**/*', (route) => (external(route.request().url()) ? route.abort('blockedbyclient') : route.continue()));
    const page = context.pages()[0] || (await context.newPage());
    page.on('console', (msg) => {
      if (msg.type() === 'error') verdict.console_errors.push(msg.text());
    });
    page.on('pageerror', (err) => verdict.page_errors.push(String(err && err.message ? err.message : err)));
    await page.goto(pathToFileURL(resolve(pagePath)).href, { waitUntil: 'load', timeout: 60_000 });
    opened = true;

    const canvas = page.locator('#view3d-canvas');
    if ((await canvas.count()) !== 1) throw new Error('the page has no #view3d-canvas');
    await canvas.scrollIntoViewIfNeeded();
    await page.waitForFunction(() => {
      const s = document.getElementById('view3d-canvas').getAttribute('data-state');
      return s === 'drawn' || s === 'unavailable';
    }, null, { timeout: 30_000 });
    verdict.state = await canvas.getAttribute('data-state');
    if (noWebgl) {
      const m = page.locator('#view3d-msg');
      verdict.message = await m.textContent();
      verdict.message_visible = await m.isVisible();
      const png = await page.locator('.view3d-stage').screenshot({ type: 'png' });
      if (outDir) {
        mkdirSync(outDir, { recursive: true });
        writeFileSync(join(outDir, 'view3d_no_webgl.png'), png);
        verdict.screenshots.push(join(outDir, 'view3d_no_webgl.png'));
      }
      await page.waitForTimeout(100);
    } else if (verdict.state !== 'drawn') {
      verdict.message = await page.locator('#view3d-msg').textContent();
      throw new Error('the viewer did not draw: ' + verdict.message);
    }
    if (!noWebgl) await interact(page, canvas, outDir, verdict);
  } catch (e) {
    verdict.error = String(e && e.message ? e.message : e);
  } finally {
    if (context) await context.close().catch(() => {});
    rmSync(profile, { recursive: true, force: true });
    clearTimeout(timer);
  }
  const clean = verdict.console_errors.length === 0 && verdict.page_errors.length === 0 && verdict.external_requests.length === 0;
  verdict.ok = !verdict.error && clean && (noWebgl
    ? verdict.state === 'unavailable' && verdict.message_visible && /WebGL/.test(verdict.message)
    : verdict.state === 'drawn' &&
      verdict.drawn_fraction >= MIN_DRAWN_FRACTION && verdict.drag_changed_fraction >= MIN_CHANGED_FRACTION &&
      verdict.zoom_changed_fraction >= MIN_CHANGED_FRACTION && verdict.reset_difference_fraction <= MAX_RESET_DIFFERENCE &&
      verdict.hidden_in_print === true);
  // An error before the page opened means the check could not run.
  if (verdict.error && !opened) out(verdict, 2);
  out(verdict, verdict.ok ? 0 : 1);
}

// Screenshots of the canvas before and after a drag, a wheel zoom and Reset.
async function interact(page, canvas, outDir, verdict) {
  const frames = async () => Number(await canvas.getAttribute('data-frames'));
  const shot = async (name) => {
    const png = await canvas.screenshot({ type: 'png' });
    if (outDir) {
      mkdirSync(outDir, { recursive: true });
      const p = join(outDir, name);
      writeFileSync(p, png);
      verdict.screenshots.push(p);
    }
    return decodePng(png);
  };
  const nextFrame = async (before) =>
    page.waitForFunction((n) => Number(document.getElementById('view3d-canvas').getAttribute('data-frames')) > n, before, { timeout: 10_000 });

  const initial = await shot('view3d_initial.png');
  verdict.drawn_fraction = drawnFraction(initial);

  const box = await canvas.boundingBox();
  const cx = box.x + box.width / 2, cy = box.y + box.height / 2;
  let before = await frames();
  await page.mouse.move(cx, cy);
  await page.mouse.down();
  for (let k = 1; k <= 10; k++) await page.mouse.move(cx + 16 * k, cy + 5 * k);
  await page.mouse.up();
  await nextFrame(before);
  await page.waitForTimeout(100);
  const rotated = await shot('view3d_rotated.png');
  verdict.drag_changed_fraction = changedFraction(initial, rotated);

  before = await frames();
  await page.mouse.move(cx, cy);
  await page.mouse.wheel(0, -400);
  await nextFrame(before);
  await page.waitForTimeout(100);
  const zoomed = await shot('view3d_zoomed.png');
  verdict.zoom_changed_fraction = changedFraction(rotated, zoomed);

  before = await frames();
  await page.click('#view3d-reset');
  await nextFrame(before);
  await page.waitForTimeout(100);
  const reset = await shot('view3d_reset.png');
  verdict.reset_difference_fraction = changedFraction(initial, reset);
  verdict.frames = await frames();
  // Print keeps the static figures only.
  await page.emulateMedia({ media: 'print' });
  verdict.hidden_in_print = await page.evaluate(() => getComputedStyle(document.getElementById('view3d')).display === 'none');
  await page.emulateMedia({ media: 'screen' });
  await page.waitForTimeout(100);
}

main();
