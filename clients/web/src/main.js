// geoprox viewer: a mesh from geoproxd, its geodesic field from clicked sources, the path to a
// shift-clicked target. three.js does the WebGL and the maths; three-mesh-bvh the picking.
import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
import { Line2 } from 'three/addons/lines/Line2.js';
import { LineGeometry } from 'three/addons/lines/LineGeometry.js';
import { LineMaterial } from 'three/addons/lines/LineMaterial.js';
import { acceleratedRaycast, computeBoundsTree, disposeBoundsTree } from 'three-mesh-bvh';
import { Api, ApiError } from './api.js';
import { SOURCE_PALETTE, VIRIDIS_GLSL, viridis } from './viridis.js';

THREE.BufferGeometry.prototype.computeBoundsTree = computeBoundsTree;
THREE.BufferGeometry.prototype.disposeBoundsTree = disposeBoundsTree;
THREE.Mesh.prototype.raycast = acceleratedRaycast;

const $ = (id) => document.getElementById(id);
const params = new URLSearchParams(window.location.search);

// ---------------------------------------------------------------- state
const state = {
  api: params.get('api') || '',
  mesh: params.get('mesh') || '',
  sources: params.getAll('source'), // point strings "f:FACE:B0:B1:B2"
  target: params.get('target') || '',
  camera: params.get('camera') || '', // px,py,pz,tx,ty,tz
  colour: params.get('colour') || '',
  meshes: [],
  fieldMax: 0, // largest finite distance of the current field
  distance: null, // the last path's result
};
const api = new Api(state.api, sessionStorage.getItem('geoprox-token') || '');

// ---------------------------------------------------------------- three.js scene
const view = $('view');
/** The WebGL renderer's name, and whether it draws in software (SwiftShader, llvmpipe: a machine
 *  without a GPU), where multisampling multiplies the cost of every frame. */
function rendererName() {
  const gl = document.createElement('canvas').getContext('webgl2');
  if (!gl) return { name: '', software: false };
  const info = gl.getExtension('WEBGL_debug_renderer_info');
  const name = String(gl.getParameter(info ? info.UNMASKED_RENDERER_WEBGL : gl.RENDERER));
  gl.getExtension('WEBGL_lose_context')?.loseContext();
  return { name, software: /swiftshader|llvmpipe|softpipe|software/i.test(name) };
}
const gpu = rendererName();
let renderer;
try {
  renderer = new THREE.WebGLRenderer({ antialias: !gpu.software, preserveDrawingBuffer: true });
} catch (e) {
  showError(`This browser gives no WebGL 2 context, which the viewer needs: ${e.message}`);
  throw e;
}
renderer.setPixelRatio(window.devicePixelRatio || 1);
renderer.setClearColor(0x1b1d22);
view.appendChild(renderer.domElement);
const scene = new THREE.Scene();
const camera = new THREE.PerspectiveCamera(40, 1, 0.01, 100);
const controls = new OrbitControls(camera, renderer.domElement);
controls.enableDamping = false;

let mesh = null; // THREE.Mesh of the current mesh
let meshDiag = 1;
let markers = new THREE.Group();
let pathLine = null;
scene.add(markers);

const uniforms = {
  uHasField: { value: 0 },
  uMax: { value: 1 },
  uCutoff: { value: 1e30 },
  uSpacing: { value: 0.1 },
  uMode: { value: 0 }, // 0 distance, 1 nearest source
  uPalette: { value: SOURCE_PALETTE.map((c) => new THREE.Vector3(...c)) },
};

