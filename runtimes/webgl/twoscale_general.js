// twoscale_general.js: the general GPU export (`twoscale export --format webgl --preset default`,
// runtimes/webgl/README.md "The general export") on WebGL2: the two-scale BRDF at any parameters, per point.
// twoscale.js re-exports loadTables, and its evalPoints takes what loadTables returns:
//
//   import { loadTables, evalPoints } from './twoscale.js';
//   const t = await loadTables(url);  // OUT/tables.json; every binary's size and SHA-256, and SHA256SUMS, checked
//   const s = await loadTables(url, { publicKey });  // and first SHA256SUMS.minisig by this minisign key (verifySignature)
//   const rho = await evalPoints(t, points, { material: { beta: 0.08, p: 1.2, sigma_s: 0.02, b: 1.5, c: 2.2 },
//                                              fresnel: 'one', lobe: 'exact', energy: 'single' });
//
// A point may carry its own `material`. twoscale_brdf.glsl's ts_general_eval does the work (TS_GENERAL).
import { checkSums, fetchOk, hex, signedSums, expectComment } from './verify.js';
import { compileProgram, evalProgram, floatTexture, fragmentShader, bindTextures, drawFloat, renderFloat, shaderSource } from './gl.js';

const FORMAT = 'twoscale-webgl-general/1';
const ROW = 2048; // texels a row and rows a layer of the R32F and R16F array textures (ts_gat, ts_globe_at)
const BATCH = 256; // points a draw: BATCH x BATCH
const PARAMS = ['beta', 'p', 'sigma_s', 'b', 'c'];
// The tables the shader reads and the value planes it takes from them.
const PLANES = [['norm', 'epd_norm', 'n'], ['g1', 'epd_g1', 'g1'], ['kc', 'kcorr_renorm', 'r'], ['s_cos', 'zh_convolution', 's_cos'],
  ['g_cos', 'zh_convolution', 'g_cos'], ['g', 'zh_convolution', 'g'], ['q', 'epd_quantile', 'theta'], ['alb', 'epd_albedo', 'e'],
  ['alb_avg', 'epd_albedo_avg', 'e_avg']];
const TABLES = ['epd_norm', 'epd_g1', 'epd_quantile', 'kcorr_renorm', 'zh_convolution', 'zh_lobe', 'epd_albedo', 'epd_albedo_avg'];

const bigEndian = new Uint8Array(new Uint16Array([1]).buffer)[0] !== 1;

// One binary: its size against the descriptor's shape, values and dtype, then its SHA-256; a Float32Array (float32)
// or the float16 bits as a Uint16Array, nodes x values interleaved.
async function loadBinary(base, e, descName) {
  const width = { float32: 4, float16: 2 }[e.dtype];
  if (typeof e.file !== 'string' || !width || !Array.isArray(e.shape) || !Array.isArray(e.values) || typeof e.sha256 !== 'string') {
    throw new Error(`${descName}: table ${e.table}: needs file, dtype (float32 or float16), shape, values and sha256`);
  }
  const nodes = e.shape.reduce((n, s) => n * s, 1);
  if (e.bytes !== width * nodes * e.values.length) throw new Error(`${descName}: ${e.file}: ${e.bytes} bytes for ${nodes} nodes x ${e.values.length} ${e.dtype} values`);
  const buf = await (await fetchOk(new URL(e.file, base), e.file)).arrayBuffer();
  if (buf.byteLength < e.bytes) throw new Error(`${e.file}: truncated: ${buf.byteLength} bytes, expected ${e.bytes}`);
  if (buf.byteLength !== e.bytes) throw new Error(`${e.file}: ${buf.byteLength} bytes, expected ${e.bytes}`);
  if (!globalThis.crypto?.subtle) throw new Error(`${e.file}: cannot verify its SHA-256: SubtleCrypto needs a secure context (https, or http on localhost/127.0.0.1)`);
  const got = hex(await crypto.subtle.digest('SHA-256', buf));
  if (got !== e.sha256.toLowerCase()) throw new Error(`${e.file}: SHA-256 mismatch (expected ${e.sha256}, got ${got})`);
  const v = new DataView(buf);
  if (e.dtype === 'float16') return bigEndian ? Uint16Array.from({ length: buf.byteLength / 2 }, (_, i) => v.getUint16(2 * i, true)) : new Uint16Array(buf);
  return bigEndian ? Float32Array.from({ length: buf.byteLength / 4 }, (_, i) => v.getFloat32(4 * i, true)) : new Float32Array(buf);
}

