// fiberlab explore: the page. Every number it shows comes from the server's API
// (crates/explorer/src/api); this file wires the controls, the views and the URL.

import './style.css';
import * as api from './api';
import { buildControls, el } from './controls';
import { formatNumber } from './colormap';
import { drawHeat, heatSvg, pick, type Heat } from './heatmap';
import { LOBE_COLORS, plotSvg, type Series } from './lineplot';
import { changed, defaultValue } from './params';
import { decodeState, encodeState, type PageState, type Tab } from './state';
import { paramsToml } from './toml';
import type { CompareAnswer, MapAnswer, ModelInfo, NumbersAnswer, Params, SlicesAnswer, TableSummary } from './types';

let models: ModelInfo[] = [];
let state: PageState;
let lastMap: MapAnswer | null = null;
let lastSlices: { m: string; n: string } = { m: '', n: '' };
let fiberView: import('./fiber3d').FiberView | null = null;
const tables = new Map<number, TableSummary>();

const $ = <T extends HTMLElement = HTMLElement>(id: string) => document.getElementById(id) as T;

function model(name = state.model): ModelInfo {
  return models.find((m) => m.name === name) ?? models[0];
}

function isSurface(): boolean {
  return model().kind === 'surface';
}

function status(text: string, error = false): void {
  const s = $('status');
  s.textContent = text;
  s.classList.toggle('error', error);
}

function fail(e: unknown): void {
  if (api.isAbort(e)) return;
  status(e instanceof Error ? e.message : String(e), true);
}

// ---------------------------------------------------------------- state, URL, requests

function saveUrl(): void {
  history.replaceState(null, '', encodeState(state) + location.hash);
}

/** What every view request of model A carries. */
function view(extra: Record<string, unknown> = {}): Record<string, unknown> {
  return {
    model: state.model,
    params: changed(model(), state.params),
    theta_i: state.thetaI,
    phi_i: state.phiI,
    ...(state.h === null || isSurface() ? {} : { h: state.h }),
    channel: state.channel,
    ...extra,
  };
}

const timers = new Map<string, number>();
function debounce(kind: string, ms: number, run: () => void): void {
  clearTimeout(timers.get(kind));
  timers.set(kind, window.setTimeout(run, ms));
}

/** Re-plots what the knobs change (each view debounced; stale requests are aborted). */
function refresh(): void {
  saveUrl();
  debounce('map', 30, updateMap);
  debounce('slices', 120, updateSlices);
  debounce('numbers', 300, updateNumbers);
  if (state.tab === 'compare') debounce('compare', 250, updateCompare);
  if (state.tab === 'render' && rendering) debounce('render', 300, startRender);
}

// ---------------------------------------------------------------- header and controls

function buildHeader(): void {
  const select = $<HTMLSelectElement>('model');
  select.replaceChildren();
  for (const kind of ['fiber', 'surface'] as const) {
    const group = el('optgroup', { label: kind === 'fiber' ? 'fiber models' : 'surface models' });
    for (const m of models.filter((x) => x.kind === kind)) {
      group.append(el('option', { value: m.name, textContent: m.name + (m.needs_data ? ' (needs a table)' : ''), disabled: m.needs_data, selected: m.name === state.model }));
    }
    select.append(group);
  }
  select.onchange = () => {
    const was = model().kind;
    state.model = select.value;
    state.params = {};
    state.lobes = null;
    state.free = [];
    if (model().kind !== was) {
      state.thetaI = model().kind === 'surface' ? 30 : state.thetaI;
      state.scene = model().kind === 'surface' ? 'sphere' : 'fiber';
      state.compareModel = null;
      state.compareParams = {};
    }
    buildAll();
    refresh();
  };
  $('share').onclick = async () => {
    saveUrl();
    try {
      await navigator.clipboard.writeText(location.href);
      status('Link copied: ' + location.href);
    } catch {
      status('Link: ' + location.href);
    }
  };
  $('export-toml').onclick = () => download(`${state.model}.toml`, paramsToml(state.model, changed(model(), state.params)), 'application/toml');
}

function showAbout(): void {
  const m = model();
  $('about').textContent = `${m.summary} — ${m.citation}`;
}

function buildParams(): void {
  const host = $('params');
  host.replaceChildren(el('h2', { textContent: `${model().name} parameters` }));
  const box = el('div');
  host.append(box);
  buildControls(box, model(), state.params, (key, value) => {
    if (value === undefined) delete state.params[key];
    else state.params[key] = value;
    refresh();
  });
  const reset = el('button', { textContent: 'Defaults' });
  reset.onclick = () => {
    state.params = {};
    buildParams();
    refresh();
  };
  host.append(reset);
}

