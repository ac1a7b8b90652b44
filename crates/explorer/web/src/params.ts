// Parameter values: defaults from the registry's text, slider ranges, conversion to and from
// the text of a URL, and checks the page makes before asking the server (which checks again).

import type { ModelInfo, ParamSpec, ParamValue, Params } from './types';

/** The default of a parameter as a value (undefined: optional, no default). */
export function defaultValue(p: ParamSpec): ParamValue | undefined {
  if (p.default === '') return undefined;
  return parseText(p, p.default);
}

/** A parameter's value from its text (`0.3`, `0.1,0.2,0.3`, `r,tt`, `on`). */
export function parseText(p: ParamSpec, text: string): ParamValue | undefined {
  const t = text.trim();
  switch (p.kind) {
    case 'number':
    case 'integer': {
      const x = Number(t);
      return t !== '' && Number.isFinite(x) ? x : undefined;
    }
    case 'color': {
      const parts = t.split(',').map((s) => Number(s.trim()));
      if (parts.some((x) => !Number.isFinite(x)) || t === '') return undefined;
      if (parts.length === 1) return parts[0];
      return parts.length === 3 ? parts : undefined;
    }
    case 'subset':
      return t === '' ? [] : t.split(',').map((s) => s.trim());
    case 'choice':
    case 'text':
      return t;
  }
}

/** A value as the text of a URL or of `--param key=value`. */
export function toText(v: ParamValue): string {
  return Array.isArray(v) ? v.join(',') : String(v);
}

/** Whether `x` lies in the parameter's range. */
export function inRange(p: ParamSpec, x: number): boolean {
  const lo = p.min ?? -Infinity;
  const hi = p.max ?? Infinity;
  return (p.min_inclusive ? x >= lo : x > lo) && (p.max_inclusive ? x <= hi : x < hi);
}

/** Why `v` is not a valid value of `p`, or null when it is. */
export function problem(p: ParamSpec, v: ParamValue): string | null {
  const numbers = Array.isArray(v) ? v : [v];
  if (p.kind === 'number' || p.kind === 'integer' || p.kind === 'color') {
    for (const x of numbers) {
      if (typeof x !== 'number' || !Number.isFinite(x)) return `\`${p.key}\`: expected a number`;
      if (!inRange(p, x)) return `\`${p.key}\` = ${x} is out of range; valid range ${p.valid}`;
      if (p.kind === 'integer' && !Number.isInteger(x)) return `\`${p.key}\`: expected a whole number`;
    }
  }
  if (p.kind === 'choice' && !(p.choices ?? []).includes(String(v))) return `\`${p.key}\`: one of ${(p.choices ?? []).join(', ')}`;
  if (p.kind === 'subset' && (!Array.isArray(v) || v.length === 0)) return `\`${p.key}\`: choose at least one`;
  return null;
}

/** The slider's span [lo, hi] and step for a number: the range, or around the default where open. */
export function sliderSpan(p: ParamSpec): { lo: number; hi: number; step: number } {
  const d = Number(p.default.split(',')[0]);
  const dflt = Number.isFinite(d) ? d : 0;
  let lo = p.min ?? Math.min(0, dflt);
  let hi = p.max ?? Math.max(1, dflt > 0 ? dflt * 5 : 10);
  if (!Number.isFinite(lo)) lo = Math.min(-10, dflt * 5);
  if (!Number.isFinite(hi)) hi = Math.max(1, dflt > 0 ? 5 * dflt : 10);
  const width = hi - lo || 1;
  const step = p.kind === 'integer' ? 1 : Number((width / 1000).toPrecision(1));
  // Open ends are not valid values: keep the slider one step inside them.
  if (!p.min_inclusive && p.min !== null) lo += step;
  if (!p.max_inclusive && p.max !== null) hi -= step;
  return { lo, hi, step };
}

/** A choice that is exactly on/off: drawn as a switch. */
export function isSwitch(p: ParamSpec): boolean {
  const c = p.choices ?? [];
  return p.kind === 'choice' && c.length === 2 && c.includes('on') && c.includes('off');
}

/** A colour whose channels are reflectances in [0, 1]: it gets a colour picker. */
export function isPickable(p: ParamSpec): boolean {
  return p.kind === 'color' && p.min === 0 && p.max === 1;
}

/** The parameters given (those that differ from the defaults), for requests and the URL. */
export function changed(model: ModelInfo, params: Params): Params {
  const out: Params = {};
  for (const p of model.params) {
    const v = params[p.key];
    if (v === undefined) continue;
    const d = defaultValue(p);
    if (d === undefined || toText(d) !== toText(v)) out[p.key] = v;
  }
  return out;
}

/** `#rrggbb` of a colour in [0, 1] (display-referred: the value is taken as sRGB-encoded). */
export function toHex(v: number | number[]): string {
  const c = Array.isArray(v) ? v : [v, v, v];
  return '#' + c.map((x) => Math.round(Math.min(1, Math.max(0, x)) * 255).toString(16).padStart(2, '0')).join('');
}

/** [r, g, b] in [0, 1] of `#rrggbb` (three decimals). */
export function fromHex(hex: string): number[] {
  const m = /^#?([0-9a-f]{2})([0-9a-f]{2})([0-9a-f]{2})$/i.exec(hex);
  if (!m) return [0, 0, 0];
  return [m[1], m[2], m[3]].map((h) => Math.round((parseInt(h, 16) / 255) * 1000) / 1000);
}
