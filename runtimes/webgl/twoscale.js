// twoscale.js: load a `twoscale export --format webgl` material and evaluate its two-scale BRDF on the GPU with
// twoscale_brdf.glsl (runtimes/webgl/README.md). An ES module without dependencies or build step; WebGL2.
//
//   import { loadMaterial, evalPoints } from './twoscale.js';
//   const m = await loadMaterial(url);  // the descriptor's URL; every binary's size and SHA-256, and SHA256SUMS, checked
//   const s = await loadMaterial(url, { publicKey });  // and first SHA256SUMS.minisig by this minisign key
//   const rho = await evalPoints(m, [{ wi: [x, y, z], wo: [x, y, z], lambda: 0.55 }], { fresnel: 'one', lobe: 'exact', energy: 'single' });
//
// For pages that draw with the BRDF: shaderSource, fragmentShader, compileProgram, uploadMaterial, bindMaterial.
// The general export (the default preset's tables, any parameters per point): loadTables, and evalPoints on what it
// returns (twoscale_general.js).
import { evalGeneral } from './twoscale_general.js';
import { checkSums, expectComment, fetchOk, hex, signedSums } from './verify.js';
import { bindTextures, evalProgram, floatTexture, renderFloat } from './gl.js';

export { loadTables, bindTables, uploadTables, generalModes, bakeTables, bindBake } from './twoscale_general.js';
export { fetchOk, hex, checkSums, verifySignature, expectComment, signedSums } from './verify.js';
export {
  shaderSource, fragmentShader, FULLSCREEN_VERTEX, compileProgram, evalProgram, floatTexture, bindTextures, drawFloat, renderFloat,
} from './gl.js';

const FORMAT = 'twoscale-webgl/1';
const ROW = 2048; // texels per row of the material's data texture (ts_at in twoscale_brdf.glsl)
const BATCH = 256; // evalPoints renders up to BATCH x BATCH points per draw

// ---------------------------------------------------------------------------------------------------------
// Loading and verifying an export.

const fileName = (url) => decodeURIComponent(new URL(url).pathname.split('/').pop() || String(url));

// Little-endian float32 (a DataView copy on a big-endian host).
function float32LE(buf) {
  if (new Uint8Array(new Uint16Array([1]).buffer)[0] === 1) return new Float32Array(buf);
  const v = new DataView(buf), out = new Float32Array(buf.byteLength / 4);
  for (let i = 0; i < out.length; i++) out[i] = v.getFloat32(4 * i, true);
  return out;
}

// One table's binary: its size against the descriptor (and the descriptor's size against its axes and values),
// then its SHA-256; a Float32Array of nodes x values, interleaved.
async function loadTable(base, entry, descName) {
  const file = entry.file;
  if (typeof file !== 'string' || !Array.isArray(entry.axes) || !Array.isArray(entry.values) || !(entry.bytes >= 0) || typeof entry.sha256 !== 'string') {
    throw new Error(`${descName}: table ${entry.table}: needs file, bytes, sha256, values and axes`);
  }
  const nodes = entry.axes.reduce((n, a) => n * a.size, 1);
  if (entry.bytes !== 4 * nodes * entry.values.length) {
    throw new Error(`${descName}: ${file}: ${entry.bytes} bytes for ${nodes} nodes x ${entry.values.length} values`);
  }
  const buf = await (await fetchOk(new URL(file, base), file)).arrayBuffer();
  if (buf.byteLength < entry.bytes) throw new Error(`${file}: truncated: ${buf.byteLength} bytes, expected ${entry.bytes}`);
  if (buf.byteLength !== entry.bytes) throw new Error(`${file}: ${buf.byteLength} bytes, expected ${entry.bytes}`);
  if (!globalThis.crypto?.subtle) throw new Error(`${file}: cannot verify its SHA-256: SubtleCrypto needs a secure context (https, or http on localhost/127.0.0.1)`);
  const got = hex(await crypto.subtle.digest('SHA-256', buf));
  if (got !== entry.sha256.toLowerCase()) throw new Error(`${file}: SHA-256 mismatch (expected ${entry.sha256}, got ${got})`);
  return float32LE(buf);
}

