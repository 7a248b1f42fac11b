// The BRDF explorer (index.html): a lit sphere, a polar plot, the (theta_h, theta_d) slice and the directional
// albedo of one twoscale-webgl export, after Disney's BRDF Explorer. Every BRDF value comes from twoscale.js:
// the sphere's fragment shader calls ts_eval / ts_sample (twoscale_brdf.glsl), the plots batch their points
// through evalPoints. Query string: ?material=URL (default material/material.json, what `twoscale view`
// serves) or ?tables=URL (the general export: every parameter a slider, and a parameter map on the sphere),
// &spp=N (sky directions a pixel before the sphere stops refining, default 128), &bench=1 [&n=20&size=256]
// (the sphere pass against a GGX pass, timed; with tables, also against the per-material pass of &material=;
// nothing else is drawn), and the controls' initial values (&theta=, &lambda=, &exposure=, &eta=, &kappa=,
// &lobe=, &energy=, &fresnel=, &light=, &slice-axis=; with tables &beta=, &p=, &sigma_s=, &b=, &c=, &map=).
import {
  loadMaterial, loadTables, evalPoints, shaderSource, fragmentShader, shaderModes, generalModes, fresnelAverage, compileProgram,
  uploadMaterial, uploadTables, bindMaterial, bindTables, bakeTables, bindBake,
} from './twoscale.js';

const $ = (id) => document.getElementById(id);
const query = new URLSearchParams(location.search);
const DEG = Math.PI / 180;
const VIS = [0.38, 0.78];     // the visible range the sphere integrates over (micrometres)
const NL = 12;                // wavelengths of the point-light pass (bins of 33 nm)
const POLAR_LAMBDAS = [0.45, 0.55, 0.65];
const DECADES = 6;            // of the polar plot's log scale
const SLICE_N = 128;
const SLICE_DECADES = 7;      // of the slice's
const ALBEDO_THETAS = Array.from({ length: 24 }, (_, i) => (88 * i) / 23);

// ---------------------------------------------------------------------------------------------- page state
const pageStart = performance.now();
const status = { ready: false, errors: [], drawn: {}, ms: {} };
let material = null;
const ui = {};   // the controls' current values (readControls)

function writeStatus() { $('status-json').textContent = JSON.stringify(status); }

// One line of error on the page; the first error stays (the page stops drawing on a failed load).
function showError(err) {
  const msg = String((err && err.message) || err || 'unknown error').split('\n')[0];
  status.errors.push(msg);
  const el = $('error');
  if (!el.classList.contains('shown')) { el.textContent = msg; el.title = msg; el.classList.add('shown'); }
  writeStatus();
}
window.addEventListener('error', (e) => showError(e.error || e.message));
window.addEventListener('unhandledrejection', (e) => showError(e.reason));

// -------------------------------------------------------------------------------------------------- colour
// CIE 1931 colour matching functions, the multi-lobe Gaussian fit of Wyman, Sloan & Shirley (JCGT 2013),
// lambda in nm; then XYZ to linear sRGB (D65 primaries).
function cmf(nm) {
  const g = (mu, s1, s2) => { const t = (nm - mu) / (nm < mu ? s1 : s2); return Math.exp(-0.5 * t * t); };
  return [1.056 * g(599.8, 37.9, 31.0) + 0.362 * g(442.0, 16.0, 26.7) - 0.065 * g(501.1, 20.4, 26.2),
    0.821 * g(568.8, 46.9, 40.5) + 0.286 * g(530.9, 16.3, 31.1),
    1.217 * g(437.0, 11.8, 36.0) + 0.681 * g(459.0, 26.0, 13.8)];
}
const XYZ_TO_RGB = [[3.2406, -1.5372, -0.4986], [-0.9689, 1.8758, 0.0415], [0.0557, -0.2040, 1.0570]];
const rgbOf = (nm) => { const c = cmf(nm); return XYZ_TO_RGB.map((r) => r[0] * c[0] + r[1] * c[1] + r[2] * c[2]); };

// The point-light pass' wavelengths (bin centres over VIS) and their sRGB weights, white-balanced per channel
// so that a flat spectrum (equal-energy illuminant, white surface) is neutral grey 1.
function spectralWeights() {
  const lams = Array.from({ length: NL }, (_, i) => VIS[0] + ((i + 0.5) * (VIS[1] - VIS[0])) / NL);
  const w = lams.map((l) => rgbOf(1000 * l));
  const sum = [0, 1, 2].map((c) => w.reduce((s, x) => s + x[c], 0));
  return { lams, weights: w.map((x) => x.map((v, c) => v / sum[c])) };
}
// The same white balance for the continuous CMFs the environment pass samples: 1 / integral over VIS.
function continuousNorm() {
  const n = 800, h = (VIS[1] - VIS[0]) / n, s = [0, 0, 0];
  for (let i = 0; i < n; i++) rgbOf(1000 * (VIS[0] + (i + 0.5) * h)).forEach((v, c) => { s[c] += v * h; });
  return s.map((v) => 1 / v);
}
const SPECTRAL = spectralWeights(), CNORM = continuousNorm();
// A display colour for a wavelength (the legend's): its sRGB chromaticity at full brightness.
function lambdaCss(l) {
  const c = rgbOf(1000 * l).map((v) => Math.max(v, 0)), m = Math.max(...c);
  return `rgb(${c.map((v) => Math.round(255 * Math.pow(v / m, 1 / 2.2))).join(',')})`;
}

// ------------------------------------------------------------------------------------------------ material
// With the general export (material.general) the material is the sliders' parameters; the export's domain covers
// 0.36-0.83 um, so every visible wavelength.
const isGeneral = (m = material) => m.general === true;
const range = () => (isGeneral() ? VIS : material.descriptor.wavelength_range || VIS);   // null without diffraction
const clampLambda = (l) => Math.min(Math.max(l, range()[0]), range()[1]);
const layered = () => !isGeneral() && ['plastic', 'subsurface'].includes(material.descriptor.material.model || 'conductor');

// The general export's parameters: slider ranges (a log slider moves in ln x) and initial values. p from 0.2,
// the diffraction tables' bound (below it the EPD alone is defined); sigma_s to 0.3 um, where diffraction takes
// most of the light at any b.
const PARAMS = {
  beta: { lo: 0.005, hi: 0.5, log: true, init: 0.08, label: 'β' },
  p: { lo: 0.2, hi: 5, log: true, init: 1.2, label: 'p' },
  sigma_s: { lo: 0, hi: 0.3, log: false, init: 0.02, label: 'σ<sub>s</sub> (µm)' },
  b: { lo: 0.083, hi: 36, log: true, init: 1.5, label: 'b (µm)' },
  c: { lo: 1.02, hi: 3.02, log: false, init: 2.2, label: 'c' },
};
const toSlider = (k, v) => (PARAMS[k].log ? Math.log(v) : v);
const fromSlider = (k, x) => { const v = PARAMS[k].log ? Math.exp(x) : x; return Math.min(Math.max(v, PARAMS[k].lo), PARAMS[k].hi); };
// The material's numbers: the sliders' (general) or the descriptor's.
const matParams = () => (isGeneral() ? Object.fromEntries(Object.keys(PARAMS).map((k) => [k, ui[k]])) : material.descriptor.material);