const material = new THREE.ShaderMaterial({
  uniforms,
  // Pushes the surface back in depth so that the path drawn on it stays in front.
  polygonOffset: true,
  polygonOffsetFactor: 1,
  polygonOffsetUnits: 1,
  vertexShader: /* glsl */ `
    attribute float dist;
    attribute float nearest;
    varying float vDist;
    flat varying float vNearest;
    varying vec3 vNormal;
    void main() {
      vDist = dist;
      vNearest = nearest;
      vNormal = normalize(normalMatrix * normal);
      gl_Position = projectionMatrix * modelViewMatrix * vec4(position, 1.0);
    }`,
  fragmentShader: /* glsl */ `
    uniform float uHasField;
    uniform float uMax;
    uniform float uCutoff;
    uniform float uSpacing;
    uniform int uMode;
    uniform vec3 uPalette[${SOURCE_PALETTE.length}];
    varying float vDist;
    flat varying float vNearest;
    varying vec3 vNormal;
    ${VIRIDIS_GLSL}
    void main() {
      vec3 n = normalize(vNormal);
      float shade = 0.55 + 0.45 * abs(n.z);  // head light
      vec3 base = vec3(0.62);
      if (uHasField > 0.5 && vDist >= 0.0 && vDist <= uCutoff) {
        if (uMode == 1 && vNearest >= 0.0) {
          base = uPalette[int(mod(vNearest + 0.5, ${SOURCE_PALETTE.length}.0))];
        } else {
          base = viridis(vDist / uMax);
        }
        float x = vDist / uSpacing;
        float w = max(fwidth(x), 1e-6);
        float edge = abs(fract(x + 0.5) - 0.5);
        float line = smoothstep(0.5 * w, 1.5 * w, edge);
        base *= mix(0.3, 1.0, line);
      }
      gl_FragColor = vec4(base * shade, 1.0);
    }`,
});

function resize() {
  const w = view.clientWidth || 1;
  const h = view.clientHeight || 1;
  renderer.setSize(w, h, false);
  camera.aspect = w / h;
  camera.updateProjectionMatrix();
  requestRender();
}
window.addEventListener('resize', resize);

let renderPending = 0; // the requestAnimationFrame id of the frame asked for, 0 when none
const frameWaiters = [];
/** Draws now: the scene with every change so far, then resolves the frame's waiters. */
function drawNow() {
  if (renderPending) cancelAnimationFrame(renderPending);
  renderPending = 0;
  renderer.render(scene, camera);
  if (hook.syncFrames) {
    // Waits for the frame to be drawn (for timing it), not only submitted.
    const gl = renderer.getContext();
    gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, new Uint8Array(4));
  }
  const waiters = frameWaiters.splice(0);
  waiters.forEach((f) => f());
}
function requestRender() {
  if (!renderPending) renderPending = requestAnimationFrame(drawNow);
}
/** Resolves once a frame including every change so far has been drawn. */
function nextFrame() {
  return new Promise((resolve) => {
    frameWaiters.push(resolve);
    requestRender();
  });
}
controls.addEventListener('change', requestRender);
controls.addEventListener('end', () => writeUrl());

// ---------------------------------------------------------------- UI helpers
function showError(msg) {
  const el = $('error');
  if (!msg) {
    el.hidden = true;
    el.textContent = '';
    return;
  }
  el.hidden = false;
  el.textContent = msg;
}
function status(msg) {
  $('status').textContent = msg;
}
function fmt(x) {
  if (!Number.isFinite(x)) return String(x);
  const a = Math.abs(x);
  if (a === 0) return '0';
  if (a >= 1000 || a < 0.01) return x.toExponential(2);
  return Number(x.toPrecision(3)).toString();
}
function niceStep(range, count) {
  const raw = range / count;
  const p = Math.pow(10, Math.floor(Math.log10(raw)));
  const m = raw / p;
  return (m < 1.5 ? 1 : m < 3.5 ? 2 : m < 7.5 ? 5 : 10) * p;
}

function writeUrl() {
  const q = new URLSearchParams();
  if (state.api) q.set('api', state.api);
  if (state.mesh) q.set('mesh', state.mesh);
  state.sources.forEach((s) => q.append('source', s));
  if (state.target) q.set('target', state.target);
  if (mesh) {
    const p = camera.position;
    const t = controls.target;
    q.set('camera', [p.x, p.y, p.z, t.x, t.y, t.z].map((v) => Number(v.toPrecision(6))).join(','));
  }
  if ($('colour').value !== 'distance' || state.colour) q.set('colour', $('colour').value);
  history.replaceState(null, '', `${window.location.pathname}?${q.toString()}`);
}

