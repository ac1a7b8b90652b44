import { describe, expect, it } from 'vitest';
import { barTicks, diverging, formatNumber, niceTicks, position, scaleFor, viridis } from '../src/colormap';
import { cellColours, pick } from '../src/heatmap';
import { plotSvg } from '../src/lineplot';
import { changed, defaultValue, fromHex, isPickable, isSwitch, parseText, problem, sliderSpan, toHex } from '../src/params';
import { splitEvents } from '../src/sse';
import { decodeState, defaultState, encodeState } from '../src/state';
import { paramsToml } from '../src/toml';
import type { ModelInfo, ParamSpec } from '../src/types';

const spec = (p: Partial<ParamSpec>): ParamSpec => ({
  key: 'x', kind: 'number', unit: '', default: '', min: null, max: null, min_inclusive: true, max_inclusive: true, choices: null, valid: '', doc: '', ...p,
});

const chiang: ModelInfo = {
  name: 'chiang', kind: 'fiber', summary: '', citation: '', needs_data: false, properties: { near_field: true }, lobes: [], lobe_parameter: null,
  params: [
    spec({ key: 'beta_m', default: '0.3', min: 0, max: 1, min_inclusive: false, valid: '(0, 1]' }),
    spec({ key: 'sigma_a', kind: 'color', default: '0.1,0.2,0.3', min: 0, max: null, valid: '[0, ∞) per channel' }),
    spec({ key: 'color', kind: 'color', default: '', min: 0, max: 1, valid: '[0, 1] per channel' }),
    spec({ key: 'glints', kind: 'choice', default: 'on', choices: ['on', 'off'] }),
    spec({ key: 'lobes', kind: 'subset', default: 'r,tt,trt', choices: ['r', 'tt', 'trt'] }),
    spec({ key: 'n', kind: 'integer', default: '3', min: 1, max: 8 }),
  ],
};
const lambertian: ModelInfo = { ...chiang, name: 'lambertian', kind: 'surface', params: [spec({ key: 'k_d', kind: 'color', default: '0.8', min: 0, max: 1 })] };
const measured: ModelInfo = { ...chiang, name: 'measured', needs_data: true, params: [] };
const models = [chiang, lambertian, measured];

describe('colour scales', () => {
  it('viridis runs from purple to yellow and clamps', () => {
    expect(viridis(0)).toEqual([68, 1, 84]);
    expect(viridis(1)).toEqual([253, 231, 37]);
    expect(viridis(-3)).toEqual(viridis(0));
    expect(viridis(NaN)).toEqual(viridis(0));
  });
  it('diverging is white at zero, blue below, red above', () => {
    expect(diverging(0)).toEqual([255, 255, 255]);
    expect(diverging(-1)[2]).toBeGreaterThan(diverging(-1)[0]);
    expect(diverging(1)[0]).toBeGreaterThan(diverging(1)[2]);
  });
  it('a log scale spans the decades below the maximum', () => {
    const s = scaleFor(100, true, 4);
    expect([s.lo, s.hi]).toEqual([-2, 2]);
    expect(position(s, 100)).toBe(1);
    expect(position(s, 1)).toBeCloseTo(0.5);
    expect(position(s, 1e-3)).toBe(0);
    expect(position(s, 0)).toBe(0);
    expect(barTicks(s)).toEqual([0.01, 0.1, 1, 10, 100]);
    const lin = scaleFor(2, false);
    expect(position(lin, 1)).toBe(0.5);
  });
  it('ticks are round and labels short', () => {
    expect(niceTicks(-180, 180, 8)).toEqual([-150, -100, -50, 0, 50, 100, 150]);
    expect(niceTicks(0, 1, 4)).toEqual([0, 0.25, 0.5, 0.75, 1]);
    expect(formatNumber(0.000123)).toBe('1.23e-4');
    expect(formatNumber(12345)).toBe('1.23e4');
    expect(formatNumber(0.5)).toBe('0.5');
    expect(formatNumber(0)).toBe('0');
  });
});

describe('heat map', () => {
  const heat = { rows: 2, cols: 3, values: [1, 2, 3, 4, 5, 6], theta: [-90, 90] as [number, number], phi: [-180, 180] as [number, number], max: 6 };
  it('puts row 0 (the lowest θ) at the bottom of the image', () => {
    const c = cellColours(heat, { title: '', xLabel: '', yLabel: '', unit: '', log: false, decades: 4 });
    // Pixel (0, 0) is the top-left: row 1's first cell (value 4).
    expect([...c.slice(0, 3)]).toEqual(viridis(4 / 6));
    expect([...c.slice(12, 15)]).toEqual(viridis(1 / 6));
  });
  it('picks (θ, φ) under the cursor', () => {
    const p = pick(heat, 758, 468, 58 + 304, 26 + 200);
    expect(p?.phi).toBeCloseTo(0);
    expect(p?.theta).toBeCloseTo(0);
    expect(pick(heat, 758, 468, 10, 10)).toBeNull();
  });
});