function describe(d) {
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
function brdfOptions(energy = ui.energy) {
  const o = { lobe: ui.lobe, energy, fresnel: ui.fresnel === 'conductor' ? { eta: ui.eta, k: ui.kappa } : 'one' };
  return isGeneral() ? { ...o, material: matParams() } : o;
}

// --------------------------------------------------------------------------------------------- sphere GLSL
// The sphere under a point light (NL wavelengths, deterministic) and, with ACCUMULATE, either that light
// alone into a float texture (u_env 0) or the environment estimated by ts_sample (hero wavelengths over
// VIS), averaged over frames into a float texture. Without ACCUMULATE, the point light tone-mapped to the
// screen: the bench's pass, where BRDF_GGX swaps ts_eval for a GGX conductor (its baseline): the spectral
// loop, the light and the tone mapping are the same code.
const SPHERE_GLSL = `
uniform vec2 u_res;
uniform vec3 u_light;          // world direction towards the point light (x right, y up, z to the camera)
uniform float u_lams[${NL}];
uniform vec3 u_wts[${NL}];     // sRGB weight of each wavelength (white-balanced)
uniform vec2 u_range;          // the material's wavelengths: lambda is clamped into them
// 0: F = 1, 1: conductor eta + i k; a constant (FRESNEL, defined per program), not a uniform: SwiftShader runs
// both sides of a uniform branch, and the kind decides ts_fresnel_eval's branch in every ts_eval call
const int u_fresnel = FRESNEL;
uniform float u_eta, u_k, u_alpha;
uniform float u_f_avg;         // the conductor's F_avg (fresnelAverage, in double on the CPU, once per draw)
uniform float u_exposure;
out vec4 o_color;

#if defined(TS_GENERAL) && !defined(BRDF_GGX)
// The general tables at the sliders' parameters, or per pixel with the map: beta = beta_slider 4^(2v - 1)
// (clamped to the domain) or sigma_s = sigma_s_slider 2v, v in [0, 1] the map at the sphere point's (longitude,
// latitude).
uniform float u_beta, u_p, u_sigma_s, u_b, u_c;
uniform int u_map;             // 0: none, 1: beta, 2: sigma_s
uniform sampler2D u_map_tex;   // R8, linear
TsParams g_params;
void set_params(vec3 n) {
  g_params = TsParams(u_beta, u_p, u_sigma_s, u_b, u_c);
  if (u_map == 0) return;
  float v = texture(u_map_tex, vec2(atan(n.x, n.z) / (2.0 * ts_pi) + 0.5, asin(clamp(n.y, -1.0, 1.0)) / ts_pi + 0.5)).r;
  if (u_map == 1) g_params.beta = clamp(u_beta * pow(4.0, 2.0 * v - 1.0), 0.005, 0.5);
  else g_params.sigma_s = u_sigma_s * 2.0 * v;
}
float brdf(vec3 wi, vec3 wo, float lam, TsFresnel F) { return ts_general_eval(wi, wo, lam, g_params, F, TS_G_EXACT, TS_G_COMP); }
vec3 brdf_sample(vec3 wi, float lam, vec2 xi, TsFresnel F, out float pdf, out float weight) {
  return ts_general_sample(wi, lam, xi, g_params, F, TS_G_EXACT, TS_G_COMP, pdf, weight);
}
#else
void set_params(vec3 n) {}
vec3 brdf_sample(vec3 wi, float lam, vec2 xi, TsFresnel F, out float pdf, out float weight) { return ts_sample(wi, lam, xi, F, pdf, weight); }
#endif

#ifdef BRDF_GGX
// GGX / Trowbridge-Reitz with the height-correlated Smith G2 and the exact unpolarised conductor Fresnel.
float fresnel_conductor(float c, float eta, float k) {
  float c2 = c * c, s2 = 1.0 - c2, a = eta * eta - k * k - s2;
  float t = sqrt(a * a + 4.0 * eta * eta * k * k), aa = sqrt(max(0.5 * (t + a), 0.0));
  float rs = (t + c2 - 2.0 * aa * c) / (t + c2 + 2.0 * aa * c);
  float rp = rs * (t * c2 + s2 * s2 - 2.0 * aa * c * s2) / (t * c2 + s2 * s2 + 2.0 * aa * c * s2);
  return 0.5 * (rs + rp);
}
float ggx_lambda(float c, float a2) { return 0.5 * (sqrt(1.0 + a2 * (1.0 - c * c) / (c * c)) - 1.0); }
float brdf(vec3 wi, vec3 wo, float lam, TsFresnel F) {
  if (wi.z <= 0.0 || wo.z <= 0.0) return 0.0;
  vec3 h = normalize(wi + wo);
  float a2 = u_alpha * u_alpha, d = h.z * h.z * (a2 - 1.0) + 1.0;
  float D = a2 / (${Math.PI} * d * d);
  float G = 1.0 / (1.0 + ggx_lambda(wi.z, a2) + ggx_lambda(wo.z, a2));
  float Fr = u_fresnel == 1 ? fresnel_conductor(clamp(dot(wi, h), 0.0, 1.0), u_eta, u_k) : 1.0;
  return Fr * D * G / (4.0 * wi.z * wo.z);
}
#elif !defined(TS_GENERAL)
float brdf(vec3 wi, vec3 wo, float lam, TsFresnel F) { return ts_eval(wi, wo, lam, F); }
#endif

// An orthonormal basis around n (Duff et al. 2017, branchless).
void basis(vec3 n, out vec3 t, out vec3 b) {
  float s = n.z >= 0.0 ? 1.0 : -1.0, a = -1.0 / (s + n.z), c = n.x * n.y * a;
  t = vec3(1.0 + s * n.x * n.x * a, s * c, -s * n.x);
  b = vec3(c, s + n.y * n.y * a, -n.y);
}

// Linear sRGB radiance of the sphere point under the point light (irradiance pi: a white Lambertian facing
// it shows 1). wi = the camera (z), as twoscale_brdf.glsl's convention: wi towards the viewer.
vec3 point_light(vec3 n, vec3 t, vec3 b, TsFresnel F) {
  vec3 L = normalize(u_light), v = vec3(0.0, 0.0, 1.0);
  vec3 wi = vec3(dot(v, t), dot(v, b), dot(v, n)), wo = vec3(dot(L, t), dot(L, b), dot(L, n));
  if (wo.z <= 0.0) return vec3(0.0);
  vec3 c = vec3(0.0);
#if defined(TS_GENERAL) && !defined(BRDF_GGX)
  if (wi.z <= 0.0) return c;
  TsGeneralGeom g = ts_general_geometry(wi, wo, g_params, TS_G_EXACT, TS_G_COMP);   // once for the wavelengths
  for (int k = 0; k < ${NL}; k++) c += ts_general_eval_at(g, clamp(u_lams[k], u_range.x, u_range.y), g_params, F, TS_G_EXACT, TS_G_COMP) * u_wts[k];
#else
  for (int k = 0; k < ${NL}; k++) c += brdf(wi, wo, clamp(u_lams[k], u_range.x, u_range.y), F) * u_wts[k];
#endif
  return c * (${Math.PI} * wo.z);
}

// The sphere fills 92 % of the shorter side; false outside it.
bool sphere_normal(out vec3 n) {
  vec2 p = (2.0 * gl_FragCoord.xy - u_res) / (0.92 * min(u_res.x, u_res.y));
  float r2 = dot(p, p);
  n = vec3(p, sqrt(max(1.0 - r2, 0.0)));
  return r2 < 1.0;
}
// F_avg from the CPU: ts_fresnel_conductor would spend 8 Fresnel evaluations a pixel on it.
TsFresnel fresnel() {
  if (u_fresnel == 1) return TsFresnel(1, u_eta, u_k, u_f_avg);
  return ts_fresnel_one();
}
vec3 srgb(vec3 c) {
  c = mix(c, 0.8 + 0.2 * (1.0 - exp(-5.0 * (c - 0.8))), step(0.8, c));   // as the display pass
  c = clamp(c, 0.0, 1.0);
  return mix(12.92 * c, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055, step(0.0031308, c));
}

#ifdef ACCUMULATE
uniform sampler2D u_prev;      // the running mean so far (linear sRGB, alpha 1 on the sphere)
uniform float u_count;         // frames in u_prev
uniform int u_frame, u_spp, u_env;
uniform vec3 u_cnorm;          // white balance of the continuous CMFs (1 / their integral over VIS)
uniform vec2 u_vis;

// The CMF fit, as cmf() in explorer.js, to linear sRGB.
float lobe(float x, float mu, float s1, float s2) { float t = (x - mu) / (x < mu ? s1 : s2); return exp(-0.5 * t * t); }
vec3 cmf_rgb(float nm) {
  vec3 xyz = vec3(1.056 * lobe(nm, 599.8, 37.9, 31.0) + 0.362 * lobe(nm, 442.0, 16.0, 26.7) - 0.065 * lobe(nm, 501.1, 20.4, 26.2),
                  0.821 * lobe(nm, 568.8, 46.9, 40.5) + 0.286 * lobe(nm, 530.9, 16.3, 31.1),
                  1.217 * lobe(nm, 437.0, 11.8, 36.0) + 0.681 * lobe(nm, 459.0, 26.0, 13.8));
  return mat3(3.2406, -0.9689, 0.0557, -1.5372, 1.8758, -0.2040, -0.4986, 0.0415, 1.0570) * xyz;
}
// The environment: a sky brightest at the horizon over a checkered floor (its edges show how a lobe blurs a
// reflection, and where a surface diffracts, its colour fringes). Spectral radiance at lam (um): the sky
// faintly blue (a lambda^-4 share), the floor warm grey. Smooth enough for BRDF sampling to converge in a
// few frames.
float environment(vec3 w, float lam) {
  if (w.y > 0.0) return (0.3 + 0.7 * pow(1.0 - w.y, 4.0)) * (0.8 + 0.2 * pow(0.55 / lam, 4.0));
  vec2 q = floor(vec2(w.x, w.z) / max(-w.y, 1e-4) * 1.5);   // the floor plane one unit below, squares of 2/3
  float tone = mod(q.x + q.y, 2.0) == 0.0 ? 0.16 : 0.03;
  return tone * (0.8 + 0.4 * (lam - 0.38) / 0.4) * smoothstep(0.0, 0.15, -w.y) + 0.04 * smoothstep(0.15, 0.0, -w.y);
}
// A hash to uniform numbers (PCG, Jarzynski & Olano 2020).
uint pcg(uint v) { uint s = v * 747796405u + 2891336453u; uint w = ((s >> ((s >> 28u) + 4u)) ^ s) * 277803737u; return (w >> 22u) ^ w; }
float rnd(inout uint s) { s = pcg(s); return float(s >> 8) * (1.0 / 16777216.0); }

// u_spp directions a pixel, each sampled by ts_sample at a hero wavelength and evaluated at HERO_K wavelengths
// (the hero and its rotations by 1/HERO_K of VIS: Wilkie et al. 2014's hero wavelength sampling), all
// weighted by the hero's pdf: the colour noise of one wavelength a direction is gone, and the weights stay
// bounded (the diffraction lobes of two wavelengths differ in width by at most their ratio).
#define HERO_K 4
vec3 sky_light(vec3 n, vec3 t, vec3 b, TsFresnel F) {
  vec3 wi = vec3(t.z, b.z, n.z);   // the camera (0, 0, 1) in the local frame
  uint s = pcg(uint(gl_FragCoord.x) + 4096u * uint(gl_FragCoord.y)) ^ pcg(uint(u_frame) * 9781u + 1u);
  vec3 c = vec3(0.0);
  float stratum = rnd(s), span = u_vis.y - u_vis.x;
  for (int j = 0; j < u_spp; j++) {
    float u = (float(j) + stratum) / float(u_spp);   // stratified over the frame's directions
    float lam = u_vis.x + span * u, pdf, weight;
    vec3 o = brdf_sample(wi, clamp(lam, u_range.x, u_range.y), vec2(rnd(s), rnd(s)), F, pdf, weight);
    if (pdf <= 0.0 || !(weight < 1e30)) continue;
    vec3 ow = o.x * t + o.y * b + o.z * n;
    c += environment(ow, lam) * weight * cmf_rgb(1000.0 * lam);
#if defined(TS_GENERAL) && !defined(BRDF_GGX)
    TsGeneralGeom g = ts_general_geometry(wi, o, g_params, TS_G_EXACT, TS_G_COMP);   // once for the other wavelengths
#endif
    for (int k = 1; k < HERO_K; k++) {
      float lk = u_vis.x + span * fract(u + float(k) / float(HERO_K));
#if defined(TS_GENERAL) && !defined(BRDF_GGX)
      float f = ts_general_eval_at(g, clamp(lk, u_range.x, u_range.y), g_params, F, TS_G_EXACT, TS_G_COMP) * o.z / pdf;
#else
      float f = brdf(wi, o, clamp(lk, u_range.x, u_range.y), F) * o.z / pdf;
#endif
      if (f < 1e30) c += environment(ow, lk) * f * cmf_rgb(1000.0 * lk);
    }
  }
  return c * u_cnorm * (span / float(u_spp * HERO_K));
}

void main() {
  vec3 n, t, b;
  if (!sphere_normal(n)) { o_color = vec4(0.0); return; }
  set_params(n);
  basis(n, t, b);
  TsFresnel F = fresnel();
  if (u_env == 0) { o_color = vec4(point_light(n, t, b, F), 1.0); return; }   // the point light, once
  vec3 c = sky_light(n, t, b, F);
  vec4 prev = texelFetch(u_prev, ivec2(gl_FragCoord.xy), 0);
  o_color = vec4(u_count > 0.0 ? mix(prev.rgb, c, 1.0 / (u_count + 1.0)) : c, 1.0);   // the running mean
}
#else
// The bench's pass: the point light straight to the screen (tone-mapped, 8 bits).
void main() {
  vec3 n, t, b;
  if (!sphere_normal(n)) { o_color = vec4(0.1, 0.1, 0.1, 1.0); return; }
  set_params(n);
  basis(n, t, b);
  o_color = vec4(srgb(point_light(n, t, b, fresnel()) * u_exposure), 1.0);
}
#endif
`;

// The display pass: the accumulated linear image, exposure, sRGB transfer; the panel's colour outside.
const DISPLAY_FS = `#version 300 es
precision highp float;
uniform sampler2D u_point, u_sky;   // the point light's image, the sky's running mean (linear sRGB)
uniform float u_exposure, u_use_sky;
out vec4 o_color;
void main() {
  vec4 c = texelFetch(u_point, ivec2(gl_FragCoord.xy), 0) + u_use_sky * texelFetch(u_sky, ivec2(gl_FragCoord.xy), 0);
  // exposure, then linear to 0.8 and a soft shoulder to 1 (a highlight keeps its gradient), then sRGB
  vec3 l = max(c.rgb * u_exposure, 0.0);
  l = clamp(mix(l, 0.8 + 0.2 * (1.0 - exp(-5.0 * (l - 0.8))), step(0.8, l)), 0.0, 1.0);
  vec3 s = mix(12.92 * l, 1.055 * pow(l, vec3(1.0 / 2.4)) - 0.055, step(0.0031308, l));
  o_color = vec4(mix(vec3(0.122, 0.133, 0.149), s, min(c.a, 1.0)), 1.0);
}`;
const EMPTY_FS = `#version 300 es
precision highp float;
out vec4 o_color;
void main() { o_color = vec4(0.5); }`;

// ------------------------------------------------------------------------------------------- parameter map
// The sphere's parameter map (general tables): none, beta or sigma_s, from values v in [0, 1] over (longitude,
// latitude): the procedural pattern below, or the luminance of an image the user drops on the sphere.
const MAPS = ['none', 'beta', 'sigma_s'];
const MAP_SIZE = 256;
let mapPixels = null;   // Uint8Array MAP_SIZE^2 (or the dropped image's size), row 0 at latitude -90 deg
let mapSize = [MAP_SIZE, MAP_SIZE];
const mapTextures = new WeakMap();   // gl -> [texture, pixels uploaded]

// A worn metal: 0.5 overall, a polished patch (0), three scratches (1) and a worn band (0.8) about the equator.
function proceduralMap() {
  const n = MAP_SIZE, px = new Uint8Array(n * n);
  for (let y = 0; y < n; y++) for (let x = 0; x < n; x++) {
    const u = x / n, v = y / n;
    let val = 0.5;
    if (Math.abs(v - 0.5) < 0.06) val = 0.8;
    if ((u - 0.55) ** 2 + ((v - 0.62) * 2) ** 2 < 0.012) val = 0;
    for (const [a, b, w] of [[0.35, 0.2, 0.004], [0.62, -0.3, 0.003], [0.48, 0.5, 0.002]]) {
      if (Math.abs(v - (b + (u - a) * 3 + 0.5)) < w * 8 && Math.abs(u - a) < 0.08) val = 1;
    }
    px[y * n + x] = Math.round(255 * val);
  }
  return px;
}

// The beta range of the sphere's pixels (the bake's): the map's beta_slider 4^(2v - 1) within the domain, or the slider's.
function betaRange(beta) {
  const [lo, hi] = material.domain.beta, clamp = (x) => Math.min(Math.max(x, lo), hi);
  return ui.map === 'beta' ? [clamp(beta / 4), clamp(4 * beta)] : [beta, beta];
}

// The map's R8 texture (LINEAR: 8-bit textures filter everywhere) on unit `unit`, uploaded when it changed.
function bindMaterialMap(gl, p, unit) {
  let entry = mapTextures.get(gl);
  if (!entry) mapTextures.set(gl, (entry = [gl.createTexture(), null]));
  gl.activeTexture(gl.TEXTURE0 + unit);
  gl.bindTexture(gl.TEXTURE_2D, entry[0]);
  if (entry[1] !== mapPixels) {
    gl.pixelStorei(gl.UNPACK_ALIGNMENT, 1);
    gl.texImage2D(gl.TEXTURE_2D, 0, gl.R8, mapSize[0], mapSize[1], 0, gl.RED, gl.UNSIGNED_BYTE, mapPixels);
    for (const k of [gl.TEXTURE_MIN_FILTER, gl.TEXTURE_MAG_FILTER]) gl.texParameteri(gl.TEXTURE_2D, k, gl.LINEAR);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_S, gl.REPEAT);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_T, gl.CLAMP_TO_EDGE);
    entry[1] = mapPixels;
  }
  const loc = gl.getUniformLocation(p, 'u_map_tex');
  if (loc) gl.uniform1i(loc, unit);
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
  mapPixels = px;
  mapSize = [img.width, img.height];
  $('map-note').textContent = `map: ${file.name} (${img.width} × ${img.height})`;
  if (ui.map === 'none') document.querySelector('input[name=map][value=beta]').click();
  else restartSphere();
}

