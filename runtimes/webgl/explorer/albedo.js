// The directional albedo a(theta_i) of each energy mode, integrated in the half vector.
import { evalPoints } from '../twoscale.js';
import { $, status, ui, material, DEG } from './page.js';
import { isGeneral, clampLambda, matParams, brdfOptions } from './material.js';
import { canvas2d, GRID, AXIS, TEXT } from './plot.js';

export const ALBEDO_THETAS = Array.from({ length: 24 }, (_, i) => (88 * i) / 23);   // degrees

// Why a curve is above 1, or '' where none is (by more than the rule's error, 1e-3). The rule agrees with the
// albedo tables' own integration (maths.md section 9: 6e-5 against a material's `e` with diffraction, 3.8e-4 against
// `epd_albedo` without, tests/test_explorer_albedo.py), so a curve above 1 is the BRDF's: single scattering with
// diffraction is the paper's model, whose diffraction part adds energy (maths.md section 7); the general tables'
// compensation, unlike a material folder's, does not scale that part back (runtimes.md, "General mode").
export function albedoNote(curves, general) {
  const over = (e) => curves[e] && Math.max(...curves[e].values) > 1 + 1e-3;
  const notes = [];
  if (over('single')) notes.push('single above 1: the diffraction part of the paper\'s model adds energy');
  if (over('compensated')) {
    notes.push(general ? 'compensated above 1: the general tables\' compensation does not scale the diffraction part back'
      : 'compensated above 1');
  }
  return notes.join('; ');
}

// Gauss-Legendre nodes and weights on [-1, 1] (Newton on P_n).
export function gaussLegendre(n) {
  const x = new Float64Array(n), w = new Float64Array(n);
  for (let i = 0; i < n; i++) {
    let z = Math.cos((Math.PI * (i + 0.75)) / (n + 0.5)), dp = 1;
    for (let it = 0; it < 100; it++) {
      let p1 = 1, p0 = 0;
      for (let j = 1; j <= n; j++) { const pm = p0; p0 = p1; p1 = ((2 * j - 1) * z * p0 - (j - 1) * pm) / j; }
      dp = (n * (z * p1 - p0)) / (z * z - 1);
      const dz = p1 / dp;
      z -= dz;
      if (Math.abs(dz) < 1e-15) break;
    }
    x[i] = z; w[i] = 2 / ((1 - z * z) * dp * dp);
  }
  return { x, w };
}

// The directional albedo a(theta_i) = int rho cos theta_o d omega_o, in the half vector h of (wi, wo):
// d omega_o = 4 (wi.h) d omega_h, and theta_h through v = ln tan theta_h, so that d omega_h = sin^2 theta_h
// cos theta_h dv dphi puts as many nodes on every decade of theta_h: a peak of any width (beta 0.005 as 0.5)
// and the diffraction lobe are resolved alike. v runs from ln(1e-3 w) (w the narrower of beta and
// lambda / b: the cap below holds ~1e-6 of the lobe) to the horizon, where wo.z = 0: tan 2 theta_h =
// -cos theta_i / (sin theta_i cos phi), so no node falls below it and the integrand has no kink;
// 24 panels of 6-point Gauss-Legendre. phi over [0, pi] (the plane of incidence is a mirror), 24-point
// Gauss-Legendre in tau with phi = pi/2 + s sinh(tau), s = cot theta_i: at grazing incidence the horizon
// turns within ~cot theta_i of phi = 90 deg, and the nodes gather there. 3456 points an angle. Against a
// 200-panel x 8 x 256-node rule on the C BRDF (the 36 test materials, both energy modes, 0-88 deg, 0.55 um)
// the error is 5.5e-4 at most (chi9 compensated at normal incidence), 2e-4 elsewhere; for plastic1
// (white) the page's curve is 1 to 5e-6.
const GL6 = gaussLegendre(6), GL24 = gaussLegendre(24);
export function albedoRule(thetaI, lambda) {
  const m = matParams(), si = Math.sin(thetaI), ci = Math.cos(thetaI);
  const width = Math.min(m.beta, 0.1, m.sigma_s ? lambda / m.b : 1);
  const vmin = Math.log(1e-3 * width), panels = 24;
  const s = Math.min(Math.max(ci / Math.max(si, 1e-9), 0.01), 10), tm = Math.asinh(Math.PI / 2 / s);
  const wi = [si, 0, ci], dirs = [], weights = [];
  for (let a = 0; a < GL24.x.length; a++) {
    const tau = tm * GL24.x[a], phi = Math.PI / 2 + s * Math.sinh(tau);
    const wphi = 2 * tm * GL24.w[a] * s * Math.cosh(tau);   // x 2: phi in [pi, 2 pi] mirrors [0, pi]
    const cp = Math.cos(phi), sp = Math.sin(phi);
    const vmax = Math.log(Math.tan(0.5 * Math.atan2(ci, -si * cp)));
    if (!(vmax > vmin)) continue;
    const dv = (vmax - vmin) / panels;
    for (let k = 0; k < panels; k++) for (let q = 0; q < GL6.x.length; q++) {
      const v = vmin + dv * (k + 0.5 + 0.5 * GL6.x[q]), th = Math.atan(Math.exp(v)), st = Math.sin(th), ct = Math.cos(th);
      const hv = [st * cp, st * sp, ct], d = si * hv[0] + ci * hv[2];
      const wo = [2 * d * hv[0] - si, 2 * d * hv[1], 2 * d * hv[2] - ci];
      if (wo[2] <= 0 || d <= 0) continue;
      dirs.push({ wi, wo, lambda });
      weights.push(wphi * 0.5 * dv * GL6.w[q] * st * st * ct * 4 * d * wo[2]);
    }
  }
  return { dirs, weights };
}