describe('parameters', () => {
  it('parse the registry text of each kind', () => {
    expect(defaultValue(chiang.params[0])).toBe(0.3);
    expect(defaultValue(chiang.params[1])).toEqual([0.1, 0.2, 0.3]);
    expect(defaultValue(chiang.params[2])).toBeUndefined();
    expect(defaultValue(chiang.params[4])).toEqual(['r', 'tt', 'trt']);
    expect(parseText(chiang.params[1], '0.5')).toBe(0.5);
    expect(parseText(chiang.params[1], '1,2')).toBeUndefined();
    expect(parseText(chiang.params[0], 'x')).toBeUndefined();
  });
  it('check ranges, open ends, integers and choices', () => {
    expect(problem(chiang.params[0], 0)).toMatch(/out of range/);
    expect(problem(chiang.params[0], 1)).toBeNull();
    expect(problem(chiang.params[1], [0.1, -1, 0])).toMatch(/out of range/);
    expect(problem(chiang.params[5], 2.5)).toMatch(/whole number/);
    expect(problem(chiang.params[3], 'maybe')).toMatch(/one of/);
    expect(problem(chiang.params[4], [])).toMatch(/at least one/);
  });
  it('sliders stay inside open ranges and span open-ended ones', () => {
    const s = sliderSpan(chiang.params[0]);
    expect(s.lo).toBeGreaterThan(0);
    expect(s.hi).toBe(1);
    const open = sliderSpan(chiang.params[1]);
    expect(open.lo).toBe(0);
    expect(open.hi).toBe(1); // at least 1, else five times the default
    expect(sliderSpan(chiang.params[5]).step).toBe(1);
  });
  it('switches, pickers, colours', () => {
    expect(isSwitch(chiang.params[3])).toBe(true);
    expect(isPickable(chiang.params[2])).toBe(true);
    expect(isPickable(chiang.params[1])).toBe(false);
    expect(toHex([1, 0.5, 0])).toBe('#ff8000');
    expect(fromHex('#ff8000')).toEqual([1, 0.502, 0]);
  });
  it('only changed values are sent', () => {
    expect(changed(chiang, { beta_m: 0.3, glints: 'off', sigma_a: [0.1, 0.2, 0.3] })).toEqual({ glints: 'off' });
  });
});

describe('URL state', () => {
  it('round-trips every knob', () => {
    const s = {
      ...defaultState('chiang'), params: { beta_m: 0.25, sigma_a: [0.5, 0.6, 0.7], lobes: ['r', 'tt'], glints: 'off' },
      thetaI: -12.5, phiI: 40, h: 0.3, channel: 'g' as const, log: false, decades: 6, lobes: ['R', 'TT'], polar: true, tab: 'render' as const,
      compareModel: 'chiang', compareParams: { beta_m: 0.5 }, table: 3, scene: 'fur', spp: 128, size: 384, light: [10, 20] as [number, number],
      exposure: 1.5, free: ['beta_m'], fitLobe: 'r', iterations: 50,
    };
    expect(decodeState(encodeState(s), models)).toEqual(s);
  });
  it('writes only what differs from the defaults', () => {
    expect(encodeState(defaultState('chiang'))).toBe('?m=chiang');
  });
  it('falls back for unknown models, bad numbers and models that need data', () => {
    const s = decodeState('?m=measured&ti=abc&p.beta_m=zz&tab=nope', models);
    expect(s.model).toBe('chiang');
    expect(s.thetaI).toBe(30);
    expect(s.params).toEqual({});
    expect(s.tab).toBe('scatter');
    expect(decodeState('?m=lambertian', models).scene).toBe('sphere');
  });
});

describe('exports and streams', () => {
  it('writes the TOML that --params-file reads', () => {
    expect(paramsToml('chiang', { beta_m: 0.25, sigma_a: [0.1, 0.2, 0.3], lobes: ['r', 'tt'], glints: 'off', 'odd key': 'a"b' }, 'c')).toBe(
      '# c\nmodel = "chiang"\n\n[params]\nbeta_m = 0.25\nsigma_a = [0.1, 0.2, 0.3]\nlobes = ["r", "tt"]\nglints = "off"\n"odd key" = "a\\"b"\n',
    );
    expect(() => paramsToml('m', { x: NaN })).toThrow();
  });
  it('splits server-sent events, keeping an unfinished one', () => {
    const { events, rest } = splitEvents('data: {"a":1}\n\n: keep-alive\n\ndata: {"b":\ndata: 2}\n\ndata: {"c"');
    expect(events).toEqual(['{"a":1}', '{"b":\n2}']);
    expect(rest).toBe('data: {"c"');
    expect(splitEvents('data: x\r\n\r\n').events).toEqual(['x']);
  });
  it('draws one path per lobe and a polar figure', () => {
    const s = [{ name: 'R', x: [0, 90, 180], y: [1, 2, 3], color: '#000' }, { name: 'TT', x: [0, 90, 180], y: [3, 2, 1], color: '#f00' }];
    const cart = plotSvg(s, { title: 't', xLabel: 'x', yLabel: 'y', polar: false });
    expect(cart.match(/<path /g)?.length).toBe(2);
    expect(cart).toContain('>TT<');
    const polar = plotSvg(s, { title: 't', xLabel: 'x', yLabel: 'y', polar: true });
    expect(polar.match(/<polygon /g)?.length).toBe(2);
  });
});
