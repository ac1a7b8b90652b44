// A heat map on a canvas: the values' image with axes in degrees, a colour bar (log or linear,
// labelled in the values' unit) and optional marker lines (the specular cone θ_r = −θ_i).

import { barTicks, diverging, formatNumber, niceTicks, position, scaleFor, viridis, type Scale } from './colormap';

export interface Heat {
  rows: number;
  cols: number;
  /** Row-major, row 0 at `theta[0]`. */
  values: ArrayLike<number>;
  theta: [number, number];
  phi: [number, number];
  max: number;
}

export interface HeatStyle {
  title: string;
  xLabel: string;
  yLabel: string;
  unit: string;
  log: boolean;
  decades: number;
  /** Signed values drawn blue–white–red, symmetric about 0. */
  signed?: boolean;
  /** Horizontal marker lines (y values, degrees) with their labels. */
  markers?: { y: number; label: string }[];
}

export const MARGIN = { left: 58, right: 92, top: 26, bottom: 42 };

/** The plot area of a canvas of `width × height`. */
export function plotArea(width: number, height: number) {
  return { x: MARGIN.left, y: MARGIN.top, w: width - MARGIN.left - MARGIN.right, h: height - MARGIN.top - MARGIN.bottom };
}

/** (θ, φ) in degrees under canvas point (x, y), or null outside the plot. */
export function pick(heat: Heat, width: number, height: number, x: number, y: number): { theta: number; phi: number } | null {
  const a = plotArea(width, height);
  const u = (x - a.x) / a.w;
  const v = 1 - (y - a.y) / a.h;
  if (u < 0 || u > 1 || v < 0 || v > 1) return null;
  return { phi: heat.phi[0] + u * (heat.phi[1] - heat.phi[0]), theta: heat.theta[0] + v * (heat.theta[1] - heat.theta[0]) };
}

/** The colour of each cell as RGBA bytes (rows flipped so that θ grows upward). */
export function cellColours(heat: Heat, style: HeatStyle): Uint8ClampedArray<ArrayBuffer> {
  const out = new Uint8ClampedArray(new ArrayBuffer(heat.rows * heat.cols * 4));
  const scale: Scale = scaleFor(heat.max, style.log, style.decades);
  for (let r = 0; r < heat.rows; r++) {
    for (let c = 0; c < heat.cols; c++) {
      const v = heat.values[r * heat.cols + c];
      const rgb = style.signed ? diverging(heat.max > 0 ? v / heat.max : 0) : viridis(position(scale, v));
      const k = ((heat.rows - 1 - r) * heat.cols + c) * 4;
      out[k] = rgb[0];
      out[k + 1] = rgb[1];
      out[k + 2] = rgb[2];
      out[k + 3] = 255;
    }
  }
  return out;
}

/** Draws the map on `canvas` (sized by its attributes). */
export function drawHeat(canvas: HTMLCanvasElement, heat: Heat, style: HeatStyle): void {
  const g = canvas.getContext('2d');
  if (!g) return;
  const { width, height } = canvas;
  const a = plotArea(width, height);
  g.fillStyle = '#fff';
  g.fillRect(0, 0, width, height);
  const cells = new ImageData(cellColours(heat, style), heat.cols, heat.rows);
  const raster = document.createElement('canvas');
  raster.width = heat.cols;
  raster.height = heat.rows;
  raster.getContext('2d')?.putImageData(cells, 0, 0);
  g.imageSmoothingEnabled = false;
  g.drawImage(raster, a.x, a.y, a.w, a.h);
  g.strokeStyle = '#333';
  g.strokeRect(a.x, a.y, a.w, a.h);
  g.fillStyle = '#222';
  g.font = '12px system-ui, sans-serif';
  g.textAlign = 'center';
  const xOf = (phi: number) => a.x + ((phi - heat.phi[0]) / (heat.phi[1] - heat.phi[0])) * a.w;
  const yOf = (theta: number) => a.y + (1 - (theta - heat.theta[0]) / (heat.theta[1] - heat.theta[0])) * a.h;
  for (let p = heat.phi[0]; p <= heat.phi[1]; p += 45) {
    g.fillText(String(p), xOf(p), a.y + a.h + 15);
  }
  g.fillText(style.xLabel, a.x + a.w / 2, height - 6);
  g.textAlign = 'right';
  const step = heat.theta[1] - heat.theta[0] > 100 ? 30 : 15;
  for (let t = heat.theta[0]; t <= heat.theta[1]; t += step) g.fillText(String(t), a.x - 5, yOf(t) + 4);
  g.save();
  g.translate(14, a.y + a.h / 2);
  g.rotate(-Math.PI / 2);
  g.textAlign = 'center';
  g.fillText(style.yLabel, 0, 0);
  g.restore();
  g.textAlign = 'left';
  g.font = '13px system-ui, sans-serif';
  g.fillText(style.title, a.x, 17);
  for (const m of style.markers ?? []) {
    if (m.y < heat.theta[0] || m.y > heat.theta[1]) continue;
    g.strokeStyle = 'rgba(255,255,255,0.85)';
    g.setLineDash([5, 4]);
    g.beginPath();
    g.moveTo(a.x, yOf(m.y));
    g.lineTo(a.x + a.w, yOf(m.y));
    g.stroke();
    g.setLineDash([]);
    g.fillStyle = '#fff';
    g.font = '11px system-ui, sans-serif';
    g.fillText(m.label, a.x + 4, yOf(m.y) - 4);
  }
  drawBar(g, heat, style, a.x + a.w + 14, a.y, 14, a.h);
}

function drawBar(g: CanvasRenderingContext2D, heat: Heat, style: HeatStyle, x: number, y: number, w: number, h: number): void {
  for (let k = 0; k < h; k++) {
    const t = 1 - k / h;
    const rgb = style.signed ? diverging(2 * t - 1) : viridis(t);
    g.fillStyle = `rgb(${rgb[0]},${rgb[1]},${rgb[2]})`;
    g.fillRect(x, y + k, w, 1);
  }
  g.strokeStyle = '#333';
  g.strokeRect(x, y, w, h);
  g.fillStyle = '#222';
  g.font = '11px system-ui, sans-serif';
  g.textAlign = 'left';
  if (style.signed) {
    const ticks = niceTicks(-heat.max, heat.max, 4);
    for (const v of ticks) g.fillText(formatNumber(v), x + w + 4, y + (1 - (v / (heat.max || 1) + 1) / 2) * h + 4);
  } else {
    const s = scaleFor(heat.max, style.log, style.decades);
    for (const v of barTicks(s)) g.fillText(formatNumber(v), x + w + 4, y + (1 - position(s, v)) * h + 4);
  }
  g.fillText(style.unit, x - 2, y - 8);
}

/** The map as SVG: the raster embedded as a PNG, with the axes and colour bar as vectors. */
export function heatSvg(canvas: HTMLCanvasElement): string {
  const { width, height } = canvas;
  const data = canvas.toDataURL('image/png');
  return `<svg xmlns="http://www.w3.org/2000/svg" xmlns:xlink="http://www.w3.org/1999/xlink" width="${width}" height="${height}" viewBox="0 0 ${width} ${height}"><image width="${width}" height="${height}" xlink:href="${data}"/></svg>`;
}