// The descriptor at url, every table fetched and verified, and the layout the shader reads (prepare): rejects
// with an Error naming the file on any HTTP error, bad JSON, size or checksum mismatch, or a table the BRDF
// cannot read. With opts.publicKey the export's signature is verified first (verifySignature). Returns
// { url, name, model, descriptor, material, wavelengthRange, energies, tables }, tables { name: { entry, data: Float32Array } }.
export async function loadMaterial(url, opts = {}) {
  const base = new URL(url, globalThis.location?.href);
  const name = fileName(base);
  const signed = await signedSums(base, opts, 'loadMaterial'), sums = signed?.sums;
  const bytes = await (await fetchOk(base, name)).arrayBuffer();
  if (sums) await checkSums(base, name, bytes, [], sums);  // signed: the descriptor's digest before it is parsed
  const text = new TextDecoder().decode(bytes);
  let descriptor;
  try {
    descriptor = JSON.parse(text);
  } catch (e) {
    throw new Error(`${name}: not valid JSON (${e.message})`);
  }
  if (descriptor?.format !== FORMAT) throw new Error(`${name}: format ${JSON.stringify(descriptor?.format)}, expected ${FORMAT}`);
  if (!Array.isArray(descriptor.tables) || typeof descriptor.material !== 'object' || !descriptor.material) {
    throw new Error(`${name}: needs tables and material`);
  }
  // signed: the descriptor checked against SHA256SUMS, and the signature's comment against it, before any file it
  // names is fetched
  if (sums) await checkSums(base, name, bytes, descriptor.tables, sums);
  if (signed) expectComment(signed, descriptor, `material=${descriptor.material.name}`);
  const datas = await Promise.all(descriptor.tables.map((t) => loadTable(base, t, name)));
  if (!sums) await checkSums(base, name, bytes, descriptor.tables);
  const tables = {};
  descriptor.tables.forEach((t, i) => (tables[t.table] = { entry: t, data: datas[i] }));
  const m = {
    url: base.href,
    name: descriptor.material.name,
    model: descriptor.material.model ?? 'conductor',
    descriptor,
    material: descriptor.material,
    wavelengthRange: descriptor.wavelength_range ?? null,
    tables,
  };
  prepare(m, name);
  m.energies = m.layout.albedo ? ['single', 'compensated'] : ['single'];
  return m;
}

// The axis a of a table entry as the shader's TsGrid: e0, inv_step (uniform in the encoding from encoded_first to
// encoded_last), n, and the encoding's parameters p0, p1 (the C's, export.rs c_axis_encoding's order).
const PARAMS = { bounded_log_tan: ['eps', 'delta'], log_gap: ['end', 'eps'], log1p_sq: ['scale'], shifted_log: ['shift'], log: [], linear: [], asin_sqrt: [] };

function grid(t, a, kind, where) {
  const axis = t.entry.axes[a];
  if (axis?.encoding?.kind !== kind) throw new Error(`${where}: ${t.entry.table}'s axis ${a} is not ${kind} (docs/material_tables.md)`);
  const n = axis.size, step = (axis.encoded_last - axis.encoded_first) / (n - 1);
  if (!(n >= 2) || !Number.isFinite(step) || step === 0) throw new Error(`${where}: ${t.entry.table}'s axis ${axis.name}: bad encoded range`);
  const p = PARAMS[kind].map((k) => axis.encoding[k]);
  return { e0: axis.encoded_first, inv_step: 1 / step, n, p0: p[0] ?? 0, p1: p[1] ?? 0 };
}

// F_avg = 2 int_0^1 F(mu) mu dmu by 8-point Gauss-Legendre (nodes (1 -+ x)/2, weights w/2), in double as the C.
function gaussAvg(f) {
  const x = [0.1834346424956498, 0.525532409916329, 0.7966664774136267, 0.9602898564975363];
  const w = [0.362683783378362, 0.3137066458778873, 0.2223810344533745, 0.1012285362903763];
  return x.reduce((s, xj, j) => s + w[j] * (0.5 * (1 - xj) * f(0.5 * (1 - xj)) + 0.5 * (1 + xj) * f(0.5 * (1 + xj))), 0);
}

// A layered model's interface: the unpolarised dielectric reflectance (Walter et al. 2007) averaged.
function dielectricAvg(eta) {
  return gaussAvg((c) => {
    const g2 = eta * eta - 1 + c * c;
    if (g2 <= 0) return 1;
    const g = Math.sqrt(g2), x = (g - c) / (g + c), y = (c * (g + c) - 1) / (c * (g - c) + 1);
    return 0.5 * x * x * (1 + y * y);
  });
}

