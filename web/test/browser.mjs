// The web page (web/, built by web/build.sh) in a real browser: Debian's Chromium, headless,
// driven by puppeteer-core. For WebGPU: waits for frames, checks the canvas is not blank (pixel
// variance), switches the technique through the page's own control and checks the image changes.
// For WebGL2: checks the page says why it draws nothing and greys the techniques out. Any console
// error, page error or panic fails the run.
//
// Usage: node web/test/browser.mjs [--chromium=/usr/bin/chromium] [--screenshot=docs/web-page.png]
// (npm ci in web/test first). Exit code 0 when every check passed.
import fs from 'node:fs';
import http from 'node:http';
import os from 'node:os';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import puppeteer from 'puppeteer-core';
import { PNG } from 'pngjs';

const args = Object.fromEntries(process.argv.slice(2).map(a => a.replace(/^--/, '').split('=')));
const chromium = args.chromium || '/usr/bin/chromium';
const web = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '..');
const TIMEOUT = 180_000;
// WebGPU on SwiftShader (Dawn's CPU adapter) with a canvas the compositor shows, and WebGL2 on
// ANGLE over SwiftShader: no GPU needed.
const FLAGS = [
  '--headless=new', '--no-sandbox', '--enable-unsafe-webgpu', '--ignore-gpu-blocklist',
  '--enable-unsafe-swiftshader', '--enable-features=Vulkan', '--use-vulkan=swiftshader', '--use-angle=swiftshader',
];

const types = { '.html': 'text/html', '.js': 'text/javascript', '.wasm': 'application/wasm', '.png': 'image/png' };
const server = http.createServer((req, res) => {
  const file = path.join(web, decodeURIComponent(new URL(req.url, 'http://x').pathname));
  if (!file.startsWith(web) || !fs.existsSync(file) || fs.statSync(file).isDirectory()) {
    res.writeHead(404).end();
    return;
  }
  res.writeHead(200, { 'content-type': types[path.extname(file)] || 'application/octet-stream' });
  fs.createReadStream(file).pipe(res);
});
await new Promise(r => server.listen(0, '127.0.0.1', r));
const base = `http://127.0.0.1:${server.address().port}/index.html`;

// A 4 m floor and a 1 m box floating above it (both closed, outward-wound), as OBJ text.
function boxObj() {
  const lines = [];
  const cuboid = (x0, y0, z0, x1, y1, z1) => {
    const base = lines.filter(l => l.startsWith('v ')).length;
    for (const [x, y, z] of [[x0, y0, z0], [x1, y0, z0], [x1, y1, z0], [x0, y1, z0], [x0, y0, z1], [x1, y0, z1], [x1, y1, z1], [x0, y1, z1]]) {
      lines.push(`v ${x} ${y} ${z}`);
    }
    const quads = [[1, 4, 3, 2], [5, 6, 7, 8], [1, 2, 6, 5], [4, 8, 7, 3], [1, 5, 8, 4], [2, 3, 7, 6]];
    for (const q of quads) lines.push('f ' + q.map(i => i + base).join(' '));
  };
  cuboid(-2, -0.1, -2, 2, 0, 2);
  cuboid(-0.5, 0.8, -0.5, 0.5, 1.8, 0.5);
  return lines.join('\n') + '\n';
}

const failures = [];
const check = (ok, what) => {
  console.log(`${ok ? 'ok  ' : 'FAIL'} ${what}`);
  if (!ok) failures.push(what);
};

function pixels(buffer) {
  const png = PNG.sync.read(Buffer.from(buffer));
  return png;
}

// Variance of the luminance over the image: 0 for a blank canvas.
function variance(png) {
  let n = 0, sum = 0, sum2 = 0;
  for (let i = 0; i < png.data.length; i += 4) {
    const y = 0.2126 * png.data[i] + 0.7152 * png.data[i + 1] + 0.0722 * png.data[i + 2];
    n++; sum += y; sum2 += y * y;
  }
  return sum2 / n - (sum / n) ** 2;
}

