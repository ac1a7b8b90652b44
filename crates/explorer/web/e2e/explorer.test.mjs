// Browser tests of `fiberlab explore`: Debian's Chromium driven by playwright-core against the
// real server (the release binary, started here on a free port). They load the page, move a
// slider and see the map change, check that the albedo shown is the API's, compare two
// models, measure a fiber, fit, render a preview to a set spp, and save screenshots for the
// book (docs/book/src/explorer/).
//
// FIBERLAB_BIN: the binary (default: the workspace's target/release/fiberlab);
// CHROMIUM: the browser (default /usr/bin/chromium); SCREENSHOTS: where to write them.

import { test, before, after } from 'node:test';
import assert from 'node:assert/strict';
import { spawn } from 'node:child_process';
import { mkdtempSync, mkdirSync, rmSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { dirname, join, resolve } from 'node:path';
import { fileURLToPath } from 'node:url';
import { chromium } from 'playwright-core';

const here = dirname(fileURLToPath(import.meta.url));
const root = resolve(here, '../../../..');
const bin = process.env.FIBERLAB_BIN ?? join(root, 'target/release/fiberlab');
const shots = process.env.SCREENSHOTS ?? join(root, 'docs/book/src/explorer');
mkdirSync(shots, { recursive: true });

let server;
let base;
let browser;
let page;
let profile;

before(async () => {
  server = spawn(bin, ['explore', '--port', '0'], { stdio: ['ignore', 'pipe', 'inherit'] });
  base = await new Promise((ok, fail) => {
    let out = '';
    server.stdout.on('data', (d) => {
      out += d;
      const m = /(http:\/\/[^\s]+\/)/.exec(out);
      if (m) ok(m[1]);
    });
    server.on('exit', (code) => fail(new Error(`fiberlab explore exited with ${code}`)));
    setTimeout(() => fail(new Error('no address printed in 20 s')), 20000);
  });
  profile = mkdtempSync(join(tmpdir(), 'fiberlab-chromium-'));
  // A fresh profile (playwright passes it as --user-data-dir).
  browser = await chromium.launchPersistentContext(profile, {
    executablePath: process.env.CHROMIUM ?? '/usr/bin/chromium',
    headless: true,
    viewport: { width: 1400, height: 1000 },
    args: ['--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run', '--disable-background-networking',
      '--disable-component-update', '--disable-sync', '--enable-unsafe-swiftshader'],
  });
  page = await browser.newPage();
  page.on('pageerror', (e) => console.error('page error:', e));
});

after(async () => {
  await browser?.close();
  server?.kill();
  if (profile) rmSync(profile, { recursive: true, force: true });
});

const mapPixels = () => page.evaluate(() => document.getElementById('heat').toDataURL());
const waitMapChange = async (before) => {
  await page.waitForFunction((b) => document.getElementById('heat').toDataURL() !== b, before, { timeout: 20000 });
};

test('the page loads, draws the map and the slider moves it', async () => {
  await page.goto(`${base}?m=chiang&ti=30`);
  await page.waitForSelector('body[data-ready="1"]');
  await page.waitForFunction(() => Number(document.getElementById('heat').dataset.max) > 0, null, { timeout: 20000 });
  await page.waitForSelector('#numbers-table', { timeout: 30000 });
  await page.waitForSelector('#slice-n svg');
  const first = await mapPixels();
  await page.screenshot({ path: join(shots, 'scattering.png') });
  // Move θ_i with the slider: the map is re-plotted.
  await page.locator('#theta-i').fill('-20');
  await waitMapChange(first);
  assert.match(page.url(), /ti=-20/);
  // A parameter: the longitudinal width.
  const second = await mapPixels();
  await page.locator('#p-beta_m').fill('0.6');
  await page.locator('#p-beta_m').dispatchEvent('change');
  await waitMapChange(second);
  assert.match(page.url(), /p\.beta_m=0\.6/);
});

test('the albedo shown is the one the API computes', async () => {
  await page.goto(`${base}?m=chiang&ti=25&p.beta_m=0.4`);
  await page.waitForSelector('#numbers-table', { timeout: 30000 });
  const shown = await page.evaluate(() => JSON.parse(document.getElementById('numbers').dataset.albedo));
  const cells = await page.locator('tr[data-row="albedo-light"] td').allTextContents();
  const r = await fetch(`${base}api/numbers`, {
    method: 'POST', headers: { 'content-type': 'application/json' },
    body: JSON.stringify({ model: 'chiang', params: { beta_m: 0.4 }, theta_i: 25, phi_i: 0, channel: 'luminance' }),
  });
  const api = await r.json();
  assert.deepEqual(shown, api.albedo_light);
  assert.deepEqual(cells.slice(2).map(Number), api.albedo_light.map((x) => Number(x.toFixed(4))));
});

test('a surface model, the 3D view and the lobe toggles', async () => {
  await page.goto(`${base}?m=marschner&ti=40&p.lobes=r,trt`);
  await page.waitForFunction(() => Number(document.getElementById('heat').dataset.max) > 0, null, { timeout: 20000 });
  await page.waitForSelector('#numbers-table', { timeout: 30000 });
  await page.screenshot({ path: join(shots, 'lobes.png') });
  await page.waitForSelector('#fiber3d canvas');
  await page.locator('#fiber3d').scrollIntoViewIfNeeded();
  await page.locator('#fiber3d').screenshot({ path: join(shots, 'fiber3d.png') });
  await page.locator('#polar').check();
  await page.waitForFunction(() => document.querySelector('#slice-n svg polygon') !== null, null, { timeout: 20000 });
  await page.locator('#slice-n').screenshot({ path: join(shots, 'polar.png') });
  await page.goto(`${base}?m=wood&ti=35&p.preset=tigers-eye`);
  await page.waitForFunction(() => Number(document.getElementById('heat').dataset.max) > 0, null, { timeout: 20000 });
  await page.waitForSelector('#numbers-table', { timeout: 60000 });
  await page.screenshot({ path: join(shots, 'surface.png') });
});

test('compare two models', async () => {
  await page.goto(`${base}?m=chiang&ti=30&tab=compare&cm=marschner`);
  await page.waitForSelector('#compare-l2', { timeout: 30000 });
  const rows = await page.locator('#compare-l2 tr').allTextContents();
  assert.ok(rows.some((t) => t.startsWith('TT')), rows.join('|'));
  await page.screenshot({ path: join(shots, 'compare.png') });
});

test('measure a fiber on the server, compare and fit', async () => {
  await page.goto(`${base}?m=kajiya-kay&ti=30&tab=compare`);
  await page.waitForSelector('#measure', { state: 'attached' });
  await page.locator('details', { hasText: 'measure an explicit fiber' }).locator('summary').click();
  await page.locator('#measure-rays').selectOption('100000');
  await page.locator('#measure').click();
  await page.waitForSelector('#compare-l2', { timeout: 60000 });
  // The measured table is the reference chosen (the form, with its progress bar, is rebuilt).
  const chosen = await page.locator('#compare-table').evaluate((s) => s.selectedOptions[0].textContent);
  assert.match(chosen, /measured θ_i = 30°, 100000 rays \(fiber\)/);
  await page.screenshot({ path: join(shots, 'measure.png') });
  await page.locator('#tabs button[data-tab="fit"]').click();
  await page.locator('#fit-free input[value="k_s"]').check();
  await page.locator('#fit-iterations').fill('40');
  await page.locator('#fit-iterations').dispatchEvent('change');
  await page.locator('#fit-run').click();
  await page.waitForSelector('#fit-done', { timeout: 60000 });
  assert.match(await page.locator('#fit-done').textContent(), /χ²/);
  await page.screenshot({ path: join(shots, 'fit.png') });
});

test('a render preview reaches the samples asked for', async () => {
  await page.goto(`${base}?m=chiang&tab=render&rs=fiber&rspp=8&rsz=128`);
  await page.waitForSelector('#render-go');
  await page.locator('#render-go').click();
  await page.waitForFunction(() => document.getElementById('render-spp-count').dataset.done === '1', null, { timeout: 60000 });
  assert.equal(await page.locator('#render-spp-count').evaluate((e) => e.dataset.spp), '8');
  const src = await page.locator('#render-image').getAttribute('src');
  assert.ok(src.startsWith('data:image/png;base64,'));
  await page.screenshot({ path: join(shots, 'render.png') });
});
