// The page's whole state and its URL: every knob is a query parameter, so that a view can
// be shared or bookmarked (`?m=chiang&p.beta_m=0.2&ti=30`…). Only values that differ from the
// defaults are written.

import { parseText, toText } from './params';
import type { ModelInfo, Params } from './types';

export type Tab = 'scatter' | 'compare' | 'fit' | 'render';
export type Channel = 'luminance' | 'r' | 'g' | 'b';

export interface PageState {
  model: string;
  params: Params;
  /** Light inclination and azimuth, degrees. */
  thetaI: number;
  phiI: number;
  /** Offset across a near-field fiber; null: averaged over the width. */
  h: number | null;
  channel: Channel;
  log: boolean;
  decades: number;
  /** Lobes shown (null: all). */
  lobes: string[] | null;
  polar: boolean;
  tab: Tab;
  compareModel: string | null;
  compareParams: Params;
  table: number | null;
  scene: string;
  spp: number;
  size: number;
  light: [number, number];
  exposure: number;
  free: string[];
  fitLobe: string;
  iterations: number;
}

export function defaultState(model = 'chiang'): PageState {
  return {
    model, params: {}, thetaI: 30, phiI: 0, h: null, channel: 'luminance', log: true, decades: 4,
    lobes: null, polar: false, tab: 'scatter', compareModel: null, compareParams: {}, table: null,
    scene: 'fiber', spp: 64, size: 256, light: [35, 40], exposure: 0, free: [], fitLobe: 'all', iterations: 200,
  };
}

function list(text: string | null): string[] | null {
  return text === null ? null : text === '' ? [] : text.split(',');
}

function num(text: string | null, fallback: number): number {
  const x = text === null ? NaN : Number(text);
  return Number.isFinite(x) ? x : fallback;
}

/** Parameters `prefix.key=text` of `model` from a query. */
function readParams(q: URLSearchParams, prefix: string, model: ModelInfo | undefined): Params {
  const out: Params = {};
  if (!model) return out;
  for (const p of model.params) {
    const t = q.get(`${prefix}.${p.key}`);
    if (t === null) continue;
    const v = parseText(p, t);
    if (v !== undefined) out[p.key] = v;
  }
  return out;
}

/** The state a query describes (unknown models fall back to the first one). */
export function decodeState(search: string, models: ModelInfo[]): PageState {
  const q = new URLSearchParams(search);
  const usable = models.filter((m) => !m.needs_data);
  const byName = (n: string | null) => usable.find((m) => m.name === n);
  const model = byName(q.get('m')) ?? byName('chiang') ?? usable[0];
  const d = defaultState(model?.name ?? 'chiang');
  const tabs: Tab[] = ['scatter', 'compare', 'fit', 'render'];
  const channels: Channel[] = ['luminance', 'r', 'g', 'b'];
  const h = q.get('h');
  const cm = byName(q.get('cm'));
  const light = list(q.get('rl'));
  return {
    ...d,
    params: readParams(q, 'p', model),
    thetaI: num(q.get('ti'), d.thetaI),
    phiI: num(q.get('pi'), d.phiI),
    h: h === null || h === 'avg' ? null : num(h, 0),
    channel: channels.find((c) => c === q.get('ch')) ?? d.channel,
    log: q.get('log') !== '0',
    decades: num(q.get('dec'), d.decades),
    lobes: list(q.get('lobes')),
    polar: q.get('pol') === '1',
    tab: tabs.find((t) => t === q.get('tab')) ?? d.tab,
    compareModel: cm?.name ?? null,
    compareParams: readParams(q, 'cp', cm),
    table: q.get('ct') === null ? null : num(q.get('ct'), 0),
    scene: q.get('rs') ?? (model?.kind === 'surface' ? 'sphere' : d.scene),
    spp: num(q.get('rspp'), d.spp),
    size: num(q.get('rsz'), d.size),
    light: light && light.length === 2 ? [num(light[0], 35), num(light[1], 40)] : d.light,
    exposure: num(q.get('rex'), d.exposure),
    free: list(q.get('ff')) ?? [],
    fitLobe: q.get('fl') ?? d.fitLobe,
    iterations: num(q.get('fi'), d.iterations),
  };
}

/** The query of a state (`?…`), writing only what differs from the defaults. */
export function encodeState(s: PageState): string {
  const d = defaultState(s.model);
  const q = new URLSearchParams();
  q.set('m', s.model);
  for (const [k, v] of Object.entries(s.params)) q.set(`p.${k}`, toText(v));
  const put = (k: string, v: string, dv: string) => {
    if (v !== dv) q.set(k, v);
  };
  put('ti', String(s.thetaI), String(d.thetaI));
  put('pi', String(s.phiI), String(d.phiI));
  if (s.h !== null) q.set('h', String(s.h));
  put('ch', s.channel, d.channel);
  if (!s.log) q.set('log', '0');
  put('dec', String(s.decades), String(d.decades));
  if (s.lobes !== null) q.set('lobes', s.lobes.join(','));
  if (s.polar) q.set('pol', '1');
  put('tab', s.tab, d.tab);
  if (s.compareModel !== null) {
    q.set('cm', s.compareModel);
    for (const [k, v] of Object.entries(s.compareParams)) q.set(`cp.${k}`, toText(v));
  }
  if (s.table !== null) q.set('ct', String(s.table));
  put('rs', s.scene, d.scene);
  put('rspp', String(s.spp), String(d.spp));
  put('rsz', String(s.size), String(d.size));
  put('rl', s.light.join(','), d.light.join(','));
  put('rex', String(s.exposure), String(d.exposure));
  if (s.free.length > 0) q.set('ff', s.free.join(','));
  put('fl', s.fitLobe, d.fitLobe);
  put('fi', String(s.iterations), String(d.iterations));
  return '?' + q.toString();
}