function slider(label: string, id: string, lo: number, hi: number, step: number, value: number, unit: string, set: (v: number) => void): HTMLElement {
  const range = el('input', { type: 'range', min: String(lo), max: String(hi), step: String(step), value: String(value), id });
  const out = el('input', { type: 'number', step: 'any', value: String(value), id: `${id}-value` });
  range.oninput = () => {
    out.value = range.value;
    set(Number(range.value));
  };
  out.onchange = () => {
    range.value = out.value;
    set(Number(out.value));
  };
  return el('div', { className: 'control' }, el('div', { className: 'label' }, el('b', { textContent: label }), el('span', { className: 'unit', textContent: unit })), el('div', { className: 'row' }, range, out));
}

function buildLight(): void {
  const host = $('light');
  const surface = isSurface();
  host.replaceChildren(el('h2', { textContent: 'light and view' }));
  const [lo, hi] = surface ? [0, 89] : [-89, 89];
  state.thetaI = Math.min(hi, Math.max(lo, state.thetaI));
  host.append(
    slider('θ_i', 'theta-i', lo, hi, 0.5, state.thetaI, surface ? 'degrees from the normal' : 'degrees from the normal plane (+ toward the tip)', (v) => {
      state.thetaI = v;
      refresh();
    }),
    slider('φ_i', 'phi-i', -180, 180, 1, state.phiI, surface ? 'degrees from the tangent' : 'degrees about the axis', (v) => {
      state.phiI = v;
      refresh();
    }),
  );
  const near = model().properties?.near_field;
  if (!surface && near) {
    const avg = el('input', { type: 'checkbox', checked: state.h === null, id: 'h-average' });
    const hs = slider('h', 'h', -1, 1, 0.01, state.h ?? 0, 'offset across the fiber', (v) => {
      state.h = v;
      avg.checked = false;
      refresh();
    });
    avg.onchange = () => {
      state.h = avg.checked ? null : Number(($('h') as HTMLInputElement).value);
      refresh();
    };
    host.append(el('div', { className: 'control' }, el('label', {}, avg, ' average over the width (far field)')), hs);
  }
  const channel = el('select', { id: 'channel' });
  for (const c of ['luminance', 'r', 'g', 'b']) channel.append(el('option', { value: c, textContent: c, selected: c === state.channel }));
  channel.onchange = () => {
    state.channel = channel.value as PageState['channel'];
    refresh();
  };
  const log = el('input', { type: 'checkbox', checked: state.log, id: 'log' });
  log.onchange = () => {
    state.log = log.checked;
    drawMap();
    saveUrl();
  };
  const decades = el('input', { type: 'number', min: '1', max: '12', step: '1', value: String(state.decades), id: 'decades' });
  decades.onchange = () => {
    state.decades = Math.max(1, Math.min(12, Number(decades.value) || 4));
    drawMap();
    saveUrl();
  };
  host.append(el('div', { className: 'control row' }, 'channel ', channel, el('label', {}, log, ' log'), decades, ' decades'));
  // Lobe toggles for models that separate their lobes without a `lobes` parameter.
  const m = model();
  if (!surface && !m.lobe_parameter && m.lobes.length > 1) {
    const checks = el('div', { className: 'checks', id: 'lobe-toggles' });
    for (const l of m.lobes) {
      const input = el('input', { type: 'checkbox', checked: state.lobes === null || state.lobes.includes(l.name), value: l.name });
      input.onchange = () => {
        const on = [...checks.querySelectorAll('input')].filter((i) => i.checked).map((i) => i.value);
        state.lobes = on.length === m.lobes.length ? null : on;
        refresh();
      };
      checks.append(el('label', {}, input, ` ${l.name}`));
    }
    host.append(el('div', { className: 'control' }, el('div', { className: 'label' }, el('b', { textContent: 'lobes shown' })), checks));
  }
}

// ---------------------------------------------------------------- scattering views

function heatOf(map: MapAnswer): Heat {
  return { rows: map.rows, cols: map.cols, values: map.values, theta: map.theta, phi: map.phi, max: map.max ?? 0 };
}

function drawMap(): void {
  if (!lastMap) return;
  const surface = lastMap.kind === 'surface';
  const canvas = $<HTMLCanvasElement>('heat');
  const name = `${state.model}${state.lobes ? ` [${state.lobes.join('+')}]` : ''}`;
  drawHeat(canvas, heatOf(lastMap), {
    title: surface
      ? `f_r of ${name} over the hemisphere, light at θ_i = ${state.thetaI}°, φ_i = ${state.phiI}° (${state.channel})`
      : `f_s of ${name}, θ_i = ${state.thetaI}°, φ_i = ${state.phiI}°${state.h === null ? '' : `, h = ${state.h}`} (${state.channel})${lastMap.delta ? ' — delta lobe: see the cone slice' : ''}`,
    xLabel: surface ? 'φ_o (degrees; light at φ_i)' : 'φ = φ_r − φ_i (degrees; 0 = backscatter, ±180 = forward)',
    yLabel: surface ? 'θ_o (degrees from the normal)' : 'θ_r (degrees)',
    unit: 'sr⁻¹',
    log: state.log,
    decades: state.decades,
    markers: surface ? [] : [{ y: -state.thetaI, label: 'specular cone θ_r = −θ_i' }],
  });
  fiberView?.update(lastMap, state.thetaI, state.phiI, state.log, state.decades);
}