export async function computeAlbedo(energy, lambda) {
  const rules = ALBEDO_THETAS.map((t) => albedoRule(t * DEG, lambda));
  const points = rules.flatMap((r) => r.dirs);
  const rho = await evalPoints(material, points, brdfOptions(energy));
  let i = 0;
  return { points: points.length, values: rules.map((r) => r.weights.reduce((s, w) => s + w * rho[i++], 0)) };
}

export async function drawAlbedo(stale) {
  const lambda = clampLambda(ui.lambda), curves = {};
  for (const e of isGeneral() ? ['single', 'compensated'] : material.energies || ['single', 'compensated']) {
    curves[e] = await computeAlbedo(e, lambda);
    if (stale()) return;
  }
  const { g, w, h } = canvas2d('albedo');
  const left = 40, right = 12, top = 10, bottom = 32, pw = w - left - right, ph = h - top - bottom;
  const all = Object.values(curves).flatMap((c) => c.values);
  const ymax = Math.max(1.1, Math.ceil(Math.max(...all) * 10 + 0.5) / 10);
  const X = (t) => left + (pw * t) / 90, Y = (a) => top + ph * (1 - a / ymax);
  g.strokeStyle = GRID;
  g.fillStyle = TEXT;
  g.lineWidth = 1;
  g.textAlign = 'right';
  for (let a = 0; a <= ymax + 1e-9; a += ymax > 2 ? 0.5 : 0.2) {
    g.beginPath(); g.moveTo(left, Y(a)); g.lineTo(left + pw, Y(a)); g.stroke();
    g.fillText(a.toFixed(1), left - 5, Y(a) + 4);
  }
  g.textAlign = 'center';
  for (let t = 0; t <= 90; t += 15) {
    g.beginPath(); g.moveTo(X(t), top); g.lineTo(X(t), top + ph); g.stroke();
    g.fillText(`${t}°`, X(t), top + ph + 14);
  }
  g.fillText('θi', left + pw / 2, top + ph + 27);
  g.strokeStyle = AXIS;
  g.setLineDash([2, 3]);
  g.beginPath(); g.moveTo(left, Y(1)); g.lineTo(left + pw, Y(1)); g.stroke();
  g.beginPath(); g.moveTo(X(ui.theta), top); g.lineTo(X(ui.theta), top + ph); g.stroke();
  const styles = { single: ['#f0a35e', [6, 4]], compensated: ['#6fb3ff', []] };
  for (const [e, c] of Object.entries(curves)) {
    g.strokeStyle = styles[e][0];
    g.setLineDash(styles[e][1]);
    g.lineWidth = e === ui.energy ? 2.2 : 1.3;
    g.beginPath();
    c.values.forEach((a, i) => (i ? g.lineTo(X(ALBEDO_THETAS[i]), Y(a)) : g.moveTo(X(ALBEDO_THETAS[i]), Y(a))));
    g.stroke();
  }
  g.setLineDash([]);
  // legend: each mode with its value at the current theta_i (linear between the 24 angles)
  const at = (vals) => {
    const x = (ui.theta / 88) * 23, i = Math.min(Math.floor(x), 22), t = x - i;
    return vals[i] + t * (vals[i + 1] - vals[i]);
  };
  // the legend in the first corner (lower right, upper right, lower left, upper left) that no curve crosses
  const corners = [[left + pw - 228, top + ph - 44], [left + pw - 228, top + 6], [left + 6, top + ph - 44], [left + 6, top + 6]];
  const crosses = ([x, y]) => Object.values(curves).some((c) => c.values.some((a, i) => {
    const px = X(ALBEDO_THETAS[i]), py = Y(a);
    return px > x - 8 && px < x + 228 && py > y - 8 && py < y + 46;
  }));
  const [lx, ly] = corners.find((c) => !crosses(c)) || corners[0];
  g.fillStyle = 'rgba(31, 34, 38, 0.9)';
  g.fillRect(lx, ly, 220, 38);
  g.textAlign = 'left';
  Object.entries(curves).forEach(([e, c], j) => {
    g.strokeStyle = styles[e][0];
    g.setLineDash(styles[e][1]);
    g.lineWidth = 2;
    g.beginPath(); g.moveTo(lx + 8, ly + 12 + 15 * j); g.lineTo(lx + 30, ly + 12 + 15 * j); g.stroke();
    g.fillStyle = TEXT;
    g.fillText(`${e}: a(${ui.theta}°) = ${at(c.values).toFixed(4)}`, lx + 36, ly + 16 + 15 * j);
  });
  g.setLineDash([]);
  const note = albedoNote(curves, isGeneral());
  $('albedo-sub').textContent = `${(1000 * lambda).toFixed(0)} nm · ${Object.values(curves).reduce((n, c) => n + c.points, 0)} points`
    + (note ? ` · ${note}` : '');
  status.albedo = { lambda, theta: ALBEDO_THETAS, note };
  for (const [e, c] of Object.entries(curves)) status.albedo[e] = c.values.map((v) => +v.toFixed(6));
  status.drawn.albedo = true;
}