// Programs and uniforms of the sphere on one WebGL2 context.
class SphereRenderer {
  constructor(gl, src, m = material) {   // m: a material or the general tables
    this.gl = gl;
    this.src = src;
    this.m = m;
    this.programs = {};
    if (isGeneral(m)) uploadTables(gl, m);
    else uploadMaterial(gl, m);
    this.vao = gl.createVertexArray();
  }
  // Each BRDF program is compiled for the material's model and the current lobe and energy (shaderModes: their
  // uniform branches would run both sides on SwiftShader), once per combination.
  program(kind) {   // 'accumulate', 'direct' (the bench's twoscale pass), 'ggx', 'display', 'empty'
    const brdf = kind === 'accumulate' || kind === 'direct' || kind === 'ggx';
    const modes = !brdf ? '' : isGeneral(this.m) ? generalModes(ui.lobe, ui.energy, kind !== 'ggx') : shaderModes(this.m, { lobe: ui.lobe, energy: ui.energy });
    const fresnelKind = ui.fresnel === 'conductor' ? 1 : 0;
    const key = `${kind}\n${modes}${fresnelKind}`;
    if (!this.programs[key]) {
      const defs = ({ accumulate: '#define ACCUMULATE\n', direct: '', ggx: '#define BRDF_GGX\n' }[kind] ?? '') + `#define FRESNEL ${fresnelKind}\n`;
      this.programs[key] = compileProgram(this.gl, kind === 'display' ? DISPLAY_FS : kind === 'empty' ? EMPTY_FS
        : fragmentShader(this.src, defs + SPHERE_GLSL, modes));
    }
    return this.programs[key];
  }
  // Binds the program, the material (texture units from 1: unit 0 is the accumulation's) and the uniforms.
  use(kind, res, extra = {}) {
    const gl = this.gl, p = this.program(kind), general = isGeneral(this.m), mp = general ? matParams() : this.m.descriptor.material;
    // The general sphere reads a bake at the sliders' c, p, b over the pixels' beta range (bakeTables: made again
    // only when they change), as the per-material pass reads its material's tables.
    if (general && (kind === 'accumulate' || kind === 'direct')) this.bake = bakeTables(gl, this.m, this.src, { ...mp, beta: betaRange(mp.beta), lobe: ui.lobe }, this.bake);
    gl.useProgram(p);
    if (kind === 'accumulate' || kind === 'direct' || kind === 'ggx') {
      if (general) {
        const unit = bindTables(gl, p, this.m, 1);
        bindMaterialMap(gl, p, kind === 'ggx' ? unit : bindBake(gl, p, this.bake, unit));
      } else bindMaterial(gl, p, this.m, { lobe: ui.lobe, energy: ui.energy }, 1);
      const sw = SPECTRAL, th = ui.theta * DEG, az = 35 * DEG;
      const set = {
        u_res: res, u_light: [Math.sin(th) * Math.cos(az), Math.sin(th) * Math.sin(az), Math.cos(th)],
        'u_lams[0]': sw.lams, 'u_wts[0]': sw.weights.flat(), u_range: range(),
        u_eta: ui.eta, u_k: ui.kappa, u_f_avg: fresnelAverage(ui.eta, ui.kappa), u_alpha: Math.max(mp.beta, 1e-3), u_exposure: 2 ** ui.exposure,
        u_vis: VIS, u_cnorm: CNORM, ...(general ? { u_beta: mp.beta, u_p: mp.p, u_sigma_s: mp.sigma_s, u_b: mp.b, u_c: mp.c, u_map: MAPS.indexOf(ui.map) } : {}),
        ...extra,
      };
      for (const [name, v] of Object.entries(set)) {
        const loc = gl.getUniformLocation(p, name);
        if (loc == null) continue;   // optimised out in this variant
        if (['u_frame', 'u_spp', 'u_env', 'u_prev', 'u_map'].includes(name)) gl.uniform1i(loc, v);
        else if (typeof v === 'number') gl.uniform1f(loc, v);
        else if (name === 'u_lams[0]') gl.uniform1fv(loc, v);
        else if (name === 'u_wts[0]' || name === 'u_light' || name === 'u_cnorm') gl.uniform3fv(loc, v);
        else gl.uniform2fv(loc, v);
      }
    }
    gl.bindVertexArray(this.vao);
    return p;
  }
  draw() { this.gl.drawArrays(this.gl.TRIANGLES, 0, 3); }
}

