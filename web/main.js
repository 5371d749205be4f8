// The page around shadowlab-web (pkg/: what web/build.sh builds with wasm-bindgen).
// Query: ?backend=webgpu|webgl2|auto (default auto), &scene=NAME, &technique=SPEC, &size=WxH (the
// canvas's pixels; default 320x240).
// `window.shadowlab` exposes the state to tests: { app, frames, error, ready }.
import init, { App, scenes, techniques } from './pkg/shadowlab_web.js';

const query = new URLSearchParams(location.search);
const $ = id => document.getElementById(id);
const state = (window.shadowlab = { app: null, frames: 0, error: '', ready: false, technique: '' });

function fail(message) {
  state.error = message;
  $('error').textContent = message;
}

// Milliseconds between the last frames (requestAnimationFrame's own clock), a running median.
const frameTimes = [];

function status() {
  const app = state.app;
  if (!app) return;
  const sorted = [...frameTimes].sort((a, b) => a - b);
  const ms = sorted.length ? sorted[sorted.length >> 1].toFixed(1) : '-';
  $('status').textContent =
    `${app.backend()} on ${app.adapter()}\nscene ${app.scene() || '-'}, technique ${app.technique()}\n` +
    `frames ${app.frames()}, ${ms} ms a frame (median of the last ${sorted.length})`;
}

// The scene's views and lights, after a scene is shown.
function describeScene(app) {
  const views = $('views');
  views.replaceChildren(...app.views().map(v => new Option(v, v)));
  $('lights').textContent = 'Lights:\n' + app.lights();
}

async function main() {
  await init();
  const canvas = $('scene');
  const backend = query.get('backend') || 'auto';
  const scene = query.get('scene') || 'room';
  const technique = query.get('technique') || 'pcss';
  const size = /^(\d+)x(\d+)$/.exec(query.get('size') || '');
  if (size) [canvas.width, canvas.height] = [Number(size[1]), Number(size[2])];
  let app;
  try {
    app = await App.start(canvas, backend, scene, technique);
  } catch (e) {
    fail(`cannot start: ${e.message || e}`);
    return;
  }
  state.app = app;
  state.technique = technique;
  $('note').textContent = app.note();

  describeScene(app);
  $('views').onchange = () => {
    try { app.set_view($('views').value); } catch (e) { fail(e.message); }
  };
  const sceneList = $('scenes');
  for (const name of scenes()) sceneList.add(new Option(name, name, false, name === scene));
  const techList = $('techniques');
  for (const t of JSON.parse(techniques())) {
    const option = new Option(t.id, t.id, false, t.id === technique);
    // Greyed out, with the reason, where the adapter cannot run it.
    const available = app.compute() || t.fragment;
    option.title = t.summary + (available ? '' : ' (not available here: it needs compute shaders, which WebGL2 lacks)');
    option.disabled = !available;
    techList.add(option);
  }

  sceneList.onchange = () => {
    try { app.load_builtin(sceneList.value); describeScene(app); $('error').textContent = ''; } catch (e) { fail(e.message); }
  };
  const applySpec = spec => {
    try {
      const fellBack = app.set_technique(spec);
      state.technique = spec;
      $('error').textContent = fellBack ? `hard on ${fellBack.split('\n').join(', ')} (not taken by ${spec})` : '';
    } catch (e) { fail(e.message); }
  };
  techList.onchange = () => applySpec(techList.value);
  $('spec').onkeydown = e => { if (e.key === 'Enter') applySpec($('spec').value.trim()); };
  const loadFile = async file => {
    try {
      const warnings = app.load_file(file.name, new Uint8Array(await file.arrayBuffer()));
      describeScene(app);
      $('error').textContent = warnings;
    } catch (e) { fail(e.message); }
  };
  $('file').onchange = e => e.target.files[0] && loadFile(e.target.files[0]);
  const drop = $('drop');
  drop.ondragover = e => { e.preventDefault(); drop.classList.add('over'); };
  drop.ondragleave = () => drop.classList.remove('over');
  drop.ondrop = e => {
    e.preventDefault();
    drop.classList.remove('over');
    if (e.dataTransfer.files[0]) loadFile(e.dataTransfer.files[0]);
  };

  let dragging = null;
  canvas.onpointerdown = e => { dragging = [e.clientX, e.clientY]; canvas.setPointerCapture(e.pointerId); };
  canvas.onpointerup = () => { dragging = null; };
  canvas.onpointermove = e => {
    if (!dragging) return;
    app.orbit((e.clientX - dragging[0]) * 0.01, (e.clientY - dragging[1]) * 0.01);
    dragging = [e.clientX, e.clientY];
  };
  canvas.onwheel = e => { e.preventDefault(); app.zoom(e.deltaY > 0 ? 1.1 : 0.9); };

  state.ready = true;
  let last = null;
  const loop = now => {
    if (last !== null) {
      frameTimes.push(now - last);
      if (frameTimes.length > 30) frameTimes.shift();
    }
    last = now;
    try {
      app.frame();
      state.frames = app.frames();
    } catch (e) {
      fail(`frame: ${e.message || e}`);
      console.error(e);
      return;
    }
    status();
    requestAnimationFrame(loop);
  };
  status();
  requestAnimationFrame(loop);
}

main().catch(e => { fail(String(e)); console.error(e); });
