// Calls to the server. Every request names the page (header `x-fiberlab-page`), so that the
// server cancels the page's stale request of a kind when a newer one arrives; the page also
// aborts its own stale fetches. Errors carry the server's message.

import { readEvents } from './sse';
import type { ModelInfo } from './types';

/** This page's id (random per load). */
export const PAGE = Math.random().toString(36).slice(2) + Date.now().toString(36);

export class ApiError extends Error {
  constructor(readonly status: number, message: string) {
    super(message);
  }
}

const inFlight = new Map<string, AbortController>();

/** Aborts the page's request of `kind`, if any. */
export function abort(kind: string): void {
  inFlight.get(kind)?.abort();
  inFlight.delete(kind);
}

async function failure(r: Response): Promise<ApiError> {
  let message = `${r.status} ${r.statusText}`;
  try {
    const body = (await r.json()) as { error?: string };
    if (body.error) message = body.error;
  } catch {
    // not JSON
  }
  return new ApiError(r.status, message);
}

/** POSTs `body` as JSON to `/api/{path}`; a newer call of the same kind aborts this one. */
export async function post<T>(path: string, body: unknown, kind = path): Promise<T> {
  abort(kind);
  const controller = new AbortController();
  inFlight.set(kind, controller);
  const r = await fetch(`/api/${path}`, {
    method: 'POST',
    headers: { 'content-type': 'application/json', 'x-fiberlab-page': PAGE },
    body: JSON.stringify(body),
    signal: controller.signal,
  });
  if (inFlight.get(kind) === controller) inFlight.delete(kind);
  if (!r.ok) throw await failure(r);
  return (await r.json()) as T;
}

/** The registry. */
export async function models(): Promise<ModelInfo[]> {
  const r = await fetch('/api/models');
  if (!r.ok) throw await failure(r);
  return (await r.json()) as ModelInfo[];
}

/** Uploads a table's CSV text. */
export async function uploadTable<T>(name: string, text: string): Promise<T> {
  const r = await fetch(`/api/tables?name=${encodeURIComponent(name)}`, { method: 'POST', body: text, headers: { 'x-fiberlab-page': PAGE } });
  if (!r.ok) throw await failure(r);
  return (await r.json()) as T;
}

/**
 * POSTs to an event-stream endpoint and calls `on` for each event; aborting `kind` (or a
 * newer stream of that kind) closes the connection, which stops the server's work.
 */
export async function stream(path: string, body: unknown, on: (e: Record<string, unknown>) => void, kind = path): Promise<void> {
  abort(kind);
  const controller = new AbortController();
  inFlight.set(kind, controller);
  try {
    const r = await fetch(`/api/${path}`, {
      method: 'POST',
      headers: { 'content-type': 'application/json', 'x-fiberlab-page': PAGE },
      body: JSON.stringify(body),
      signal: controller.signal,
    });
    if (!r.ok) throw await failure(r);
    if (!r.body) throw new ApiError(500, 'no response body');
    await readEvents(r.body, (e) => {
      if (e.type === 'error') throw new ApiError(Number(e.status ?? 500), String(e.error));
      on(e);
    });
  } finally {
    if (inFlight.get(kind) === controller) inFlight.delete(kind);
  }
}

/** Whether an error is an abort (a stale request), not a failure to show. */
export function isAbort(e: unknown): boolean {
  return (e instanceof DOMException && e.name === 'AbortError') || (e instanceof ApiError && e.status === 409);
}