// ---------------------------------------------------------------- mesh list
let listTimer = 0;
async function refreshMeshes() {
  clearTimeout(listTimer);
  let again = 5000;
  try {
    const res = await api.json('/v1/meshes');
    state.meshes = res.meshes;
    renderMeshList();
    if (state.meshes.some((m) => m.state !== 'ready' && m.state !== 'failed')) again = 1000;
    if (!mesh && !loading) {
      const wanted = state.mesh || (state.meshes.find((m) => m.state === 'ready') || {}).id;
      if (wanted) loadMesh(wanted, { keepState: wanted === state.mesh });
    }
    if ($('error').dataset.kind === 'list') showError('');
  } catch (e) {
    showError(e.message);
    $('error').dataset.kind = 'list';
    again = 3000;
  }
  listTimer = setTimeout(refreshMeshes, again);
}

function renderMeshList() {
  const body = $('meshes').querySelector('tbody');
  body.textContent = '';
  for (const m of state.meshes) {
    const tr = document.createElement('tr');
    tr.className = 'mesh' + (m.id === state.mesh ? ' current' : '') + (m.state === 'ready' ? '' : ' disabled');
    tr.dataset.id = m.id;
    let st = m.state;
    if (m.state !== 'ready' && m.state !== 'failed' && m.progress != null) {
      st += ` ${Math.round(m.progress * 100)}%${m.phase ? ' (' + m.phase + ')' : ''}`;
    }
    const why = m.state === 'failed' && m.error ? String(m.error.message || m.error) : '';
    if (why) {
      // The short reason in the row ("[NonManifoldVertex]"), all of it on hover and on click.
      const reason = why.match(/\[([A-Za-z]+)\]/);
      st += reason ? ` (${reason[1]})` : '';
      tr.title = why;
    }
    for (const text of [m.id, st, m.state === 'failed' ? '' : m.faces]) {
      const td = document.createElement('td');
      td.textContent = text;
      tr.appendChild(td);
    }
    tr.addEventListener('click', () => {
      if (m.state === 'ready' && m.id !== state.mesh) loadMesh(m.id, { keepState: false });
      else if (m.state === 'failed') showError(`Mesh ${m.id} failed: ${why}`);
      else if (m.state !== 'ready') showError(`Mesh ${m.id} is ${m.state}; it opens once it is ready.`);
    });
    body.appendChild(tr);
  }
}

// ---------------------------------------------------------------- mesh loading
let loading = false;
async function loadMesh(id, { keepState }) {
  loading = true;
  status(`Loading ${id}...`);
  showError('');
  const t0 = performance.now();
  try {
    const [positions, triangles] = await Promise.all([
      api.array(`/v1/meshes/${encodeURIComponent(id)}/geometry`, { array: 'positions', dtype: 'float32' }),
      api.array(`/v1/meshes/${encodeURIComponent(id)}/geometry`, { array: 'triangles' }),
    ]);
    if (mesh) {
      scene.remove(mesh);
      mesh.geometry.disposeBoundsTree();
      mesh.geometry.dispose();
    }
    const geometry = new THREE.BufferGeometry();
    geometry.setAttribute('position', new THREE.BufferAttribute(positions, 3));
    geometry.setIndex(new THREE.BufferAttribute(triangles, 1));
    geometry.computeVertexNormals();
    const n = positions.length / 3;
    geometry.setAttribute('dist', new THREE.BufferAttribute(new Float32Array(n).fill(-1), 1));
    geometry.setAttribute('nearest', new THREE.BufferAttribute(new Float32Array(n).fill(-1), 1));
    geometry.computeBoundingBox();
    geometry.computeBoundingSphere();
    // indirect: the BVH must not reorder the index, whose triangle order is the server's face ids.
    geometry.computeBoundsTree({ indirect: true });
    mesh = new THREE.Mesh(geometry, material);
    scene.add(mesh);
    const box = geometry.boundingBox;
    meshDiag = box.getSize(new THREE.Vector3()).length();
    state.mesh = id;
    if (!keepState) {
      state.sources = [];
      state.target = '';
      state.camera = '';
    }
    placeCamera();
    uniforms.uHasField.value = 0;
    clearPath();
    renderMarkers();
    renderMeshList();
    status(`${id}: ${n} vertices, ${triangles.length / 3} faces, loaded in ${(performance.now() - t0).toFixed(0)} ms`);
    writeUrl();
    await nextFrame();
    hook.meshSeq++;
    if (state.sources.length) await updateField();
    if (state.target) await updatePath();
  } catch (e) {
    showError(`Loading mesh ${id}: ${e.message}`);
    if (e instanceof ApiError && e.reason === 'MeshNotReady') {
      setTimeout(() => loadMesh(id, { keepState }), Math.max(500, e.retryAfterMs || 1000));
    }
  } finally {
    loading = false;
  }
}

