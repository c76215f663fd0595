// Helpers of the Node.js end-to-end tests (tests/hil/*/*.cjs): counted checks, waiting with a bound, a
// free loopback port, JSON over HTTP, a `teamscan demo` child whose output is echoed and kept, and the
// view's page opened in headless Chromium.
'use strict';
const { spawn } = require('node:child_process');
const fs = require('node:fs');
const http = require('node:http');
const net = require('node:net');
const os = require('node:os');
const path = require('node:path');

let failures = 0;
function check(ok, what) {
  console.log(`${ok ? 'ok  ' : 'FAIL'} ${what}`);
  if (!ok) failures++;
}
const failed = () => failures;
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

function freePort() {
  return new Promise((resolve, reject) => {
    const s = net.createServer();
    s.listen(0, '127.0.0.1', () => {
      const { port } = s.address();
      s.close(() => resolve(port));
    });
    s.on('error', reject);
  });
}

// GET url: { status, json } (json null unless 200; status 0 if the request failed).
function getJson(url) {
  return new Promise((resolve) => {
    http.get(url, (res) => {
      let body = '';
      res.on('data', (d) => (body += d));
      res.on('end', () => resolve({ status: res.statusCode, json: res.statusCode === 200 ? JSON.parse(body) : null }));
    }).on('error', () => resolve({ status: 0, json: null }));
  });
}

// Polls fn (sync or async) every 100 ms until it returns something truthy; throws after timeoutMs.
async function waitFor(what, timeoutMs, fn) {
  const end = Date.now() + timeoutMs;
  for (;;) {
    const v = await fn();
    if (v) return v;
    if (Date.now() > end) throw new Error(`timed out waiting for ${what}`);
    await sleep(100);
  }
}

// `teamscan ARGS...` with stdout and stderr echoed as "demo| ..." and kept in demo.output; onText(output)
// after each chunk.
function spawnDemo(teamscan, args, onText = () => {}) {
  const demo = { child: spawn(teamscan, args, { stdio: ['ignore', 'pipe', 'pipe'], env: process.env }), output: '', exited: false };
  demo.child.on('exit', () => (demo.exited = true));
  const collect = (d) => {
    const text = d.toString();
    process.stdout.write(text.split('\n').filter((l) => l).map((l) => `demo| ${l}`).join('\n') + '\n');
    demo.output += text;
    onText(demo.output);
  };
  demo.child.stdout.on('data', collect);
  demo.child.stderr.on('data', collect);
  return demo;
}

// SIGINT (the demo stops its daemons and the station in order), SIGKILL after 30 s.
async function stopDemo(demo) {
  if (demo.exited) return;
  demo.child.kill('SIGINT');
  const end = Date.now() + 30000;
  while (!demo.exited && Date.now() < end) await sleep(100);
  if (!demo.exited) demo.child.kill('SIGKILL');
}

// The view URL the demo prints once its station serves it.
function waitForViewUrl(demo, timeoutMs) {
  return waitFor('the demo to print the view URL', timeoutMs, () => {
    if (demo.exited) throw new Error('the demo exited early');
    const m = /live view at (http:\/\/127\.0\.0\.1:\d+\/)/.exec(demo.output);
    return m && m[1];
  });
}

// Debian's /usr/bin/chromium, headless, with a fresh profile, driven by playwright-core (NODE_PATH: the
// view's node_modules). WebGL without a GPU: SwiftShader (Chromium no longer falls back to it silently).
const CHROMIUM_FLAGS = ['--headless', '--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run',
  '--disable-background-networking', '--disable-component-update', '--disable-sync',
  '--use-angle=swiftshader', '--enable-unsafe-swiftshader'];

// Opens `url` (the view) in a new headless Chromium; { context, page, close() }. Page errors are echoed.
async function openView(url, timeoutMs) {
  const { chromium } = require('playwright-core');
  const profile = fs.mkdtempSync(path.join(os.tmpdir(), 'teamscan-view-chromium-'));
  const context = await chromium.launchPersistentContext(profile, {
    executablePath: '/usr/bin/chromium', headless: true, args: CHROMIUM_FLAGS, viewport: { width: 1280, height: 800 },
  });
  const close = async () => {
    await context.close().catch(() => {});
    fs.rmSync(profile, { recursive: true, force: true });
  };
  try {
    const page = context.pages()[0] || (await context.newPage());
    page.on('console', (m) => { if (m.type() === 'error') console.log(`page error: ${m.text()}`); });
    await waitFor('the page to load', timeoutMs, async () => {
      try {
        await page.goto(url, { timeout: 15000 });
        return true;
      } catch (e) {
        return false;
      }
    });
    return { context, page, close };
  } catch (e) {
    await close();
    throw e;
  }
}

// The demo's view (its printed URL) opened by openView; checks that the page draws with WebGL.
// { context, page, url, close() }.
async function openDemoView(demo) {
  const url = await waitForViewUrl(demo, 120000);
  const view = await openView(url, 120000);
  check(await view.page.evaluate(() => !!window.teamscanView && window.teamscanView.webgl), 'the page draws with WebGL');
  return { ...view, url };
}

module.exports = { check, failed, sleep, freePort, getJson, waitFor, spawnDemo, stopDemo, waitForViewUrl, openView, openDemoView };
