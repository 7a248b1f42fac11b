// The WebGL runtime's test harness (runtimes/webgl/tests/test_webgl_brdf.py): one page load runs a case
// (?case=URL, JSON) and writes { id: base64 of a Float32Array, or { error } } into #result, then "done"
// into #status. A case:
//   { materials: { name: descriptor URL },
//     evals:   [{ id, material, opts, points: URL }],   // points: float32 [n][9] = wi, wo, lambda, eta, k -> evalPoints
//     samples: [{ id, material, lobe, energy, inputs: URL }],  // float32 [n][12] = wi, lambda0, xi1, xi2, eta, k, wo, 0
//                                                         // -> [n][8] = ts_sample's wo, pdf, weight, ts_pdf(wi, wo sampled), ts_pdf(wi, wo given), 0
//     rejects: [{ id, url }],                              // loadMaterial(url) must reject: its message
//     general: [{ id, tables: URL, opts, points: URL[, range] }],   // float32 [n][14] = wi, wo, lambda, beta, p, sigma_s, b, c,
//                                                          // eta, k -> evalPoints(loadTables(tables), points, opts);
//                                                          // range: [first, end) of the file's points
//     generalSamples: [{ id, tables: URL, lobe, energy, inputs: URL }], // float32 [n][16] = wi, lambda0, xi1, xi2, beta, p,
//                                                          // sigma_s, b, c, eta, k, wo -> [n][8] as samples, by ts_general_sample / _pdf
//     generalRejects: [{ id, url }],                       // loadTables(url) must reject: its message
//     albedos: [{ id, tables: URL | material, ui, lambda, energies }], // the explorer's albedo curves (explorer/albedo.js)
//                                                          // with its controls' values ui (beta, p, ... for the tables)
//                                                          // -> { theta (deg), <energy>: values, note: albedoNote's }
//     loads: [{ id, url, opts, general, points, noEd25519 }] } // loadMaterial(url, opts) (general: loadTables) ->
//                                                          // { rejected: its message } or { tables: how many[, rho: base64 of
//                                                          // evalPoints(points as evals', exact single F = 1)] }; noEd25519:
//                                                          // importKey refuses Ed25519 as a browser without it does
import * as ts from '../twoscale.js';

const SAMPLE_BODY = `
uniform highp sampler2D ts_h_a, ts_h_b, ts_h_c;  // (wi, lambda0), (xi1, xi2, eta, k), (wo, 0)
uniform int ts_h_pass;
out vec4 ts_h_out;
void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    vec4 a = texelFetch(ts_h_a, p, 0), b = texelFetch(ts_h_b, p, 0), c = texelFetch(ts_h_c, p, 0);
    TsFresnel f = ts_fresnel_one();  // (no ?: on structures in ESSL)
    if (b.z > 0.0) f = ts_fresnel_conductor(b.z, b.w);
    float pdf, weight;
    vec3 wo = ts_sample(a.xyz, a.w, b.xy, f, pdf, weight);
    ts_h_out = ts_h_pass == 0 ? vec4(wo, pdf) : vec4(weight, ts_pdf(a.xyz, wo, a.w), ts_pdf(a.xyz, c.xyz, a.w), 0.0);
}`;

const GENERAL_SAMPLE_BODY = `
uniform highp sampler2D ts_h_a, ts_h_b, ts_h_c, ts_h_d;  // (wi, lambda0), (xi1, xi2, eta, k), (wo, 0), (beta, p, sigma_s, b)
uniform highp sampler2D ts_h_e;                          // (c, 0, 0, 0)
uniform int ts_h_pass;
out vec4 ts_h_out;
void main() {
    ivec2 q = ivec2(gl_FragCoord.xy);
    vec4 a = texelFetch(ts_h_a, q, 0), b = texelFetch(ts_h_b, q, 0), c = texelFetch(ts_h_c, q, 0), d = texelFetch(ts_h_d, q, 0);
    TsParams m = TsParams(d.x, d.y, d.z, d.w, texelFetch(ts_h_e, q, 0).x);
    TsFresnel f = ts_fresnel_one();
    if (b.z > 0.0) f = ts_fresnel_conductor(b.z, b.w);
    float pdf, weight;
    vec3 wo = ts_general_sample(a.xyz, a.w, b.xy, m, f, TS_G_EXACT, TS_G_COMP, pdf, weight);
    ts_h_out = ts_h_pass == 0 ? vec4(wo, pdf)
        : vec4(weight, ts_general_pdf(a.xyz, wo, a.w, m, TS_G_COMP), ts_general_pdf(a.xyz, c.xyz, a.w, m, TS_G_COMP), 0.0);
}`;