function placeCamera() {
  const sphere = mesh.geometry.boundingSphere;
  camera.near = sphere.radius / 100;
  camera.far = sphere.radius * 100;
  const v = state.camera ? state.camera.split(',').map(Number) : [];
  if (v.length === 6 && v.every(Number.isFinite)) {
    camera.position.set(v[0], v[1], v[2]);
    controls.target.set(v[3], v[4], v[5]);
  } else {
    const dist = sphere.radius / Math.sin(THREE.MathUtils.degToRad(camera.fov / 2)) * 1.05;
    controls.target.copy(sphere.center);
    // A three-quarter view.
    const dir = new THREE.Vector3(-1, 0.35, -0.75).normalize();
    camera.position.copy(sphere.center).addScaledVector(dir, dist);
  }
  camera.updateProjectionMatrix();
  controls.update();
  resize();
}

// ---------------------------------------------------------------- picking
const raycaster = new THREE.Raycaster();
raycaster.firstHitOnly = true;

/** The surface point under client coordinates (x, y): face, barycentrics, position. */
function pick(clientX, clientY) {
  if (!mesh) return null;
  const rect = renderer.domElement.getBoundingClientRect();
  const ndc = new THREE.Vector2(
    ((clientX - rect.left) / rect.width) * 2 - 1,
    -((clientY - rect.top) / rect.height) * 2 + 1,
  );
  raycaster.setFromCamera(ndc, camera);
  const hits = raycaster.intersectObject(mesh, false);
  if (!hits.length) return null;
  const hit = hits[0];
  const { a, b, c } = hit.face;
  const pos = mesh.geometry.attributes.position;
  const tri = new THREE.Triangle(
    new THREE.Vector3().fromBufferAttribute(pos, a),
    new THREE.Vector3().fromBufferAttribute(pos, b),
    new THREE.Vector3().fromBufferAttribute(pos, c),
  );
  const bc = tri.getBarycoord(hit.point, new THREE.Vector3());
  let bary = [bc.x, bc.y, bc.z].map((x) => Math.max(0, x));
  const sum = bary[0] + bary[1] + bary[2];
  bary = bary.map((x) => x / sum);
  const point = `f:${hit.faceIndex}:${bary.map((x) => String(x)).join(':')}`;
  return { face: hit.faceIndex, bary, point, position: hit.point.clone(), distance: hit.distance };
}

let down = null;
renderer.domElement.addEventListener('pointerdown', (e) => {
  down = { x: e.clientX, y: e.clientY, t: e.timeStamp };
});
renderer.domElement.addEventListener('pointerup', (e) => {
  if (!down || e.button !== 0) return;
  const moved = Math.hypot(e.clientX - down.x, e.clientY - down.y);
  down = null;
  if (moved > 4) return; // an orbit, not a click
  const t0 = performance.now();
  const hit = pick(e.clientX, e.clientY);
  if (!hit) return;
  hook.lastPick = hit;
  showError(''); // a new question: the last one's error goes
  if (e.shiftKey) {
    state.target = hit.point;
    renderMarkers();
    writeUrl();
    updatePath(t0);
  } else {
    if (e.altKey || $('add-sources').checked) state.sources.push(hit.point);
    else state.sources = [hit.point];
    renderMarkers(false); // drawn with the field, one frame instead of two on the way

    writeUrl();
    updateField(t0).then(() => (state.target ? updatePath() : null));
  }
});

