// The parameters as a TOML file that every command's `--params-file` reads: `model = "…"` and
// a `[params]` table (numbers, strings, arrays; `fiberlab_render::toml_params` converts them).

import type { ParamValue, Params } from './types';

/** A TOML basic string. */
export function tomlString(s: string): string {
  return '"' + s.replace(/\\/g, '\\\\').replace(/"/g, '\\"').replace(/\n/g, '\\n').replace(/\t/g, '\\t') + '"';
}

/** A TOML number (always a float or integer TOML accepts). */
export function tomlNumber(x: number): string {
  if (!Number.isFinite(x)) throw new Error(`${x} cannot be written in TOML parameters`);
  return String(x);
}

function value(v: ParamValue): string {
  if (Array.isArray(v)) return '[' + (v as (number | string)[]).map((x) => (typeof x === 'number' ? tomlNumber(x) : tomlString(x))).join(', ') + ']';
  if (typeof v === 'number') return tomlNumber(v);
  if (typeof v === 'boolean') return v ? 'true' : 'false';
  return tomlString(v);
}

/** A bare key, or a quoted one. */
function key(k: string): string {
  return /^[A-Za-z0-9_-]+$/.test(k) ? k : tomlString(k);
}

/** The file: a comment, `model`, then `[params]`. */
export function paramsToml(model: string, params: Params, comment = 'written by fiberlab explore'): string {
  const lines = [`# ${comment}`, `model = ${tomlString(model)}`, '', '[params]'];
  for (const [k, v] of Object.entries(params)) lines.push(`${key(k)} = ${value(v)}`);
  return lines.join('\n') + '\n';
}
