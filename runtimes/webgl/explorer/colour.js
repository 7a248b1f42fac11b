// Colour: the visible range, the point-light pass' wavelengths and their sRGB weights, display colours.

export const VIS = [0.38, 0.78];     // the visible range the sphere integrates over (micrometres)
export const NL = 12;                // wavelengths of the point-light pass (bins of 33 nm)

// CIE 1931 colour matching functions, the multi-lobe Gaussian fit of Wyman, Sloan & Shirley (JCGT 2013),
// lambda in nm; then XYZ to linear sRGB (D65 primaries).
function cmf(nm) {
  const g = (mu, s1, s2) => { const t = (nm - mu) / (nm < mu ? s1 : s2); return Math.exp(-0.5 * t * t); };
  return [1.056 * g(599.8, 37.9, 31.0) + 0.362 * g(442.0, 16.0, 26.7) - 0.065 * g(501.1, 20.4, 26.2),
    0.821 * g(568.8, 46.9, 40.5) + 0.286 * g(530.9, 16.3, 31.1),
    1.217 * g(437.0, 11.8, 36.0) + 0.681 * g(459.0, 26.0, 13.8)];
}
const XYZ_TO_RGB = [[3.2406, -1.5372, -0.4986], [-0.9689, 1.8758, 0.0415], [0.0557, -0.2040, 1.0570]];
const rgbOf = (nm) => { const c = cmf(nm); return XYZ_TO_RGB.map((r) => r[0] * c[0] + r[1] * c[1] + r[2] * c[2]); };

// The point-light pass' wavelengths (bin centres over VIS) and their sRGB weights, white-balanced per channel
// so that a flat spectrum (equal-energy illuminant, white surface) is neutral grey 1.
function spectralWeights() {
  const lams = Array.from({ length: NL }, (_, i) => VIS[0] + ((i + 0.5) * (VIS[1] - VIS[0])) / NL);
  const w = lams.map((l) => rgbOf(1000 * l));
  const sum = [0, 1, 2].map((c) => w.reduce((s, x) => s + x[c], 0));
  return { lams, weights: w.map((x) => x.map((v, c) => v / sum[c])) };
}
// The same white balance for the continuous CMFs the environment pass samples: 1 / integral over VIS.
function continuousNorm() {
  const n = 800, h = (VIS[1] - VIS[0]) / n, s = [0, 0, 0];
  for (let i = 0; i < n; i++) rgbOf(1000 * (VIS[0] + (i + 0.5) * h)).forEach((v, c) => { s[c] += v * h; });
  return s.map((v) => 1 / v);
}
export const SPECTRAL = spectralWeights(), CNORM = continuousNorm();
// A display colour for a wavelength (the legend's): its sRGB chromaticity at full brightness.
export function lambdaCss(l) {
  const c = rgbOf(1000 * l).map((v) => Math.max(v, 0)), m = Math.max(...c);
  return `rgb(${c.map((v) => Math.round(255 * Math.pow(v / m, 1 / 2.2))).join(',')})`;
}

// The slice's colour map:
export const inferno = (t) => {   // matplotlib's inferno, a polynomial fit (Matt Zucker, CC0)
  const c = [[0.0002189, 0.0016510, -0.0194809], [0.1065134, 0.5639564, 3.9327124], [11.6024931, -3.9728540, -15.9423941],
    [-41.7039961, 17.4363989, 44.3541452], [77.1629357, -33.4023589, -81.8073093], [-71.3194282, 32.6260643, 73.2095199],
    [25.1311262, -12.2426690, -23.0703250]];
  return [0, 1, 2].map((k) => Math.round(255 * Math.min(Math.max(c.reduceRight((s, ci) => s * t + ci[k], 0), 0), 1)));
};
