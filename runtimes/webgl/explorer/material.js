// The material shown: a per-material export's descriptor, or the general tables at the sliders' parameters.
import { material, ui } from './page.js';
import { VIS } from './colour.js';

// With the general export (material.general) the material is the sliders' parameters; the export's domain covers
// 0.36-0.83 um, so every visible wavelength.
export const isGeneral = (m = material) => m.general === true;
export const range = () => (isGeneral() ? VIS : material.descriptor.wavelength_range || VIS);   // null without diffraction
export const clampLambda = (l) => Math.min(Math.max(l, range()[0]), range()[1]);
export const layered = () => !isGeneral() && ['plastic', 'subsurface'].includes(material.descriptor.material.model || 'conductor');

// The general export's parameters: slider ranges (a log slider moves in ln x) and initial values. p from 0.2,
// the diffraction tables' bound (below it the EPD alone is defined); sigma_s to 0.3 um, where diffraction takes
// most of the light at any b.
export const PARAMS = {
  beta: { lo: 0.005, hi: 0.5, log: true, init: 0.08, label: 'β' },
  p: { lo: 0.2, hi: 5, log: true, init: 1.2, label: 'p' },
  sigma_s: { lo: 0, hi: 0.3, log: false, init: 0.02, label: 'σ<sub>s</sub> (µm)' },
  b: { lo: 0.083, hi: 36, log: true, init: 1.5, label: 'b (µm)' },
  c: { lo: 1.02, hi: 3.02, log: false, init: 2.2, label: 'c' },
};
export const toSlider = (k, v) => (PARAMS[k].log ? Math.log(v) : v);
export const fromSlider = (k, x) => { const v = PARAMS[k].log ? Math.exp(x) : x; return Math.min(Math.max(v, PARAMS[k].lo), PARAMS[k].hi); };
// The material's numbers: the sliders' (general) or the descriptor's.
export const matParams = () => (isGeneral() ? Object.fromEntries(Object.keys(PARAMS).map((k) => [k, ui[k]])) : material.descriptor.material);

export function describe(d) {
  if (isGeneral()) {
    const f = (v) => +v.toPrecision(3);
    return [`<b>general tables</b> (${esc(d.preset)})`, `β ${f(ui.beta)}`, `p ${f(ui.p)}`, ui.sigma_s > 0 ? `σ<sub>s</sub> ${f(ui.sigma_s)} µm · b ${f(ui.b)} µm · c ${f(ui.c)}` : 'no diffraction',
      `${esc(d.generator?.name || '')} ${esc(d.generator?.version || '')}`].join(' · ');
  }
  const m = d.material, f = (v) => (typeof v === 'number' ? +v.toPrecision(4) : esc(v)); // a descriptor's text is never markup
  const spec = (v) => (v && typeof v === 'object' ? `${Math.min(...v.values)}–${Math.max(...v.values)} over ${v.wavelengths[0]}–${v.wavelengths[v.wavelengths.length - 1]} µm` : f(v));
  const parts = [`<b>${esc(m.name)}</b>`, esc(m.model || 'conductor'), `β ${f(m.beta)}`, `p ${f(m.p)}`];
  if (m.sigma_s) parts.push(`σ<sub>s</sub> ${f(m.sigma_s)} µm`, `b ${f(m.b)} µm`, `c ${f(m.c)}`);
  else parts.push('no diffraction');
  if (m.ior != null) parts.push(`ior ${f(m.ior)}`);
  if (m.diffuse != null) parts.push(`diffuse ${esc(spec(m.diffuse))}`);
  if (m.albedo != null) parts.push(`albedo ${esc(spec(m.albedo))}`);
  if (m.g != null) parts.push(`g ${f(m.g)}`);
  if (d.wavelength_range) parts.push(`λ ${f(d.wavelength_range[0])}–${f(d.wavelength_range[1])} µm`);
  parts.push(esc(d.preset || ''), `${esc(d.generator?.name || '')} ${esc(d.generator?.version || '')}`);
  return parts.filter((s) => s.trim()).join(' · ');
}
function esc(s) { return String(s).replace(/[&<>"]/g, (c) => ({ '&': '&amp;', '<': '&lt;', '>': '&gt;', '"': '&quot;' })[c]); }

// evalPoints' options from the controls (a layered model takes its interface's Fresnel and ignores this).
export function brdfOptions(energy = ui.energy) {
  const o = { lobe: ui.lobe, energy, fresnel: ui.fresnel === 'conductor' ? { eta: ui.eta, k: ui.kappa } : 'one' };
  return isGeneral() ? { ...o, material: matParams() } : o;
}