// ---------------------------------------------------------------- points and markers
/** Position in space of a point string "v:I" or "f:F:B0:B1:B2". */
function pointPosition(p) {
  const pos = mesh.geometry.attributes.position;
  const parts = p.split(':');
  if (parts[0] === 'v') return new THREE.Vector3().fromBufferAttribute(pos, Number(parts[1]));
  if (parts[0] === 'f') {
    const f = Number(parts[1]);
    const idx = mesh.geometry.index;
    const out = new THREE.Vector3();
    for (let k = 0; k < 3; k++) {
      out.addScaledVector(new THREE.Vector3().fromBufferAttribute(pos, idx.getX(3 * f + k)), Number(parts[2 + k]));
    }
    return out;
  }
  return null;
}

function renderMarkers(render = true) {
  markers.clear();
  if (!mesh) return;
  const r = meshDiag * 0.006;
  const geo = new THREE.SphereGeometry(r, 12, 8);
  state.sources.forEach((s, i) => {
    const p = pointPosition(s);
    if (!p) return;
    const c = state.sources.length > 1 ? SOURCE_PALETTE[i % SOURCE_PALETTE.length] : [1, 1, 1];
    const m = new THREE.Mesh(geo, new THREE.MeshBasicMaterial({ color: new THREE.Color(...c) }));
    m.position.copy(p);
    markers.add(m);
  });
  if (state.target) {
    const p = pointPosition(state.target);
    if (p) {
      const m = new THREE.Mesh(geo, new THREE.MeshBasicMaterial({ color: 0xffa000 }));
      m.position.copy(p);
      markers.add(m);
    }
  }
  $('sources').textContent = state.sources.length ? `${state.sources.length}` : 'none';
  if (render) requestRender();
}

// ---------------------------------------------------------------- field
let fieldRequest = 0;
async function updateField(t0 = performance.now()) {
  if (!mesh) return;
  const my = ++fieldRequest;
  const geometry = mesh.geometry;
  if (!state.sources.length) {
    uniforms.uHasField.value = 0;
    updateLegend();
    requestRender();
    return;
  }
  const path = `/v1/meshes/${encodeURIComponent(state.mesh)}/field`;
  const several = state.sources.length > 1;
  const p = several ? { sources: state.sources } : { source: state.sources[0] };
  try {
    const tf = performance.now();
    const [dist, nearest] = await Promise.all([
      api.array(path, { ...p, dtype: 'float32' }),
      several ? api.array(path, { ...p, array: 'nearest_source' }) : null,
    ]);
    const fetchMs = performance.now() - tf;
    hook.lastFieldTiming = resourceTiming(path);
    if (my !== fieldRequest) return; // a newer click won
    const da = geometry.attributes.dist;
    let max = 0;
    for (let i = 0; i < dist.length; i++) {
      const d = dist[i];
      if (Number.isFinite(d)) {
        da.array[i] = d;
        if (d > max) max = d;
      } else da.array[i] = -1;
    }
    da.needsUpdate = true;
    // One source: every vertex's nearest is 0, uploaded once rather than at every click.
    const na = geometry.attributes.nearest;
    if (nearest) {
      for (let i = 0; i < nearest.length; i++) na.array[i] = nearest[i] === 0xffffffff ? -1 : nearest[i];
      na.needsUpdate = true;
      na.allZero = false;
    } else if (!na.allZero) {
      na.array.fill(0);
      na.needsUpdate = true;
      na.allZero = true;
    }
    state.fieldMax = max;
    uniforms.uHasField.value = 1;
    if (several && !state.colour) $('colour').value = 'nearest';
    if (!several && !state.colour) $('colour').value = 'distance';
    applyControls();
    // An answer is drawn as it arrives, not at the next animation frame: the browser shows the
    // canvas at its next refresh either way, and waiting for the frame's start added up to one.
    drawNow();
    const total = performance.now() - t0;
    hook.lastFieldMs = total;
    hook.lastFieldFetchMs = fetchMs;
    hook.fieldSeq++;
    $('field-latency').textContent = `${total.toFixed(1)} ms click to colours (${fetchMs.toFixed(1)} ms request)`;
    if ($('error').dataset.kind === 'field') showError('');
  } catch (e) {
    if (my !== fieldRequest) return;
    requestRender();
    showError(`Field: ${e.message}`);
    $('error').dataset.kind = 'field';
    hook.fieldErrors++;
    if (e instanceof ApiError && e.reason === 'MeshNotReady') {
      setTimeout(() => updateField(), Math.max(500, e.retryAfterMs || 1000));
    }
  }
}

