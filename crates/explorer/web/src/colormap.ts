// Colour maps and scales of the heat maps: viridis (perceptually uniform, the CLI's plots use
// it too), a diverging blue–white–red map for differences, and the log scale with its ticks.

// Viridis at 9 stops (matplotlib's table sampled at 0, 1/8, …, 1).
const VIRIDIS: [number, number, number][] = [
  [68, 1, 84], [71, 44, 122], [59, 81, 139], [44, 113, 142], [33, 144, 141],
  [39, 173, 129], [92, 200, 99], [170, 220, 50], [253, 231, 37],
];

/** Viridis at t ∈ [0, 1] (clamped), as [r, g, b] bytes. */
export function viridis(t: number): [number, number, number] {
  const x = Math.min(1, Math.max(0, Number.isFinite(t) ? t : 0)) * (VIRIDIS.length - 1);
  const i = Math.min(VIRIDIS.length - 2, Math.floor(x));
  const f = x - i;
  const a = VIRIDIS[i];
  const b = VIRIDIS[i + 1];
  return [0, 1, 2].map((c) => Math.round(a[c] + (b[c] - a[c]) * f)) as [number, number, number];
}

/** Blue (−1) – white (0) – red (+1), for signed differences. */
export function diverging(t: number): [number, number, number] {
  const x = Math.min(1, Math.max(-1, Number.isFinite(t) ? t : 0));
  const blue = [33, 102, 172];
  const red = [178, 24, 43];
  const end = x < 0 ? blue : red;
  const k = Math.abs(x);
  return [0, 1, 2].map((c) => Math.round(255 + (end[c] - 255) * k)) as [number, number, number];
}

/** A colour scale from values to [0, 1]. */
export interface Scale {
  log: boolean;
  lo: number;
  hi: number;
}

/**
 * The scale of a map: logarithmic over `decades` decades below the maximum (values below
 * map to 0), or linear from 0 to the maximum.
 */
export function scaleFor(max: number, log: boolean, decades = 4): Scale {
  const top = max > 0 && Number.isFinite(max) ? max : 1;
  return log ? { log, lo: Math.log10(top) - decades, hi: Math.log10(top) } : { log, lo: 0, hi: top };
}

/** Position of `v` on the scale, in [0, 1]. */
export function position(s: Scale, v: number): number {
  const x = s.log ? (v > 0 ? Math.log10(v) : -Infinity) : v;
  if (!(x > s.lo)) return 0;
  return Math.min(1, (x - s.lo) / (s.hi - s.lo || 1));
}

/** Tick values of a colour bar: powers of ten for a log scale, nice steps for a linear one. */
export function barTicks(s: Scale): number[] {
  if (s.log) {
    const out: number[] = [];
    for (let e = Math.ceil(s.lo); e <= Math.floor(s.hi); e++) out.push(10 ** e);
    return out;
  }
  return niceTicks(s.lo, s.hi, 5);
}

/** About `count` round tick values covering [lo, hi]. */
export function niceTicks(lo: number, hi: number, count: number): number[] {
  if (!(hi > lo)) return [lo];
  const raw = (hi - lo) / Math.max(1, count);
  const mag = 10 ** Math.floor(Math.log10(raw));
  const step = [1, 2, 2.5, 5, 10].map((m) => m * mag).find((s) => s >= raw) ?? 10 * mag;
  const out: number[] = [];
  for (let v = Math.ceil(lo / step) * step; v <= hi + step * 1e-9; v += step) out.push(Math.abs(v) < step * 1e-9 ? 0 : v);
  return out;
}

/** A number for a label: 3 significant digits, exponent form outside [1e−3, 1e4). */
export function formatNumber(v: number): string {
  if (v === 0) return '0';
  if (!Number.isFinite(v)) return String(v);
  const a = Math.abs(v);
  if (a >= 1e4 || a < 1e-3) {
    const [m, e] = v.toExponential(2).split('e');
    return `${m.replace(/\.?0+$/, '')}e${Number(e)}`;
  }
  return String(Number(v.toPrecision(3)));
}