// Pixels whose colour differs by more than 8 levels in any channel.
function changed(a, b) {
  let count = 0;
  for (let i = 0; i < a.data.length; i += 4) {
    if ([0, 1, 2].some(c => Math.abs(a.data[i + c] - b.data[i + c]) > 8)) count++;
  }
  return count;
}

const browser = await puppeteer.launch({ executablePath: chromium, headless: true, args: FLAGS, protocolTimeout: TIMEOUT });
const version = await browser.version();
console.log(`browser: ${version}`);
// The GPU process must be up before a WebGPU page loads (else the canvas may lose its device).
const cdp = await browser.target().createCDPSession();
await cdp.send('SystemInfo.getInfo');
await cdp.detach();

async function open(backend, technique, extra = '') {
  const page = await browser.newPage();
  await page.setViewport({ width: 720, height: 400 });
  const errors = [];
  page.on('console', m => {
    console.log(`  [console.${m.type()}] ${m.text()}`);
    if (m.type() === 'error') errors.push(m.text());
  });
  page.on('pageerror', e => { console.log(`  [pageerror] ${e.message}`); errors.push(e.message); });
  await page.goto(`${base}?backend=${backend}&scene=penumbra&technique=${technique}${extra}`, { waitUntil: 'load', timeout: TIMEOUT });
  await page.waitForFunction(() => window.shadowlab && (window.shadowlab.ready || window.shadowlab.error), {
    timeout: TIMEOUT, polling: 100,
  });
  return { page, errors };
}

async function framesAfter(page, count) {
  const start = await page.evaluate(() => window.shadowlab.frames);
  await page.waitForFunction(n => window.shadowlab.frames >= n || window.shadowlab.error, { timeout: TIMEOUT, polling: 100 }, start + count);
}

async function canvas(page) {
  return pixels(await (await page.$('#scene')).screenshot({ type: 'png' }));
}