// The descriptor at url and the binaries the shader reads, each verified, then SHA256SUMS: rejects with an Error
// naming the file on an HTTP error, bad JSON, a size or checksum mismatch, or a table the shader cannot read. With
// opts.publicKey the export's signature is verified first (twoscale.js' verifySignature).
// Returns { url, general: true, descriptor, domain, tables: { name: { entry, data } }, layout }.
export async function loadTables(url, opts = {}) {
  const base = new URL(url, globalThis.location?.href);
  const name = decodeURIComponent(base.pathname.split('/').pop() || String(url));
  const signed = await signedSums(base, opts, 'loadTables'), sums = signed?.sums;
  const bytes = await (await fetchOk(base, name)).arrayBuffer();
  if (sums) await checkSums(base, name, bytes, [], sums);  // signed: the descriptor's digest before it is parsed
  let d;
  try {
    d = JSON.parse(new TextDecoder().decode(bytes));
  } catch (e) {
    throw new Error(`${name}: not valid JSON (${e.message})`);
  }
  if (d?.format !== FORMAT) throw new Error(`${name}: format ${JSON.stringify(d?.format)}, expected ${FORMAT}`);
  if (!Array.isArray(d.tables) || typeof d.domain !== 'object' || !d.domain) throw new Error(`${name}: needs tables and domain`);
  const entries = TABLES.map((t) => {
    const e = d.tables.find((x) => x.table === t);
    if (!e) throw new Error(`${name}: no table ${t}`);
    return e;
  });
  // signed: the descriptor checked against SHA256SUMS, and the signature's comment against it, before any file it
  // names is fetched
  if (sums) await checkSums(base, name, bytes, d.tables, sums);
  if (signed) expectComment(signed, d, `preset=${d.preset}`);
  const datas = await Promise.all(entries.map((e) => loadBinary(base, e, name)));
  if (!sums) await checkSums(base, name, bytes, d.tables);
  const tables = {};
  entries.forEach((e, i) => (tables[e.table] = { entry: e, data: datas[i] }));
  const t = { url: base.href, general: true, descriptor: d, domain: d.domain, tables };
  t.layout = layout(t, name);
  return t;
}

// An axis as the shader's TsGrid (twoscale.js' grid, for an entry of the general export), checking its encoding.
const ENC_PARAMS = {
  bounded_log: ['eps', 'delta'], bounded_log_tan: ['eps', 'delta'], log_gap: ['end', 'eps'], log1p_sq: ['scale'], shifted_log: ['shift'],
  log: [], linear: [], reciprocal: [], log_plus_log_log1p_sq: [], asin_sqrt: [],
};
function grid(entry, a, kind, where) {
  const axis = entry.axes[a];
  if (axis?.encoding?.kind !== kind) throw new Error(`${where}: ${entry.table}'s axis ${a} is not ${kind}`);
  const n = axis.size, step = (axis.encoded_last - axis.encoded_first) / (n - 1);
  if (!(n >= 2) || !Number.isFinite(step) || step === 0) throw new Error(`${where}: ${entry.table}'s axis ${axis.name}: bad encoded range`);
  const p = ENC_PARAMS[kind].map((k) => axis.encoding[k]);
  return { e0: axis.encoded_first, inv_step: 1 / step, n, p0: p[0] ?? 0, p1: p[1] ?? 0 };
}

// A node's physical coordinate from its encoded one (the encodings of zh_lobe's axes), in double.
const DECODE = { log1p_sq: (e, a) => a.scale * Math.sqrt(Math.expm1(e)), linear: (e) => e, shifted_log: (e, a) => Math.exp(e) + a.shift, log: (e) => Math.exp(e) };