// F_avg of a conductor eta + i k (twoscale_fresnel_conductor's, in double): ts_fresnel_conductor computes it in the
// shader with 8 Fresnel evaluations; a shader that draws many pixels with one (eta, k) can take it as a uniform
// instead, TsFresnel(1, eta, k, fresnelAverage(eta, k)).
export function fresnelAverage(eta, k) {
  return gaussAvg((c) => {
    const c2 = c * c, s2 = 1 - c2, t1 = eta * eta - k * k - s2, ab = Math.sqrt(t1 * t1 + 4 * eta * eta * k * k);
    const a = Math.sqrt(Math.max(0.5 * (ab + t1), 0)), t3 = ab * c2 + s2 * s2;
    return ((ab + c2 - 2 * c * a) * t3) / ((ab + c2 + 2 * c * a) * (t3 + 2 * c * a * s2));
  });
}

// What twoscale_brdf_init computes once: the tables' grids, the value planes packed into one image
// (ROW texels a row, each plane at an offset), and the material's constants. m.layout.
function prepare(m, where) {
  const mat = m.material, T = m.tables;
  const need = (name, dims) => {
    const t = T[name];
    if (!t) throw new Error(`${where}: the material lacks the table ${name} (export the whole material folder)`);
    if (t.entry.axes.length !== dims) throw new Error(`${where}: ${name} has ${t.entry.axes.length} axes, expected ${dims}`);
    return t;
  };
  const num = (k, dflt) => (typeof mat[k] === 'number' ? mat[k] : dflt);
  const model = { conductor: 0, plastic: 1, subsurface: 2 }[m.model];
  if (model === undefined) throw new Error(`${where}: unknown material model ${JSON.stringify(m.model)}`);
  const beta = num('beta'), p = num('p'), n_p = num('n_p'), sigma_s = num('sigma_s', 0), b = num('b', 0), c = num('c', 0);
  if (!(beta > 0 && p > 0 && n_p > 0)) throw new Error(`${where}: the material needs beta, p and n_p`);
  const diffracting = sigma_s > 0;
  const planes = []; // [name, table, value name]
  const grids = {};
  const L = { model, diffracting, grids, offsets: {} };
  const g1 = need('epd_g1', 1), samp = need('epd_sampling', 1);
  grids.g1_theta = grid(g1, 0, 'bounded_log_tan', where);
  grids.samp_xi = grid(samp, 0, 'asin_sqrt', where);
  planes.push(['g1', g1, 'g1'], ['samp', samp, 'theta_m']);
  const albDims = diffracting ? 2 : 1;
  if (T.albedo) {
    const t = need('albedo', albDims);
    L.albedo = { mu: grid(t, 0, 'bounded_log_tan', where), lam: diffracting ? grid(t, 1, 'log', where) : null };
    planes.push(['alb_g', t, 'g'], ['alb_e', t, 'e_comp'], ['alb_avg', t, 'e_comp_avg']);
  }
  if (model !== 0) {
    const t = need('interface_albedo', albDims);
    L.interface = { mu: grid(t, 0, 'bounded_log_tan', where), lam: diffracting ? grid(t, 1, 'log', where) : null };
    planes.push(['ia_e_f', t, 'e_f'], ['ia_e_f_avg', t, 'e_f_avg'], ['ia_e_fc', t, 'e_fc'], ['ia_e_fc_avg', t, 'e_fc_avg']);
    // compensated reads both tables on one grid (the C checks it)
    const same = (a, b) => !a || !b || ['e0', 'inv_step', 'n', 'p0', 'p1'].every((k) => a[k] === b[k]);
    if (L.albedo && !(same(L.albedo.mu, L.interface.mu) && same(L.albedo.lam, L.interface.lam))) {
      throw new Error(`${where}: interface_albedo and albedo have different axes`);
    }
    // the layer's albedo: a plastic's diffuse d, a subsurface medium's alpha'; a number or {wavelengths, values}
    const layer = mat[model === 1 ? 'diffuse' : 'albedo'];
    const ws = typeof layer === 'number' ? [0] : layer?.wavelengths, vs = typeof layer === 'number' ? [layer] : layer?.values;
    if (!(num('ior', 0) > 1) || !Array.isArray(ws) || !Array.isArray(vs) || vs.length < 1 || ws.length !== vs.length) {
      throw new Error(`${where}: a plastic or subsurface material needs ior > 1 and its layer's albedo`);
    }
    if (model === 2 && !(Math.abs(num('g', 0)) < 1 && num('single_max', -1) >= 0)) throw new Error(`${where}: a subsurface material needs |g| < 1 and single_max >= 0`);
    planes.push(['layer_w', null, Float32Array.from(ws)], ['layer_v', null, Float32Array.from(vs)]);
    L.layer_n = vs.length;
  }
  if (diffracting) {
    const kc = need('kcorr_renorm', 2), lobe = need('zh_lobe', 2), ls = need('zh_lobe_sampling', 2), conv = need('zh_convolution', 1);
    Object.assign(grids, {
      kc_s: grid(kc, 0, 'log_gap', where), kc_b: grid(kc, 1, 'log', where),
      lobe_u: grid(lobe, 0, 'log1p_sq', where), lobe_v: grid(lobe, 1, 'linear', where),
      ls_u: grid(ls, 0, 'log1p_sq', where), ls_xi: grid(ls, 1, 'asin_sqrt', where),
      conv_u: grid(conv, 0, 'shifted_log', where),
    });
    const d = (lobe.entry.derived_axes ?? [])[0];
    if (lobe.entry.derived_axes?.length !== 1 || d.kind !== 'material_lobe_angle' || d.axis !== lobe.entry.axes[1].name || d.inputs?.[0] !== lobe.entry.axes[0].name) {
      throw new Error(`${where}: zh_lobe's angle axis is not the material_lobe_angle of (u, theta_h)`);
    }
    L.lobe_angle = d;
    planes.push(['kc', kc, 'r'], ['lobe', lobe, 'c_lobe'], ['ls', ls, 'theta_h'], ['s_cos', conv, 's_cos'], ['g_cos', conv, 'g_cos']);
  }
  // the planes, de-interleaved into one image
  let total = 0;
  const cols = planes.map(([key, t, value]) => {
    let col = value;
    if (t) {
      const nc = t.entry.values.length, c = t.entry.values.indexOf(value);
      if (c < 0) throw new Error(`${where}: ${t.entry.table} lacks the value ${value}`);
      col = new Float32Array(t.data.length / nc);
      for (let i = 0; i < col.length; i++) col[i] = t.data[i * nc + c];
    }
    L.offsets[key] = total;
    total += col.length;
    return col;
  });
  L.rows = Math.ceil(total / ROW);
  L.image = new Float32Array(L.rows * ROW);
  cols.forEach((col, i) => L.image.set(col, L.offsets[planes[i][0]]));
  // The texture's texel k holds node k's bilinear footprint (v[k], v[k + 1], v[k + nb], v[k + nb + 1]), nb the
  // plane's row length (its table's last axis; 0 for a 1-D table): the shader reads an interpolation's 2 or 4
  // nodes with ONE texelFetch (the same values and arithmetic as 4 fetches: bit-identical results). A fetch is
  // what ts_eval spends most on under SwiftShader (measured: 25 % of the sphere pass with energy single, 48 %
  // compensated, with a fetch a node); 4x the memory (a few MB). Past a plane's end the spare channels hold its
  // neighbour's values or 0, which no cell reads (ts_cell keeps i <= n - 2).
  L.quad = new Float32Array(4 * L.image.length);
  planes.forEach(([key, t], p) => {
    const nb = t && t.entry.axes.length === 2 ? t.entry.axes[1].size : 0, off = L.offsets[key], img = L.image;
    for (let k = off; k < off + cols[p].length; k++) {
      L.quad[4 * k] = img[k];
      L.quad[4 * k + 1] = img[k + 1] ?? 0;
      L.quad[4 * k + 2] = img[k + nb] ?? 0;
      L.quad[4 * k + 3] = img[k + nb + 1] ?? 0;
    }
  });
  // constants (twoscale_brdf_init), in double; the shader gets them as float32
  const inv_beta2 = 1 / (beta * beta);
  L.scalars = {
    ts_inv_beta2: inv_beta2, ts_spec_scale: 0.25 * n_p * inv_beta2, ts_d_cut: Math.pow(104, 1 / p), ts_p: p,
    ts_k_scale: ((c - 1) / (2 * Math.PI)) * n_p * inv_beta2, ts_lobe_power: -0.5 * (c + 1), ts_sigma4pi: 4 * Math.PI * sigma_s, ts_b: b,
    ts_inv_u_scale: diffracting ? 1 / grids.lobe_u.p0 : 0, ts_edge_d2: diffracting ? L.lobe_angle.edge_d ** 2 : 0,
    ts_inv_theta_cap: diffracting ? 1 / L.lobe_angle.theta_cap : 0, ts_v_anchor: diffracting ? L.lobe_angle.v_anchor : 0,
    ts_v_ln2: diffracting ? L.lobe_angle.v_anchor / Math.LN2 : 0,
    ts_ior: num('ior', 1), ts_interface_avg: model ? dielectricAvg(num('ior')) : 1, ts_phase_g: num('g', 0), ts_single_max: num('single_max', 0),
  };
  m.layout = L;
}

