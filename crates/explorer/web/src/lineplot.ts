// Line plots as SVG: Cartesian (x in degrees, y linear or log) or polar (angle = x, radius =
// y / max), one series per lobe, with a legend. The SVG is the figure: export writes it as is.

import { formatNumber, niceTicks } from './colormap';

export interface Series {
  name: string;
  x: number[];
  y: number[];
  color: string;
  dashed?: boolean;
}

export interface PlotStyle {
  title: string;
  xLabel: string;
  yLabel: string;
  polar: boolean;
  log?: boolean;
  width?: number;
  height?: number;
}

export const LOBE_COLORS = ['#1f77b4', '#d62728', '#2ca02c', '#9467bd', '#ff7f0e', '#8c564b', '#e377c2', '#17becf'];

const esc = (s: string) => s.replace(/&/g, '&amp;').replace(/</g, '&lt;').replace(/>/g, '&gt;');

/** The SVG text of a plot. */
export function plotSvg(series: Series[], style: PlotStyle): string {
  const W = style.width ?? 420;
  const H = style.height ?? 300;
  const parts: string[] = [];
  parts.push(`<svg xmlns="http://www.w3.org/2000/svg" width="${W}" height="${H}" viewBox="0 0 ${W} ${H}" font-family="system-ui, sans-serif" font-size="11">`);
  parts.push(`<rect width="${W}" height="${H}" fill="#fff"/>`);
  parts.push(`<text x="8" y="15" font-size="13">${esc(style.title)}</text>`);
  const ymax = Math.max(0, ...series.flatMap((s) => s.y.filter(Number.isFinite)));
  if (style.polar) {
    const cx = W / 2;
    const cy = H / 2 + 8;
    const R = Math.min(W, H - 30) / 2 - 18;
    for (const f of [0.25, 0.5, 0.75, 1]) parts.push(`<circle cx="${cx}" cy="${cy}" r="${R * f}" fill="none" stroke="#ddd"/>`);
    for (let a = 0; a < 360; a += 30) {
      const t = (a * Math.PI) / 180;
      parts.push(`<line x1="${cx}" y1="${cy}" x2="${cx + R * Math.cos(t)}" y2="${cy - R * Math.sin(t)}" stroke="#eee"/>`);
      parts.push(`<text x="${cx + (R + 10) * Math.cos(t)}" y="${cy - (R + 10) * Math.sin(t) + 4}" text-anchor="middle" fill="#666">${a}°</text>`);
    }
    for (const s of series) {
      if (ymax <= 0) break;
      const pts = s.x.map((x, i) => {
        const t = (x * Math.PI) / 180;
        const r = (Math.max(0, s.y[i]) / ymax) * R;
        return `${(cx + r * Math.cos(t)).toFixed(2)},${(cy - r * Math.sin(t)).toFixed(2)}`;
      });
      parts.push(`<polygon points="${pts.join(' ')}" fill="none" stroke="${s.color}" stroke-width="1.6"${s.dashed ? ' stroke-dasharray="4 3"' : ''}/>`);
    }
    parts.push(`<text x="${W - 8}" y="${H - 6}" text-anchor="end" fill="#666">radius: ${esc(style.yLabel)} / max (${formatNumber(ymax)})</text>`);
  } else {
    const m = { l: 56, r: 10, t: 24, b: 34 };
    const pw = W - m.l - m.r;
    const ph = H - m.t - m.b;
    const xs = series.flatMap((s) => s.x);
    const x0 = Math.min(...xs);
    const x1 = Math.max(...xs);
    const positive = series.flatMap((s) => s.y.filter((v) => v > 0));
    const log = !!style.log && positive.length > 0;
    const ylo = log ? Math.max(Math.min(...positive), ymax * 1e-4) : 0;
    const Y = (v: number) => (log ? Math.log10(Math.max(v, ylo)) : v);
    const y0 = Y(ylo);
    const y1 = Math.max(Y(ymax || 1), y0 + 1e-12);
    const px = (x: number) => m.l + ((x - x0) / (x1 - x0 || 1)) * pw;
    const py = (v: number) => m.t + (1 - (Y(v) - y0) / (y1 - y0)) * ph;
    parts.push(`<rect x="${m.l}" y="${m.t}" width="${pw}" height="${ph}" fill="none" stroke="#999"/>`);
    for (const x of niceTicks(x0, x1, 6)) parts.push(`<text x="${px(x)}" y="${m.t + ph + 14}" text-anchor="middle">${formatNumber(x)}</text>`);
    const yt = log ? Array.from({ length: Math.floor(y1) - Math.ceil(y0) + 1 }, (_, k) => 10 ** (Math.ceil(y0) + k)) : niceTicks(0, ymax || 1, 4);
    for (const v of yt) {
      parts.push(`<line x1="${m.l}" x2="${m.l + pw}" y1="${py(v)}" y2="${py(v)}" stroke="#eee"/>`);
      parts.push(`<text x="${m.l - 4}" y="${py(v) + 4}" text-anchor="end">${formatNumber(v)}</text>`);
    }
    parts.push(`<text x="${m.l + pw / 2}" y="${H - 4}" text-anchor="middle">${esc(style.xLabel)}</text>`);
    parts.push(`<text transform="translate(11 ${m.t + ph / 2}) rotate(-90)" text-anchor="middle">${esc(style.yLabel)}</text>`);
    for (const s of series) {
      const d = s.x.map((x, i) => `${i === 0 ? 'M' : 'L'}${px(x).toFixed(2)},${py(s.y[i]).toFixed(2)}`).join('');
      parts.push(`<path d="${d}" fill="none" stroke="${s.color}" stroke-width="1.6"${s.dashed ? ' stroke-dasharray="4 3"' : ''}/>`);
    }
  }
  // Legend at the top right, as wide as its longest name (about 6.2 px a character).
  const x0 = W - 30 - 6.2 * Math.max(0, ...series.map((s) => s.name.length));
  series.forEach((s, i) => {
    const y = 30 + 14 * i;
    parts.push(`<line x1="${x0}" x2="${x0 + 18}" y1="${y}" y2="${y}" stroke="${s.color}" stroke-width="2"${s.dashed ? ' stroke-dasharray="4 3"' : ''}/>`);
    parts.push(`<text x="${x0 + 22}" y="${y + 4}">${esc(s.name)}</text>`);
  });
  parts.push('</svg>');
  return parts.join('');
}