// The grids, the float32 planes packed into one image (plane k at offsets[k]; zh_lobe's nodes per axis last) and
// zh_lobe's float16 residual as its own image.
function layout(t, where) {
  const T = t.tables, e = (n) => T[n].entry;
  const lobe = e('zh_lobe'), d = lobe.derived_axes?.[0];
  if (lobe.dtype !== 'float16' || lobe.values?.[0] !== 'ln_c_residual' || lobe.derived_axes?.length !== 1 || d.kind !== 'anchored_lobe_angle') {
    throw new Error(`${where}: zh_lobe is not the float16 residual over an anchored_lobe_angle (the general export's)`);
  }
  const zc = e('zh_convolution');
  if (JSON.stringify((zc.value_encoding ?? []).map((v) => [v.value, v.kind])) !== '[["s","ln"],["s_cos","ln"]]') {
    throw new Error(`${where}: zh_convolution does not store s and s_cos as ln (an export of version 0.13.0 or later)`);
  }
  const grids = {
    gn_p: grid(e('epd_norm'), 0, 'reciprocal', where),
    gg_p: grid(e('epd_g1'), 0, 'reciprocal', where), gg_a: grid(e('epd_g1'), 1, 'bounded_log', where),
    gk_s: grid(e('kcorr_renorm'), 0, 'log_gap', where), gk_b: grid(e('kcorr_renorm'), 1, 'log_plus_log_log1p_sq', where),
    gk_c: grid(e('kcorr_renorm'), 2, 'shifted_log', where),
    gz_u: grid(zc, 0, 'shifted_log', where), gz_c: grid(zc, 1, 'linear', where), gz_p: grid(zc, 2, 'log', where), gz_beta: grid(zc, 3, 'log', where),
    gl_u: grid(lobe, 0, 'log1p_sq', where), gl_c: grid(lobe, 1, 'linear', where), gl_p: grid(lobe, 2, 'shifted_log', where),
    gl_beta: grid(lobe, 3, 'log', where), gl_v: grid(lobe, 4, 'linear', where),
    gq_p: grid(e('epd_quantile'), 0, 'log', where), gq_xi: grid(e('epd_quantile'), 1, 'asin_sqrt', where),
    ga_p: grid(e('epd_albedo'), 0, 'reciprocal', where), ga_beta: grid(e('epd_albedo'), 1, 'log', where),
    ga_theta: grid(e('epd_albedo'), 2, 'bounded_log_tan', where),
  };
  // epd_albedo_avg is read on epd_albedo's (p, beta) stencils
  const same = (a, b) => ['e0', 'inv_step', 'n'].every((k) => a[k] === b[k]);
  if (!same(grid(e('epd_albedo_avg'), 0, 'reciprocal', where), grids.ga_p) || !same(grid(e('epd_albedo_avg'), 1, 'log', where), grids.ga_beta)) {
    throw new Error(`${where}: epd_albedo_avg's axes are not epd_albedo's p and beta`);
  }
  const cols = PLANES.map(([, table, value]) => {
    const { entry, data } = T[table], nc = entry.values.length, c = entry.values.indexOf(value);
    if (c < 0) throw new Error(`${where}: ${table} lacks the value ${value}`);
    const col = new Float32Array(data.length / nc);
    for (let i = 0; i < col.length; i++) col[i] = data[i * nc + c];
    return col;
  });
  const nodes = [];
  for (const a of lobe.axes) {
    for (let i = 0; i < a.size; i++) nodes.push(DECODE[a.encoding.kind](a.encoded_first + (i * (a.encoded_last - a.encoded_first)) / (a.size - 1), a.encoding));
  }
  cols.push(Float32Array.from(nodes));
  const keys = [...PLANES.map(([k]) => k), 'nodes'], offsets = {};
  let total = 0;
  keys.forEach((k, i) => {
    offsets[k] = total;
    total += cols[i].length;
  });
  const image = new Float32Array(total);
  keys.forEach((k, i) => image.set(cols[i], offsets[k]));
  const dom = t.domain;
  return {
    grids, offsets, image, lobe: T.zh_lobe.data,
    scalars: { ts_gl_k: d.k, ts_gl_v_anchor: d.v_anchor, ts_gl_theta_cap: d.theta_cap, ts_gp_diff_lo: dom.p_diffraction[0], ts_gp_diff_hi: dom.p_diffraction[1] },
  };
}