// ---------------------------------------------------------------------------------------------------------
// The shader and the material on a WebGL2 context.

// The #define lines that make the shader's choices (model, lobe, energy, diffraction) constants for the material m
// and choices {lobe, energy}, for fragmentShader: SwiftShader runs both sides of a uniform branch (as a SIMD GPU
// does where it does not skip a branch no lane takes), so a program with the choices as uniforms pays for every
// model and mode; with them constant the compiler drops the others (the sphere pass: 2.3x faster). bindMaterial
// still sets the remaining uniforms; a program compiled so must be bound with the same m and choices.
export function shaderModes(m, choices = {}) {
  const { lobe, energy } = checkChoices(m, choices);
  return `#define TS_MODEL ${m.layout.model}\n#define TS_EXACT ${lobe === 'exact'}\n#define TS_COMPENSATED ${energy === 'compensated'}\n`
    + `#define TS_DIFFRACTING ${!!m.layout.diffracting}\n`;
}

const textures = new WeakMap(); // gl -> WeakMap(m -> texture)

// The material's data texture on this context (RGBA32F, each texel a node's bilinear footprint; NEAREST:
// texelFetch only), uploaded once.
export function uploadMaterial(gl, m) {
  let perGl = textures.get(gl);
  if (!perGl) textures.set(gl, (perGl = new WeakMap()));
  let tex = perGl.get(m);
  if (tex) return tex;
  const L = m.layout;
  tex = gl.createTexture();
  const prev = gl.getParameter(gl.TEXTURE_BINDING_2D);
  const store = [gl.UNPACK_ALIGNMENT, gl.UNPACK_ROW_LENGTH, gl.UNPACK_SKIP_ROWS, gl.UNPACK_SKIP_PIXELS, gl.UNPACK_FLIP_Y_WEBGL, gl.UNPACK_PREMULTIPLY_ALPHA_WEBGL];
  const saved = store.map((k) => gl.getParameter(k));
  const prevUnpack = gl.getParameter(gl.PIXEL_UNPACK_BUFFER_BINDING);
  gl.bindBuffer(gl.PIXEL_UNPACK_BUFFER, null);
  [4, 0, 0, 0, false, false].forEach((v, i) => gl.pixelStorei(store[i], v));
  gl.bindTexture(gl.TEXTURE_2D, tex);
  gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA32F, ROW, L.rows, 0, gl.RGBA, gl.FLOAT, L.quad);
  gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.NEAREST);
  gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.NEAREST);
  gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_S, gl.CLAMP_TO_EDGE);
  gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_T, gl.CLAMP_TO_EDGE);
  gl.bindTexture(gl.TEXTURE_2D, prev);
  saved.forEach((v, i) => gl.pixelStorei(store[i], v));
  gl.bindBuffer(gl.PIXEL_UNPACK_BUFFER, prevUnpack);
  perGl.set(m, tex);
  return tex;
}

