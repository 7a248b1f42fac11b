// The polar plot: rho in the plane of incidence at three wavelengths, on a log scale.
import { evalPoints } from '../twoscale.js';
import { $, status, ui, material, DEG } from './page.js';
import { lambdaCss } from './colour.js';
import { clampLambda, matParams, brdfOptions } from './material.js';
import { canvas2d, decadeLabel, logTop, GRID, AXIS, TEXT } from './plot.js';

const POLAR_LAMBDAS = [0.45, 0.55, 0.65];
const DECADES = 6;            // of the polar plot's log scale

// Polar plot of rho in the incidence plane: wi at theta_i on the left, wo at theta in (-90, 90) deg
// (positive to the right, where the mirror direction is), radius log10 rho over DECADES decades.
// A 0.5-degree grid plus 241 points within 6 lobe widths of the mirror direction, so that a sharp
// peak (beta 0.005: 0.6 degrees wide in theta_o) is resolved.
function polarAngles(thetaI) {
  const beta = matParams().beta, w = Math.max(2 * Math.atan(beta), 0.002) / DEG;
  const a = [];
  for (let t = -89.75; t < 90; t += 0.5) a.push(t);
  for (let i = -120; i <= 120; i++) a.push(thetaI + (6 * w * i) / 120);
  return [...new Set(a.filter((t) => t > -89.99 && t < 89.99).map((t) => +t.toFixed(6)))].sort((x, y) => x - y);
}

export async function drawPolar(stale) {
  const th = ui.theta * DEG, wi = [-Math.sin(th), 0, Math.cos(th)];
  const lams = [...new Set(POLAR_LAMBDAS.map(clampLambda))];
  const angles = polarAngles(ui.theta);
  const points = [];
  for (const lambda of lams) for (const t of angles) points.push({ wi, wo: [Math.sin(t * DEG), 0, Math.cos(t * DEG)], lambda });
  const rho = await evalPoints(material, points, brdfOptions());
  if (stale()) return;
  const { g, w, h } = canvas2d('polar');
  const cx = w / 2, cy = h - 22, R = Math.min(w / 2 - 34, h - 44);
  const top = logTop(rho), lo = top - DECADES;
  const rad = (v) => (v > 0 ? R * Math.min(Math.max((Math.log10(v) - lo) / DECADES, 0), 1) : 0);
  // decade half-circles and angle spokes
  g.lineWidth = 1;
  g.strokeStyle = GRID;
  g.fillStyle = TEXT;
  for (let k = 1; k <= DECADES; k++) {
    g.beginPath(); g.arc(cx, cy, (R * k) / DECADES, Math.PI, 2 * Math.PI); g.stroke();
    if (k % (DECADES > 6 ? 2 : 1) === 0) decadeLabel(g, lo + k, cx + (R * k) / DECADES - 2, cy + 14, 'center');
  }
  g.textAlign = 'center';
  for (let a = -90; a <= 90; a += 30) {
    const s = Math.sin(a * DEG), c = Math.cos(a * DEG);
    g.beginPath(); g.moveTo(cx, cy); g.lineTo(cx + R * s, cy - R * c); g.stroke();
    if (Math.abs(a) !== 90) g.fillText(`${a}°`, cx + (R + 13) * s, cy - (R + 13) * c + 4);
  }
  g.strokeStyle = AXIS;
  g.beginPath(); g.moveTo(cx - R - 8, cy); g.lineTo(cx + R + 8, cy); g.stroke();
  // the incident direction (solid, left) and the mirror direction (dashed, right)
  g.setLineDash([]);
  g.strokeStyle = '#e6e6e6';
  g.lineWidth = 1.5;
  g.beginPath(); g.moveTo(cx, cy); g.lineTo(cx - R * Math.sin(th), cy - R * Math.cos(th)); g.stroke();
  g.fillStyle = '#e6e6e6';
  // its label beside the line, clear of the angle labels on the rim
  g.fillText('ωi', cx - 0.72 * R * Math.sin(th) - 12 * Math.cos(th), cy - 0.72 * R * Math.cos(th) + 12 * Math.sin(th) - 4);
  g.setLineDash([4, 4]);
  g.strokeStyle = AXIS;
  g.lineWidth = 1;
  g.beginPath(); g.moveTo(cx, cy); g.lineTo(cx + R * Math.sin(th), cy - R * Math.cos(th)); g.stroke();
  g.setLineDash([]);
  // the lobes
  lams.forEach((l, j) => {
    g.strokeStyle = lambdaCss(l);
    g.lineWidth = 2.8 - 0.8 * j;   // narrower on top: coinciding lobes stay visible as stripes
    g.beginPath();
    angles.forEach((a, i) => {
      const r = rad(rho[j * angles.length + i]), x = cx + r * Math.sin(a * DEG), y = cy - r * Math.cos(a * DEG);
      if (i === 0) g.moveTo(x, y); else g.lineTo(x, y);
    });
    g.stroke();
    g.fillStyle = lambdaCss(l);
    g.fillRect(8, 8 + 15 * j, 14, 3);
    g.fillStyle = TEXT;
    g.textAlign = 'left';
    g.fillText(`${(1000 * l).toFixed(0)} nm`, 27, 13 + 15 * j);
  });
  g.textAlign = 'right';
  g.fillStyle = TEXT;
  g.fillText('ρ (1/sr), log scale', w - 6, 13);
  $('polar-sub').textContent = `θi ${ui.theta}° · ${points.length} points`;
  status.polar = { points: points.length, max: Math.max(...rho) };
  status.drawn.polar = true;
}