async function updateMap(): Promise<void> {
  try {
    const t0 = performance.now();
    lastMap = await api.post<MapAnswer>('map', view(state.lobes ? { lobes: state.lobes } : {}));
    drawMap();
    status(`map ${lastMap.rows} × ${lastMap.cols}: max ${formatNumber(lastMap.max ?? 0)} sr⁻¹, ${Math.round(performance.now() - t0)} ms`);
    $('heat').dataset.max = String(lastMap.max ?? 0);
  } catch (e) {
    fail(e);
  }
}

function series(names: string[], x: number[], data: Record<string, number[]>): Series[] {
  return names.filter((n) => data[n]).map((n, i) => ({ name: n, x, y: data[n], color: LOBE_COLORS[i % LOBE_COLORS.length] }));
}

async function updateSlices(): Promise<void> {
  try {
    const s = await api.post<SlicesAnswer>('slices', view());
    const polar = state.polar;
    if (s.kind === 'fiber') {
      const m = s.delta
        ? plotSvg(series(s.lobes, s.phi, s.cone ?? {}), { title: `delta lobe on the cone θ_r = −θ_i (${state.model})`, xLabel: 'φ (degrees)', yLabel: 'n(φ)·A', polar })
        : plotSvg(series(s.lobes, s.theta, s.longitudinal ?? {}), { title: 'M(θ_r) = ∫ f_s dφ per lobe', xLabel: 'θ_r (degrees)', yLabel: 'sr⁻¹·rad', polar });
      const n = plotSvg(series(s.lobes, s.phi, s.azimuthal), { title: 'N(φ) = ∫ f_s cos²θ_r dθ_r per lobe', xLabel: 'φ (degrees; 0 = backscatter)', yLabel: 'power per radian', polar });
      lastSlices = { m, n };
    } else {
      const planes: Series[] = [
        { name: 'plane of incidence', x: s.theta, y: s.incidence_plane ?? [], color: LOBE_COLORS[0] },
        { name: 'plane across', x: s.theta, y: s.across_plane ?? [], color: LOBE_COLORS[1] },
      ];
      const m = plotSvg(planes, { title: 'f_r along two planes (signed θ_o; + toward the mirror side)', xLabel: 'θ_o (degrees)', yLabel: 'sr⁻¹', polar: false });
      const n = plotSvg(series(['all'], s.phi, s.azimuthal), { title: '∫ f_r cosθ_o sinθ_o dθ_o', xLabel: 'φ_o (degrees)', yLabel: 'per radian', polar });
      lastSlices = { m, n };
    }
    $('slice-m').innerHTML = lastSlices.m;
    $('slice-n').innerHTML = lastSlices.n;
  } catch (e) {
    fail(e);
  }
}

function rgbCells(c: [number, number, number]): string {
  const sw = `rgb(${c.map((x) => Math.round(255 * Math.min(1, Math.max(0, x)) ** (1 / 2.2))).join(',')})`;
  return `<td><span class="swatch" style="background:${sw}"></span></td>` + c.map((x) => `<td>${x.toFixed(4)}</td>`).join('');
}