const LOBES = ['exact', 'fit'], ENERGIES = ['single', 'compensated'];

function checkChoices(m, { lobe = 'exact', energy = 'single' } = {}) {
  if (!LOBES.includes(lobe)) throw new Error(`lobe ${JSON.stringify(lobe)}: 'exact' or 'fit'`);
  if (!ENERGIES.includes(energy)) throw new Error(`energy ${JSON.stringify(energy)}: 'single' or 'compensated'`);
  if (energy === 'compensated' && !m.layout.albedo) throw new Error(`${m.name}: energy 'compensated' needs the albedo table, which this export lacks`);
  return { lobe, energy };
}

const locations = new WeakMap(); // program -> Map(name -> location)

// Binds the material's texture to unit firstUnit and sets every uniform twoscale_brdf.glsl reads (the program is
// made current); returns the next free texture unit. lobe 'exact' | 'fit', energy 'single' | 'compensated'.
export function bindMaterial(gl, program, m, choices = {}, firstUnit = 0) {
  const { lobe, energy } = checkChoices(m, choices);
  const L = m.layout, comp = energy === 'compensated';
  let locs = locations.get(program);
  if (!locs) locations.set(program, (locs = new Map()));
  const loc = (name) => {
    if (!locs.has(name)) locs.set(name, gl.getUniformLocation(program, name));
    return locs.get(name);
  };
  gl.useProgram(program);
  gl.activeTexture(gl.TEXTURE0 + firstUnit);
  gl.bindTexture(gl.TEXTURE_2D, uploadMaterial(gl, m));
  gl.uniform1i(loc('ts_data'), firstUnit);
  // the albedo grid: albedo's, or a layered model's interface_albedo with energy single (the C's choice)
  const alb = (L.interface && !comp) || !L.albedo ? L.interface : L.albedo;
  const none = { e0: 0, inv_step: 1, n: 2, p0: 0, p1: 0 };
  const grids = { ...L.grids, alb_mu: alb?.mu, alb_lam: alb?.lam };
  for (const g of ['g1_theta', 'samp_xi', 'kc_s', 'kc_b', 'lobe_u', 'lobe_v', 'ls_u', 'ls_xi', 'conv_u', 'alb_mu', 'alb_lam']) {
    const v = grids[g] ?? none;
    gl.uniform1f(loc(`ts_${g}.e0`), v.e0);
    gl.uniform1f(loc(`ts_${g}.inv_step`), v.inv_step);
    gl.uniform1i(loc(`ts_${g}.n`), v.n);
    gl.uniform1f(loc(`ts_${g}.p0`), v.p0);
    gl.uniform1f(loc(`ts_${g}.p1`), v.p1);
  }
  const o = L.offsets;
  const offsets = {
    g1: o.g1, samp: o.samp, alb_g: o.alb_g, alb_e: o.alb_e, alb_avg: o.alb_avg,
    ia_e: comp ? o.ia_e_fc : o.ia_e_f, ia_avg: comp ? o.ia_e_fc_avg : o.ia_e_f_avg,
    kc: o.kc, lobe: o.lobe, ls: o.ls, s_cos: o.s_cos, g_cos: o.g_cos, layer_w: o.layer_w, layer_v: o.layer_v,
  };
  for (const [k, v] of Object.entries(offsets)) gl.uniform1i(loc(`ts_off_${k}`), v ?? 0);
  gl.uniform1i(loc('ts_layer_n'), L.layer_n ?? 1);
  gl.uniform1i(loc('ts_model'), L.model);
  gl.uniform1i(loc('ts_exact'), lobe === 'exact' ? 1 : 0);
  gl.uniform1i(loc('ts_compensated'), comp ? 1 : 0);
  gl.uniform1i(loc('ts_diffracting'), L.diffracting ? 1 : 0);
  gl.uniform1i(loc('ts_layered'), L.model !== 0 ? 1 : 0);
  for (const [k, v] of Object.entries(L.scalars)) gl.uniform1f(loc(k), v);
  return firstUnit + 1;
}