// An image of texels as an array texture of ROW x ROW layers (R32F from a Float32Array, R16F from float16 bits).
function arrayTexture(gl, data, half) {
  const n = data.length, rows = Math.ceil(n / ROW), layers = Math.ceil(rows / ROW), height = layers > 1 ? ROW : rows;
  const padded = new data.constructor(ROW * height * layers);
  padded.set(data);
  const tex = gl.createTexture();
  gl.bindTexture(gl.TEXTURE_2D_ARRAY, tex);
  gl.pixelStorei(gl.UNPACK_ALIGNMENT, 1);
  gl.texImage3D(gl.TEXTURE_2D_ARRAY, 0, half ? gl.R16F : gl.R32F, ROW, height, layers, 0, gl.RED, half ? gl.HALF_FLOAT : gl.FLOAT, padded);
  for (const k of [gl.TEXTURE_MIN_FILTER, gl.TEXTURE_MAG_FILTER]) gl.texParameteri(gl.TEXTURE_2D_ARRAY, k, gl.NEAREST);
  gl.bindTexture(gl.TEXTURE_2D_ARRAY, null);
  return tex;
}

const uploads = new WeakMap(); // gl -> WeakMap(t -> [data, lobe])

// The tables' two array textures on this context, uploaded once.
export function uploadTables(gl, t) {
  let perGl = uploads.get(gl);
  if (!perGl) uploads.set(gl, (perGl = new WeakMap()));
  if (!perGl.has(t)) perGl.set(t, [arrayTexture(gl, t.layout.image, false), arrayTexture(gl, t.layout.lobe, true)]);
  return perGl.get(t);
}

// Binds the tables' textures to units firstUnit and firstUnit + 1 and sets the uniforms of ts_general_eval (the
// program is made current); returns the next free unit.
export function bindTables(gl, program, t, firstUnit = 0) {
  const L = t.layout, loc = (n) => gl.getUniformLocation(program, n);
  gl.useProgram(program);
  uploadTables(gl, t).forEach((tex, i) => {
    gl.activeTexture(gl.TEXTURE0 + firstUnit + i);
    gl.bindTexture(gl.TEXTURE_2D_ARRAY, tex);
  });
  gl.uniform1i(loc('ts_gdata'), firstUnit);
  gl.uniform1i(loc('ts_globe'), firstUnit + 1);
  setGrids(gl, program, L.grids);
  for (const [k, v] of Object.entries(L.offsets)) gl.uniform1i(loc(`ts_goff_${k}`), v);
  for (const [k, v] of Object.entries(L.scalars)) gl.uniform1f(loc(k), v);
  return firstUnit + 2;
}

// The #define lines of a general program: TS_GENERAL, the lobe and the energy mode (constants: SwiftShader runs
// both sides of a uniform branch), and TS_G_BAKED where the diffraction part reads a bake (bakeTables).
export function generalModes(lobe, energy, baked = false) {
  return `#define TS_GENERAL 1\n#define TS_G_EXACT ${lobe === 'exact'}\n#define TS_G_COMP ${energy === 'compensated'}\n${baked ? '#define TS_G_BAKED 1\n' : ''}`;
}

// The bake (twoscale_brdf.glsl's ts_bake_value, runtimes/webgl/README.md "The bake"): its grid, chosen by
// measurement (bake_frontier.py, docs/benchmarks.md "The bake"): u nodes log1p_sq of scale 0.5 over [0, b / lambda_min], beta layers log over the
// range (two equal layers for one beta), v nodes over [0, 1].
export const BAKE = { u: 65, beta: 32, v: 257, uScale: 0.5 };
const BAKE_BODY = `
out vec4 ts_out;
void main() {
    ivec2 q = ivec2(gl_FragCoord.xy);
    ts_out = vec4(ts_bake_value(q.y * 2048 + q.x), 0.0, 0.0, 1.0);
}`;
const PACK_BODY = `
uniform highp sampler2D ts_bk_raw;
out vec4 ts_out;
float ts_bk_raw_at(int i) {
    i = min(i, ts_bk_total - 1);
    return texelFetch(ts_bk_raw, ivec2(i & 2047, i >> 11), 0).r;
}
void main() {
    ivec2 q = ivec2(gl_FragCoord.xy);
    int i = q.y * 2048 + q.x, nb = ts_bake_row(i);
    ts_out = vec4(ts_bk_raw_at(i), ts_bk_raw_at(i + 1), ts_bk_raw_at(i + nb), ts_bk_raw_at(i + nb + 1));
}`;
const bakePrograms = new WeakMap(); // gl -> [bake, pack]

// The bake's programs read the tables on texture units BAKE_UNIT and BAKE_UNIT + 1 and pass 1's output on
// BAKE_UNIT + 2, away from the units a page's own passes bind (WebGL2 gives a fragment shader at least 16).
const BAKE_UNIT = 13;