// Real shadows, switched from the page: on WebGPU every technique, on WebGL2 the fragment paths.
async function shadows(backend, page) {
  const label = backend === 'webgpu' ? 'WebGPU' : 'WebGL2';
  const info = await page.evaluate(() => window.shadowlab.app.backend() + ' on ' + window.shadowlab.app.adapter());
  console.log(`  ${info}`);
  check(info.startsWith(label), `${label}: the adapter is a ${label} one`);
  await framesAfter(page, 3);
  const hard = await canvas(page);
  const v = variance(hard);
  // A blank or uniform canvas has variance 0; the penumbra scene's lit plane, its square and the
  // shadow measured 5 636 here (both backends). Bound: 100.
  check(v > 100, `${label}: the canvas shows the scene (luminance variance ${v.toFixed(0)})`);
  await page.select('#techniques', 'none');
  await framesAfter(page, 3);
  const none = await canvas(page);
  const n = changed(hard, none);
  // `none` lights the shadow: 2 654 pixels of 76 800 measured different from `hard`; bound 500.
  check(n > 500, `${label}: switching hard → none changes the image (${n} pixels)`);
  await page.select('#techniques', 'pcss');
  await framesAfter(page, 3);
  const pcss = await canvas(page);
  const m = changed(none, pcss);
  // Measured 3 101 pixels; bound 500.
  check(m > 500, `${label}: switching none → pcss changes the image (${m} pixels)`);
  const chosen = await page.evaluate(() => window.shadowlab.app.technique());
  check(chosen === 'pcss', `${label}: the engine runs the technique chosen (${chosen})`);
  // A technique with parameters typed into the page, then one it must refuse in words.
  const typeSpec = async spec => {
    await page.click('#spec', { clickCount: 3 });
    await page.keyboard.press('Backspace');
    await page.type('#spec', spec);
    await page.keyboard.press('Enter');
  };
  await typeSpec('pcf:taps=4');
  const typed = await page.evaluate(() => window.shadowlab.app.technique());
  check(typed === 'pcf:taps=4', `${label}: a spec typed with parameters runs (${typed})`);
  await typeSpec('pcf:taps=many');
  const refused = await page.evaluate(() => [window.shadowlab.app.technique(), document.getElementById('error').textContent]);
  check(refused[0] === 'pcf:taps=4' && refused[1].includes('taps'),
    `${label}: a bad parameter is refused in words and the technique stays (${refused[1]})`);
  await page.evaluate(() => { document.getElementById('error').textContent = ''; window.shadowlab.error = ''; });
  if (backend === 'webgpu' && info.includes('cpu adapter')) {
    // `ssm` on WebGPU on the CPU (SwiftShader): compiling its shaders took the GPU process past
    // 6 GB and the browser down with it; the page refuses it in words and keeps what it ran.
    await typeSpec('ssm');
    const ssm = await page.evaluate(() => [window.shadowlab.app.technique(), document.getElementById('error').textContent]);
    check(ssm[0] === 'pcf:taps=4' && /too large.*SwiftShader/.test(ssm[1]),
      `${label}: ssm is refused in words on a CPU adapter, and the technique stays (${ssm[1]})`);
    await page.evaluate(() => { document.getElementById('error').textContent = ''; window.shadowlab.error = ''; });
  }
  if (backend === 'webgpu') {
    // Every technique in the page's list draws frames on WebGPU without an error (`lightmesh`'s
    // precomputation panicked in wasm on a timer of the BVH builder's until it was built untimed).
    const ids = await page.evaluate(() => [...document.querySelectorAll('#techniques option')].map(o => o.value));
    const failed = [];
    for (const id of ids.filter(id => !(id === 'ssm' && info.includes('cpu adapter')))) {
      await typeSpec(id);
      await framesAfter(page, 2);
      // (The page's error state; its message line also carries notes, as a light given `hard`.)
      const [running, error] = await page.evaluate(() => [window.shadowlab.app.technique(), window.shadowlab.error]);
      if (running !== id || error) failed.push(`${id}: ${running} ${error}`);
      await page.evaluate(() => { document.getElementById('error').textContent = ''; window.shadowlab.error = ''; });
    }
    // The page listed 13 techniques; bound: more than 10, so that an emptied list cannot pass.
    check(ids.length > 10 && failed.length === 0,
      `${label}: every technique listed draws frames (${ids.length} listed${failed.length ? '; ' + failed.join('; ') : ''})`);
  }
  // The camera from the page's own handlers (a drag, a wheel step), and values no handler sends.
  await framesAfter(page, 2);
  const before = await canvas(page);
  const canvasBox = await (await page.$('#scene')).boundingBox();
  await page.mouse.move(canvasBox.x + 100, canvasBox.y + 100);
  await page.mouse.down();
  await page.mouse.move(canvasBox.x + 160, canvasBox.y + 120, { steps: 4 });
  await page.mouse.up();
  await page.mouse.wheel({ deltaY: 100 });
  await page.evaluate(() => { window.shadowlab.app.orbit(NaN, Infinity); window.shadowlab.app.zoom(-1); });
  await framesAfter(page, 2);
  const moved = changed(before, await canvas(page));
  // The orbit turns the view: 10 127 pixels measured changed (both backends); bound 500. The odd
  // values (NaN, a negative zoom) are ignored: no error, no panic.
  check(moved > 500, `${label}: dragging the canvas orbits the camera (${moved} pixels changed)`);
  // Zooming out without end stops at 100 times the scene's size, and seven steps back in (× 1/128)
  // bring the scene back into view: without the bound about 128 steps of × 2 took the camera to
  // infinity, where no step back could reach (the canvas stayed blank).
  await page.evaluate(() => { for (let i = 0; i < 200; i++) window.shadowlab.app.zoom(2); });
  await framesAfter(page, 2);
  const far = await canvas(page);
  await page.evaluate(() => { for (let i = 0; i < 7; i++) window.shadowlab.app.zoom(0.5); });
  await framesAfter(page, 2);
  const back = changed(far, await canvas(page));
  const zoomError = await page.evaluate(() => window.shadowlab.error);
  // Measured: 58 728 pixels changed (WebGPU), 58 727 (WebGL2), 0 without the bound; bound 500, as
  // for the orbit above.
  check(!zoomError && back > 500, `${label}: zooming out 200 times, then 7 back in, shows the scene again (${back} pixels changed${zoomError ? '; ' + zoomError : ''})`);
  const views = await page.evaluate(() => [...document.querySelectorAll('#views option')].map(o => o.value));
  check(views.length > 0, `${label}: the scene's views are listed (${views.join(', ')})`);
  return { hard, pcss };
}

