// The sphere's programs and uniforms on one WebGL2 context (the interactive sphere's and the bench's).
import {
  uploadMaterial, uploadTables, bindMaterial, bindTables, bakeTables, bindBake, shaderModes, generalModes, fresnelAverage, compileProgram,
  fragmentShader,
} from '../twoscale.js';
import { material, ui, DEG } from './page.js';
import { VIS, SPECTRAL, CNORM } from './colour.js';
import { isGeneral, matParams, range } from './material.js';
import { MAPS, betaRange, bindMaterialMap } from './map.js';
import { SPHERE_GLSL, DISPLAY_FS, EMPTY_FS } from './sphere_shader.js';

// Programs and uniforms of the sphere on one WebGL2 context.
export class SphereRenderer {
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