// The interactive sphere: the point light drawn once into a float texture, the sky's running mean in a
// ping-pong pair of them (each animation frame adds SPP_FRAME samples a pixel until spp are in, then the
// page idles); the display pass adds them, exposes and encodes.
const SPP_FRAME = 2;   // directions a pixel a frame (each at 4 wavelengths)
const sphere = { renderer: null, size: 0, point: null, targets: [], count: 0, frames: 0, raf: 0, float: false };

function initSphere(src) {
  const canvas = $('sphere');
  const gl = canvas.getContext('webgl2', { antialias: false, preserveDrawingBuffer: true, alpha: false });
  if (!gl) throw new Error('WebGL2 is not available: the sphere needs it');
  sphere.float = !!gl.getExtension('EXT_color_buffer_float');
  sphere.gl = gl;
  sphere.renderer = new SphereRenderer(gl, src);
  const dbg = gl.getExtension('WEBGL_debug_renderer_info'), renderer = gl.getParameter(dbg ? dbg.UNMASKED_RENDERER_WEBGL : gl.RENDERER);
  $('gpu-note').textContent = `WebGL2: ${renderer}` + (/swiftshader/i.test(renderer) ? ' (a CPU rasteriser: slow, but the same shader)' : '');
  resizeSphere();
}

function target(gl, size) {
  const tex = gl.createTexture();
  gl.bindTexture(gl.TEXTURE_2D, tex);
  // RGBA32F where it can be rendered to (EXT_color_buffer_float), else 8 bits (and no sky: see envOn)
  if (sphere.float) gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA32F, size, size, 0, gl.RGBA, gl.FLOAT, null);
  else gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA8, size, size, 0, gl.RGBA, gl.UNSIGNED_BYTE, null);
  gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.NEAREST);
  gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.NEAREST);
  const fb = gl.createFramebuffer();
  gl.bindFramebuffer(gl.FRAMEBUFFER, fb);
  gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0, gl.TEXTURE_2D, tex, 0);
  return { tex, fb };
}

function resizeSphere() {
  const canvas = $('sphere'), gl = sphere.gl, dpr = window.devicePixelRatio || 1;
  const size = Math.max(64, Math.round(Math.min(canvas.clientWidth, canvas.clientHeight) * dpr));
  if (size === sphere.size) return;
  sphere.size = size;
  canvas.width = canvas.height = size;
  for (const t of [sphere.point, ...sphere.targets].filter(Boolean)) { gl.deleteTexture(t.tex); gl.deleteFramebuffer(t.fb); }
  sphere.point = target(gl, size);
  sphere.targets = [target(gl, size), target(gl, size)];
  restartSphere();
}