async function updateNumbers(): Promise<void> {
  const host = $('numbers');
  try {
    host.classList.add('busy');
    const n = await api.post<NumbersAnswer>('numbers', view());
    const over = Math.max(...n.albedo_light) > 1 + 1e-3;
    const lobeRows = n.lobes
      .map((l) => {
        const total = n.albedo_light.reduce((a, b) => a + b, 0) || 1;
        const share = l.albedo.reduce((a, b) => a + b, 0) / total;
        return `<tr><td>${l.name}</td>${rgbCells(l.albedo).replace(/^<td>.*?<\/td>/, '<td></td>')}<td><div class="bar" style="width:${Math.round(60 * share)}px"></div></td></tr>`;
      })
      .join('');
    host.innerHTML = `<h3>Numbers at ω_i (the harness's integrals)</h3>
      <table class="numbers" id="numbers-table">
        <tr><th></th><th></th><th>r</th><th>g</th><th>b</th></tr>
        <tr data-row="albedo-light"><td>light-side albedo ρ(ω_i)</td>${rgbCells(n.albedo_light)}</tr>
        <tr data-row="albedo-camera"><td>camera-side (furnace) at ω_o = ω_i</td>${rgbCells(n.albedo_camera)}</tr>
        ${lobeRows ? `<tr><th>energy per lobe</th><th></th><th></th><th></th><th></th><th>share</th></tr>${lobeRows}` : ''}
      </table>
      <p>reciprocity: max relative defect <b data-row="reciprocity">${n.reciprocity === null ? '–' : formatNumber(n.reciprocity)}</b>
        <span class="claim">(${n.reciprocal ? 'claimed reciprocal' : 'not claimed reciprocal'})</span><br/>
        ∫ pdf dω at ω_o = ω_i: <b data-row="pdf">${n.pdf_integral === null ? '–' : n.pdf_integral.toFixed(5)}</b><br/>
        <span class="${over && n.energy_conserving ? 'bad' : 'claim'}">${n.energy_conserving ? 'claims energy conservation' : 'no energy claim'}${over ? '; ρ > 1 here' : ''}</span><br/>
        <span class="claim">quadrature: ${n.quadrature}</span></p>`;
    host.dataset.albedo = JSON.stringify(n.albedo_light);
  } catch (e) {
    fail(e);
  } finally {
    host.classList.remove('busy');
  }
}

function heatDrag(): void {
  const canvas = $<HTMLCanvasElement>('heat');
  let dragging = false;
  const move = (ev: PointerEvent) => {
    if (!dragging || !lastMap) return;
    const r = canvas.getBoundingClientRect();
    const p = pick(heatOf(lastMap), canvas.width, canvas.height, ((ev.clientX - r.left) * canvas.width) / r.width, ((ev.clientY - r.top) * canvas.height) / r.height);
    if (!p) return;
    if (lastMap.kind === 'surface') {
      // The mirror direction follows the cursor: light at (θ_o, φ_o + 180°).
      state.thetaI = Math.min(89, Math.round(p.theta * 2) / 2);
      state.phiI = Math.round(((p.phi + 360) % 360) - 180);
      $<HTMLInputElement>('phi-i').value = String(state.phiI);
      $<HTMLInputElement>('phi-i-value').value = String(state.phiI);
    } else {
      state.thetaI = Math.round(-p.theta * 2) / 2;
    }
    $<HTMLInputElement>('theta-i').value = String(state.thetaI);
    $<HTMLInputElement>('theta-i-value').value = String(state.thetaI);
    refresh();
  };
  canvas.addEventListener('pointerdown', (ev) => {
    dragging = true;
    canvas.setPointerCapture(ev.pointerId);
    move(ev);
  });
  canvas.addEventListener('pointermove', move);
  canvas.addEventListener('pointerup', () => (dragging = false));
}

// ---------------------------------------------------------------- exports

function download(name: string, data: string, type: string): void {
  const a = el('a', { href: data.startsWith('data:') ? data : URL.createObjectURL(new Blob([data], { type })), download: name });
  document.body.append(a);
  a.click();
  a.remove();
}

async function svgToPng(svg: string): Promise<string> {
  const img = new Image();
  img.src = 'data:image/svg+xml;charset=utf-8,' + encodeURIComponent(svg);
  await img.decode();
  const c = el('canvas', { width: img.width * 2, height: img.height * 2 });
  const g = c.getContext('2d');
  g?.scale(2, 2);
  g?.drawImage(img, 0, 0);
  return c.toDataURL('image/png');
}

function wireExports(): void {
  const base = () => `${state.model}-theta${state.thetaI}`;
  for (const b of document.querySelectorAll<HTMLButtonElement>('[data-export]')) {
    b.onclick = async () => {
      const what = b.dataset.export;
      const heat = $<HTMLCanvasElement>('heat');
      if (what === 'heat-png') download(`${base()}-map.png`, heat.toDataURL('image/png'), 'image/png');
      if (what === 'heat-svg') download(`${base()}-map.svg`, heatSvg(heat), 'image/svg+xml');
      if (what === 'm-svg') download(`${base()}-M.svg`, lastSlices.m, 'image/svg+xml');
      if (what === 'n-svg') download(`${base()}-N.svg`, lastSlices.n, 'image/svg+xml');
      if (what === 'm-png') download(`${base()}-M.png`, await svgToPng(lastSlices.m), 'image/png');
      if (what === 'n-png') download(`${base()}-N.png`, await svgToPng(lastSlices.n), 'image/png');
      if (what === '3d-png' && fiberView) download(`${base()}-3d.png`, fiberView.png(), 'image/png');
    };
  }
  $<HTMLInputElement>('polar').checked = state.polar;
  $<HTMLInputElement>('polar').onchange = () => {
    state.polar = $<HTMLInputElement>('polar').checked;
    saveUrl();
    updateSlices();
  };
}

