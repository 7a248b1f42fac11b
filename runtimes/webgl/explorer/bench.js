// The bench (&bench=1): the sphere pass against a GGX pass, timed on the page.
import { loadMaterial, bakeTables } from '../twoscale.js';
import { $, query, ui, material } from './page.js';
import { NL } from './colour.js';
import { isGeneral, matParams } from './material.js';
import { betaRange } from './map.js';
import { SphereRenderer } from './sphere_renderer.js';

// The per-pixel cost of the twoscale sphere pass against GGX: n draws of each at size x size, interleaved,
// each timed to completion (gl.finish and a 1-pixel readPixels), medians; a constant-colour pass gives the
// fixed cost of a draw, which the net ratio removes. With the general tables and &material=URL, the general
// pass (with &map=beta, its parameters per pixel) also against that material's own pass.
export async function bench(src) {
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
