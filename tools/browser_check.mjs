// Open an HTML file in headless Chromium and say, as one JSON line on
// stdout, whether it is a sound self-contained page:
//   - no console error and no uncaught page error,
//   - no request to anything but file: and data: URLs (others are recorded,
//     then aborted: nothing leaves the machine),
//   - every <img> decodes (complete, naturalWidth > 0, img.decode() resolves),
//   - a full-page screenshot is not blank (decoded here: many distinct
//     colours, no colour covering almost everything).
//
//   node tools/browser_check.mjs PAGE.html [--screenshot OUT.png]
//
// Environment: COAPT_NODE_MODULES, the node_modules folder holding
// playwright-core (default: tools/node_modules, then
// ~/.cache/coapt-node/node_modules); COAPT_CHROMIUM, the browser
// (default /usr/bin/chromium).
// Exit status: 0 all checks pass, 1 a check fails, 2 the check could not run
// (playwright-core or the browser missing, page not found); the JSON says why.

import { createRequire } from 'node:module';
import { existsSync, mkdtempSync, rmSync, writeFileSync } from 'node:fs';
import { tmpdir, homedir } from 'node:os';
import { join, resolve, dirname } from 'node:path';
import { fileURLToPath, pathToFileURL } from 'node:url';
import { inflateSync } from 'node:zlib';

const here = dirname(fileURLToPath(import.meta.url));
// A screenshot counts as blank below these.
const MIN_DISTINCT_COLOURS = 16;
const MAX_DOMINANT_FRACTION = 0.985;
const DEADLINE_MS = 90_000;

export function out(verdict, code) {
  process.stdout.write(JSON.stringify(verdict) + '\n');
  process.exit(code);
}

// ---------------------------------------------------------------- PNG decoding

const PNG_SIGNATURE = Buffer.from([0x89, 0x50, 0x4e, 0x47, 0x0d, 0x0a, 0x1a, 0x0a]);

function paeth(a, b, c) {
  const p = a + b - c;
  const pa = Math.abs(p - a), pb = Math.abs(p - b), pc = Math.abs(p - c);
  if (pa <= pb && pa <= pc) return a;
  return pb <= pc ? b : c;
}

// Decode an 8-bit, non-interlaced grey/grey+alpha/RGB/RGBA PNG (what
// Chromium writes) into { width, height, channels, pixels }.
export function decodePng(buf) {
  if (buf.length < 8 || !buf.subarray(0, 8).equals(PNG_SIGNATURE)) throw new Error('not a PNG');
  let pos = 8, ihdr = null;
  const idat = [];
  while (pos + 8 <= buf.length) {
    const len = buf.readUInt32BE(pos);
    const type = buf.toString('latin1', pos + 4, pos + 8);
    const data = buf.subarray(pos + 8, pos + 8 + len);
    if (data.length !== len) throw new Error('truncated PNG chunk ' + type);
    if (type === 'IHDR') ihdr = data;
    else if (type === 'IDAT') idat.push(data);
    else if (type === 'IEND') break;
    pos += 12 + len;
  }
  if (!ihdr) throw new Error('PNG without IHDR');
  const width = ihdr.readUInt32BE(0), height = ihdr.readUInt32BE(4);
  const depth = ihdr[8], colourType = ihdr[9], interlace = ihdr[12];
  const channels = { 0: 1, 2: 3, 4: 2, 6: 4 }[colourType];
  if (depth !== 8 || !channels || interlace !== 0) {
    throw new Error(`unsupported PNG: depth ${depth}, colour type ${colourType}, interlace ${interlace}`);
  }
  const raw = inflateSync(Buffer.concat(idat));
  const stride = width * channels;
  if (raw.length < height * (stride + 1)) throw new Error('PNG data too short');
  const pixels = Buffer.alloc(height * stride);
  for (let y = 0; y < height; y++) {
    const filter = raw[y * (stride + 1)];
    const line = raw.subarray(y * (stride + 1) + 1, (y + 1) * (stride + 1));
    const o = y * stride;
    for (let i = 0; i < stride; i++) {
      const a = i >= channels ? pixels[o + i - channels] : 0;
      const b = y > 0 ? pixels[o - stride + i] : 0;
      const c = y > 0 && i >= channels ? pixels[o - stride + i - channels] : 0;
      let v;
      switch (filter) {
        case 0: v = line[i]; break;
        case 1: v = line[i] + a; break;
        case 2: v = line[i] + b; break;
        case 3: v = line[i] + ((a + b) >> 1); break;
        case 4: v = line[i] + paeth(a, b, c); break;
        default: throw new Error('bad PNG filter ' + filter);
      }
      pixels[o + i] = v & 0xff;
    }
  }
  return { width, height, channels, pixels };
}

