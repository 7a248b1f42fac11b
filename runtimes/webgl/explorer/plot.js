// What the 2-D plots share: a canvas in device pixels, the colours of grids and labels, log-scale labels.
import { $ } from './page.js';

// A canvas sized to its box in device pixels; drawing in CSS pixels.
export function canvas2d(id) {
  const c = $(id), dpr = window.devicePixelRatio || 1, w = c.clientWidth, h = c.clientHeight;
  c.width = Math.round(w * dpr);
  c.height = Math.round(h * dpr);
  const g = c.getContext('2d');
  g.setTransform(dpr, 0, 0, dpr, 0, 0);
  g.clearRect(0, 0, w, h);
  g.font = '11px system-ui, sans-serif';
  return { g, w, h };
}
export const GRID = '#3a3f46', AXIS = '#8a9099', TEXT = '#b8bdc4';

// "10^k" with a raised exponent.
export function decadeLabel(g, k, x, y, align = 'left') {
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
export function logTop(values) {
  let m = 0;
  for (const v of values) if (v > m && Number.isFinite(v)) m = v;
  return m > 0 ? Math.ceil(Math.log10(m) - 1e-9) : 0;
}