/** Resource timing of the last request to path: time waiting for the answer, and in all. */
function resourceTiming(path) {
  const entries = performance.getEntriesByType('resource').filter((e) => e.name.includes(path));
  const e = entries[entries.length - 1];
  performance.clearResourceTimings();
  if (!e) return null;
  // Cross-origin entries without Timing-Allow-Origin have no request/response marks (0).
  const waitMs = e.requestStart > 0 && e.responseStart > 0 ? e.responseStart - e.requestStart : null;
  return { waitMs, totalMs: e.responseEnd - e.startTime };
}

function applyControls() {
  const max = state.fieldMax || 1;
  const frac = Number($('cutoff').value) / 1000;
  const cutoff = frac >= 1 ? 1e30 : max * frac;
  uniforms.uCutoff.value = cutoff;
  const shown = Math.min(max, cutoff);
  uniforms.uMax.value = shown > 0 ? shown : 1;
  const spacing = niceStep(shown > 0 ? shown : 1, Number($('iso').value));
  uniforms.uSpacing.value = spacing;
  uniforms.uMode.value = $('colour').value === 'nearest' ? 1 : 0;
  $('cutoff-value').textContent = frac >= 1 ? 'none' : fmt(cutoff);
  $('iso-value').textContent = `every ${fmt(spacing)}`;
  updateLegend();
  requestRender();
}

function updateLegend() {
  const canvas = $('legend-bar');
  const ctx = canvas.getContext('2d');
  const ticks = $('legend-ticks');
  ticks.textContent = '';
  if (!uniforms.uHasField.value) {
    ctx.clearRect(0, 0, canvas.width, canvas.height);
    $('legend-note').textContent = 'Click the mesh to set a source.';
    return;
  }
  const img = ctx.createImageData(canvas.width, canvas.height);
  for (let x = 0; x < canvas.width; x++) {
    const c = viridis(x / (canvas.width - 1));
    for (let y = 0; y < canvas.height; y++) {
      const o = 4 * (y * canvas.width + x);
      img.data[o] = c[0] * 255;
      img.data[o + 1] = c[1] * 255;
      img.data[o + 2] = c[2] * 255;
      img.data[o + 3] = 255;
    }
  }
  ctx.putImageData(img, 0, 0);
  const max = uniforms.uMax.value;
  const step = niceStep(max, 4);
  for (let v = 0; v <= max * 1.0001; v += step) {
    const s = document.createElement('span');
    s.style.left = `${(v / max) * 100}%`;
    s.textContent = fmt(v);
    ticks.appendChild(s);
  }
  $('legend-note').textContent =
    `Distance in mesh units, 0 to ${fmt(max)}; iso-lines every ${fmt(uniforms.uSpacing.value)}` +
    (uniforms.uCutoff.value < 1e30 ? `; grey beyond the cutoff ${fmt(uniforms.uCutoff.value)}` : '') +
    (uniforms.uMode.value === 1 ? '; colours: nearest source' : '');
}

for (const id of ['cutoff', 'iso']) $(id).addEventListener('input', applyControls);
$('colour').addEventListener('change', () => {
  state.colour = $('colour').value;
  applyControls();
  writeUrl();
});
$('clear').addEventListener('click', () => {
  state.sources = [];
  state.target = '';
  clearPath();
  renderMarkers();
  updateField();
  writeUrl();
});

// ---------------------------------------------------------------- path
function clearPath() {
  if (pathLine) {
    scene.remove(pathLine);
    pathLine.geometry.dispose();
    pathLine = null;
  }
  state.distance = null;
  $('distance').textContent = '-';
  $('exact').textContent = '-';
  $('latency').textContent = '-';
  requestRender();
}