function restartSphere() {
  sphere.count = 0;
  sphere.frames = 0;
  if (!sphere.raf) sphere.raf = requestAnimationFrame(sphereFrame);
}

const targetSpp = () => Math.max(1, +(query.get('spp') || 128));
const envOn = () => ui.light === 'env' && sphere.float;

// One frame: the point light if the view changed, else SPP_FRAME more sky samples; then the display.
function sphereFrame() {
  sphere.raf = 0;
  const gl = sphere.gl, r = sphere.renderer, size = sphere.size;
  let pass = null;
  if (sphere.frames === 0) {
    gl.bindFramebuffer(gl.FRAMEBUFFER, sphere.point.fb);
    gl.activeTexture(gl.TEXTURE0);
    gl.bindTexture(gl.TEXTURE_2D, null); // the display pass left sphere.point's texture there: a feedback loop, no draw
    r.use('accumulate', [size, size], { u_env: 0 });
    pass = 'point';
  } else if (envOn() && sphere.count * SPP_FRAME < targetSpp()) {
    const [src, dst] = sphere.targets;
    gl.bindFramebuffer(gl.FRAMEBUFFER, dst.fb);
    gl.activeTexture(gl.TEXTURE0);
    gl.bindTexture(gl.TEXTURE_2D, src.tex);
    r.use('accumulate', [size, size], { u_prev: 0, u_count: sphere.count, u_frame: sphere.frames, u_spp: SPP_FRAME, u_env: 1 });
    sphere.targets = [dst, src];
    sphere.count += 1;
    pass = 'sky';
  }
  if (pass) {
    gl.viewport(0, 0, size, size);
    r.draw();
    sphere.frames += 1;
  }
  displaySphere();
  const spp = sphere.count * SPP_FRAME;
  const r0 = range(), clamped = r0[0] > VIS[0] || r0[1] < VIS[1];
  $('sphere-sub').textContent = `${size}² px · ${envOn() ? `point + sky, ${spp} spp` : 'point light'} · ${NL} λ over ${VIS.map((l) => 1000 * l).join('–')} nm`
    + (clamped ? ` (ρ at λ clamped to ${r0.join('–')} µm)` : '');
  const more = envOn() && spp < targetSpp();   // the sky still refining: another frame
  if (!status.drawn.sphere) status.ms.sphere = Math.round(performance.now() - pageStart);   // to the first image
  if (!more || !status.drawn.sphere) {
    status.sphere = { ...sphereStats(), spp: envOn() ? spp : 0, done: !more };
    status.drawn.sphere = true;
    maybeReady();
  }
  if (more) sphere.raf = requestAnimationFrame(sphereFrame);
}

function displaySphere() {
  const gl = sphere.gl;
  gl.bindFramebuffer(gl.FRAMEBUFFER, null);
  gl.viewport(0, 0, sphere.size, sphere.size);
  const p = sphere.renderer.use('display');
  gl.activeTexture(gl.TEXTURE0);
  gl.bindTexture(gl.TEXTURE_2D, sphere.point.tex);
  gl.activeTexture(gl.TEXTURE1);
  gl.bindTexture(gl.TEXTURE_2D, sphere.targets[0].tex);
  gl.uniform1i(gl.getUniformLocation(p, 'u_point'), 0);
  gl.uniform1i(gl.getUniformLocation(p, 'u_sky'), 1);
  gl.uniform1f(gl.getUniformLocation(p, 'u_use_sky'), envOn() && sphere.count > 0 ? 1 : 0);
  gl.uniform1f(gl.getUniformLocation(p, 'u_exposure'), 2 ** ui.exposure);
  sphere.renderer.draw();
}

// What the tests check: on the sphere's disk, how many pixels differ from the background and how they vary.
function sphereStats() {
  const gl = sphere.gl, n = sphere.size, px = new Uint8Array(4 * n * n);
  gl.bindFramebuffer(gl.FRAMEBUFFER, null);
  gl.readPixels(0, 0, n, n, gl.RGBA, gl.UNSIGNED_BYTE, px);
  let disk = 0, lit = 0, sum = 0, sum2 = 0;
  const bg = [31, 34, 38];
  for (let y = 0; y < n; y++) for (let x = 0; x < n; x++) {
    const px2 = (2 * x + 1 - n) / (0.92 * n), py = (2 * y + 1 - n) / (0.92 * n);
    if (px2 * px2 + py * py >= 0.98) continue;
    const i = 4 * (y * n + x), v = (px[i] + px[i + 1] + px[i + 2]) / 3;
    disk += 1;
    if (Math.abs(px[i] - bg[0]) + Math.abs(px[i + 1] - bg[1]) + Math.abs(px[i + 2] - bg[2]) > 6) lit += 1;
    sum += v; sum2 += v * v;
  }
  const mean = sum / disk;
  return { pixels: disk, non_background: lit, mean: +mean.toFixed(2), std: +Math.sqrt(Math.max(sum2 / disk - mean * mean, 0)).toFixed(2) };
}

// ---------------------------------------------------------------------------------------------- 2-D plots
// A canvas sized to its box in device pixels; drawing in CSS pixels.
function canvas2d(id) {
  const c = $(id), dpr = window.devicePixelRatio || 1, w = c.clientWidth, h = c.clientHeight;
  c.width = Math.round(w * dpr);
  c.height = Math.round(h * dpr);
  const g = c.getContext('2d');
  g.setTransform(dpr, 0, 0, dpr, 0, 0);
  g.clearRect(0, 0, w, h);
  g.font = '11px system-ui, sans-serif';
  return { g, w, h };
}
const GRID = '#3a3f46', AXIS = '#8a9099', TEXT = '#b8bdc4';

// "10^k" with a raised exponent.
function decadeLabel(g, k, x, y, align = 'left') {
  const base = '10', exp = String(k).replace('-', '−');
  g.font = '11px system-ui, sans-serif';
  const wb = g.measureText(base).width;
  g.font = '8px system-ui, sans-serif';
  const we = g.measureText(exp).width;
  const x0 = align === 'right' ? x - wb - we : align === 'center' ? x - (wb + we) / 2 : x;
  g.textAlign = 'left';
  g.font = '11px system-ui, sans-serif';
  g.fillText(base, x0, y);
  g.font = '8px system-ui, sans-serif';
  g.fillText(exp, x0 + wb, y - 5);
  g.font = '11px system-ui, sans-serif';
}

// The top of a log scale: the decade above the largest finite positive value.
function logTop(values) {
  let m = 0;
  for (const v of values) if (v > m && Number.isFinite(v)) m = v;
  return m > 0 ? Math.ceil(Math.log10(m) - 1e-9) : 0;
}

// Polar plot of rho in the incidence plane: wi at theta_i on the left, wo at theta in (-90, 90) deg
// (positive to the right, where the mirror direction is), radius log10 rho over DECADES decades.
// A 0.5-degree grid plus 241 points within 6 lobe widths of the mirror direction, so that a sharp
// peak (beta 0.005: 0.6 degrees wide in theta_o) is resolved.
function polarAngles(thetaI) {
  const beta = matParams().beta, w = Math.max(2 * Math.atan(beta), 0.002) / DEG;
  const a = [];
  for (let t = -89.75; t < 90; t += 0.5) a.push(t);
  for (let i = -120; i <= 120; i++) a.push(thetaI + (6 * w * i) / 120);
  return [...new Set(a.filter((t) => t > -89.99 && t < 89.99).map((t) => +t.toFixed(6)))].sort((x, y) => x - y);
}