// ---------------------------------------------------------------------------------------------------------
// evalPoints: rho at any number of points, rendered into a float target and read back.

const EVAL_BODY = `
uniform highp sampler2D ts_in_wi, ts_in_wo, ts_in_ek;  // (wi, lambda), (wo, 0), (eta, k, 0, 0)
uniform int ts_in_fresnel;                             // 0: F = 1; 1: a constant (eta, k); 2: each point's
uniform vec2 ts_in_eta_k;
out vec4 ts_out;
void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    vec4 a = texelFetch(ts_in_wi, p, 0), b = texelFetch(ts_in_wo, p, 0);
    TsFresnel f = ts_fresnel_one();
    if (ts_in_fresnel == 1) f = ts_fresnel_conductor(ts_in_eta_k.x, ts_in_eta_k.y);
    if (ts_in_fresnel == 2) {
        vec4 c = texelFetch(ts_in_ek, p, 0);
        f = ts_fresnel_conductor(c.x, c.y);
    }
    ts_out = vec4(ts_eval(a.xyz, b.xyz, a.w, f), 0.0, 0.0, 1.0);
}`;

function checkOptions(m, opts) {
  const known = ['fresnel', 'lobe', 'energy'];
  const extra = Object.keys(opts).filter((k) => !known.includes(k));
  if (extra.length) throw new Error(`evalPoints: unknown option ${extra.join(', ')} (fresnel, lobe, energy)`);
  const choices = checkChoices(m, opts);
  const f = opts.fresnel ?? 'one';
  let fresnel;
  if (f === 'one') fresnel = { mode: 0 };
  else if (f === 'conductor') fresnel = { mode: 2 };
  else if (typeof f === 'object' && f !== null && Number.isFinite(f.eta) && Number.isFinite(f.k) && Object.keys(f).every((k) => k === 'eta' || k === 'k')) {
    fresnel = { mode: 1, eta: f.eta, k: f.k };
  } else throw new Error(`fresnel ${JSON.stringify(f)}: 'one', {eta, k} or 'conductor'`);
  return { ...choices, fresnel };
}