// Distinct colours and the share of the most frequent one.
export function colourStats({ width, height, channels, pixels }) {
  const counts = new Map();
  for (let p = 0; p < width * height; p++) {
    let key = 0;
    for (let c = 0; c < channels; c++) key = key * 256 + pixels[p * channels + c];
    counts.set(key, (counts.get(key) || 0) + 1);
  }
  let top = 0;
  for (const n of counts.values()) top = Math.max(top, n);
  const total = width * height;
  return { distinct_colours: counts.size, dominant_fraction: total ? top / total : 1 };
}

// ---------------------------------------------------------------- the check

// Compare our decoding of `png` with the browser's own (an <img> drawn on a
// canvas, in a blank page of its own) on a grid of pixels; returns the number
// of pixels that differ (0 when this decoder reads Chromium's PNG right).
async function crossCheckDecoder(context, png, img) {
  const points = [];
  const nx = 40, ny = 60;
  for (let j = 0; j < ny; j++) {
    for (let i = 0; i < nx; i++) {
      points.push([Math.floor(((i + 0.5) * img.width) / nx), Math.floor(((j + 0.5) * img.height) / ny)]);
    }
  }
  const check = await context.newPage();
  try {
    const theirs = await check.evaluate(async ({ b64, points }) => {
      const im = new Image();
      im.src = 'data:image/png;base64,' + b64;
      await im.decode();
      const c = document.createElement('canvas');
      c.width = im.naturalWidth;
      c.height = im.naturalHeight;
      const ctx = c.getContext('2d');
      ctx.drawImage(im, 0, 0);
      const d = ctx.getImageData(0, 0, c.width, c.height).data;
      return points.map(([x, y]) => Array.from(d.subarray((y * c.width + x) * 4, (y * c.width + x) * 4 + 3)));
    }, { b64: png.toString('base64'), points });
    let mismatches = 0;
    points.forEach(([x, y], k) => {
      const o = (y * img.width + x) * img.channels;
      const ours = img.channels >= 3
        ? [img.pixels[o], img.pixels[o + 1], img.pixels[o + 2]]
        : [img.pixels[o], img.pixels[o], img.pixels[o]];
      if (ours.some((v, c) => v !== theirs[k][c])) mismatches += 1;
    });
    return mismatches;
  } finally {
    await check.close();
  }
}

function loadPlaywright() {
  const candidates = [process.env.COAPT_NODE_MODULES, join(here, 'node_modules'), join(homedir(), '.cache', 'coapt-node', 'node_modules')]
    .filter(Boolean);
  for (const dir of candidates) {
    if (existsSync(join(dir, 'playwright-core', 'package.json'))) {
      const require = createRequire(join(resolve(dir), '_'));
      return { playwright: require('playwright-core'), from: dir };
    }
  }
  return { playwright: null, from: candidates.join(', ') };
}