// ---------------------------------------------------------------- compare

function tableOptions(select: HTMLSelectElement): void {
  select.replaceChildren(el('option', { value: '', textContent: tables.size ? '(choose a table)' : '(no table loaded)' }));
  for (const t of tables.values()) select.append(el('option', { value: String(t.id), textContent: `${t.id}: ${t.name} (${t.kind})`, selected: t.id === state.table }));
}

async function loadFile(file: File): Promise<void> {
  try {
    const t = await api.uploadTable<TableSummary>(file.name, await file.text());
    tables.set(t.id, t);
    state.table = t.id;
    status(`loaded ${t.name}: lobes ${t.lobes.join(', ')}; ${t.incidences.length} incidence(s), ${t.bins_theta} × ${t.bins_phi} bins`);
    buildCompare();
    buildFit();
    refresh();
  } catch (e) {
    fail(e);
  }
}

function buildCompare(): void {
  const host = $('tab-compare');
  const same = models.filter((m) => m.kind === model().kind && !m.needs_data);
  const which = el('select', { id: 'compare-model' });
  which.append(el('option', { value: '', textContent: '(a table instead)' }));
  for (const m of same) which.append(el('option', { value: m.name, textContent: m.name, selected: m.name === state.compareModel }));
  which.onchange = () => {
    state.compareModel = which.value || null;
    state.compareParams = {};
    if (state.compareModel) state.table = null;
    buildCompare();
    refresh();
  };
  const tableSelect = el('select', { id: 'compare-table' });
  tableOptions(tableSelect);
  tableSelect.onchange = () => {
    state.table = tableSelect.value ? Number(tableSelect.value) : null;
    if (state.table !== null) state.compareModel = null;
    buildCompare();
    refresh();
  };
  const drop = el('div', { className: 'drop', id: 'drop', textContent: 'Drop a goniophotometer table (CSV from fiberlab measure) here, or ' });
  const file = el('input', { type: 'file', accept: '.csv,text/csv', id: 'table-file' });
  file.onchange = () => file.files?.[0] && loadFile(file.files[0]);
  drop.append(file);
  drop.ondragover = (e) => {
    e.preventDefault();
    drop.classList.add('over');
  };
  drop.ondragleave = () => drop.classList.remove('over');
  drop.ondrop = (e) => {
    e.preventDefault();
    drop.classList.remove('over');
    const f = e.dataTransfer?.files?.[0];
    if (f) loadFile(f);
  };
  const bParams = el('div', { id: 'compare-params' });
  if (state.compareModel) {
    buildControls(bParams, model(state.compareModel), state.compareParams, (k, v) => {
      if (v === undefined) delete state.compareParams[k];
      else state.compareParams[k] = v;
      refresh();
    }, 'b');
  }
  host.replaceChildren(
    el('div', { className: 'panel' },
      el('h3', { textContent: `Compare ${state.model} (A) with a reference` }),
      el('div', { className: 'form' }, el('label', {}, 'reference model B ', which), el('label', {}, 'or table ', tableSelect)),
      drop,
      model().kind === 'fiber' ? measureForm() : el('p', { className: 'claim', textContent: 'Surface tables come from fiberlab measure --surface; drop one above.' }),
      el('details', {}, el('summary', { textContent: 'parameters of model B' }), bParams),
    ),
    el('div', { className: 'grid', id: 'compare-out' }),
  );
}

function measureForm(): HTMLElement {
  const fields: [string, string][] = [['eta', '1.55'], ['sigma_a', '0.5'], ['aspect', '1'], ['scale_angle', '3'], ['medulla_radius', '']];
  const inputs = fields.map(([k, v]) => el('input', { type: 'text', value: v, size: 6, id: `fiber-${k}`, placeholder: 'unset' }));
  const thetas = el('input', { type: 'text', value: String(state.thetaI), size: 10, id: 'measure-theta' });
  const rays = el('select', { id: 'measure-rays' });
  for (const r of [100_000, 300_000, 1_000_000, 3_000_000]) rays.append(el('option', { value: String(r), textContent: r.toLocaleString('en'), selected: r === 300_000 }));
  const bar = el('progress', { max: 1, value: 0, id: 'measure-progress' });
  const go = el('button', { textContent: 'Measure', id: 'measure' });
  go.onclick = async () => {
    const fiber: Record<string, number | string | number[]> = {};
    fields.forEach(([k], i) => {
      const t = inputs[i].value.trim();
      if (t === '') return;
      const parts = t.split(',').map(Number);
      fiber[k] = parts.length === 3 ? parts : parts.length === 1 && Number.isFinite(parts[0]) ? parts[0] : t;
    });
    try {
      bar.value = 0;
      await api.stream('measure', { fiber, theta_i: thetas.value.split(',').map(Number), phi_i: state.phiI, rays: Number(rays.value), bins_theta: 45, bins_phi: 90 }, (e) => {
        if (e.type === 'progress') bar.value = Number(e.done) / Number(e.total);
        if (e.type === 'done') {
          const t = e.table as TableSummary;
          tables.set(t.id, t);
          state.table = t.id;
          state.compareModel = null;
          status(`measured: ${t.name}`);
          buildCompare();
          buildFit();
          refresh();
        }
      });
    } catch (e) {
      fail(e);
    }
  };
  return el('details', {}, el('summary', { textContent: 'measure an explicit fiber on the server (goniophotometer)' }),
    el('div', { className: 'form' }, ...fields.flatMap(([k], i) => [el('label', {}, `${k} `, inputs[i])]), el('label', {}, 'θ_i (°, comma-separated) ', thetas), el('label', {}, 'rays ', rays), go),
    bar);
}

