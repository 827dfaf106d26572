'use strict';
// Interop: geoproxd against jayson, a JSON-RPC 2.0 client library written without geoprox in
// mind, over both of its transports that geoproxd speaks: jayson's TCP client (one connection
// per request, newline-delimited JSON) on the query port, and its HTTP client on POST /v1/rpc.
//
// Started by run_interop.py, which starts geoproxd and passes, in the environment:
//   GEOPROX_TCP_PORT, GEOPROX_HTTP_PORT  the daemon's ports on 127.0.0.1
//   GEOPROX_EXPECTED                     a JSON file of answers the daemon gave the Python
//                                        client (meshes, distances) to compare with
// Run alone: node --test tests/interop/jayson.test.js (with those variables set).

const assert = require('node:assert/strict');
const fs = require('node:fs');
const { describe, it, before } = require('node:test');
const jayson = require('jayson');

const HOST = '127.0.0.1';
const env = (name) => {
  const value = process.env[name];
  if (!value) throw new Error(`${name} is not set (run_interop.py sets it)`);
  return value;
};

/** Promise of one jayson request: the raw response (undefined for a notification). */
function send(client, method, params, id) {
  return new Promise((resolve, reject) => {
    client.request(method, params, id, (err, response) => (err ? reject(err) : resolve(response)));
  });
}

/** Promise of a jayson batch (client.request with an array): the raw array of responses. */
function sendBatch(client, requests) {
  return new Promise((resolve, reject) => {
    client.request(requests, (err, responses) => (err ? reject(err) : resolve(responses)));
  });
}

/** The value of geoprox_requests_total for (transport, method, outcome ok). */
async function okCount(client, transport, method) {
  const reply = await send(client, 'server.metrics', {});
  const line = reply.result.text
    .split('\n')
    .find(
      (l) =>
        l.startsWith('geoprox_requests_total{') &&
        l.includes(`transport="${transport}"`) &&
        l.includes(`method="${method}"`) &&
        l.includes('outcome="ok"'),
    );
  return line === undefined ? 0 : Number(line.slice(line.lastIndexOf(' ') + 1));
}

const expected = JSON.parse(fs.readFileSync(env('GEOPROX_EXPECTED'), 'utf8'));
const transports = {
  tcp: () => jayson.client.tcp({ host: HOST, port: Number(env('GEOPROX_TCP_PORT')) }),
  http: () =>
    jayson.client.http({ host: HOST, port: Number(env('GEOPROX_HTTP_PORT')), path: '/v1/rpc' }),
};

for (const [transport, makeClient] of Object.entries(transports)) {
  describe(`jayson ${transport} client`, () => {
    let client;
    before(() => {
      client = makeClient();
    });

    it('mesh.list lists the shipped meshes, ready, as the Python client saw them', async () => {
      const reply = await send(client, 'mesh.list', {});
      assert.equal(reply.jsonrpc, '2.0');
      assert.equal(typeof reply.id, 'string'); // jayson's generated id, echoed
      const meshes = reply.result.meshes.map((m) => [m.id, m.state, m.vertices, m.faces]);
      assert.deepEqual(
        meshes.sort(),
        expected.meshes.map((m) => [m.id, 'ready', m.vertices, m.faces]).sort(),
      );
    });

    it('geodesic.distance answers what the Python client got', async () => {
      for (const q of expected.distances) {
        const reply = await send(client, 'geodesic.distance', q.params, 7);
        assert.equal(reply.id, 7);
        assert.equal(reply.error, undefined, JSON.stringify(reply.error));
        assert.equal(reply.result.distance, q.distance, JSON.stringify(q.params));
        assert.equal(reply.result.mesh, q.params.mesh);
        assert.equal(reply.result.mesh_version, q.mesh_version);
      }
      // A known answer: a vertex is at distance 0 from itself.
      const self = await send(client, 'geodesic.distance', {
        mesh: 'spot',
        source: 'v:5',
        target: { vertex: 5 },
      });
      assert.equal(self.result.distance, 0);
    });

    it('a batch array: one response per request, by id, errors alone', async () => {
      const requests = expected.distances.map((q) => client.request('geodesic.distance', q.params));
      const unknown = { mesh: 'nope', source: 'v:0', target: 'v:1' };
      const bad = client.request('geodesic.distance', unknown);
      const info = client.request('mesh.info', { mesh: 'spot' });
      const note = client.request('server.health', {}, null); // a notification: no response
      assert.equal(note.id, undefined);
      const responses = await sendBatch(client, [...requests, bad, note, info]);
      assert.ok(Array.isArray(responses), JSON.stringify(responses));
      assert.equal(responses.length, requests.length + 2);
      const byId = new Map(responses.map((r) => [r.id, r]));
      requests.forEach((request, i) => {
        assert.equal(byId.get(request.id).result.distance, expected.distances[i].distance);
      });
      const error = byId.get(bad.id).error;
      assert.equal(error.code, -32001);
      assert.equal(error.data.reason, 'UnknownMesh');
      assert.equal(byId.get(info.id).result.vertices, 2930);
    });

    it('a notification is carried out and not answered', async () => {
      const before = await okCount(client, transport, 'geodesic.distance');
      const reply = await send(client, 'geodesic.distance', expected.distances[0].params, null);
      assert.equal(reply, undefined);
      // Carried out: the daemon's counter of answered distance requests goes up by one.
      let after = before;
      for (let i = 0; i < 200 && after === before; i += 1) {
        await new Promise((r) => setTimeout(r, 50));
        after = await okCount(client, transport, 'geodesic.distance');
      }
      assert.equal(after, before + 1);
    });

    it('an unknown mesh is an error with data.reason UnknownMesh', async () => {
      const params = { mesh: 'nope', source: 'v:0', target: 'v:1' };
      if (transport === 'tcp') {
        const reply = await send(client, 'geodesic.distance', params, 'q-1');
        assert.equal(reply.id, 'q-1');
        assert.equal(reply.result, undefined);
        assert.equal(reply.error.code, -32001);
        assert.equal(reply.error.data.reason, 'UnknownMesh');
        assert.equal(reply.error.data.retryable, false);
        return;
      }
      // Over HTTP the reply has status 404 (the HTTP API's status of UnknownMesh), and jayson's
      // HTTP client turns any status outside 2xx into a transport error whose message is the
      // body: the JSON-RPC error response itself.
      await assert.rejects(send(client, 'geodesic.distance', params, 'q-1'), (err) => {
        assert.equal(err.code, 404);
        const reply = JSON.parse(err.message);
        assert.equal(reply.id, 'q-1');
        assert.equal(reply.error.code, -32001);
        assert.equal(reply.error.data.reason, 'UnknownMesh');
        return true;
      });
    });
  });
}