async function drawPolar(gen) {
  const th = ui.theta * DEG, wi = [-Math.sin(th), 0, Math.cos(th)];
  const lams = [...new Set(POLAR_LAMBDAS.map(clampLambda))];
  const angles = polarAngles(ui.theta);
  const points = [];
  for (const lambda of lams) for (const t of angles) points.push({ wi, wo: [Math.sin(t * DEG), 0, Math.cos(t * DEG)], lambda });
  const rho = await evalPoints(material, points, brdfOptions());
  if (gen !== generation) return;
  const { g, w, h } = canvas2d('polar');
  const cx = w / 2, cy = h - 22, R = Math.min(w / 2 - 34, h - 44);
  const top = logTop(rho), lo = top - DECADES;
  const rad = (v) => (v > 0 ? R * Math.min(Math.max((Math.log10(v) - lo) / DECADES, 0), 1) : 0);
  // decade half-circles and angle spokes
  g.lineWidth = 1;
  g.strokeStyle = GRID;
  g.fillStyle = TEXT;
  for (let k = 1; k <= DECADES; k++) {
    g.beginPath(); g.arc(cx, cy, (R * k) / DECADES, Math.PI, 2 * Math.PI); g.stroke();
    if (k % (DECADES > 6 ? 2 : 1) === 0) decadeLabel(g, lo + k, cx + (R * k) / DECADES - 2, cy + 14, 'center');
  }
  g.textAlign = 'center';
  for (let a = -90; a <= 90; a += 30) {
    const s = Math.sin(a * DEG), c = Math.cos(a * DEG);
    g.beginPath(); g.moveTo(cx, cy); g.lineTo(cx + R * s, cy - R * c); g.stroke();
    if (Math.abs(a) !== 90) g.fillText(`${a}°`, cx + (R + 13) * s, cy - (R + 13) * c + 4);
  }
  g.strokeStyle = AXIS;
  g.beginPath(); g.moveTo(cx - R - 8, cy); g.lineTo(cx + R + 8, cy); g.stroke();
  // the incident direction (solid, left) and the mirror direction (dashed, right)
  g.setLineDash([]);
  g.strokeStyle = '#e6e6e6';
  g.lineWidth = 1.5;
  g.beginPath(); g.moveTo(cx, cy); g.lineTo(cx - R * Math.sin(th), cy - R * Math.cos(th)); g.stroke();
  g.fillStyle = '#e6e6e6';
  // its label beside the line, clear of the angle labels on the rim
  g.fillText('ωi', cx - 0.72 * R * Math.sin(th) - 12 * Math.cos(th), cy - 0.72 * R * Math.cos(th) + 12 * Math.sin(th) - 4);
  g.setLineDash([4, 4]);
  g.strokeStyle = AXIS;
  g.lineWidth = 1;
  g.beginPath(); g.moveTo(cx, cy); g.lineTo(cx + R * Math.sin(th), cy - R * Math.cos(th)); g.stroke();
  g.setLineDash([]);
  // the lobes
  lams.forEach((l, j) => {
    g.strokeStyle = lambdaCss(l);
    g.lineWidth = 2.8 - 0.8 * j;   // narrower on top: coinciding lobes stay visible as stripes
    g.beginPath();
    angles.forEach((a, i) => {
      const r = rad(rho[j * angles.length + i]), x = cx + r * Math.sin(a * DEG), y = cy - r * Math.cos(a * DEG);
      if (i === 0) g.moveTo(x, y); else g.lineTo(x, y);
    });
    g.stroke();
    g.fillStyle = lambdaCss(l);
    g.fillRect(8, 8 + 15 * j, 14, 3);
    g.fillStyle = TEXT;
    g.textAlign = 'left';
    g.fillText(`${(1000 * l).toFixed(0)} nm`, 27, 13 + 15 * j);
  });
  g.textAlign = 'right';
  g.fillStyle = TEXT;
  g.fillText('ρ (1/sr), log scale', w - 6, 13);
  $('polar-sub').textContent = `θi ${ui.theta}° · ${points.length} points`;
  status.polar = { points: points.length, max: Math.max(...rho) };
  status.drawn.polar = true;
}

// The slice: rho(theta_h, theta_d) at phi_d = 90 deg (h in the xz-plane, wi and wo mirrored about it across
// the plane), theta_h on a linear or square-root axis (the MERL tabulation's, which opens up a sharp peak).
const inferno = (t) => {   // matplotlib's inferno, a polynomial fit (Matt Zucker, CC0)
  const c = [[0.0002189, 0.0016510, -0.0194809], [0.1065134, 0.5639564, 3.9327124], [11.6024931, -3.9728540, -15.9423941],
    [-41.7039961, 17.4363989, 44.3541452], [77.1629357, -33.4023589, -81.8073093], [-71.3194282, 32.6260643, 73.2095199],
    [25.1311262, -12.2426690, -23.0703250]];
  return [0, 1, 2].map((k) => Math.round(255 * Math.min(Math.max(c.reduceRight((s, ci) => s * t + ci[k], 0), 0), 1)));
};
const sliceThetaH = (x) => (ui.sliceAxis === 'sqrt' ? x * x : x) * 90;

async function drawSlice(gen) {
  const lambda = clampLambda(ui.lambda), points = [];
  for (let j = 0; j < SLICE_N; j++) {        // theta_d, bottom row first
    const td = ((j + 0.5) / SLICE_N) * 90 * DEG;
    for (let i = 0; i < SLICE_N; i++) {
      const thh = sliceThetaH((i + 0.5) / SLICE_N) * DEG;
      const hx = Math.sin(thh), hz = Math.cos(thh), cd = Math.cos(td), sd = Math.sin(td);
      // d = (0, sin td, cos td) in the frame of h, rotated by theta_h about y
      const wi = [cd * hx, sd, cd * hz], wo = [cd * hx, -sd, cd * hz];
      points.push({ wi, wo, lambda });
    }
  }
  const rho = await evalPoints(material, points, brdfOptions());
  if (gen !== generation) return;
  const { g, w, h } = canvas2d('slice');
  const left = 40, bottom = 30, bar = 46, size = Math.max(32, Math.min(w - left - bar - 12, h - bottom - 10));
  const x0 = left + Math.max(0, (w - left - bar - 12 - size) / 2), y0 = 8;
  // the scale's top from theta_d <= 75 deg: towards grazing rho grows as 1 / (cos theta_i cos theta_o) and
  // would push the peak and its tail into the colour map's bottom; brighter values saturate
  const top = logTop(rho.subarray(0, Math.round((75 / 90) * SLICE_N) * SLICE_N)), lo = top - SLICE_DECADES;
  const img = new ImageData(SLICE_N, SLICE_N);
  for (let j = 0; j < SLICE_N; j++) for (let i = 0; i < SLICE_N; i++) {
    const v = rho[j * SLICE_N + i], o = 4 * ((SLICE_N - 1 - j) * SLICE_N + i);
    const [r, gg, b] = v > 0 ? inferno(Math.min(Math.max((Math.log10(v) - lo) / SLICE_DECADES, 0), 1)) : [24, 26, 30];
    img.data.set([r, gg, b, 255], o);
  }
  const tmp = new OffscreenCanvas(SLICE_N, SLICE_N);
  tmp.getContext('2d').putImageData(img, 0, 0);
  g.imageSmoothingEnabled = false;
  g.drawImage(tmp, x0, y0, size, size);
  // axes
  g.strokeStyle = AXIS;
  g.strokeRect(x0 - 0.5, y0 - 0.5, size + 1, size + 1);
  g.fillStyle = TEXT;
  g.textAlign = 'center';
  const ticks = ui.sliceAxis === 'sqrt' ? [0, 2, 10, 22.5, 45, 90] : [0, 15, 30, 45, 60, 75, 90];
  for (const t of ticks) {
    const x = x0 + size * (ui.sliceAxis === 'sqrt' ? Math.sqrt(t / 90) : t / 90);
    g.beginPath(); g.moveTo(x, y0 + size); g.lineTo(x, y0 + size + 4); g.stroke();
    g.fillText(`${t}°`, x, y0 + size + 15);
  }
  g.fillText(`θh${ui.sliceAxis === 'sqrt' ? ' (√ axis)' : ''}`, x0 + size / 2, y0 + size + 27);
  g.textAlign = 'right';
  for (const t of [0, 30, 60, 90]) {
    const y = y0 + size * (1 - t / 90);
    g.beginPath(); g.moveTo(x0 - 4, y); g.lineTo(x0, y); g.stroke();
    g.fillText(`${t}°`, x0 - 6, y + 4);
  }
  g.save(); g.translate(11, y0 + size / 2); g.rotate(-Math.PI / 2); g.textAlign = 'center'; g.fillText('θd', 0, 0); g.restore();
  // colour bar with its decades
  const bx = x0 + size + 10;
  for (let k = 0; k < size; k++) { const [r, gg, b] = inferno(1 - k / size); g.fillStyle = `rgb(${r},${gg},${b})`; g.fillRect(bx, y0 + k, 10, 1.5); }
  g.fillStyle = TEXT;
  for (let k = 1; k <= SLICE_DECADES; k += 2) decadeLabel(g, lo + k, bx + 13, y0 + size * (1 - k / SLICE_DECADES) + 4);
  $('slice-sub').textContent = `${(1000 * lambda).toFixed(0)} nm · ${SLICE_N}² points`;
  status.slice = { points: points.length, max: Math.max(...rho) };
  status.drawn.slice = true;
}