async function updateCompare(): Promise<void> {
  if (!state.compareModel && state.table === null) return;
  const out = $('compare-out');
  try {
    const body = view(state.compareModel ? { b: { model: state.compareModel, params: changed(model(state.compareModel), state.compareParams) } } : { table: state.table });
    const c = await api.post<CompareAnswer>('compare', body);
    const heat = (values: number[], max: number): Heat => ({ rows: c.rows, cols: c.cols, values, theta: c.theta, phi: c.phi, max });
    const refName = state.compareModel ?? tables.get(state.table ?? -1)?.name ?? `table ${state.table}`;
    const canvases = [0, 1, 2].map((i) => el('canvas', { width: 560, height: 300, id: `compare-${['a', 'b', 'd'][i]}` }));
    const xLabel = c.theta[0] === 0 ? 'φ_o (degrees)' : 'φ (degrees)';
    const yLabel = c.theta[0] === 0 ? 'θ_o (degrees)' : 'θ_r (degrees)';
    const where = c.incidence ? ` at the table's θ_i = ${c.incidence.theta_i.toFixed(1)}°` : '';
    drawHeat(canvases[0], heat(c.a, c.max ?? 0), { title: `A: ${state.model}${where}`, xLabel, yLabel, unit: 'sr⁻¹', log: state.log, decades: state.decades });
    drawHeat(canvases[1], heat(c.b, c.max ?? 0), { title: `reference: ${refName}`, xLabel, yLabel, unit: 'sr⁻¹', log: state.log, decades: state.decades });
    drawHeat(canvases[2], heat(c.difference, c.difference_max ?? 0), { title: 'A − reference', xLabel, yLabel, unit: 'sr⁻¹', log: false, decades: 1, signed: true });
    const rows = c.lobes.map((l) => `<tr><td>${l.name}</td><td>${l.rel_l2 === null ? '–' : l.rel_l2.toFixed(4)}</td><td>${l.mc_rel_l2 == null ? '' : l.mc_rel_l2.toFixed(4)}</td></tr>`).join('');
    const table = el('div', { className: 'panel' });
    table.innerHTML = `<h3>Relative L2 per lobe</h3><table class="numbers" id="compare-l2"><tr><th>lobe</th><th>rel. L2</th><th>table noise alone</th></tr>${rows}</table>
      <p class="claim">sqrt(Σ w (A − ref)² / Σ w ref²) over the bins, w = the bins' measure.</p>`;
    out.replaceChildren(...canvases.map((cv) => el('figure', { className: 'panel' }, cv)), table);
  } catch (e) {
    fail(e);
  }
}

// ---------------------------------------------------------------- fit

function buildFit(): void {
  const host = $('tab-fit');
  const t = state.table === null ? undefined : tables.get(state.table);
  if (!t) {
    host.replaceChildren(el('div', { className: 'panel' }, el('h3', { textContent: 'Fit' }), el('p', { textContent: 'Load or measure a table in Compare first; then fit this model to it here.' })));
    return;
  }
  const m = model();
  const free = el('div', { className: 'checks', id: 'fit-free' });
  for (const p of m.params.filter((q) => q.kind === 'number' || q.kind === 'color')) {
    const box = el('input', { type: 'checkbox', value: p.key, checked: state.free.includes(p.key) });
    box.onchange = () => {
      state.free = [...free.querySelectorAll('input')].filter((i) => i.checked).map((i) => i.value);
      saveUrl();
    };
    free.append(el('label', {}, box, ` ${p.key}`));
  }
  const lobe = el('select', { id: 'fit-lobe' });
  for (const l of t.lobes) lobe.append(el('option', { value: l, textContent: l, selected: l === state.fitLobe }));
  lobe.onchange = () => (state.fitLobe = lobe.value);
  const iterations = el('input', { type: 'number', value: String(state.iterations), min: '1', max: '5000', id: 'fit-iterations' });
  iterations.onchange = () => (state.iterations = Number(iterations.value));
  const go = el('button', { textContent: 'Fit', id: 'fit-run' });
  const live = el('div', { id: 'fit-live' });
  const chart = el('div', { className: 'plot', id: 'fit-chart' });
  go.onclick = () => runFit(t, live, chart);
  host.replaceChildren(el('div', { className: 'panel' },
    el('h3', { textContent: `Fit ${m.name} to ${t.name}` }),
    el('div', { className: 'form' }, el('span', { textContent: 'free parameters (start at the current values):' }), free),
    el('div', { className: 'form' }, el('label', {}, 'lobe ', lobe), el('label', {}, 'iterations ', iterations), go)),
    el('div', { className: 'grid' }, el('div', { className: 'panel' }, live), el('div', { className: 'panel' }, chart)));
}