// rho (1/sr, without the cosine) at each { wi, wo, lambda } (local frame, micrometres), as a Float32Array, by
// twoscale_brdf.glsl on the GPU. opts: lobe 'exact' | 'fit', energy 'single' | 'compensated', fresnel 'one' |
// { eta, k } | 'conductor' (each point's eta and k). Rejects on an unknown option or a malformed point.
export async function evalPoints(m, points, opts = {}) {
  if (m?.general) return evalGeneral(m, points, opts ?? {});
  if (!m?.layout) throw new Error('evalPoints: not a material of loadMaterial or loadTables');
  if (!Array.isArray(points)) throw new Error('evalPoints: points must be an array');
  const { lobe, energy, fresnel } = checkOptions(m, opts ?? {});
  const n = points.length, rho = new Float32Array(n);
  const vec = (v) => Array.isArray(v) && v.length === 3 && v.every((x) => typeof x === 'number');
  points.forEach((q, i) => {
    if (!q || !vec(q.wi) || !vec(q.wo) || typeof q.lambda !== 'number') throw new Error(`evalPoints: point ${i}: needs wi, wo (3 numbers each) and lambda`);
    if (fresnel.mode === 2 && !(typeof q.eta === 'number' && typeof q.k === 'number')) throw new Error(`evalPoints: point ${i}: fresnel 'conductor' needs its eta and k`);
  });
  if (n === 0) return rho;
  const { gl, program } = await evalProgram(shaderModes(m, { lobe, energy }), EVAL_BODY);
  bindMaterial(gl, program, m, { lobe, energy }, 0);
  gl.uniform1i(gl.getUniformLocation(program, 'ts_in_fresnel'), fresnel.mode);
  gl.uniform2f(gl.getUniformLocation(program, 'ts_in_eta_k'), fresnel.eta ?? 1, fresnel.k ?? 0);
  ['ts_in_wi', 'ts_in_wo', 'ts_in_ek'].forEach((u, i) => gl.uniform1i(gl.getUniformLocation(program, u), 1 + i));
  for (let start = 0; start < n; start += BATCH * BATCH) {
    const count = Math.min(BATCH * BATCH, n - start), w = Math.min(count, BATCH), h = Math.ceil(count / w);
    const a = new Float32Array(4 * w * h), b = new Float32Array(4 * w * h), c = new Float32Array(4 * w * h);
    for (let i = 0; i < count; i++) {
      const q = points[start + i];
      a.set([q.wi[0], q.wi[1], q.wi[2], q.lambda], 4 * i);
      b.set([q.wo[0], q.wo[1], q.wo[2], 0], 4 * i);
      if (fresnel.mode === 2) c.set([q.eta, q.k, 0, 0], 4 * i);
    }
    const inputs = [a, b, c].map((d) => floatTexture(gl, w, h, d));
    bindTextures(gl, inputs, 1);
    const out = renderFloat(gl, w, h);
    inputs.forEach((t) => gl.deleteTexture(t));
    for (let i = 0; i < count; i++) rho[start + i] = out[4 * i];
  }
  return rho;
}
