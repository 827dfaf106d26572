// The geoproxd HTTP API (docs/http.md): JSON and binary arrays, bearer token, plain errors.

export class ApiError extends Error {
  constructor(message, { status = 0, reason = '', retryAfterMs = 0, body = null } = {}) {
    super(message);
    this.status = status;
    this.reason = reason;
    this.retryAfterMs = retryAfterMs;
    this.body = body;
  }
}

export class Api {
  /** base: '' for the page's own origin, or e.g. 'http://127.0.0.1:7880'. */
  constructor(base, token = '') {
    this.base = (base || '').replace(/\/+$/, '');
    this.token = token;
  }

  url(path, params) {
    const q = new URLSearchParams();
    for (const [k, v] of Object.entries(params || {})) {
      if (v === undefined || v === null) continue;
      if (Array.isArray(v)) v.forEach((x) => q.append(k, String(x)));
      else q.append(k, String(v));
    }
    const qs = q.toString();
    return `${this.base}${path}${qs ? '?' + qs : ''}`;
  }

  async request(path, params, accept) {
    const headers = { Accept: accept };
    if (this.token) headers.Authorization = `Bearer ${this.token}`;
    const url = this.url(path, params);
    let res;
    try {
      res = await fetch(url, { headers, cache: 'no-store' });
    } catch (e) {
      const where = this.base || window.location.origin;
      throw new ApiError(`Cannot reach the geoprox server at ${where} (${e.message}).`, {
        reason: 'NetworkError',
      });
    }
    if (!res.ok) throw await errorFrom(res);
    return res;
  }

  async json(path, params) {
    const res = await this.request(path, params, 'application/json');
    return res.json();
  }

  /** One binary array: Float32Array for dtype float32, Uint32Array for uint32. */
  async array(path, params) {
    const res = await this.request(path, params, 'application/octet-stream');
    const dtype = res.headers.get('X-Geoprox-Dtype');
    const buf = await res.arrayBuffer();
    if (dtype === 'float32') return new Float32Array(buf);
    if (dtype === 'uint32') return new Uint32Array(buf);
    if (dtype === 'float64') return new Float64Array(buf);
    // Without CORS-exposed headers, fall back on what was asked for.
    if (params && params.dtype === 'float32') return new Float32Array(buf);
    throw new ApiError(`Unexpected array dtype ${dtype} from ${path}.`);
  }
}

async function errorFrom(res) {
  let body = null;
  let text = '';
  try {
    text = await res.text();
    body = JSON.parse(text);
  } catch {
    body = null;
  }
  const err = body && body.error;
  const reason = (err && err.data && err.data.reason) || '';
  let retryAfterMs = (err && err.data && err.data.retry_after_ms) || 0;
  const ra = res.headers.get('Retry-After');
  if (!retryAfterMs && ra) retryAfterMs = Number(ra) * 1000;
  let message = (err && err.message) || text.trim() || res.statusText;
  if (res.status === 401) message = 'This server needs a query token: enter it above.';
  else if (res.status === 403) message = 'The query token was refused.';
  else if (reason === 'MeshNotReady') message = `The mesh is still building: ${message}`;
  else if (reason === 'MeshBuildFailed') message = `The mesh's graph build failed: ${message}`;
  else if (reason === 'Unreachable') message = `Unreachable: ${message}`;
  return new ApiError(`${message} (HTTP ${res.status}${reason ? ', ' + reason : ''})`, {
    status: res.status,
    reason,
    retryAfterMs,
    body,
  });
}
