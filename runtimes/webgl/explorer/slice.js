// The slice: rho over (theta_h, theta_d) at phi_d = 90 deg, a colour map on a log scale.
import { evalPoints } from '../twoscale.js';
import { $, status, ui, material, DEG } from './page.js';
import { inferno } from './colour.js';
import { clampLambda, brdfOptions } from './material.js';
import { canvas2d, decadeLabel, logTop, AXIS, TEXT } from './plot.js';

const SLICE_N = 128;
const SLICE_DECADES = 7;      // of the slice's log scale

// The slice: rho(theta_h, theta_d) at phi_d = 90 deg (h in the xz-plane, wi and wo mirrored about it across
// the plane), theta_h on a linear or square-root axis (the MERL tabulation's, which opens up a sharp peak).
const sliceThetaH = (x) => (ui.sliceAxis === 'sqrt' ? x * x : x) * 90;

export async function drawSlice(stale) {
  const lambda = clampLambda(ui.lambda), points = [];
  for (let j = 0; j < SLICE_N; j++) {        // theta_d, bottom row first
    const td = ((j + 0.5) / SLICE_N) * 90 * DEG;
    for (let i = 0; i < SLICE_N; i++) {
      const thh = sliceThetaH((i + 0.5) / SLICE_N) * DEG;
      const hx = Math.sin(thh), hz = Math.cos(thh), cd = Math.cos(td), sd = Math.sin(td);
      // d = (0, sin td, cos td) in the frame of h, rotated by theta_h about y
      const wi = [cd * hx, sd, cd * hz], wo = [cd * hx, -sd, cd * hz];
      points.push({ wi, wo, lambda });
    }
  }
  const rho = await evalPoints(material, points, brdfOptions());
  if (stale()) return;
  const { g, w, h } = canvas2d('slice');
  const left = 40, bottom = 30, bar = 46, size = Math.max(32, Math.min(w - left - bar - 12, h - bottom - 10));
  const x0 = left + Math.max(0, (w - left - bar - 12 - size) / 2), y0 = 8;
  // the scale's top from theta_d <= 75 deg: towards grazing rho grows as 1 / (cos theta_i cos theta_o) and
  // would push the peak and its tail into the colour map's bottom; brighter values saturate
  const top = logTop(rho.subarray(0, Math.round((75 / 90) * SLICE_N) * SLICE_N)), lo = top - SLICE_DECADES;
  const img = new ImageData(SLICE_N, SLICE_N);
  for (let j = 0; j < SLICE_N; j++) for (let i = 0; i < SLICE_N; i++) {
    const v = rho[j * SLICE_N + i], o = 4 * ((SLICE_N - 1 - j) * SLICE_N + i);
    const [r, gg, b] = v > 0 ? inferno(Math.min(Math.max((Math.log10(v) - lo) / SLICE_DECADES, 0), 1)) : [24, 26, 30];
    img.data.set([r, gg, b, 255], o);
  }
  const tmp = new OffscreenCanvas(SLICE_N, SLICE_N);
  tmp.getContext('2d').putImageData(img, 0, 0);
  g.imageSmoothingEnabled = false;
  g.drawImage(tmp, x0, y0, size, size);
  // axes
  g.strokeStyle = AXIS;
  g.strokeRect(x0 - 0.5, y0 - 0.5, size + 1, size + 1);
  g.fillStyle = TEXT;
  g.textAlign = 'center';
  const ticks = ui.sliceAxis === 'sqrt' ? [0, 2, 10, 22.5, 45, 90] : [0, 15, 30, 45, 60, 75, 90];
  for (const t of ticks) {
    const x = x0 + size * (ui.sliceAxis === 'sqrt' ? Math.sqrt(t / 90) : t / 90);
    g.beginPath(); g.moveTo(x, y0 + size); g.lineTo(x, y0 + size + 4); g.stroke();
    g.fillText(`${t}°`, x, y0 + size + 15);
  }
  g.fillText(`θh${ui.sliceAxis === 'sqrt' ? ' (√ axis)' : ''}`, x0 + size / 2, y0 + size + 27);
  g.textAlign = 'right';
  for (const t of [0, 30, 60, 90]) {
    const y = y0 + size * (1 - t / 90);
    g.beginPath(); g.moveTo(x0 - 4, y); g.lineTo(x0, y); g.stroke();
    g.fillText(`${t}°`, x0 - 6, y + 4);
  }
  g.save(); g.translate(11, y0 + size / 2); g.rotate(-Math.PI / 2); g.textAlign = 'center'; g.fillText('θd', 0, 0); g.restore();
  // colour bar with its decades
  const bx = x0 + size + 10;
  for (let k = 0; k < size; k++) { const [r, gg, b] = inferno(1 - k / size); g.fillStyle = `rgb(${r},${gg},${b})`; g.fillRect(bx, y0 + k, 10, 1.5); }
  g.fillStyle = TEXT;
  for (let k = 1; k <= SLICE_DECADES; k += 2) decadeLabel(g, lo + k, bx + 13, y0 + size * (1 - k / SLICE_DECADES) + 4);
  $('slice-sub').textContent = `${(1000 * lambda).toFixed(0)} nm · ${SLICE_N}² points`;
  status.slice = { points: points.length, max: Math.max(...rho) };
  status.drawn.slice = true;
}
