// Controls generated from the registry: a slider and a number box for numbers (with the unit
// and valid range), one number or r,g,b for colours (a colour picker for reflectances in
// [0, 1]), a switch for on/off choices, a menu for other choices (presets), checkboxes for
// subsets (lobe toggles). Text parameters (file names) are not offered.

import { defaultValue, isPickable, isSwitch, problem, sliderSpan, toHex, fromHex } from './params';
import type { ModelInfo, ParamSpec, ParamValue, Params } from './types';

function el<K extends keyof HTMLElementTagNameMap>(tag: K, props: Partial<HTMLElementTagNameMap[K]> = {}, ...children: (Node | string)[]): HTMLElementTagNameMap[K] {
  const e = document.createElement(tag);
  Object.assign(e, props);
  for (const c of children) e.append(c);
  return e;
}
export { el };

/** Builds the controls of `model` into `host`; `onChange(key, value)` on every edit. */
export function buildControls(host: HTMLElement, model: ModelInfo, params: Params, onChange: (key: string, value: ParamValue | undefined) => void, idPrefix = 'p'): void {
  host.replaceChildren();
  for (const p of model.params) {
    if (p.kind === 'text') continue;
    host.append(control(p, params[p.key] ?? defaultValue(p), (v) => onChange(p.key, v), idPrefix));
  }
}

function header(p: ParamSpec): HTMLElement {
  const unit = p.unit ? ` (${p.unit})` : '';
  return el('div', { className: 'label' }, el('b', { textContent: p.key }), el('span', { className: 'unit', textContent: `${p.valid}${unit}` }));
}

function control(p: ParamSpec, value: ParamValue | undefined, set: (v: ParamValue | undefined) => void, idPrefix: string): HTMLElement {
  const box = el('div', { className: 'control' });
  box.dataset.key = p.key;
  box.append(header(p));
  const report = (v: ParamValue | undefined) => {
    const why = v === undefined ? null : problem(p, v);
    box.classList.toggle('invalid', why !== null);
    box.title = why ?? p.doc;
    if (why === null) set(v);
  };
  if (p.kind === 'number' || p.kind === 'integer') {
    box.append(numberRow(p, typeof value === 'number' ? value : undefined, report, `${idPrefix}-${p.key}`));
  } else if (p.kind === 'color') {
    box.append(colorRow(p, value as number | number[] | undefined, report, `${idPrefix}-${p.key}`));
  } else if (isSwitch(p)) {
    const input = el('input', { type: 'checkbox', checked: value === 'on', id: `${idPrefix}-${p.key}` });
    input.addEventListener('change', () => report(input.checked ? 'on' : 'off'));
    box.append(el('label', {}, input, ' on'));
  } else if (p.kind === 'choice') {
    const select = el('select', { id: `${idPrefix}-${p.key}` });
    for (const c of p.choices ?? []) select.append(el('option', { value: c, textContent: c, selected: c === value }));
    select.addEventListener('change', () => report(select.value));
    box.append(select);
  } else if (p.kind === 'subset') {
    const chosen = new Set(Array.isArray(value) ? (value as string[]) : []);
    const checks = el('div', { className: 'checks' });
    for (const c of p.choices ?? []) {
      const input = el('input', { type: 'checkbox', checked: chosen.has(c), value: c });
      input.addEventListener('change', () => {
        const on = [...checks.querySelectorAll('input')].filter((i) => i.checked).map((i) => i.value);
        report(on);
      });
      checks.append(el('label', {}, input, ` ${c}`));
    }
    box.append(checks);
  }
  if (p.doc) box.append(el('div', { className: 'doc', textContent: p.doc }));
  return box;
}

function numberRow(p: ParamSpec, value: number | undefined, report: (v: ParamValue | undefined) => void, id: string): HTMLElement {
  const { lo, hi, step } = sliderSpan(p);
  const range = el('input', { type: 'range', min: String(lo), max: String(hi), step: String(step), id: `${id}-range` });
  const box = el('input', { type: 'number', step: 'any', id });
  const show = (v: number | undefined) => {
    if (v === undefined) {
      box.value = '';
      box.placeholder = 'unset';
      return;
    }
    range.value = String(v);
    box.value = String(v);
  };
  show(value);
  range.addEventListener('input', () => {
    box.value = range.value;
    report(Number(range.value));
  });
  box.addEventListener('change', () => {
    if (box.value === '') return report(undefined);
    const v = Number(box.value);
    range.value = box.value;
    report(v);
  });
  return el('div', { className: 'row' }, range, box);
}

function colorRow(p: ParamSpec, value: number | number[] | undefined, report: (v: ParamValue | undefined) => void, id: string): HTMLElement {
  const text = el('input', { type: 'text', id, size: 16, value: value === undefined ? '' : Array.isArray(value) ? value.join(', ') : String(value), placeholder: 'x or r, g, b' });
  const row = el('div', { className: 'row' });
  const read = (): ParamValue | undefined => {
    const parts = text.value.split(',').map((s) => s.trim()).filter((s) => s !== '').map(Number);
    if (parts.length === 0) return undefined;
    return parts.length === 1 ? parts[0] : parts;
  };
  if (isPickable(p)) {
    const picker = el('input', { type: 'color', value: toHex(value ?? 0), id: `${id}-picker` });
    picker.addEventListener('input', () => {
      const c = fromHex(picker.value);
      text.value = c.join(', ');
      report(c);
    });
    text.addEventListener('change', () => {
      const v = read();
      if (v !== undefined) picker.value = toHex(v as number | number[]);
      report(v);
    });
    row.append(picker, text);
  } else {
    // A grey value on a slider as well as the text box (absorption coefficients, …).
    const { lo, hi, step } = sliderSpan(p);
    const range = el('input', { type: 'range', min: String(lo), max: String(hi), step: String(step) });
    if (typeof value === 'number') range.value = String(value);
    range.addEventListener('input', () => {
      text.value = range.value;
      report(Number(range.value));
    });
    text.addEventListener('change', () => report(read()));
    row.append(range, text);
  }
  return row;
}
