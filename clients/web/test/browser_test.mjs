// Browser test of the viewer: geoproxd on the sample meshes, serving dist/ at "/" of its HTTP
// listener (its default static directory, or --static-dir), the page loaded from the daemon in
// headless Chromium (puppeteer-core). Clicks a source and shift-clicks a target at
// computed screen positions, compares the distance the page shows with the daemon's own answer
// (1e-9), checks the pixels (viridis field, path), saves a screenshot and times 20 clicks.
//
//   node test/browser_test.mjs --geoproxd PATH [--screenshot out.png] [--chromium /usr/bin/chromium]
//                              [--clicks 20] [--mesh spot] [--keep]
//                              [--mesh ID --mesh-file FILE [--ready-timeout SECONDS]]
//                              [--static-dir DIR] [--graph-dir DIR]
// Exit status: 0 all checks pass, 1 a check failed, 2 an error (a timeout, the daemon exited),
// 77 (ctest's skip) when what it needs is missing: node_modules, dist/, Chromium.
// Environment instead of flags: GEOPROXD, CHROMIUM, GEOPROX_WEB_SCREENSHOT, GEOPROX_WEB_GL
// (extra Chromium flags for WebGL, space-separated; default --use-angle=swiftshader
// --enable-unsafe-swiftshader).
import { spawn } from 'node:child_process';
import fs from 'node:fs';
import net from 'node:net';
import os from 'node:os';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import { viridis } from '../src/viridis.js';

const SKIP = 77;
/** Exits with ctest's skip code and a one-line reason. */
function skip(reason) {
  console.log(`skip: ${reason}`);
  process.exit(SKIP);
}
// Loaded here, not imported statically, so that a missing node_modules is a skip, not a crash.
let puppeteer;
let PNG;
try {
  puppeteer = (await import('puppeteer-core')).default;
  ({ PNG } = await import('pngjs'));
} catch (e) {
  skip(`no clients/web/node_modules (scripts/install-deps runs npm ci there): ${e.code || e}`);
}

const here = path.dirname(fileURLToPath(import.meta.url));
const webDir = path.resolve(here, '..');
const repoRoot = path.resolve(webDir, '../..');
const distDir = path.join(webDir, 'dist');

function arg(name, env, dflt) {
  const i = process.argv.indexOf(`--${name}`);
  if (i >= 0 && i + 1 < process.argv.length) return process.argv[i + 1];
  if (env && process.env[env]) return process.env[env];
  return dflt;
}
const geoproxd = arg('geoproxd', 'GEOPROXD', '');
const chromium = arg('chromium', 'CHROMIUM', '/usr/bin/chromium');
const screenshotPath = path.resolve(arg('screenshot', 'GEOPROX_WEB_SCREENSHOT', 'viewer-test.png'));
const clicks = Number(arg('clicks', null, '20'));
const meshId = arg('mesh', null, 'spot');
const keep = process.argv.includes('--keep');
// Another mesh than the samples (lucy, a subdivided lucy): served alone, under --mesh's id.
const meshFile = arg('mesh-file', null, '');
// The daemon's static directory; default: its own default (the build tree's clients/web/dist).
const staticDir = arg('static-dir', null, '');
// Graphs kept between runs (a big mesh's build takes minutes); default: a temp dir.
const graphDir = arg('graph-dir', null, '');
const readyTimeoutS = Number(arg('ready-timeout', null, '180'));
// How long a click may take to show its field or path: a frame of a big mesh takes seconds in
// software WebGL.
const waitMs = meshFile ? 180000 : 30000;
const glFlags = (arg('gl', 'GEOPROX_WEB_GL', '--use-angle=swiftshader --enable-unsafe-swiftshader'))
  .split(/\s+/)
  .filter(Boolean);

let failures = 0;
function check(ok, what) {
  console.log(`${ok ? 'ok  ' : 'FAIL'} ${what}`);
  if (!ok) failures++;
  return ok;
}
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));
const median = (xs) => {
  const s = [...xs].sort((a, b) => a - b);
  const m = s.length >> 1;
  return s.length % 2 ? s[m] : (s[m - 1] + s[m]) / 2;
};

