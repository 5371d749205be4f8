// The page around shadowlab-web (pkg/: what web/build.sh builds with wasm-bindgen).
// Query: ?backend=webgpu|webgl2|auto (default auto), &scene=NAME, &technique=SPEC.
// `window.shadowlab` exposes the state to tests: { app, frames, error, ready }.
import init, { App, scenes, techniques } from './pkg/shadowlab_web.js';

const query = new URLSearchParams(location.search);
const $ = id => document.getElementById(id);
const state = (window.shadowlab = { app: null, frames: 0, error: '', ready: false, technique: '' });

function fail(message) {
  state.error = message;
  $('error').textContent = message;
}

function status() {
  const app = state.app;
  if (!app) return;
  $('status').textContent =
    `${app.backend()} on ${app.adapter()}\nscene ${app.scene() || '-'}, technique ${app.technique()}\nframes ${app.frames()}`;
}

async function main() {
  await init();
  const canvas = $('scene');
  const backend = query.get('backend') || 'auto';
  const scene = query.get('scene') || 'room';
  const technique = query.get('technique') || 'pcss';
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
    try { app.load_builtin(sceneList.value); $('error').textContent = ''; } catch (e) { fail(e.message); }
  };
  techList.onchange = () => {
    try {
      const fellBack = app.set_technique(techList.value);
      state.technique = techList.value;
      $('error').textContent = fellBack ? `hard on ${fellBack.split('\n').join(', ')} (not taken by ${techList.value})` : '';
    } catch (e) { fail(e.message); }
  };
  const loadFile = async file => {
    try {
      const warnings = app.load_file(file.name, new Uint8Array(await file.arrayBuffer()));
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
  const loop = () => {
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
