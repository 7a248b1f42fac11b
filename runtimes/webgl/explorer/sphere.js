// The interactive sphere: a point light, then the sky refined frame by frame, shown with the exposure.
import { $, query, status, ui, pageStart, maybeReady } from './page.js';
import { VIS, NL } from './colour.js';
import { range } from './material.js';
import { SphereRenderer } from './sphere_renderer.js';

// The interactive sphere: the point light drawn once into a float texture, the sky's running mean in a
// ping-pong pair of them (each animation frame adds SPP_FRAME samples a pixel until spp are in, then the
// page idles); the display pass adds them, exposes and encodes.
const SPP_FRAME = 2;   // directions a pixel a frame (each at 4 wavelengths)
const sphere = { renderer: null, size: 0, point: null, targets: [], count: 0, frames: 0, raf: 0, float: false };

export function initSphere(src) {
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

export function resizeSphere() {
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

export function restartSphere() {
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

export function displaySphere() {
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