async function runFit(t: TableSummary, live: HTMLElement, chart: HTMLElement): Promise<void> {
  const m = model();
  if (state.free.length === 0) return status('choose at least one free parameter', true);
  const free = state.free.map((key) => {
    const p = m.params.find((q) => q.key === key)!;
    const v = state.params[key] ?? defaultValue(p) ?? 0.5;
    return { key, start: Array.isArray(v) ? v : Number(v) };
  });
  const fixed: Params = {};
  for (const [k, v] of Object.entries(changed(m, state.params))) if (!state.free.includes(k)) fixed[k] = v;
  const history: { iteration: number; chi2: number }[] = [];
  const draw = () => (chart.innerHTML = plotSvg([{ name: 'χ²', x: history.map((h) => h.iteration), y: history.map((h) => h.chi2), color: LOBE_COLORS[1] }], { title: 'χ² of the best point', xLabel: 'iteration', yLabel: 'χ²', polar: false, log: true }));
  const show = (params: [string, number][], extra = '') => (live.innerHTML = `<table class="numbers" id="fit-params"><tr><th>parameter</th><th>value</th></tr>${params.map(([k, v]) => `<tr><td>${k}</td><td>${formatNumber(v)}</td></tr>`).join('')}</table>${extra}`);
  try {
    status(`fitting ${state.free.join(', ')} to ${t.name} (${state.fitLobe})…`);
    await api.stream('fit', { model: state.model, params: fixed, free, table: t.id, lobe: state.fitLobe, iterations: state.iterations }, (e) => {
      if (e.type === 'step') {
        history.push({ iteration: Number(e.iteration), chi2: Number(e.chi2) });
        show(e.params as [string, number][], `<p>iteration ${e.iteration}, χ² = ${formatNumber(Number(e.chi2))}</p>`);
        draw();
      }
      if (e.type === 'done') {
        const sigmas = (e.uncertainties as { sigma?: number; undefined?: string }[]).map((u) => (u.sigma !== undefined ? `± ${formatNumber(u.sigma)}` : `(${u.undefined})`));
        const params = e.params as [string, number][];
        live.innerHTML = `<table class="numbers" id="fit-params"><tr><th>parameter</th><th>value</th><th>1σ</th></tr>${params.map(([k, v], i) => `<tr><td>${k}</td><td>${formatNumber(v)}</td><td>${sigmas[i]}</td></tr>`).join('')}</table>
          <p id="fit-done">done: χ² = ${formatNumber(Number(e.chi2))}, ${e.dof} degrees of freedom (χ²/dof = ${formatNumber(Number(e.reduced_chi2))}), ${e.iterations} iterations</p>`;
        const apply = el('button', { textContent: 'Use these values', id: 'fit-apply' });
        apply.onclick = () => {
          for (const [k, v] of Object.entries(e.values as Record<string, number[]>)) state.params[k] = v.length === 1 ? v[0] : v;
          buildParams();
          refresh();
        };
        live.append(apply);
        status('fit done');
      }
    });
  } catch (err) {
    fail(err);
  }
}

// ---------------------------------------------------------------- render preview

let rendering = false;