/** n distinct free TCP ports on 127.0.0.1 (all held open until all are found). */
async function freePorts(n) {
  const servers = [];
  for (let i = 0; i < n; i++) {
    servers.push(
      await new Promise((resolve, reject) => {
        const srv = net.createServer();
        srv.on('error', reject);
        srv.listen(0, '127.0.0.1', () => resolve(srv));
      }),
    );
  }
  const ports = servers.map((s) => s.address().port);
  await Promise.all(servers.map((s) => new Promise((r) => s.close(r))));
  return ports;
}

// ---------------------------------------------------------------- pixels
const VIRIDIS_TABLE = Array.from({ length: 65 }, (_, i) => viridis(i / 64));
/** Bucket 0..15 of the viridis colour a pixel is a shade of, or -1. */
function viridisBucket(r, g, b) {
  const p = [r / 255, g / 255, b / 255];
  const sat = Math.max(...p) - Math.min(...p);
  if (sat < 0.12) return -1; // greys: the bare mesh, the background
  let best = -1;
  let bestErr = 0.05;
  VIRIDIS_TABLE.forEach((v, i) => {
    const vv = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
    const k = (p[0] * v[0] + p[1] * v[1] + p[2] * v[2]) / vv;
    if (k < 0.45 || k > 1.05) return;
    const err = Math.hypot(p[0] - k * v[0], p[1] - k * v[1], p[2] - k * v[2]);
    if (err < bestErr) {
      bestErr = err;
      best = i;
    }
  });
  return best < 0 ? -1 : Math.min(15, best >> 2);
}
function analyse(pngBuffer) {
  const png = PNG.sync.read(pngBuffer);
  const { width, height, data } = png;
  let viridisPixels = 0;
  const buckets = new Set();
  let pathPixels = 0;
  let minX = width, maxX = -1, minY = height, maxY = -1;
  for (let y = 0; y < height; y++) {
    for (let x = 0; x < width; x++) {
      const o = 4 * (y * width + x);
      const r = data[o], g = data[o + 1], b = data[o + 2];
      // The path: 0xff2050, which viridis never comes near.
      if (r > 200 && g < 90 && b > 40 && b < 140) {
        pathPixels++;
        minX = Math.min(minX, x); maxX = Math.max(maxX, x);
        minY = Math.min(minY, y); maxY = Math.max(maxY, y);
        continue;
      }
      const k = viridisBucket(r, g, b);
      if (k >= 0) {
        viridisPixels++;
        buckets.add(k);
      }
    }
  }
  const extent = maxX < 0 ? 0 : Math.max(maxX - minX, maxY - minY);
  return { width, height, viridisPixels, buckets: buckets.size, pathPixels, pathExtent: extent };
}

