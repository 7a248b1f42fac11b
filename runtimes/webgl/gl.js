// gl.js: the WebGL2 plumbing the runtime's modules share: twoscale_brdf.glsl's source, shaders and programs,
// float textures and render targets, and the module's own context for evaluating points. twoscale.js re-exports it.
import { fetchOk } from './verify.js';

let sourcePromise = null;

// twoscale_brdf.glsl beside this module (fetched once).
export function shaderSource() {
  sourcePromise ??= fetchOk(new URL('twoscale_brdf.glsl', import.meta.url), 'twoscale_brdf.glsl')
    .then((r) => r.text())
    .catch((e) => {
      sourcePromise = null;
      throw e;
    });
  return sourcePromise;
}

// A GLSL ES 3.00 fragment shader: the version line, highp precisions (a fragment shader's sampler2D defaults
// to lowp), twoscale_brdf.glsl, then the caller's body (its outputs and main).
// modes: shaderModes(m, choices) to compile for one material and mode (faster; bind it with the same m and choices).
export function fragmentShader(glsl, body, modes = '') {
  return `#version 300 es\nprecision highp float;\nprecision highp int;\nprecision highp sampler2D;\n${modes}${glsl}\n${body}`;
}

// A full-screen triangle (no attributes): drawArrays(TRIANGLES, 0, 3) covers the viewport.
export const FULLSCREEN_VERTEX = `#version 300 es
void main() {
    vec2 p = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2));
    gl_Position = vec4(2.0 * p - 1.0, 0.0, 1.0);
}`;

// A linked program; compile or link errors as an Error with the info log.
export function compileProgram(gl, fragmentSource, vertexSource = FULLSCREEN_VERTEX) {
  const shader = (type, src, what) => {
    const s = gl.createShader(type);
    gl.shaderSource(s, src);
    gl.compileShader(s);
    if (!gl.getShaderParameter(s, gl.COMPILE_STATUS)) {
      const log = gl.getShaderInfoLog(s);
      gl.deleteShader(s);
      throw new Error(`${what} shader: ${log}`);
    }
    return s;
  };
  const vs = shader(gl.VERTEX_SHADER, vertexSource, 'vertex'), fs = shader(gl.FRAGMENT_SHADER, fragmentSource, 'fragment');
  const p = gl.createProgram();
  gl.attachShader(p, vs);
  gl.attachShader(p, fs);
  gl.linkProgram(p);
  gl.deleteShader(vs);
  gl.deleteShader(fs);
  if (!gl.getProgramParameter(p, gl.LINK_STATUS)) {
    const log = gl.getProgramInfoLog(p);
    gl.deleteProgram(p);
    throw new Error(`program link: ${log}`);
  }
  return p;
}

let context = null; // { gl, programs: Map(modes and body -> program) }

// The module's WebGL2 context for evalPoints (an OffscreenCanvas, or a detached canvas; twoscale_general.js' too) and
// the program of fragmentShader(glsl, body, modes), each compiled once.
export async function evalProgram(modes, body) {
  if (!context) {
    const canvas = typeof OffscreenCanvas !== 'undefined' ? new OffscreenCanvas(1, 1) : document.createElement('canvas');
    const gl = canvas.getContext('webgl2', { antialias: false, depth: false, stencil: false, alpha: true, preserveDrawingBuffer: false });
    if (!gl) throw new Error('evalPoints: WebGL2 is not available');
    if (!gl.getExtension('EXT_color_buffer_float')) throw new Error('evalPoints: EXT_color_buffer_float is not available (a float render target is needed)');
    context = { gl, programs: new Map() };
  }
  const { gl, programs } = context, key = `${modes}\n${body}`;
  if (!programs.has(key)) programs.set(key, compileProgram(gl, fragmentShader(await shaderSource(), body, modes)));
  return { gl, program: programs.get(key) };
}

// An RGBA32F texture of w x h texels (NEAREST), data or empty; the active unit's binding is left as it was.
export function floatTexture(gl, w, h, data = null) {
  const t = gl.createTexture(), prev = gl.getParameter(gl.TEXTURE_BINDING_2D);
  gl.bindTexture(gl.TEXTURE_2D, t);
  gl.pixelStorei(gl.UNPACK_ALIGNMENT, 4);
  gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA32F, w, h, 0, gl.RGBA, gl.FLOAT, data);
  gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.NEAREST);
  gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.NEAREST);
  gl.bindTexture(gl.TEXTURE_2D, prev);
  return t;
}

// Binds each texture to unit firstUnit + i.
export function bindTextures(gl, list, firstUnit) {
  list.forEach((t, i) => {
    gl.activeTexture(gl.TEXTURE0 + firstUnit + i);
    gl.bindTexture(gl.TEXTURE_2D, t);
  });
}

// Draws the bound program's full-screen triangle into a new w x h RGBA32F texture; with `read`, also returns its texels
// (RGBA, FLOAT). The caller's framebuffer and viewport are restored. A lost context or a refused draw is an Error,
// never zeros read back as a result.
export function drawFloat(gl, w, h, read = false) {
  const prevFb = gl.getParameter(gl.FRAMEBUFFER_BINDING), prevView = gl.getParameter(gl.VIEWPORT);
  const texture = floatTexture(gl, w, h), fb = gl.createFramebuffer();
  gl.bindFramebuffer(gl.FRAMEBUFFER, fb);
  gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0, gl.TEXTURE_2D, texture, 0);
  const status = gl.checkFramebufferStatus(gl.FRAMEBUFFER);
  if (status !== gl.FRAMEBUFFER_COMPLETE) throw new Error(`a float render target is incomplete (status 0x${status.toString(16)})`);
  gl.viewport(0, 0, w, h);
  gl.disable(gl.BLEND);
  gl.drawArrays(gl.TRIANGLES, 0, 3);
  const texels = read ? new Float32Array(4 * w * h) : null;
  if (read) gl.readPixels(0, 0, w, h, gl.RGBA, gl.FLOAT, texels);
  const err = gl.getError();
  if (gl.isContextLost() || err !== gl.NO_ERROR) throw new Error(gl.isContextLost() ? 'the WebGL context was lost' : `WebGL error 0x${err.toString(16)} in a float render`);
  gl.bindFramebuffer(gl.FRAMEBUFFER, prevFb);
  gl.viewport(...prevView);
  gl.deleteFramebuffer(fb);
  return { texture, texels };
}

// Draws the bound program's full-screen triangle into a w x h RGBA32F target; returns its texels (RGBA, FLOAT).
export function renderFloat(gl, w, h) {
  const { texture, texels } = drawFloat(gl, w, h, true);
  gl.deleteTexture(texture);
  return texels;
}