// What every check needs before Chromium starts: the page, playwright-core
// and Chromium, each missing one a verdict with exit 2; and a deadline.
export function preflight(verdict, pagePath, deadlineMs) {
  if (!pagePath || !existsSync(pagePath)) {
    verdict.error = `page not found: ${pagePath}`;
    out(verdict, 2);
  }
  const { playwright, from } = loadPlaywright();
  if (!playwright) {
    verdict.error = `playwright-core not found in ${from}`;
    out(verdict, 2);
  }
  const executablePath = process.env.COAPT_CHROMIUM || '/usr/bin/chromium';
  if (!existsSync(executablePath)) {
    verdict.error = `chromium not found at ${executablePath}`;
    out(verdict, 2);
  }
  const timer = setTimeout(() => {
    verdict.error = `no answer within ${deadlineMs / 1000} s`;
    out(verdict, 2);
  }, deadlineMs);
  return { playwright, executablePath, timer };
}

async function main() {
  const args = process.argv.slice(2);
  const page_path = args.find((a, i) => !a.startsWith('--') && args[i - 1] !== '--screenshot');
  const shotAt = args.indexOf('--screenshot');
  const shot_path = shotAt >= 0 ? args[shotAt + 1] : null;
  const verdict = {
    ok: false, page: page_path || null, console_errors: [], page_errors: [], external_requests: [],
    images: { total: 0, decoded: 0, broken: [] }, screenshot: null, text_chars: 0, error: null,
  };
  const { playwright, executablePath, timer } = preflight(verdict, page_path, DEADLINE_MS);

  const profile = mkdtempSync(join(tmpdir(), 'coapt-chromium-'));
  let context = null;
  try {
    context = await playwright.chromium.launchPersistentContext(profile, {
      executablePath,
      headless: true,
      viewport: { width: 1200, height: 900 },
      args: [
        '--headless', '--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run',
        '--disable-background-networking', '--disable-component-update', '--disable-sync',
        '--disable-default-apps', '--disable-extensions', '--no-default-browser-check',
        // Belt and braces: no host name resolves, so nothing could be fetched anyway.
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
    await page.goto(pathToFileURL(resolve(page_path)).href, { waitUntil: 'load', timeout: 60_000 });
    const imgs = await page.evaluate(async () =>
      Promise.all(
        Array.from(document.images).map(async (img) => {
          let decodes = true;
          try {
            await img.decode();
          } catch {
            decodes = false;
          }
          return { src: img.getAttribute('src') || '', complete: img.complete, width: img.naturalWidth, decodes };
        }),
      ),
    );
    verdict.images.total = imgs.length;
    for (const i of imgs) {
      if (i.complete && i.width > 0 && i.decodes) verdict.images.decoded += 1;
      else verdict.images.broken.push(i.src.length > 80 ? i.src.slice(0, 80) + '…' : i.src);
    }
    verdict.text_chars = (await page.evaluate(() => document.body ? document.body.innerText : '')).trim().length;
    const png = await page.screenshot({ fullPage: true, type: 'png' });
    if (shot_path) writeFileSync(shot_path, png);
    const img = decodePng(png);
    const stats = colourStats(img);
    verdict.screenshot = {
      path: shot_path, width: img.width, height: img.height, ...stats,
      blank: stats.distinct_colours < MIN_DISTINCT_COLOURS || stats.dominant_fraction > MAX_DOMINANT_FRACTION,
      decoder_mismatches: await crossCheckDecoder(context, png, img),
    };
    // Let late console messages arrive.
    await page.waitForTimeout(100);
  } catch (e) {
    verdict.error = String(e && e.message ? e.message : e);
  } finally {
    if (context) await context.close().catch(() => {});
    rmSync(profile, { recursive: true, force: true });
    clearTimeout(timer);
  }
  if (verdict.error) out(verdict, 2);
  verdict.ok =
    verdict.console_errors.length === 0 && verdict.page_errors.length === 0 && verdict.external_requests.length === 0 &&
    verdict.images.broken.length === 0 && verdict.screenshot !== null && !verdict.screenshot.blank && verdict.screenshot.decoder_mismatches === 0 &&
    verdict.text_chars > 0;
  out(verdict, verdict.ok ? 0 : 1);
}

// Run only as a script (the decoder is importable for a self-test).
if (process.argv[1] && resolve(process.argv[1]) === fileURLToPath(import.meta.url)) {
  main();
}
