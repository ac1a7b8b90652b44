// Server-sent events read from a fetch() body (POST requests cannot use EventSource): the
// `data:` lines of each event, joined, parsed as JSON.

/** Splits SSE text into complete events; returns their data and the unfinished rest. */
export function splitEvents(buffer: string): { events: string[]; rest: string } {
  const text = buffer.replace(/\r\n/g, '\n');
  const blocks = text.split('\n\n');
  const rest = blocks.pop() ?? '';
  const events: string[] = [];
  for (const block of blocks) {
    const data = block
      .split('\n')
      .filter((l) => l.startsWith('data:'))
      .map((l) => l.slice(5).replace(/^ /, ''));
    if (data.length > 0) events.push(data.join('\n'));
  }
  return { events, rest };
}

/** Reads a stream of JSON events, calling `on` for each until it ends or `signal` aborts. */
export async function readEvents(body: ReadableStream<Uint8Array>, on: (event: Record<string, unknown>) => void): Promise<void> {
  const reader = body.getReader();
  const decoder = new TextDecoder();
  let buffer = '';
  for (;;) {
    const { done, value } = await reader.read();
    if (done) break;
    buffer += decoder.decode(value, { stream: true });
    const { events, rest } = splitEvents(buffer);
    buffer = rest;
    for (const e of events) on(JSON.parse(e) as Record<string, unknown>);
  }
}