function buildRender(): void {
  const host = $('tab-render');
  const scenes = isSurface() ? ['sphere', 'sample'] : ['fiber', 'tress', 'fur'];
  if (!scenes.includes(state.scene)) state.scene = scenes[0];
  const scene = el('select', { id: 'render-scene' });
  for (const s of scenes) scene.append(el('option', { value: s, textContent: s, selected: s === state.scene }));
  scene.onchange = () => {
    state.scene = scene.value;
    refresh();
    if (rendering) startRender();
  };
  const size = el('select', { id: 'render-size' });
  for (const s of [128, 256, 384, 512]) size.append(el('option', { value: String(s), textContent: `${s}²`, selected: s === state.size }));
  size.onchange = () => {
    state.size = Number(size.value);
    refresh();
  };
  const spp = el('input', { type: 'number', min: '1', max: '4096', value: String(state.spp), id: 'render-spp' });
  spp.onchange = () => {
    state.spp = Math.max(1, Number(spp.value) || 1);
    refresh();
  };
  const exposure = el('input', { type: 'number', step: '0.5', value: String(state.exposure), id: 'render-exposure' });
  exposure.onchange = () => {
    state.exposure = Number(exposure.value) || 0;
    refresh();
  };
  const go = el('button', { textContent: rendering ? 'Stop' : 'Render', id: 'render-go' });
  go.onclick = () => (rendering ? stopRender() : startRender());
  const img = el('img', { id: 'render-image', alt: 'render preview' });
  const counter = el('div', { className: 'spp', id: 'render-spp-count', textContent: '' });
  let dragging = false;
  const move = (ev: PointerEvent) => {
    if (!dragging) return;
    const r = img.getBoundingClientRect();
    const u = (ev.clientX - r.left) / r.width;
    const v = (ev.clientY - r.top) / r.height;
    state.light = [Math.round((u - 0.5) * 360), Math.round(90 - v * 180)];
    counter.textContent = `light: azimuth ${state.light[0]}°, elevation ${state.light[1]}°`;
    refresh();
  };
  img.addEventListener('pointerdown', (ev) => {
    dragging = true;
    img.setPointerCapture(ev.pointerId);
    move(ev);
  });
  img.addEventListener('pointermove', move);
  img.addEventListener('pointerup', () => (dragging = false));
  img.ondragstart = () => false;
  host.replaceChildren(el('div', { className: 'panel' },
    el('h3', { textContent: `Render preview of ${state.model}` }),
    el('div', { className: 'form' }, el('label', {}, 'scene ', scene), el('label', {}, 'size ', size), el('label', {}, 'spp ', spp), el('label', {}, 'exposure ', exposure), go),
    el('p', { className: 'claim', textContent: 'Path traced by the renderer on the server, progressively (1, 2, 4, … spp). Drag on the image to move the light: left–right its azimuth, up–down its elevation.' }),
    img, counter));
}

async function startRender(): Promise<void> {
  rendering = true;
  $('render-go').textContent = 'Stop';
  const counter = $('render-spp-count');
  const img = $<HTMLImageElement>('render-image');
  try {
    await api.stream('render', { model: state.model, params: changed(model(), state.params), scene: state.scene, light: state.light, size: state.size, spp: state.spp, exposure: state.exposure }, (e) => {
      if (e.type === 'frame') {
        img.src = String(e.png);
        counter.textContent = `${e.spp} / ${e.target} spp, ${Number(e.seconds).toFixed(1)} s`;
        counter.dataset.spp = String(e.spp);
      }
      if (e.type === 'done') {
        counter.textContent += ' — done';
        counter.dataset.done = '1';
      }
    });
  } catch (e) {
    fail(e);
  } finally {
    if (counter.dataset.done === '1') {
      rendering = false;
      $('render-go').textContent = 'Render';
    }
  }
}

function stopRender(): void {
  rendering = false;
  api.abort('render');
  $('render-go').textContent = 'Render';
}

// ---------------------------------------------------------------- tabs and start

function showTab(tab: Tab): void {
  state.tab = tab;
  for (const b of document.querySelectorAll<HTMLButtonElement>('#tabs button')) b.classList.toggle('active', b.dataset.tab === tab);
  for (const t of ['scatter', 'compare', 'fit', 'render']) $(`tab-${t}`).classList.toggle('active', t === tab);
  if (tab !== 'render' && rendering) stopRender();
  saveUrl();
  if (tab === 'compare') updateCompare();
}

function buildAll(): void {
  buildHeader();
  showAbout();
  buildLight();
  buildParams();
  buildCompare();
  buildFit();
  buildRender();
}

async function start(): Promise<void> {
  try {
    models = await api.models();
  } catch (e) {
    return fail(e);
  }
  state = decodeState(location.search, models);
  if (state.table !== null) {
    try {
      const r = await fetch(`/api/tables/${state.table}`);
      if (r.ok) tables.set(state.table, (await r.json()) as TableSummary);
      else state.table = null;
    } catch {
      state.table = null;
    }
  }
  buildAll();
  for (const b of document.querySelectorAll<HTMLButtonElement>('#tabs button')) b.onclick = () => showTab(b.dataset.tab as Tab);
  heatDrag();
  wireExports();
  try {
    const { FiberView } = await import('./fiber3d');
    fiberView = new FiberView($('fiber3d'));
  } catch (e) {
    $('fiber3d').textContent = `The 3D view needs WebGL (${e instanceof Error ? e.message : e}).`;
  }
  showTab(state.tab);
  refresh();
  document.body.dataset.ready = '1';
}

start();
