// The sphere's fragment shaders (GLSL ES 3.0 around twoscale_brdf.glsl): the BRDF passes and the display.
import { NL } from './colour.js';

// The sphere under a point light (NL wavelengths, deterministic) and, with ACCUMULATE, either that light
// alone into a float texture (u_env 0) or the environment estimated by ts_sample (hero wavelengths over
// VIS), averaged over frames into a float texture. Without ACCUMULATE, the point light tone-mapped to the
// screen: the bench's pass, where BRDF_GGX swaps ts_eval for a GGX conductor (its baseline): the spectral
// loop, the light and the tone mapping are the same code.
export const SPHERE_GLSL = `
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

// The CMF fit, as cmf() in colour.js, to linear sRGB.
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
export const DISPLAY_FS = `#version 300 es
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
export const EMPTY_FS = `#version 300 es
precision highp float;
out vec4 o_color;
void main() { o_color = vec4(0.5); }`;