// WebGPU: every technique; scene files.
let webgpuHard = null;
{
  const t0 = performance.now();
  const { page, errors } = await open('webgpu', 'hard');
  const error = await page.evaluate(() => window.shadowlab.error);
  check(!error, `WebGPU: the page started${error ? ': ' + error : ''}`);
  if (!error) {
    const { hard, pcss } = await shadows('webgpu', page);
    webgpuHard = hard;
    console.log(`  checks done after ${((performance.now() - t0) / 1000).toFixed(1)} s`);
    // A scene file through the page's file picker: an OBJ (a floor and a box above it, lit by the
    // default sun the loader adds), then bytes that are no scene, which must be refused in words.
    const dir = fs.mkdtempSync(path.join(os.tmpdir(), 'shadowlab-web-'));
    const obj = path.join(dir, 'box.obj');
    fs.writeFileSync(obj, boxObj());
    const junk = path.join(dir, 'junk.glb');
    fs.writeFileSync(junk, Buffer.from([...Array(256).keys()].map(i => (i * 73 + 11) % 256)));
    const input = await page.$('#file');
    await input.uploadFile(obj);
    await page.waitForFunction(() => window.shadowlab.app.scene() === 'box.obj' || document.getElementById('error').textContent, {
      timeout: TIMEOUT, polling: 100,
    });
    const loaded = await page.evaluate(() => [window.shadowlab.app.scene(), document.getElementById('error').textContent]);
    check(loaded[0] === 'box.obj', `WebGPU: an OBJ file from the file picker is shown (${loaded.join(' | ')})`);
    await framesAfter(page, 3);
    const box = await canvas(page);
    const b = changed(pcss, box);
    check(b > 500, `WebGPU: the loaded scene is drawn (${b} pixels changed)`);
    await input.uploadFile(junk);
    await page.waitForFunction(() => document.getElementById('error').textContent.includes('junk.glb'), {
      timeout: TIMEOUT, polling: 100,
    }).catch(() => {});
    const refused = await page.evaluate(() => [window.shadowlab.app.scene(), document.getElementById('error').textContent]);
    console.log(`  refused: ${refused[1]}`);
    check(refused[0] === 'box.obj' && refused[1].includes('junk.glb'),
      'WebGPU: bytes that are no scene are refused with a message, and the scene stays');
    fs.rmSync(dir, { recursive: true, force: true });
    // The same file dropped on the drop zone (a DataTransfer built in the page).
    await page.evaluate(text => {
      const data = new DataTransfer();
      data.items.add(new File([text], 'dropped.obj'));
      document.getElementById('drop').dispatchEvent(new DragEvent('drop', { dataTransfer: data, bubbles: true, cancelable: true }));
    }, boxObj());
    await page.waitForFunction(() => window.shadowlab.app.scene() === 'dropped.obj', { timeout: TIMEOUT, polling: 100 }).catch(() => {});
    const dropped = await page.evaluate(() => window.shadowlab.app.scene());
    check(dropped === 'dropped.obj', `WebGPU: a file dropped on the page is shown (${dropped})`);
    if (args.screenshot) {
      await page.setViewport({ width: 720, height: 660 });
      await page.evaluate(() => { document.getElementById('spec').value = ''; });
      await page.select('#techniques', 'pcss');
      await page.select('#scenes', 'room');
      await framesAfter(page, 3);
      await page.evaluate(() => { document.getElementById('error').textContent = ''; });
      await page.screenshot({ path: args.screenshot, type: 'png' });
      console.log(`  screenshot → ${args.screenshot}`);
    }
  }
  check(errors.length === 0, `WebGPU: no console error or panic (${errors.length})`);
  await page.close();
}

