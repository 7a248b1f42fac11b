// The BRDF explorer (index.html): a lit sphere, a polar plot, the (theta_h, theta_d) slice and the directional
// albedo of one twoscale-webgl export, after Disney's BRDF Explorer. Every BRDF value comes from twoscale.js:
// the sphere's fragment shader calls ts_eval / ts_sample (twoscale_brdf.glsl), the plots batch their points
// through evalPoints. Query string: ?material=URL (default material/material.json, what `twoscale view`
// serves) or ?tables=URL (the general export: every parameter a slider, and a parameter map on the sphere),
// &spp=N (sky directions a pixel before the sphere stops refining, default 128), &bench=1 [&n=20&size=256]
// (the sphere pass against a GGX pass, timed; with tables, also against the per-material pass of &material=;
// nothing else is drawn), and the controls' initial values (&theta=, &lambda=, &exposure=, &eta=, &kappa=,
// &lobe=, &energy=, &fresnel=, &light=, &slice-axis=; with tables &beta=, &p=, &sigma_s=, &b=, &c=, &map=).
//
// The page's parts are the modules of explorer/ (page state, colour, material, sphere, plots, controls, bench).
import { loadMaterial, loadTables, shaderSource } from './twoscale.js';
import { $, query, status, material, setMaterial, writeStatus, showError } from './explorer/page.js';
import { VIS } from './explorer/colour.js';
import { range, clampLambda, layered, describe } from './explorer/material.js';
import { readControls, materialControls, schedulePlots, onControl } from './explorer/controls.js';
import { initSphere, resizeSphere } from './explorer/sphere.js';
import { bench } from './explorer/bench.js';

async function main() {
  const general = query.has('tables');
  const url = general ? query.get('tables') : query.get('material') || 'material/material.json';
  const t0 = performance.now();
  try {
    setMaterial(general ? await loadTables(url) : await loadMaterial(url));
    status.ms.load = Math.round(performance.now() - t0);
  } catch (e) {
    $('status').textContent = `could not load ${url}`;
    status.failed = true;
    showError(e);
    return;
  }
  const d = material.descriptor;
  if (general) materialControls();
  readControls();
  $('status').innerHTML = describe(d);
  document.title = `${general ? 'general tables' : d.material.name} · twoscale BRDF explorer`;
  // the wavelength slider spans the visible range within the material's
  const lam = $('lambda');
  lam.min = Math.max(VIS[0], range()[0]);
  lam.max = Math.min(VIS[1], range()[1]);
  lam.value = clampLambda(0.55);
  if (!general && !(material.energies || ['single', 'compensated']).includes('compensated')) {   // an export without the albedo table
    const c = document.querySelector('input[name=energy][value=compensated]');
    c.disabled = true;
    c.checked = false;
    document.querySelector('input[name=energy][value=single]').checked = true;
  }
  if (layered()) {
    for (const el of document.querySelectorAll('input[name=fresnel], #eta, #kappa')) el.disabled = true;
    $('fresnel-note').textContent = `${d.material.model}: the interface's Fresnel factor (ior ${d.material.ior}); this choice is ignored`;
  }
  // initial control values from the query string (theta, lambda, exposure, eta, kappa; lobe, energy, fresnel, light)
  for (const id of ['theta', 'lambda', 'exposure', 'eta', 'kappa']) if (query.has(id)) $(id).value = query.get(id);
  for (const name of ['lobe', 'energy', 'fresnel', 'light', 'slice-axis']) {
    const el = query.has(name) && document.querySelector(`input[name=${name}][value="${CSS.escape(query.get(name))}"]`);
    if (el && !el.disabled) el.checked = true;
  }
  readControls();
  const src = await shaderSource();
  if (query.get('bench')) {
    status.bench = await bench(src);
    status.ready = true;
    document.body.dataset.ready = '1';
    writeStatus();
    return;
  }
  for (const el of document.querySelectorAll('aside input')) el.addEventListener('input', onControl);
  initSphere(src);
  window.addEventListener('resize', () => { resizeSphere(); schedulePlots(['polar', 'slice', 'albedo']); });
  schedulePlots(['polar', 'slice', 'albedo']);
}

main().catch(showError);
