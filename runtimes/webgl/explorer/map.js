// The sphere's parameter map (general tables): which parameter it drives, its pixels and their texture.
import { material, ui } from './page.js';

// The sphere's parameter map (general tables): none, beta or sigma_s, from values v in [0, 1] over (longitude,
// latitude): the procedural pattern below, or the luminance of an image the user drops on the sphere.
export const MAPS = ['none', 'beta', 'sigma_s'];
const MAP_SIZE = 256;
let mapPixels = null;   // Uint8Array MAP_SIZE^2 (or the dropped image's size), row 0 at latitude -90 deg
let mapSize = [MAP_SIZE, MAP_SIZE];
// The map's values (row 0 at latitude -90 deg) and their size: the procedural one, or a dropped image's.
export function setMap(pixels, size = [MAP_SIZE, MAP_SIZE]) { mapPixels = pixels; mapSize = size; }
const mapTextures = new WeakMap();   // gl -> [texture, pixels uploaded]

// A worn metal: 0.5 overall, a polished patch (0), three scratches (1) and a worn band (0.8) about the equator.
export function proceduralMap() {
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
export function betaRange(beta) {
  const [lo, hi] = material.domain.beta, clamp = (x) => Math.min(Math.max(x, lo), hi);
  return ui.map === 'beta' ? [clamp(beta / 4), clamp(4 * beta)] : [beta, beta];
}

// The map's R8 texture (LINEAR: 8-bit textures filter everywhere) on unit `unit`, uploaded when it changed.
export function bindMaterialMap(gl, p, unit) {
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