// A lost device (a driver reset, the browser's GPU process ended; here the device destroyed): the
// page says so and stops drawing, and a technique chosen afterwards is refused in words, where a
// call on the lost device would have panicked (a buffer mapped at creation fails outright).
{
  const { page, errors } = await open('webgpu', 'hard');
  await framesAfter(page, 2);
  await page.evaluate(() => window.shadowlab.app.lose_device());
  await page.waitForFunction(() => window.shadowlab.error, { timeout: TIMEOUT, polling: 100 }).catch(() => {});
  const shown = await page.evaluate(() => window.shadowlab.error);
  check(/lost/.test(shown), `WebGPU: a lost device is reported (${shown})`);
  await page.select('#techniques', 'pcss');
  const after = await page.evaluate(() => [window.shadowlab.app.technique(), document.getElementById('error').textContent]);
  check(after[0] === 'hard' && /lost/.test(after[1]), `WebGPU: after the loss a technique is refused in words (${after.join(' | ')})`);
  // The frame loop logs the loss once; anything else (a panic above all) fails.
  const others = errors.filter(e => !/lost/.test(e));
  check(others.length === 0, `WebGPU: nothing but the loss is logged after it (${others.join(' | ')})`);
  await page.close();
}

// A canvas wider than the device's largest texture (WebGPU's default limit is 8192): refused in
// words at the start, where every target made at its size failed as a device error.
{
  const { page, errors } = await open('webgpu', 'hard', '&size=9000x16');
  const error = await page.evaluate(() => window.shadowlab.error);
  check(/9000 × 16 pixels.*at most \d+ a side/.test(error), `WebGPU: a canvas too wide is refused in words (${error})`);
  check(errors.length === 0, `WebGPU: no console error or panic with a canvas too wide (${errors.join(' | ')})`);
  await page.close();
}

// `auto` (the page's default) takes WebGPU where the browser offers it, as this one does.
{
  const { page, errors } = await open('auto', 'hard');
  const backend = await page.evaluate(() => window.shadowlab.app && window.shadowlab.app.backend());
  check(backend === 'WebGPU', `auto: WebGPU where the browser has it (${backend})`);
  check(errors.length === 0, `auto: no console error or panic (${errors.length})`);
  await page.close();
}

// WebGL2: no compute shaders; the techniques with a fragment path run, the others are greyed out.
{
  const { page, errors } = await open('webgl2', 'hard');
  const error = await page.evaluate(() => window.shadowlab.error);
  check(!error, `WebGL2: the page started${error ? ': ' + error : ''}`);
  if (!error) {
    const { hard } = await shadows('webgl2', page);
    if (webgpuHard) {
      // The same shader on both paths: measured 0 of 76 800 pixels differing by more than 8
      // levels between WebGPU's compute resolve and WebGL2's fragment resolve; bound 1% for
      // another browser's rounding.
      const d = changed(webgpuHard, hard);
      check(d < 768, `WebGL2: hard matches WebGPU's (${d} pixels differ)`);
    }
    const state = await page.evaluate(() => ({
      note: document.getElementById('note').textContent,
      options: [...document.querySelectorAll('#techniques option')].map(o => [o.value, o.disabled, o.title]),
    }));
    check(state.note.includes('WebGL2'), 'WebGL2: the page says what it cannot run');
    const fragment = ['none', 'hard', 'pcf', 'pcss', 'cascaded'];
    const wrong = state.options.filter(([id, disabled, title]) =>
      fragment.includes(id) ? disabled : !(disabled && title.includes('compute shaders')));
    check(wrong.length === 0, `WebGL2: exactly the techniques without a fragment path are greyed out, with the reason (${wrong.map(w => w[0]).join(', ') || 'none wrong'})`);
  }
  check(errors.length === 0, `WebGL2: no console error or panic (${errors.length})`);
  await page.close();
}

await browser.close();
server.close();
console.log(failures.length ? `${failures.length} check(s) failed` : `all checks passed (${version})`);
process.exit(failures.length ? 1 : 0);
