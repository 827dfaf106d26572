// Viridis as a degree-6 polynomial fit (Matt Zucker's CC0 fit of matplotlib's table), the same
// coefficients in GLSL for the shader and in JavaScript for the legend and the browser test.
export const VIRIDIS_COEFFS = [
  [0.2777273272234177, 0.005407344544966578, 0.3340998053353061],
  [0.1050930431085774, 1.404613529898575, 1.384590162594685],
  [-0.3308618287255563, 0.214847559468213, 0.09509516302823659],
  [-4.634230498983486, -5.799100973351585, -19.33244095627987],
  [6.228269936347081, 14.17993336680509, 56.69055260068105],
  [4.776384997670288, -13.74514537774601, -65.35303263337234],
  [-5.435455855934631, 4.645852612178535, 26.3124352495832],
];

/** viridis(t) for t in [0, 1], as [r, g, b] in [0, 1]. */
export function viridis(t) {
  const x = Math.min(1, Math.max(0, t));
  const out = [0, 0, 0];
  for (let ch = 0; ch < 3; ch++) {
    let v = 0;
    for (let k = VIRIDIS_COEFFS.length - 1; k >= 0; k--) v = VIRIDIS_COEFFS[k][ch] + x * v;
    out[ch] = Math.min(1, Math.max(0, v));
  }
  return out;
}

const vec = (c) => `vec3(${c.map((x) => x.toPrecision(17)).join(', ')})`;

export const VIRIDIS_GLSL = `
vec3 viridis(float t) {
  t = clamp(t, 0.0, 1.0);
${VIRIDIS_COEFFS.map((c, i) => `  const vec3 c${i} = ${vec(c)};`).join('\n')}
  return clamp(c0 + t * (c1 + t * (c2 + t * (c3 + t * (c4 + t * (c5 + t * c6))))), 0.0, 1.0);
}
`;

/** Distinct colours for nearest-source regions (Tableau 10). */
export const SOURCE_PALETTE = [
  [0.122, 0.467, 0.706], [1.0, 0.498, 0.055], [0.173, 0.627, 0.173], [0.839, 0.153, 0.157],
  [0.58, 0.404, 0.741], [0.549, 0.337, 0.294], [0.89, 0.467, 0.761], [0.498, 0.498, 0.498],
  [0.737, 0.741, 0.133], [0.09, 0.745, 0.812],
];