// ts_general_sample and ts_general_pdf through bindTables, the program compiled for the job's lobe and energy.
const generalSamplers = new Map();
async function runGeneralSamples(t, job) {
  const modes = ts.generalModes(job.lobe, job.energy);
  if (!generalSamplers.has(modes)) {
    const gl = generalSamplers.size ? generalSamplers.values().next().value.gl : new OffscreenCanvas(1, 1).getContext('webgl2');
    if (!gl.getExtension('EXT_color_buffer_float')) throw new Error('no EXT_color_buffer_float');
    generalSamplers.set(modes, { gl, program: ts.compileProgram(gl, ts.fragmentShader(await ts.shaderSource(), GENERAL_SAMPLE_BODY, modes)) });
  }
  const { gl, program } = generalSamplers.get(modes);
  const x = await floats(job.inputs), n = x.length / 16;
  const ins = [0, 1, 2, 3, 4].map(() => new Float32Array(4 * n));
  for (let i = 0; i < n; i++) {
    ins[0].set(x.subarray(16 * i, 16 * i + 4), 4 * i);
    ins[1].set(x.subarray(16 * i + 4, 16 * i + 6), 4 * i);
    ins[1].set(x.subarray(16 * i + 11, 16 * i + 13), 4 * i + 2);
    ins[2].set(x.subarray(16 * i + 13, 16 * i + 16), 4 * i);
    ins[3].set(x.subarray(16 * i + 6, 16 * i + 10), 4 * i);
    ins[4][4 * i] = x[16 * i + 10];
  }
  const unit = ts.bindTables(gl, program, t, 0);
  const inputs = ins.map((d) => ts.floatTexture(gl, n, 1, d));
  ts.bindTextures(gl, inputs, unit);
  ['ts_h_a', 'ts_h_b', 'ts_h_c', 'ts_h_d', 'ts_h_e'].forEach((u, i) => gl.uniform1i(gl.getUniformLocation(program, u), unit + i));
  const out = new Float32Array(8 * n);
  for (const pass of [0, 1]) {
    gl.uniform1i(gl.getUniformLocation(program, 'ts_h_pass'), pass);
    const px = ts.renderFloat(gl, n, 1);
    for (let i = 0; i < n; i++) out.set(px.subarray(4 * i, 4 * i + 4), 8 * i + 4 * pass);
  }
  inputs.forEach((tex) => gl.deleteTexture(tex));
  return out;
}

function b64(f32) {
  const bytes = new Uint8Array(f32.buffer, f32.byteOffset, f32.byteLength);
  let s = '';
  for (let i = 0; i < bytes.length; i += 0x8000) s += String.fromCharCode.apply(null, bytes.subarray(i, i + 0x8000));
  return btoa(s);
}

async function floats(url) {
  const r = await fetch(url);
  if (!r.ok) throw new Error(`${url}: HTTP ${r.status}`);
  return new Float32Array(await r.arrayBuffer());
}

// ts_sample and ts_pdf through the explorer's API: shaderSource, fragmentShader, bindMaterial on a page context.
let sampler = null;
async function runSamples(m, job) {
  if (!sampler) {
    const gl = new OffscreenCanvas(1, 1).getContext('webgl2');
    if (!gl.getExtension('EXT_color_buffer_float')) throw new Error('no EXT_color_buffer_float');
    sampler = { gl, program: ts.compileProgram(gl, ts.fragmentShader(await ts.shaderSource(), SAMPLE_BODY)) };
  }
  const { gl, program } = sampler;
  const x = await floats(job.inputs), n = x.length / 12;
  const a = new Float32Array(4 * n), b = new Float32Array(4 * n), c = new Float32Array(4 * n);
  for (let i = 0; i < n; i++) {
    a.set(x.subarray(12 * i, 12 * i + 4), 4 * i);
    b.set(x.subarray(12 * i + 4, 12 * i + 8), 4 * i);
    c.set(x.subarray(12 * i + 8, 12 * i + 12), 4 * i);
  }
  const unit = ts.bindMaterial(gl, program, m, { lobe: job.lobe, energy: job.energy }, 0);
  const inputs = [a, b, c].map((d) => ts.floatTexture(gl, n, 1, d));
  ts.bindTextures(gl, inputs, unit);
  ['ts_h_a', 'ts_h_b', 'ts_h_c'].forEach((u, i) => gl.uniform1i(gl.getUniformLocation(program, u), unit + i));
  const out = new Float32Array(8 * n);
  for (const pass of [0, 1]) {
    gl.uniform1i(gl.getUniformLocation(program, 'ts_h_pass'), pass);
    const px = ts.renderFloat(gl, n, 1);
    for (let i = 0; i < n; i++) out.set(px.subarray(4 * i, 4 * i + 4), 8 * i + 4 * pass);
  }
  inputs.forEach((t) => gl.deleteTexture(t));
  return out;
}