// Gauss-Legendre nodes and weights on [-1, 1] (Newton on P_n).
function gaussLegendre(n) {
  const x = new Float64Array(n), w = new Float64Array(n);
  for (let i = 0; i < n; i++) {
    let z = Math.cos((Math.PI * (i + 0.75)) / (n + 0.5)), dp = 1;
    for (let it = 0; it < 100; it++) {
      let p1 = 1, p0 = 0;
      for (let j = 1; j <= n; j++) { const pm = p0; p0 = p1; p1 = ((2 * j - 1) * z * p0 - (j - 1) * pm) / j; }
      dp = (n * (z * p1 - p0)) / (z * z - 1);
      const dz = p1 / dp;
      z -= dz;
      if (Math.abs(dz) < 1e-15) break;
    }
    x[i] = z; w[i] = 2 / ((1 - z * z) * dp * dp);
  }
  return { x, w };
}

// The directional albedo a(theta_i) = int rho cos theta_o d omega_o, in the half vector h of (wi, wo):
// d omega_o = 4 (wi.h) d omega_h, and theta_h through v = ln tan theta_h, so that d omega_h = sin^2 theta_h
// cos theta_h dv dphi puts as many nodes on every decade of theta_h: a peak of any width (beta 0.005 as 0.5)
// and the diffraction lobe are resolved alike. v runs from ln(1e-3 w) (w the narrower of beta and
// lambda / b: the cap below holds ~1e-6 of the lobe) to the horizon, where wo.z = 0: tan 2 theta_h =
// -cos theta_i / (sin theta_i cos phi), so no node falls below it and the integrand has no kink;
// 24 panels of 6-point Gauss-Legendre. phi over [0, pi] (the plane of incidence is a mirror), 24-point
// Gauss-Legendre in tau with phi = pi/2 + s sinh(tau), s = cot theta_i: at grazing incidence the horizon
// turns within ~cot theta_i of phi = 90 deg, and the nodes gather there. 3456 points an angle. Against a
// 200-panel x 8 x 256-node rule on the C BRDF (the 36 test materials, both energy modes, 0-88 deg, 0.55 um)
// the error is 5.5e-4 at most (chi9 compensated at normal incidence), 2e-4 elsewhere; for plastic1
// (white) the page's curve is 1 to 5e-6.
const GL6 = gaussLegendre(6), GL24 = gaussLegendre(24);
function albedoRule(thetaI, lambda) {
  const m = matParams(), si = Math.sin(thetaI), ci = Math.cos(thetaI);
  const width = Math.min(m.beta, 0.1, m.sigma_s ? lambda / m.b : 1);
  const vmin = Math.log(1e-3 * width), panels = 24;
  const s = Math.min(Math.max(ci / Math.max(si, 1e-9), 0.01), 10), tm = Math.asinh(Math.PI / 2 / s);
  const wi = [si, 0, ci], dirs = [], weights = [];
  for (let a = 0; a < GL24.x.length; a++) {
    const tau = tm * GL24.x[a], phi = Math.PI / 2 + s * Math.sinh(tau);
    const wphi = 2 * tm * GL24.w[a] * s * Math.cosh(tau);   // x 2: phi in [pi, 2 pi] mirrors [0, pi]
    const cp = Math.cos(phi), sp = Math.sin(phi);
    const vmax = Math.log(Math.tan(0.5 * Math.atan2(ci, -si * cp)));
    if (!(vmax > vmin)) continue;
    const dv = (vmax - vmin) / panels;
    for (let k = 0; k < panels; k++) for (let q = 0; q < GL6.x.length; q++) {
      const v = vmin + dv * (k + 0.5 + 0.5 * GL6.x[q]), th = Math.atan(Math.exp(v)), st = Math.sin(th), ct = Math.cos(th);
      const hv = [st * cp, st * sp, ct], d = si * hv[0] + ci * hv[2];
      const wo = [2 * d * hv[0] - si, 2 * d * hv[1], 2 * d * hv[2] - ci];
      if (wo[2] <= 0 || d <= 0) continue;
      dirs.push({ wi, wo, lambda });
      weights.push(wphi * 0.5 * dv * GL6.w[q] * st * st * ct * 4 * d * wo[2]);
    }
  }
  return { dirs, weights };
}

async function computeAlbedo(energy, lambda) {
  const rules = ALBEDO_THETAS.map((t) => albedoRule(t * DEG, lambda));
  const points = rules.flatMap((r) => r.dirs);
  const rho = await evalPoints(material, points, brdfOptions(energy));
  let i = 0;
  return { points: points.length, values: rules.map((r) => r.weights.reduce((s, w) => s + w * rho[i++], 0)) };
}

async function drawAlbedo(gen) {
  const lambda = clampLambda(ui.lambda), curves = {};
  for (const e of isGeneral() ? ['single', 'compensated'] : material.energies || ['single', 'compensated']) {
    curves[e] = await computeAlbedo(e, lambda);
    if (gen !== generation) return;
  }
  const { g, w, h } = canvas2d('albedo');
  const left = 40, right = 12, top = 10, bottom = 32, pw = w - left - right, ph = h - top - bottom;
  const all = Object.values(curves).flatMap((c) => c.values);
  const ymax = Math.max(1.1, Math.ceil(Math.max(...all) * 10 + 0.5) / 10);
  const X = (t) => left + (pw * t) / 90, Y = (a) => top + ph * (1 - a / ymax);
  g.strokeStyle = GRID;
  g.fillStyle = TEXT;
  g.lineWidth = 1;
  g.textAlign = 'right';
  for (let a = 0; a <= ymax + 1e-9; a += ymax > 2 ? 0.5 : 0.2) {
    g.beginPath(); g.moveTo(left, Y(a)); g.lineTo(left + pw, Y(a)); g.stroke();
    g.fillText(a.toFixed(1), left - 5, Y(a) + 4);
  }
  g.textAlign = 'center';
  for (let t = 0; t <= 90; t += 15) {
    g.beginPath(); g.moveTo(X(t), top); g.lineTo(X(t), top + ph); g.stroke();
    g.fillText(`${t}°`, X(t), top + ph + 14);
  }
  g.fillText('θi', left + pw / 2, top + ph + 27);
  g.strokeStyle = AXIS;
  g.setLineDash([2, 3]);
  g.beginPath(); g.moveTo(left, Y(1)); g.lineTo(left + pw, Y(1)); g.stroke();
  g.beginPath(); g.moveTo(X(ui.theta), top); g.lineTo(X(ui.theta), top + ph); g.stroke();
  const styles = { single: ['#f0a35e', [6, 4]], compensated: ['#6fb3ff', []] };
  for (const [e, c] of Object.entries(curves)) {
    g.strokeStyle = styles[e][0];
    g.setLineDash(styles[e][1]);
    g.lineWidth = e === ui.energy ? 2.2 : 1.3;
    g.beginPath();
    c.values.forEach((a, i) => (i ? g.lineTo(X(ALBEDO_THETAS[i]), Y(a)) : g.moveTo(X(ALBEDO_THETAS[i]), Y(a))));
    g.stroke();
  }
  g.setLineDash([]);
  // legend: each mode with its value at the current theta_i (linear between the 24 angles)
  const at = (vals) => {
    const x = (ui.theta / 88) * 23, i = Math.min(Math.floor(x), 22), t = x - i;
    return vals[i] + t * (vals[i + 1] - vals[i]);
  };
  // the legend in the first corner (lower right, upper right, lower left, upper left) that no curve crosses
  const corners = [[left + pw - 228, top + ph - 44], [left + pw - 228, top + 6], [left + 6, top + ph - 44], [left + 6, top + 6]];
  const crosses = ([x, y]) => Object.values(curves).some((c) => c.values.some((a, i) => {
    const px = X(ALBEDO_THETAS[i]), py = Y(a);
    return px > x - 8 && px < x + 228 && py > y - 8 && py < y + 46;
  }));
  const [lx, ly] = corners.find((c) => !crosses(c)) || corners[0];
  g.fillStyle = 'rgba(31, 34, 38, 0.9)';
  g.fillRect(lx, ly, 220, 38);
  g.textAlign = 'left';
  Object.entries(curves).forEach(([e, c], j) => {
    g.strokeStyle = styles[e][0];
    g.setLineDash(styles[e][1]);
    g.lineWidth = 2;
    g.beginPath(); g.moveTo(lx + 8, ly + 12 + 15 * j); g.lineTo(lx + 30, ly + 12 + 15 * j); g.stroke();
    g.fillStyle = TEXT;
    g.fillText(`${e}: a(${ui.theta}°) = ${at(c.values).toFixed(4)}`, lx + 36, ly + 16 + 15 * j);
  });
  g.setLineDash([]);
  $('albedo-sub').textContent = `${(1000 * lambda).toFixed(0)} nm · ${Object.values(curves).reduce((n, c) => n + c.points, 0)} points`;
  status.albedo = { lambda, theta: ALBEDO_THETAS };
  for (const [e, c] of Object.entries(curves)) status.albedo[e] = c.values.map((v) => +v.toFixed(6));
  status.drawn.albedo = true;
}