// ---------------------------------------------------------------- main
async function main() {
  if (!geoproxd || !fs.existsSync(geoproxd)) {
    throw new Error('give the geoproxd binary: --geoproxd PATH or GEOPROXD=PATH');
  }
  const servedDir = staticDir ? path.resolve(staticDir) : distDir;
  if (!fs.existsSync(path.join(servedDir, 'index.html'))) {
    skip(`no ${servedDir}/index.html (scripts/install-deps runs npm run build in clients/web)`);
  }
  if (!fs.existsSync(chromium)) skip(`no Chromium at ${chromium} (apt-get install chromium)`);

  // The daemon wants a query token: the page must send it (entered in its token field).
  const token = `web-test-${process.pid}-${Date.now()}`;
  const auth = { headers: { Authorization: `Bearer ${token}` } };
  const tmp = fs.mkdtempSync(path.join(os.tmpdir(), 'geoprox-web-'));
  const [port, httpPort, deadPort] = await freePorts(3);
  const cfg = {
    bind: '127.0.0.1',
    port,
    admin_port: 0,
    http_port: httpPort,
    compute_threads: 1,
    build_threads: 1,
    data_dir: path.join(repoRoot, 'data'),
    graph_dir: graphDir ? path.resolve(graphDir) : path.join(tmp, 'graphs'),
    log_level: 'warn',
    query_token: token,
    meshes: [
      { id: 'spot', mesh: 'meshes/spot.obj' },
      { id: 'dragon', mesh: 'meshes/ChineseDragon-10kv.off' },
      // Refused on purpose (a non-manifold vertex, data/meshes/README.md): a failed mesh in the list.
      { id: 'pig', mesh: 'meshes/pig.stl' },
      // Two tetrahedra apart: a target on the other one is Unreachable.
      { id: 'twins', mesh: path.join(tmp, 'twins.obj') },
    ],
  };
  fs.writeFileSync(
    path.join(tmp, 'twins.obj'),
    ['v 0 0 0', 'v 1 0 0', 'v 0 1 0', 'v 0 0 1', 'v 2 0 0', 'v 3 0 0', 'v 2 1 0', 'v 2 0 1',
      'f 1 3 2', 'f 1 2 4', 'f 2 3 4', 'f 1 4 3', 'f 5 7 6', 'f 5 6 8', 'f 6 7 8', 'f 5 8 7', ''].join('\n'),
  );
  if (meshFile) {
    cfg.data_dir = path.dirname(path.resolve(meshFile));
    cfg.meshes = [{ id: meshId, mesh: path.basename(meshFile) }];
    cfg.build_threads = 0;
  }
  if (staticDir) cfg.http_static_dir = path.resolve(staticDir);
  fs.writeFileSync(path.join(tmp, 'cfg.json'), JSON.stringify(cfg, null, 2));
  const daemonLog = fs.openSync(path.join(tmp, 'geoproxd.log'), 'w');
  const daemon = spawn(geoproxd, ['--config', path.join(tmp, 'cfg.json')], {
    stdio: ['ignore', daemonLog, daemonLog],
  });
  let daemonExited = false;
  daemon.on('exit', () => (daemonExited = true));
  process.on('exit', () => daemonExited || daemon.kill('SIGKILL')); // never leave it behind
  const apiBase = `http://127.0.0.1:${httpPort}`;
  let browser = null;
  try {
    // The daemon, ready, with the mesh's graph built.
    const t0 = Date.now();
    for (;;) {
      if (daemonExited) throw new Error(`geoproxd exited: ${fs.readFileSync(path.join(tmp, 'geoproxd.log'), 'utf8')}`);
      if (Date.now() - t0 > readyTimeoutS * 1000) throw new Error(`geoproxd not ready in ${readyTimeoutS} s`);
      try {
        const list = await (await fetch(`${apiBase}/v1/meshes`, auth)).json();
        const m = list.meshes.find((x) => x.id === meshId);
        if (m && m.state === 'ready') break;
        if (m && m.state === 'failed') throw new Error(`mesh ${meshId} failed: ${JSON.stringify(m.error)}`);
      } catch (e) {
        if (/failed:/.test(e.message)) throw e; // else: not listening yet
      }
      await sleep(200);
    }
    console.log(`geoproxd ready on ${apiBase} in ${Date.now() - t0} ms`);

    // The page from the daemon itself: same origin, no api= and no CORS; no token for files.
    const index = await fetch(`${apiBase}/`);
    const indexText = await index.text();
    check(index.status === 200 && index.headers.get('content-type') === 'text/html; charset=utf-8' &&
      index.headers.get('cache-control') === 'no-cache' &&
      indexText === fs.readFileSync(path.join(servedDir, 'index.html'), 'utf8'),
    `geoproxd serves ${servedDir}/index.html at / without the token (HTTP ${index.status}, ` +
      `${index.headers.get('content-type')}, Cache-Control ${index.headers.get('cache-control')})`);
    const asset = indexText.match(/src="\.?\/?(assets\/[^"]+\.js)"/);
    if (check(asset !== null, 'index.html names its script under assets/')) {
      const script = await fetch(`${apiBase}/${asset[1]}`);
      check(script.status === 200 && /^text\/javascript/.test(script.headers.get('content-type')) &&
        script.headers.get('cache-control') === 'public, max-age=31536000, immutable',
      `${asset[1]}: HTTP ${script.status}, ${script.headers.get('content-type')}, ` +
        `Cache-Control ${script.headers.get('cache-control')}`);
    }
    const pageUrl = `${apiBase}/?mesh=${meshId}`;
    browser = await puppeteer.launch({
      executablePath: chromium,
      headless: true,
      userDataDir: path.join(tmp, 'chromium-profile'),
      args: [
        '--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run',
        '--disable-background-networking', '--disable-component-update', '--disable-sync',
        ...glFlags,
      ],
      defaultViewport: { width: 1100, height: 720 },
    });
    // A mesh still building (the other sample mesh, when its graph is not built yet): the page
    // opened on it says so, and opens it by itself once it is ready.
    const other = meshId === 'spot' ? 'dragon' : 'spot';
    const otherState = (await (await fetch(`${apiBase}/v1/meshes`, auth)).json()).meshes.find((m) => m.id === other);
    let buildingPage = null;
    let buildingText = '';
    if (otherState && otherState.state !== 'ready') {
      buildingPage = await browser.newPage();
      await buildingPage.evaluateOnNewDocument((t) => sessionStorage.setItem('geoprox-token', t), token);
      await buildingPage.goto(`${apiBase}/?mesh=${other}`);
      await buildingPage.waitForFunction(
        () => !document.getElementById('error').hidden || (window.__geoprox && window.__geoprox.meshSeq >= 1),
        { timeout: 30000 },
      );
      buildingText = await buildingPage.$eval('#error', (e) => (e.hidden ? '' : e.textContent));
    }

    const page = await browser.newPage();
    const pageErrors = [];
    page.on('pageerror', (e) => pageErrors.push(String(e)));
    page.on('console', (m) => {
      if (m.type() === 'error') pageErrors.push(m.text());
    });
    await page.goto(pageUrl);
    // Without the token: a plain error; with it typed in the field, the mesh loads.
    await page.waitForFunction(() => !document.getElementById('error').hidden, { timeout: 20000 });
    const noToken = await page.$eval('#error', (e) => e.textContent);
    if (/WebGL/.test(noToken)) throw new Error(`${noToken} (try other flags in GEOPROX_WEB_GL)`);
    check(/query token/.test(noToken), `without the token the page says so: "${noToken}"`);
    await page.type('#token', token);
    const loadStart = performance.now();
    await page.keyboard.press('Enter');
    await page.waitForFunction(() => window.__geoprox && window.__geoprox.meshSeq >= 1, { timeout: 180000 });
    const faces = await page.evaluate(() => window.__geoprox.mesh.geometry.index.count / 3);
    console.log(`mesh ${meshId} (${faces} faces) opened in ${(performance.now() - loadStart).toFixed(0)} ms` +
      ' (token entered to the mesh shown: list, geometry, BVH, first frame)');
    pageErrors.length = 0; // the 401s before the token was entered were expected
    const glInfo = await page.evaluate(() => {
      const gl = window.__geoprox.renderer.getContext();
      const ext = gl.getExtension('WEBGL_debug_renderer_info');
      return {
        version: gl.getParameter(gl.VERSION),
        renderer: ext ? gl.getParameter(ext.UNMASKED_RENDERER_WEBGL) : '?',
        software: window.__geoprox.gpu.software,
        samples: gl.getParameter(gl.SAMPLES),
      };
    });
    console.log(`WebGL: ${glInfo.version}; ${glInfo.renderer}; flags ${glFlags.join(' ')}; ` +
      `${glInfo.software ? 'software' : 'GPU'}, ${glInfo.samples} samples per pixel`);
    // A software rasteriser draws without multisampling (the page's choice; a GPU keeps it).
    if (glInfo.software) check(glInfo.samples <= 1, 'no multisampling on a software rasteriser');
    const listText = await page.$eval('#meshes', (e) => e.textContent);
    check(listText.includes(meshId) && listText.includes('ready'), `the mesh list shows ${meshId}, ready`);

    const bare = analyse(await page.screenshot());
    check(bare.viridisPixels < 200, `no field before a click (${bare.viridisPixels} viridis pixels)`);

    // Visible vertices and their screen positions, from the page's own camera.
    const visible = await page.evaluate(() => {
      const g = window.__geoprox;
      // Points inside faces (a ray exactly through a vertex or along an edge can slip between
      // triangles), a face in 7.
      const n = g.mesh.geometry.index.count / 3;
      const out = [];
      for (let f = 0; f < n; f += 7) {
        const point = `f:${f}:0.6:0.25:0.15`;
        const s = g.screenOf(point);
        if (s.visible) out.push({ f, point, x: s.x, y: s.y, position: s.position });
      }
      return out;
    });
    check(visible.length > 50, `${visible.length} visible sample vertices`);

    const clickAt = async (v, shift = false) => {
      if (shift) await page.keyboard.down('Shift');
      await page.mouse.click(v.x, v.y);
      if (shift) await page.keyboard.up('Shift');
    };
    const waitSeq = async (key, before) => {
      try {
        await page.waitForFunction((k, b) => window.__geoprox[k] > b, { timeout: waitMs }, key, before);
      } catch (e) {
        const why = await page.evaluate(() => ({
          error: document.getElementById('error').textContent,
          status: document.getElementById('status').textContent,
          lastPick: window.__geoprox.lastPick && window.__geoprox.lastPick.point,
          debug: window.__geoprox.debug,
          fieldSeq: window.__geoprox.fieldSeq,
        }));
        throw new Error(`waiting for ${key} > ${before}: ${e.message}; page: ${JSON.stringify(why)}; console: ${pageErrors.join(' | ')}`);
      }
    };
    const seq = (key) => page.evaluate((k) => window.__geoprox[k], key);

    // The cost of one frame in this browser (software WebGL here).
    const frameMs = await page.evaluate(() => {
      const g = window.__geoprox;
      const gl = g.renderer.getContext();
      const px = new Uint8Array(4);
      const t = [];
      for (let i = 0; i < 11; i++) {
        const a = performance.now();
        g.renderer.render(g.scene, g.camera);
        gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, px);
        t.push(performance.now() - a);
      }
      return t.sort((x, y) => x - y)[5];
    });
    console.log(`one frame (render + readPixels), median of 11: ${frameMs.toFixed(1)} ms`);

    // Click-to-coloured-field, 20 clicks on visible vertices.
    await page.evaluate(() => (window.__geoprox.syncFrames = true));
    const inPage = [];
    const outside = [];
    const fetches = [];
    const waits = [];
    for (let c = 0; c < clicks; c++) {
      const v = visible[Math.floor(((c + 0.5) / clicks) * visible.length)];
      const before = await seq('fieldSeq');
      const t = performance.now();
      await clickAt(v);
      await waitSeq('fieldSeq', before);
      outside.push(performance.now() - t);
      const m = await page.evaluate(() => {
        const g = window.__geoprox;
        return { total: g.lastFieldMs, fetch: g.lastFieldFetchMs, wait: g.lastFieldTiming && g.lastFieldTiming.waitMs != null ? g.lastFieldTiming.waitMs : NaN };
      });
      inPage.push(m.total);
      fetches.push(m.fetch);
      waits.push(m.wait);
    }
    console.log(
      `click to coloured field on ${meshId}, median of ${clicks}: ${median(inPage).toFixed(1)} ms in the page` +
        ` (pointerup to the frame drawn, synced by readPixels; the fetch alone ${median(fetches).toFixed(1)} ms` +
        `${waits.every(Number.isFinite) ? `, of which waiting for the answer ${median(waits).toFixed(1)} ms` : ''}),` +
        ` ${median(outside).toFixed(1)} ms from the test's mouse click`,
    );

    await page.evaluate(() => (window.__geoprox.syncFrames = false));

    // Source and target far apart on screen (among at most 400 of the visible points: the
    // search is quadratic).
    const spread = visible.filter((_, i) => i % Math.ceil(visible.length / 400) === 0);
    let src = spread[0];
    let dst = spread[0];
    for (const a of spread) {
      for (const b of spread) {
        if (Math.hypot(a.x - b.x, a.y - b.y) > Math.hypot(src.x - dst.x, src.y - dst.y)) {
          src = a;
          dst = b;
        }
      }
    }
    let before = await seq('fieldSeq');
    await clickAt(src);
    await waitSeq('fieldSeq', before);
    const picked = await page.evaluate((v) => {
      const g = window.__geoprox;
      const p = new g.THREE.Vector3(...v.position);
      g.mesh.geometry.computeBoundingBox();
      const size = g.mesh.geometry.boundingBox.getSize(new g.THREE.Vector3()).length();
      return { source: g.state.sources[0], off: g.lastPick.position.distanceTo(p), face: g.lastPick.face, size };
    }, src);
    // Within 1e-3 of the mesh's size: where faces are smaller than a pixel the ray may hit a
    // neighbour of the face aimed at (the page's point is what is compared with the daemon).
    const pickTolerance = 1e-3 * Math.max(1, picked.size);
    check(picked.off < pickTolerance,
      `the click hit the surface point aimed at, ${src.point} (page: ${picked.source}, ` +
        `${picked.off.toExponential(2)} away, tolerance ${pickTolerance.toExponential(1)})`);
    const field = analyse(await page.screenshot());
    check(field.viridisPixels > 0.03 * field.width * field.height && field.buckets >= 8,
      `the field is coloured in viridis (${field.viridisPixels} pixels, ${field.buckets}/16 colours)`);

    before = await seq('pathSeq');
    await clickAt(dst, true);
    await waitSeq('pathSeq', before);
    const shown = await page.evaluate(() => {
      const g = window.__geoprox;
      return {
        text: document.getElementById('distance').textContent,
        exact: document.getElementById('exact').textContent,
        latency: document.getElementById('latency').textContent,
        source: g.state.distance.source,
        target: g.state.distance.target,
        ends: [g.state.distance.points[0].position, g.state.distance.points.slice(-1)[0].position],
        mine: [g.pointPosition(g.state.distance.source), g.pointPosition(g.state.distance.target)],
        size: (g.mesh.geometry.computeBoundingBox(), g.mesh.geometry.boundingBox.getSize(new g.THREE.Vector3()).length()),
        url: window.location.href,
      };
    });
    const q = new URLSearchParams({ source: shown.source, target: shown.target });
    const daemonAnswer = await (await fetch(`${apiBase}/v1/meshes/${meshId}/distance?${q}`, auth)).json();
    const pageDistance = Number(shown.text);
    check(
      Number.isFinite(pageDistance) && Math.abs(pageDistance - daemonAnswer.distance) <= 1e-9,
      `#distance ${shown.text} (${shown.exact}, ${shown.latency}) = the daemon's ${daemonAnswer.distance} ` +
        `for ${shown.source} -> ${shown.target}`,
    );

    const gap = Math.max(...[0, 1].map((k) => Math.hypot(...[0, 1, 2].map((c) => shown.ends[k][c] - shown.mine[k][c]))));
    // The page's points come from float32 positions: 1e-6 of the mesh's size.
    const endTolerance = 1e-6 * Math.max(1, shown.size);
    check(gap < endTolerance, `the path's ends from the daemon are the page's source and target ` +
      `(${gap.toExponential(2)} apart, tolerance ${endTolerance.toExponential(1)})`);

    const png = await page.screenshot({ path: screenshotPath });
    const withPath = analyse(png);
    check(withPath.pathPixels > 100 && withPath.pathExtent > 50 && field.pathPixels < 20,
      `the path is drawn (${withPath.pathPixels} path pixels over ${withPath.pathExtent} px; ${field.pathPixels} before)`);
    check(withPath.viridisPixels > 0.03 * withPath.width * withPath.height, 'the field is still coloured');
    console.log(`screenshot: ${screenshotPath}`);

    // The state in the URL: a new page on it shows the same distance.
    const page2 = await browser.newPage();
    await page2.evaluateOnNewDocument((t) => sessionStorage.setItem('geoprox-token', t), token);
    await page2.goto(shown.url);
    await page2.waitForFunction(() => window.__geoprox && window.__geoprox.pathSeq >= 1, { timeout: waitMs });
    const again = await page2.$eval('#distance', (e) => e.textContent);
    check(again === shown.text, `the page's URL restores the view (distance ${again})`);
    await page2.close();

    // An orbit (a drag) goes into the URL's camera, and a new tab on that URL has that camera.
    await page.bringToFront();
    const from = visible[Math.floor(visible.length / 2)];
    await page.mouse.move(from.x, from.y);
    const orbitStart = performance.now();
    await page.mouse.down();
    for (let k = 1; k <= 8; k++) await page.mouse.move(from.x + 15 * k, from.y + 4 * k);
    await page.mouse.up();
    console.log(`an orbit of 8 mouse moves took ${(performance.now() - orbitStart).toFixed(0)} ms`);
    const orbit = await page.evaluate(() => ({
      url: window.location.href,
      cam: window.__geoprox.camera.position.toArray(),
    }));
    const camParam = new URL(orbit.url).searchParams.get('camera') || '';
    const page4 = await browser.newPage();
    await page4.evaluateOnNewDocument((t) => sessionStorage.setItem('geoprox-token', t), token);
    await page4.goto(orbit.url);
    await page4.waitForFunction(() => window.__geoprox && window.__geoprox.pathSeq >= 1, { timeout: waitMs });
    const cam4 = await page4.evaluate(() => window.__geoprox.camera.position.toArray());
    await page4.close();
    await page.bringToFront();
    const camGap = Math.hypot(...[0, 1, 2].map((c) => cam4[c] - orbit.cam[c]));
    const moved = shown.url !== orbit.url;
    // The URL keeps 6 significant digits: the same camera within 1e-5 of its distance to 0.
    const camTolerance = 1e-5 * Math.max(1, Math.hypot(...orbit.cam));
    check(moved && camParam.split(',').length === 6 && camGap < camTolerance,
      `an orbit updates the URL (camera=${camParam}) and a new tab on it has the same camera ` +
        `(${camGap.toExponential(1)} apart, tolerance ${camTolerance.toExponential(1)})`);

    // The cutoff slider greys what is beyond it, and the legend says so in mesh units.
    const setSlider = (v) =>
      page.evaluate(async (v) => {
        const el = document.getElementById('cutoff');
        el.value = String(v);
        el.dispatchEvent(new Event('input'));
        await window.__geoprox.nextFrame();
        return document.getElementById('legend-note').textContent;
      }, v);
    const legend = await setSlider(300);
    const cut = analyse(await page.screenshot());
    check(cut.viridisPixels < 0.8 * withPath.viridisPixels && /cutoff/.test(legend),
      `the cutoff slider at 30% greys the far field (${cut.viridisPixels} viridis pixels; legend "${legend}")`);
    await setSlider(1000);

    // Several sources, coloured by nearest source: a point still visible after the orbit, at
    // its screen position from the camera of now.
    const second = await page.evaluate((points) => {
      for (const point of points) {
        const s = window.__geoprox.screenOf(point);
        if (s.visible) return s;
      }
      return null;
    }, visible.slice(3).map((v) => v.point));
    if (!second) throw new Error('no sample point visible after the orbit');
    before = await seq('fieldSeq');
    await page.keyboard.down('Alt');
    await page.mouse.click(second.x, second.y);
    await page.keyboard.up('Alt');
    await waitSeq('fieldSeq', before);
    const multi = await page.evaluate(() => ({
      n: window.__geoprox.state.sources.length,
      colour: document.getElementById('colour').value,
      nearest: Array.from(new Set(window.__geoprox.mesh.geometry.attributes.nearest.array)).sort(),
    }));
    check(multi.n === 2 && multi.colour === 'nearest' && multi.nearest.includes(0) && multi.nearest.includes(1),
      `alt-click adds a second source, coloured by nearest source (${JSON.stringify(multi)})`);

    // Errors shown plainly: an unreachable server.
    const page3 = await browser.newPage();
    await page3.goto(`${apiBase}/?api=${encodeURIComponent(`http://127.0.0.1:${deadPort}`)}`);
    await page3.waitForFunction(() => !document.getElementById('error').hidden, { timeout: 20000 });
    const err = await page3.$eval('#error', (e) => e.textContent);
    check(/Cannot reach the geoprox server/.test(err), `an unreachable server is reported: "${err}"`);
    await page3.close();

    if (!meshFile) {
      // Another component: the field does not reach it, a path to it is Unreachable, said plainly.
      await page.bringToFront();
      const seq0 = await seq('meshSeq');
      await page.waitForFunction(() => /twins\s*ready/.test(document.getElementById('meshes').textContent), { timeout: 60000 });
      await page.click('#meshes tr[data-id="twins"]');
      await waitSeq('meshSeq', seq0);
      const twins = await page.evaluate(() => {
        const g = window.__geoprox;
        const out = [];
        for (let f = 0; f < 8; f++) {
          const s = g.screenOf(`f:${f}:0.4:0.3:0.3`);
          if (s.visible) out.push({ f, x: s.x, y: s.y });
        }
        return out;
      });
      const a = twins.find((t) => t.f < 4);
      const b = twins.find((t) => t.f >= 4);
      if (!check(a && b, `both tetrahedra of twins are visible (${twins.map((t) => t.f).join(' ')})`)) return;
      let before2 = await seq('fieldSeq');
      await clickAt(a);
      await waitSeq('fieldSeq', before2);
      before2 = await seq('pathErrors');
      await clickAt(b, true);
      await waitSeq('pathErrors', before2);
      const un = await page.evaluate(() => ({
        error: document.getElementById('error').textContent,
        distance: document.getElementById('distance').textContent,
        dist: Array.from(window.__geoprox.mesh.geometry.attributes.dist.array),
      }));
      check(/Unreachable/.test(un.error) && un.distance === '-' && un.dist.slice(4).every((d) => d === -1) &&
        un.dist.slice(0, 4).every((d) => d >= 0),
        `a target on another component: "${un.error}"; the field leaves that component grey`);
      pageErrors.splice(0, pageErrors.length, ...pageErrors.filter((e) => !/status of 422/.test(e)));


      await page.waitForFunction(() => /pig\s*failed/.test(document.getElementById('meshes').textContent), { timeout: 30000 });
      const pigRow = await page.$eval('#meshes tr[data-id="pig"]', (e) => e.textContent);
      await page.click('#meshes tr[data-id="pig"]');
      const pigError = await page.$eval('#error', (e) => e.textContent);
      check(/NonManifoldVertex/.test(pigRow) && /face 3156/.test(pigError),
        `a mesh that failed is listed with its reason ("${pigRow}"), the whole message on a click`);
    }

    if (buildingPage) {
      await buildingPage.bringToFront(); // frames (and so the hook's counters) run in the front tab only
      await buildingPage.waitForFunction(() => window.__geoprox.meshSeq >= 1, { timeout: 60000 });
      check(/still building/.test(buildingText) || buildingText === '',
        `a page opened on ${other} while it was ${otherState.state} said "${buildingText || '(nothing: ready first)'}"` +
          ' and opened it once ready');
      await buildingPage.close();
    } else {
      console.log(`skip the "still building" check: ${other} was ready before the page opened`);
    }

    check(pageErrors.length === 0, `no errors in the page's console${pageErrors.length ? ': ' + pageErrors.join(' | ') : ''}`);
  } finally {
    if (browser) await browser.close();
    daemon.kill('SIGTERM');
    await new Promise((r) => (daemonExited ? r() : daemon.on('exit', r)));
    if (!keep) fs.rmSync(tmp, { recursive: true, force: true });
    else console.log(`kept ${tmp}`);
  }
}

main().then(
  () => {
    console.log(failures ? `${failures} check(s) failed` : 'all checks passed');
    process.exit(failures ? 1 : 0);
  },
  (e) => {
    console.error(`error: ${e.stack || e}`);
    process.exit(2);
  },
);