let pathRequest = 0;
async function updatePath(t0 = performance.now()) {
  if (!mesh || !state.target) return;
  if (!state.sources.length) {
    showError('Click a source first, then shift-click a target.');
    return;
  }
  const my = ++pathRequest;
  const path = `/v1/meshes/${encodeURIComponent(state.mesh)}/path`;
  try {
    // From the nearest of the sources: one path per source, the shortest kept.
    const results = await Promise.all(
      state.sources.map((s) => api.json(path, { source: s, target: state.target })),
    );
    const latency = performance.now() - t0;
    if (my !== pathRequest) return;
    let best = 0;
    results.forEach((r, i) => {
      if (r.distance < results[best].distance) best = i;
    });
    const r = results[best];
    clearPath();
    state.distance = { ...r, sourceIndex: best, source: state.sources[best], target: state.target };
    drawPath(r.points);
    $('distance').textContent = String(r.distance);
    $('exact').textContent = r.exact ? 'exact' : 'approximate (proximity graph)';
    $('latency').textContent = `${latency.toFixed(1)} ms`;
    hook.lastPathMs = latency;
    await nextFrame();
    hook.pathSeq++;
    if ($('error').dataset.kind === 'path') showError('');
  } catch (e) {
    if (my !== pathRequest) return;
    clearPath();
    showError(`Path: ${e.message}`);
    $('error').dataset.kind = 'path';
    hook.pathErrors++;
  }
}

function drawPath(points) {
  const pos = mesh.geometry.attributes.position;
  const idx = mesh.geometry.index;
  const offset = meshDiag * 0.003;
  const tri = new THREE.Triangle();
  const normal = new THREE.Vector3();
  const xyz = [];
  for (const p of points) {
    tri.setFromAttributeAndIndices(pos, idx.getX(3 * p.face), idx.getX(3 * p.face + 1), idx.getX(3 * p.face + 2));
    tri.getNormal(normal);
    xyz.push(p.position[0] + normal.x * offset, p.position[1] + normal.y * offset, p.position[2] + normal.z * offset);
  }
  const geometry = new LineGeometry();
  geometry.setPositions(xyz);
  const mat = new LineMaterial({ color: 0xff2050, linewidth: 3, worldUnits: false });
  pathLine = new Line2(geometry, mat);
  pathLine.computeLineDistances();
  scene.add(pathLine);
  requestRender();
}

// ---------------------------------------------------------------- token
$('token').value = api.token;
$('token').addEventListener('change', () => {
  api.token = $('token').value.trim();
  if (api.token) sessionStorage.setItem('geoprox-token', api.token);
  else sessionStorage.removeItem('geoprox-token');
  showError('');
  refreshMeshes();
  if (mesh) updateField().then(() => updatePath());
});
$('api-base').textContent = state.api || window.location.origin;
if (state.colour) $('colour').value = state.colour;

// ---------------------------------------------------------------- test hook
const hook = {
  THREE,
  camera,
  scene,
  controls,
  renderer,
  state,
  get mesh() {
    return mesh;
  },
  gpu, // the renderer's name and whether it is software (then no multisampling)
  syncFrames: false, // the test's timing: a frame counts once drawn
  meshSeq: 0,
  fieldSeq: 0,
  pathSeq: 0,
  fieldErrors: 0,
  pathErrors: 0,
  lastFieldMs: null,
  lastFieldFetchMs: null,
  lastFieldTiming: null,
  lastPathMs: null,
  lastPick: null,
  get debug() {
    return { fieldRequest, pathRequest, renderPending, frameWaiters: frameWaiters.length, loading };
  },
  pick,
  pointPosition: (p) => pointPosition(p).toArray(),
  /** Client coordinates of a point string ("v:I" or "f:F:B0:B1:B2"), and whether that point is
   *  the first surface hit there (not hidden, not off screen). */
  screenOf(point) {
    const p = pointPosition(point);
    const ndc = p.clone().project(camera);
    const rect = renderer.domElement.getBoundingClientRect();
    const x = rect.left + ((ndc.x + 1) / 2) * rect.width;
    const y = rect.top + ((1 - ndc.y) / 2) * rect.height;
    const inside = Math.abs(ndc.x) < 0.95 && Math.abs(ndc.y) < 0.95 && ndc.z < 1;
    const hit = inside ? pick(x, y) : null;
    const visible = !!hit && hit.position.distanceTo(p) < meshDiag * 1e-3;
    return { x, y, visible, hit: hit && hit.point, position: p.toArray() };
  },
  nextFrame,
};
window.__geoprox = hook;

resize();
refreshMeshes();