// ------------------------------------------------------------------------------------------------ controls
function readControls() {
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
function materialControls() {
  const box = $('material-controls');
  box.hidden = false;
  box.insertAdjacentHTML('beforeend', Object.entries(PARAMS).map(([k, d]) => {
    const lo = toSlider(k, d.lo), hi = toSlider(k, d.hi), v = query.has(k) ? +query.get(k) : d.init;
    return `<div class="ctl"><label><span>${d.label}</span><output id="${k}-out"></output></label>`
      + `<input id="${k}" type="range" min="${lo}" max="${hi}" step="any" value="${toSlider(k, Math.min(Math.max(v, d.lo), d.hi))}"></div>`;
  }).join(''));
  const m = query.get('map');
  if (MAPS.includes(m)) document.querySelector(`input[name=map][value=${m}]`).checked = true;
  mapPixels = proceduralMap();
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
function schedulePlots(which) {
  which.forEach((k) => dirty.add(k));
  const gen = ++generation;
  clearTimeout(timer);
  timer = setTimeout(async () => {
    try {
      for (const [k, draw] of [['polar', drawPolar], ['slice', drawSlice], ['albedo', drawAlbedo]]) {
        if (!dirty.has(k)) continue;
        const t0 = performance.now();
        await draw(gen);
        if (gen !== generation) return;
        dirty.delete(k);
        status.ms[k] = Math.round(performance.now() - t0);   // ms (virtual ones under --virtual-time-budget)
      }
      maybeReady();
    } catch (e) { showError(e); }
  }, 150);
}

function onControl(e) {
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

function maybeReady() {
  if (status.ready || !['sphere', 'polar', 'slice', 'albedo'].every((k) => status.drawn[k])) return writeStatus();
  status.ready = true;
  document.body.dataset.ready = '1';
  writeStatus();
}

// ---------------------------------------------------------------------------------------------------- bench
// The per-pixel cost of the twoscale sphere pass against GGX: n draws of each at size x size, interleaved,
// each timed to completion (gl.finish and a 1-pixel readPixels), medians; a constant-colour pass gives the
// fixed cost of a draw, which the net ratio removes. With the general tables and &material=URL, the general
// pass (with &map=beta, its parameters per pixel) also against that material's own pass.
async function bench(src) {
  const n = +(query.get('n') || 20), size = +(query.get('size') || 256);
  const canvas = document.createElement('canvas');
  canvas.width = canvas.height = size;
  const gl = canvas.getContext('webgl2', { antialias: false, preserveDrawingBuffer: true });
  if (!gl) throw new Error('WebGL2 is not available');
  const r = new SphereRenderer(gl, src), px = new Uint8Array(4);
  const peer = isGeneral() && query.has('material') ? new SphereRenderer(gl, src, await loadMaterial(query.get('material'))) : null;
  const time = (kind) => {
    const rr = kind === 'material' ? peer : r;
    rr.use(kind === 'material' ? 'direct' : kind, [size, size]);
    gl.viewport(0, 0, size, size);
    const t0 = performance.now();
    r.draw();
    gl.finish();
    gl.readPixels(size >> 1, size >> 1, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, px);
    return performance.now() - t0;
  };
  const kinds = ['direct', 'ggx', 'empty', ...(peer ? ['material'] : [])], times = { direct: [], ggx: [], empty: [], material: [] };
  for (const k of kinds) { time(k); time(k); }   // compile and warm up
  // the general pass's bake (made when a slider moves, not a draw): its time once compiled, the median of 3
  const bakes = isGeneral() ? [0, 1, 2].map(() => {
    const t0 = performance.now(), b = bakeTables(gl, material, src, { ...matParams(), beta: betaRange(matParams().beta), lobe: ui.lobe });
    const fb = gl.createFramebuffer(), texel = new Float32Array(4);   // read a texel back: finish alone may not wait
    gl.bindFramebuffer(gl.FRAMEBUFFER, fb);
    gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0, gl.TEXTURE_2D, b.texture, 0);
    gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.FLOAT, texel);
    gl.bindFramebuffer(gl.FRAMEBUFFER, null);
    gl.deleteFramebuffer(fb);
    gl.deleteTexture(b.texture);
    return performance.now() - t0;
  }) : [];
  for (let i = 0; i < n; i++) {
    for (const k of kinds) times[k].push(time(k));
    await new Promise((res) => setTimeout(res, 0));   // let the page breathe between rounds
  }
  const med = (a) => { const s = [...a].sort((x, y) => x - y); return (s[(s.length - 1) >> 1] + s[s.length >> 1]) / 2; };
  const ts = med(times.direct), ggx = med(times.ggx), empty = med(times.empty);
  const dbg = gl.getExtension('WEBGL_debug_renderer_info');
  const renderer = gl.getParameter(dbg ? dbg.UNMASKED_RENDERER_WEBGL : gl.RENDERER);
  const out = {
    twoscale_ms: +ts.toFixed(3), ggx_ms: +ggx.toFixed(3), empty_ms: +empty.toFixed(3), ratio: +(ts / ggx).toFixed(3),
    ratio_net: +((ts - empty) / Math.max(ggx - empty, 1e-6)).toFixed(3), pixels: size * size,
    ...(peer ? { general: true, map: ui.map, material_ms: +med(times.material).toFixed(3),
      ratio_material_net: +((ts - empty) / Math.max(med(times.material) - empty, 1e-6)).toFixed(3), peer: peer.m.descriptor.material.name } : {}),
    ...(bakes.length ? { bake_ms: +med(bakes).toFixed(3) } : {}),
    sphere_pixels: Math.round(Math.PI * (0.46 * size) ** 2), draws: n, wavelengths: NL, lobe: ui.lobe, energy: ui.energy,
    material: isGeneral() ? 'general tables' : material.descriptor.material.name, renderer,
    note: /swiftshader/i.test(renderer) ? 'SwiftShader is a CPU rasteriser: the ratio, not the times, is what carries over to a GPU' : '',
  };
  $('bench').textContent = JSON.stringify(out, null, 1);
  $('bench-note').textContent = `Bench: ${n} draws each of the point-light sphere pass at ${size}² px, twoscale against GGX (same spectral loop, ${NL} wavelengths, same tone mapping), medians.`
    + (out.note ? ` ${out.note}.` : '');
  return out;
}

// ----------------------------------------------------------------------------------------------------- main
async function main() {
  const general = query.has('tables');
  const url = general ? query.get('tables') : query.get('material') || 'material/material.json';
  const t0 = performance.now();
  try {
    material = general ? await loadTables(url) : await loadMaterial(url);
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
