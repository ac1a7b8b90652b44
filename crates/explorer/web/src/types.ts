// What the API answers (crates/explorer/src/api): the registry and the plots.

export type ParamKind = 'number' | 'integer' | 'color' | 'choice' | 'subset' | 'text';

export interface ParamSpec {
  key: string;
  kind: ParamKind;
  unit: string;
  default: string;
  min: number | null;
  max: number | null;
  min_inclusive: boolean;
  max_inclusive: boolean;
  choices: string[] | null;
  valid: string;
  doc: string;
}

export interface ModelInfo {
  name: string;
  kind: 'fiber' | 'surface';
  summary: string;
  citation: string;
  needs_data: boolean;
  properties: Record<string, boolean> | null;
  lobes: { name: string; delta: boolean }[];
  lobe_parameter: string | null;
  params: ParamSpec[];
}

/** A parameter's value as the page holds it (what the API takes). */
export type ParamValue = number | string | boolean | number[] | string[];

export type Params = Record<string, ParamValue>;

export interface MapAnswer {
  kind: 'fiber' | 'surface';
  rows: number;
  cols: number;
  theta: [number, number];
  phi: [number, number];
  values: number[];
  max: number | null;
  min_positive: number | null;
  delta: boolean;
  cone: number[];
}

export interface SlicesAnswer {
  kind: 'fiber' | 'surface';
  lobes: string[];
  delta: boolean;
  theta: number[];
  phi: number[];
  longitudinal?: Record<string, number[]>;
  azimuthal: Record<string, number[]>;
  cone?: Record<string, number[]>;
  incidence_plane?: number[];
  across_plane?: number[];
}

export interface NumbersAnswer {
  kind: 'fiber' | 'surface';
  albedo_light: [number, number, number];
  albedo_camera: [number, number, number];
  lobes: { name: string; albedo: [number, number, number] }[];
  reciprocity: number | null;
  pdf_integral: number | null;
  reciprocal: boolean;
  energy_conserving: boolean;
  quadrature: string;
}

export interface TableSummary {
  id: number;
  name: string;
  kind: 'fiber' | 'surface';
  lobes: string[];
  incidences: { theta_i: number; phi_i: number }[];
  bins_theta: number;
  bins_phi: number;
}

export interface CompareAnswer {
  rows: number;
  cols: number;
  theta: [number, number];
  phi: [number, number];
  a: number[];
  b: number[];
  difference: number[];
  max: number | null;
  min_positive: number | null;
  difference_max: number | null;
  lobes: { name: string; rel_l2: number | null; mc_rel_l2?: number | null }[];
  incidence: { index: number; theta_i: number; phi_i: number } | null;
}