// Bakes on this context what the diffraction part reads at one material's c, p and b and beta over [lo, hi] (inside
// the domain), for the lobe 'exact' (zh_lobe's plane too) or 'fit': { texture, uniforms, key, texels }, for bindBake and a program of generalModes(lobe, energy, true);
// glsl is shaderSource()'s text. Returns `previous` if it is the same bake, else deletes its texture. The bake's c,
// p and b must be the fragments' (TsParams), and their beta within [lo, hi]. Leaves the current program, the active
// texture unit and units BAKE_UNIT.. changed.
export function bakeTables(gl, t, glsl, { c, p, b, beta: [lo, hi], lobe = 'exact' }, previous = null) {
  const pd = Math.min(Math.max(p, t.domain.p_diffraction[0]), t.domain.p_diffraction[1]);
  const key = JSON.stringify([t.url, c, pd, b, lo, hi, lobe]);
  if (previous?.key === key) return previous;
  if (previous) gl.deleteTexture(previous.texture);
  let progs = bakePrograms.get(gl);
  if (!progs) {
    if (!gl.getExtension('EXT_color_buffer_float')) throw new Error('bakeTables: EXT_color_buffer_float is not available (the bake renders into float textures)');
    const modes = generalModes('exact', 'single');
    progs = [BAKE_BODY, PACK_BODY].map((body) => compileProgram(gl, fragmentShader(glsl, body, modes)));
    bakePrograms.set(gl, progs);
  }
  const L = t.layout, kc = L.grids.gk_s.n * L.grids.gk_b.n, layers = lo < hi ? BAKE.beta : 2;
  const uMax = b / t.domain.wavelength[0], eu = Math.log1p((uMax / BAKE.uScale) ** 2), eb = [Math.log(lo), Math.log(hi)];
  const offFs = lobe === 'exact' ? layers * BAKE.u * BAKE.v : 0, offFg = offFs + layers * BAKE.u, offKc = offFg + layers * BAKE.u, total = offKc + kc;
  const uniforms = {
    grids: {
      bk_u: { e0: 0, inv_step: (BAKE.u - 1) / eu, n: BAKE.u, p0: BAKE.uScale, p1: 0 },
      bk_beta: { e0: eb[0], inv_step: lo < hi ? (layers - 1) / (eb[1] - eb[0]) : 0, n: layers, p0: 0, p1: 0 },
    },
    ints: { ts_bk_nv: BAKE.v, ts_bk_off_fs: offFs, ts_bk_off_fg: offFg, ts_bk_off_kc: offKc, ts_bk_total: total },
    floats: { ts_bk_c: c, ts_bk_p: pd },
  };
  const rows = Math.ceil(total / ROW);
  const setBake = (prog) => {
    bindTables(gl, prog, t, BAKE_UNIT);
    setBakeUniforms(gl, prog, uniforms);
  };
  setBake(progs[0]);
  const raw = drawFloat(gl, ROW, rows).texture;
  setBake(progs[1]);
  gl.activeTexture(gl.TEXTURE0 + BAKE_UNIT + 2);
  gl.bindTexture(gl.TEXTURE_2D, raw);
  gl.uniform1i(gl.getUniformLocation(progs[1], 'ts_bk_raw'), BAKE_UNIT + 2);
  const texture = drawFloat(gl, ROW, rows).texture;
  gl.deleteTexture(raw);
  return { texture, uniforms, key, texels: total };
}

// Each grid {e0, inv_step, n, p0, p1} as the shader's TsGrid uniform ts_<name>.
function setGrids(gl, program, grids) {
  const loc = (n) => gl.getUniformLocation(program, n);
  for (const [g, v] of Object.entries(grids)) {
    for (const f of ['e0', 'inv_step', 'p0', 'p1']) gl.uniform1f(loc(`ts_${g}.${f}`), v[f]);
    gl.uniform1i(loc(`ts_${g}.n`), v.n);
  }
}

function setBakeUniforms(gl, program, u) {
  const loc = (n) => gl.getUniformLocation(program, n);
  setGrids(gl, program, u.grids);
  for (const [k, v] of Object.entries(u.ints)) gl.uniform1i(loc(k), v);
  for (const [k, v] of Object.entries(u.floats)) gl.uniform1f(loc(k), v);
}

