// The controls: their values into ui, the query string that reproduces the view, and what each change redraws.
import { $, query, status, ui, material, showError, maybeReady } from './page.js';
import { isGeneral, clampLambda, layered, PARAMS, toSlider, fromSlider, describe } from './material.js';
import { MAPS, proceduralMap, setMap } from './map.js';
import { restartSphere, displaySphere } from './sphere.js';
import { drawPolar } from './polar.js';
import { drawSlice } from './slice.js';
import { drawAlbedo } from './albedo.js';

export function readControls() {
  const radio = (name) => document.querySelector(`input[name=${name}]:checked`).value;
  Object.assign(ui, {
    theta: +$('theta').value, lambda: +$('lambda').value, lobe: radio('lobe'), energy: radio('energy'),
    fresnel: layered() ? 'one' : radio('fresnel'), eta: +$('eta').value || 1, kappa: +$('kappa').value || 0,
    light: radio('light'), exposure: +$('exposure').value, sliceAxis: radio('slice-axis'),
  });
  $('theta-out').textContent = `${ui.theta}°`;
  $('lambda-out').textContent = `${(1000 * clampLambda(ui.lambda)).toFixed(0)} nm`;
  $('exposure-out').textContent = `${ui.exposure >= 0 ? '+' : ''}${ui.exposure} EV`;
  $('eta-out').textContent = ui.eta.toFixed(2);
  $('kappa-out').textContent = ui.kappa.toFixed(2);
  if (!isGeneral()) return;
  for (const k of Object.keys(PARAMS)) {
    ui[k] = fromSlider(k, +$(k).value);
    $(`${k}-out`).textContent = `${+ui[k].toPrecision(3)}`;
  }
  ui.map = radio('map');
  $('status').innerHTML = describe(material.descriptor);
  showUrl();
}

// The query string that reproduces the view, shown on the page at once and put in the address bar 300 ms after
// the last change (browsers limit history.replaceState to about 100 calls in 30 s: a dragged slider makes more).
let urlTimer = 0;
function showUrl() {
  const q = new URLSearchParams({ tables: query.get('tables') });
  for (const k of Object.keys(PARAMS)) q.set(k, +ui[k].toPrecision(4));
  for (const k of ['theta', 'lambda', 'exposure']) q.set(k, ui[k]);
  if (ui.fresnel === 'conductor') Object.entries({ fresnel: 'conductor', eta: ui.eta, kappa: ui.kappa }).forEach(([k, v]) => q.set(k, v));
  Object.entries({ lobe: ui.lobe, energy: ui.energy, light: ui.light, 'slice-axis': ui.sliceAxis, map: ui.map }).forEach(([k, v]) => q.set(k, v));
  const text = `?${q.toString().replaceAll('%2F', '/')}`;
  $('url').textContent = text;
  $('url').href = text;
  clearTimeout(urlTimer);
  urlTimer = setTimeout(() => {
    try {
      history.replaceState(null, '', text);
    } catch { /* over the browser's rate limit: the link on the page still holds it */ }
  }, 300);
}

// The general tables' controls: a slider for each parameter (a log slider moves in ln x), and the map's.
export function materialControls() {
  const box = $('material-controls');
  box.hidden = false;
  box.insertAdjacentHTML('beforeend', Object.entries(PARAMS).map(([k, d]) => {
    const lo = toSlider(k, d.lo), hi = toSlider(k, d.hi), v = query.has(k) ? +query.get(k) : d.init;
    return `<div class="ctl"><label><span>${d.label}</span><output id="${k}-out"></output></label>`
      + `<input id="${k}" type="range" min="${lo}" max="${hi}" step="any" value="${toSlider(k, Math.min(Math.max(v, d.lo), d.hi))}"></div>`;
  }).join(''));
  const m = query.get('map');
  if (MAPS.includes(m)) document.querySelector(`input[name=map][value=${m}]`).checked = true;
  setMap(proceduralMap());
  const sph = $('sphere');
  sph.addEventListener('dragover', (e) => e.preventDefault());
  sph.addEventListener('drop', (e) => {
    e.preventDefault();
    const f = e.dataTransfer?.files?.[0];
    if (f) dropMap(f).catch(showError);
  });
}

// Plots are redrawn 150 ms after the last change (evalPoints is asynchronous). A change makes its plots dirty
// and starts a generation: a draw of an older one discards its result, and its run stops, leaving the plots
// it has not drawn dirty for the newer run.
let generation = 0, timer = 0;
const dirty = new Set();
export function schedulePlots(which) {
  which.forEach((k) => dirty.add(k));
  const gen = ++generation, stale = () => gen !== generation;
  clearTimeout(timer);
  timer = setTimeout(async () => {
    try {
      for (const [k, draw] of [['polar', drawPolar], ['slice', drawSlice], ['albedo', drawAlbedo]]) {
        if (!dirty.has(k)) continue;
        const t0 = performance.now();
        await draw(stale);
        if (stale()) return;
        dirty.delete(k);
        status.ms[k] = Math.round(performance.now() - t0);   // ms (virtual ones under --virtual-time-budget)
      }
      maybeReady();
    } catch (e) { showError(e); }
  }, 150);
}

export function onControl(e) {
  readControls();
  const id = e.target.id || e.target.name;
  if (id === 'map') { restartSphere(); return; }   // the map is the sphere's only
  if (id === 'exposure') { displaySphere(); return; }
  if (id === 'light') { restartSphere(); return; }
  if (id === 'slice-axis') { schedulePlots(['slice']); return; }
  if (id === 'theta') { restartSphere(); schedulePlots(['polar']); return; }
  if (id === 'lambda') { schedulePlots(['slice', 'albedo']); return; }
  restartSphere();
  schedulePlots(['polar', 'slice', 'albedo']);
}

// An image dropped on the sphere becomes the map: its luminance, rows flipped to latitude order.
async function dropMap(file) {
  const img = await createImageBitmap(file);
  const c = new OffscreenCanvas(img.width, img.height), g = c.getContext('2d', { willReadFrequently: true });
  g.drawImage(img, 0, 0);
  const d = g.getImageData(0, 0, img.width, img.height).data, px = new Uint8Array(img.width * img.height);
  for (let y = 0; y < img.height; y++) for (let x = 0; x < img.width; x++) {
    const i = 4 * ((img.height - 1 - y) * img.width + x);
    px[y * img.width + x] = Math.round(0.2126 * d[i] + 0.7152 * d[i + 1] + 0.0722 * d[i + 2]);
  }
  setMap(px, [img.width, img.height]);
  $('map-note').textContent = `map: ${file.name} (${img.width} × ${img.height})`;
  if (ui.map === 'none') document.querySelector('input[name=map][value=beta]').click();
  else restartSphere();
}