async function run() {
  const c = await (await fetch(new URLSearchParams(location.search).get('case'))).json();
  const results = {}, mats = {}, t0 = performance.now();
  const material = (name) => (mats[name] ??= ts.loadMaterial(c.materials[name]));
  const guard = async (id, f) => {
    try {
      results[id] = await f();
    } catch (e) {
      results[id] = { error: String(e && e.message || e) };
    }
  };
  for (const job of c.evals ?? []) {
    await guard(job.id, async () => {
      const m = await material(job.material), x = await floats(job.points), points = [];
      for (let i = 0; i < x.length; i += 9) points.push({ wi: [x[i], x[i + 1], x[i + 2]], wo: [x[i + 3], x[i + 4], x[i + 5]], lambda: x[i + 6], eta: x[i + 7], k: x[i + 8] });
      return b64(await ts.evalPoints(m, points, job.opts));
    });
  }
  for (const job of c.samples ?? []) await guard(job.id, async () => b64(await runSamples(await material(job.material), job)));
  for (const job of c.rejects ?? []) {
    await guard(job.id, async () => {
      try {
        await ts.loadMaterial(job.url);
      } catch (e) {
        return { rejected: e.message };
      }
      return { rejected: null };
    });
  }
  const tableSets = {};
  for (const job of c.general ?? []) {
    await guard(job.id, async () => {
      const t = await (tableSets[job.tables] ??= ts.loadTables(job.tables)), points = [];
      const all = await floats(job.points), x = job.range ? all.subarray(14 * job.range[0], 14 * job.range[1]) : all;
      for (let i = 0; i < x.length; i += 14) {
        points.push({ wi: [x[i], x[i + 1], x[i + 2]], wo: [x[i + 3], x[i + 4], x[i + 5]], lambda: x[i + 6], eta: x[i + 12], k: x[i + 13],
          material: { beta: x[i + 7], p: x[i + 8], sigma_s: x[i + 9], b: x[i + 10], c: x[i + 11] } });
      }
      return b64(await ts.evalPoints(t, points, job.opts));
    });
  }
  for (const job of c.generalSamples ?? []) {
    await guard(job.id, async () => b64(await runGeneralSamples(await (tableSets[job.tables] ??= ts.loadTables(job.tables)), job)));
  }
  for (const job of c.generalRejects ?? []) {
    await guard(job.id, async () => {
      try {
        await ts.loadTables(job.url);
      } catch (e) {
        return { rejected: e.message };
      }
      return { rejected: null };
    });
  }
  for (const job of c.loads ?? []) {
    await guard(job.id, async () => {
      const subtle = crypto.subtle, importKey = subtle.importKey;
      if (job.noEd25519) {
        subtle.importKey = (...a) => (a[2]?.name === 'Ed25519' ? Promise.reject(new DOMException('Algorithm: Unrecognized name', 'NotSupportedError')) : importKey.apply(subtle, a));
      }
      let m;
      try {
        m = await (job.general ? ts.loadTables : ts.loadMaterial)(job.url, job.opts);
      } catch (e) {
        return { rejected: e.message };
      } finally {
        delete subtle.importKey;
      }
      const out = { tables: Object.keys(m.tables).length };
      if (job.points) {
        const x = await floats(job.points), points = [];
        for (let i = 0; i < x.length; i += 9) points.push({ wi: [x[i], x[i + 1], x[i + 2]], wo: [x[i + 3], x[i + 4], x[i + 5]], lambda: x[i + 6] });
        out.rho = b64(await ts.evalPoints(m, points));
      }
      return out;
    });
  }
  for (const job of c.albedos ?? []) {
    await guard(job.id, async () => {
      // the explorer's own albedo curve (explorer/albedo.js), its page state set as its controls set it
      const [{ setMaterial, ui }, { computeAlbedo, albedoNote, ALBEDO_THETAS }] = await Promise.all([import('../explorer/page.js'), import('../explorer/albedo.js')]);
      setMaterial(job.tables ? await (tableSets[job.tables] ??= ts.loadTables(job.tables)) : await material(job.material));
      Object.assign(ui, { lobe: 'exact', fresnel: 'one', eta: 1, kappa: 0, ...job.ui });
      const curves = {};
      for (const e of job.energies) curves[e] = await computeAlbedo(e, job.lambda);
      return { theta: ALBEDO_THETAS, ...Object.fromEntries(Object.entries(curves).map(([e, r]) => [e, r.values])), note: albedoNote(curves, !!job.tables) };
    });
  }
  results.seconds = (performance.now() - t0) / 1e3;
  return results;
}

run().then(
  (r) => {
    document.getElementById('result').textContent = JSON.stringify(r);
    document.getElementById('status').textContent = 'done';
  },
  (e) => (document.getElementById('status').textContent = `error: ${e && e.message || e}`),
);