// Binds a bake to unit `unit` for a program of generalModes(lobe, energy, true) (after bindTables); returns the next unit.
export function bindBake(gl, program, bake, unit) {
  gl.useProgram(program);
  gl.activeTexture(gl.TEXTURE0 + unit);
  gl.bindTexture(gl.TEXTURE_2D, bake.texture);
  gl.uniform1i(gl.getUniformLocation(program, 'ts_gbake'), unit);
  setBakeUniforms(gl, program, bake.uniforms);
  return unit + 1;
}

const EVAL_BODY = `
uniform highp sampler2D ts_in_wi, ts_in_wo, ts_in_m, ts_in_m2;  // (wi, lambda), (wo, 0), (beta, p, sigma_s, b), (c, eta, k, 0)
uniform int ts_in_fresnel;                                     // 0: F = 1; 1: a constant (eta, k); 2: each point's
uniform vec2 ts_in_eta_k;
out vec4 ts_out;
void main() {
    ivec2 q = ivec2(gl_FragCoord.xy);
    vec4 a = texelFetch(ts_in_wi, q, 0), b = texelFetch(ts_in_wo, q, 0), m = texelFetch(ts_in_m, q, 0), m2 = texelFetch(ts_in_m2, q, 0);
    TsFresnel f = ts_fresnel_one();
    if (ts_in_fresnel == 1) f = ts_fresnel_conductor(ts_in_eta_k.x, ts_in_eta_k.y);
    if (ts_in_fresnel == 2) f = ts_fresnel_conductor(m2.y, m2.z);
    ts_out = vec4(ts_general_eval(a.xyz, b.xyz, a.w, TsParams(m.x, m.y, m.z, m.w, m2.x), f, TS_G_EXACT, TS_G_COMP), 0.0, 0.0, 1.0);
}`;

// A material {beta, p, sigma_s, b, c} inside the export's domain, or an Error naming the parameter and the domain.
function checkMaterial(t, mat, where) {
  if (typeof mat !== 'object' || mat === null) throw new Error(`${where}: needs a material {${PARAMS.join(', ')}}`);
  const extra = Object.keys(mat).filter((k) => !PARAMS.includes(k));
  if (extra.length) throw new Error(`${where}: unknown material parameter ${extra.join(', ')} (${PARAMS.join(', ')})`);
  for (const k of PARAMS) {
    const v = mat[k], [lo, hi] = k === 'p' && mat.sigma_s > 0 ? t.domain.p_diffraction : t.domain[k];
    const top = hi === 'inf' ? Infinity : hi;
    if (typeof v !== 'number' || !(v >= lo && v <= top)) throw new Error(`${where}: ${k} = ${v} is outside the domain [${lo}, ${hi}]${k === 'p' && mat.sigma_s > 0 ? ' (p where sigma_s > 0)' : ''}`);
  }
  return mat;
}

// evalPoints on what loadTables returned (twoscale.js' evalPoints calls it): rho (1/sr, without the cosine) at each
// { wi, wo, lambda[, material][, eta, k] } as a Float32Array. opts: material (unless every point has its own), lobe
// 'exact' | 'fit', energy 'single' | 'compensated', fresnel 'one' | { eta, k } | 'conductor' (each point's eta and k),
// baked (false): read a bake over the points' beta range (the explorer's sphere pass), every point's c, p and b the same.
export async function evalGeneral(t, points, opts = {}) {
  if (!Array.isArray(points)) throw new Error('evalPoints: points must be an array');
  const known = ['material', 'fresnel', 'lobe', 'energy', 'baked'];
  const extra = Object.keys(opts).filter((k) => !known.includes(k));
  if (extra.length) throw new Error(`evalPoints: unknown option ${extra.join(', ')} (${known.join(', ')})`);
  const { lobe = 'exact', energy = 'single', fresnel: fr = 'one' } = opts;
  if (!['exact', 'fit'].includes(lobe)) throw new Error(`lobe ${JSON.stringify(lobe)}: 'exact' or 'fit'`);
  if (!['single', 'compensated'].includes(energy)) throw new Error(`energy ${JSON.stringify(energy)}: 'single' or 'compensated'`);
  let fresnel;
  if (fr === 'one') fresnel = { mode: 0 };
  else if (fr === 'conductor') fresnel = { mode: 2 };
  else if (typeof fr === 'object' && fr !== null && Number.isFinite(fr.eta) && Number.isFinite(fr.k) && Object.keys(fr).every((k) => k === 'eta' || k === 'k')) fresnel = { mode: 1, ...fr };
  else throw new Error(`fresnel ${JSON.stringify(fr)}: 'one', {eta, k} or 'conductor'`);
  const shared = opts.material === undefined ? null : checkMaterial(t, opts.material, 'evalPoints: material');
  const vec = (v) => Array.isArray(v) && v.length === 3 && v.every((x) => typeof x === 'number');
  const mats = points.map((q, i) => {
    if (!q || !vec(q.wi) || !vec(q.wo) || typeof q.lambda !== 'number') throw new Error(`evalPoints: point ${i}: needs wi, wo (3 numbers each) and lambda`);
    const [l0, l1] = t.domain.wavelength;
    if (!(q.lambda >= l0 && q.lambda <= l1)) throw new Error(`evalPoints: point ${i}: lambda = ${q.lambda} is outside the domain [${l0}, ${l1}] (micrometres)`);
    if (fresnel.mode === 2 && !(typeof q.eta === 'number' && typeof q.k === 'number')) throw new Error(`evalPoints: point ${i}: fresnel 'conductor' needs its eta and k`);
    if (q.material === undefined && !shared) throw new Error(`evalPoints: point ${i}: no material (give opts.material or the point's own)`);
    return q.material === undefined ? shared : checkMaterial(t, q.material, `evalPoints: point ${i}`);
  });
  const n = points.length, rho = new Float32Array(n);
  if (n === 0) return rho;
  const baked = opts.baked === true;
  if (![undefined, true, false].includes(opts.baked)) throw new Error(`baked ${JSON.stringify(opts.baked)}: true or false`);
  const diffracting = mats.filter((m) => m.sigma_s > 0);
  if (baked && diffracting.some((m) => ['c', 'p', 'b'].some((k) => m[k] !== diffracting[0][k]))) {
    throw new Error('evalPoints: baked needs the same c, p and b at every point where sigma_s > 0');
  }
  const { gl, program } = await evalProgram(generalModes(lobe, energy, baked), EVAL_BODY);
  let unit = bindTables(gl, program, t, 0), bake = null;
  if (baked) {
    const m0 = diffracting[0] ?? mats[0], betas = (diffracting.length ? diffracting : mats).map((m) => m.beta);
    const range = betas.reduce(([lo, hi], x) => [Math.min(lo, x), Math.max(hi, x)], [Infinity, -Infinity]);
    bake = bakeTables(gl, t, await shaderSource(), { c: m0.c, p: m0.p, b: m0.b, beta: range, lobe });
    unit = bindBake(gl, program, bake, unit);
  }
  gl.uniform1i(gl.getUniformLocation(program, 'ts_in_fresnel'), fresnel.mode);
  gl.uniform2f(gl.getUniformLocation(program, 'ts_in_eta_k'), fresnel.eta ?? 1, fresnel.k ?? 0);
  ['ts_in_wi', 'ts_in_wo', 'ts_in_m', 'ts_in_m2'].forEach((u, i) => gl.uniform1i(gl.getUniformLocation(program, u), unit + i));
  for (let start = 0; start < n; start += BATCH * BATCH) {
    const count = Math.min(BATCH * BATCH, n - start), w = Math.min(count, BATCH), h = Math.ceil(count / w);
    const ins = [0, 1, 2, 3].map(() => new Float32Array(4 * w * h));
    for (let i = 0; i < count; i++) {
      const q = points[start + i], m = mats[start + i];
      ins[0].set([q.wi[0], q.wi[1], q.wi[2], q.lambda], 4 * i);
      ins[1].set([q.wo[0], q.wo[1], q.wo[2], 0], 4 * i);
      ins[2].set([m.beta, m.p, m.sigma_s, m.b], 4 * i);
      ins[3].set([m.c, q.eta ?? 1, q.k ?? 0, 0], 4 * i);
    }
    const inputs = ins.map((d) => floatTexture(gl, w, h, d));
    bindTextures(gl, inputs, unit);
    const out = renderFloat(gl, w, h);
    inputs.forEach((x) => gl.deleteTexture(x));
    for (let i = 0; i < count; i++) rho[start + i] = out[4 * i];
  }
  if (bake) gl.deleteTexture(bake.texture);
  return rho;
}
