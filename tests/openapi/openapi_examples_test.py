#!/usr/bin/env python3
"""Replays every example of docs/openapi.yaml against a live geoproxd and checks the responses.

    openapi_examples_test.py GEOPROXD SOURCE_DIR [--write-external]

1. docs/openapi.yaml is read as JSON by the pinned `yaml` package of tests/openapi/node_modules
   (Python's standard library reads no YAML; `redocly bundle` would inline the externalValue
   files, binary ones as text). Without node_modules (scripts/install-deps runs `npm ci` there)
   the test is skipped with exit code 77.
2. Two daemons start on configs/default.json (meshes `spot` and `dragon`; only data_dir and
   graph_dir changed: the repository's data/ and a temporary graph directory) on free ports of
   127.0.0.1 (HTTP and query; admin off): "open" (no query token), which builds the graphs, then
   "query-token" (the query token QUERY_TOKEN, from GEOPROX_QUERY_TOKEN), which maps them. The
   test waits until both list every mesh as ready.
3. Pairing (info.description of openapi.yaml says the same): each response example N under
   status S and media type M of an operation is the answer to the request made of the
   operation's examples named N: query parameters with an example N (arrays repeated), path
   parameters (example N, else the parameter's first example), and the request body example N
   (application/json). `Accept: M` is sent for the binary media types. An example's
   `x-geoprox-request` may name `server: query-token` and extra request `headers`. A request
   body example with no response example of its name expects the operation's 204, no body.
4. Checks per example: the status, the media type of Content-Type, every response header with an
   example N, and the body: text exactly; JSON as values, numbers to a relative 1e-9 (absolute
   1e-12 near zero), the members IGNORED_KEYS (mesh_version, uptime_seconds, in_flight,
   graph_file) present but not compared, nor the header X-Geoprox-Mesh-Version (they depend on
   the run and the graph builder's version);
   binary (`externalValue` files, as are large JSON bodies): .npy headers exactly, the array's
   elements by their dtype (X-Geoprox-Dtype), float64 to 1e-9, float32 to 2^-23 relative,
   uint32 exactly, NaN equal to NaN.
5. Also asserts every operation has at least one example pair and every external file exists.

--write-external rewrites the `externalValue` files with the bodies the daemon sent (after a
change of the graph builder, say); review the diff before committing it.
Bounded: one request per example, 300 s deadline for the meshes; loopback only.
"""

from __future__ import annotations

import http.client
import json
import math
import os
import shutil
import signal
import socket
import struct
import subprocess
import sys
import tempfile
import time
import urllib.parse
from pathlib import Path

SKIP = 77
QUERY_TOKEN = "openapi-examples-query-token"
IGNORED_KEYS = {"mesh_version", "uptime_seconds", "in_flight", "graph_file"}
IGNORED_HEADERS = {"x-geoprox-mesh-version"}
BINARY_TYPES = {"application/octet-stream", "application/x-npy"}
REL_TOL = 1e-9
ABS_TOL = 1e-12
FLOAT32_REL_TOL = 2.0 ** -23
READY_DEADLINE_S = 300.0
METHODS = ("get", "post", "put", "delete", "patch")


def fail(message: str) -> None:
    print(f"FAIL: {message}", file=sys.stderr)
    sys.exit(1)


# ---- the bundled description ----

YAML_TO_JSON = """
const [yamlModule, file] = process.argv.slice(1);
const YAML = require(yamlModule);
const text = require("fs").readFileSync(file, "utf8");
process.stdout.write(JSON.stringify(YAML.parse(text, {uniqueKeys: true})));
"""


def load_spec(source: Path) -> dict:
    """docs/openapi.yaml as JSON, read by the pinned `yaml` package of tests/openapi."""
    module = source / "tests" / "openapi" / "node_modules" / "yaml"
    if not (module / "package.json").exists():
        print(f"SKIP: {module.relative_to(source)} is missing: run scripts/install-deps (npm ci "
              "in tests/openapi)")
        sys.exit(SKIP)
    run = subprocess.run(["node", "-e", YAML_TO_JSON, str(module),
                          str(source / "docs" / "openapi.yaml")],
                         capture_output=True, text=True, timeout=60)
    if run.returncode != 0:
        fail(f"reading docs/openapi.yaml failed ({run.returncode}):\n{run.stderr}")
    return json.loads(run.stdout)


def resolve(spec: dict, node):
    """Follows local $refs (#/components/...)."""
    while isinstance(node, dict) and "$ref" in node:
        ref = node["$ref"]
        if not ref.startswith("#/"):
            fail(f"non-local $ref {ref}")
        node = spec
        for part in ref[2:].split("/"):
            node = node[part.replace("~1", "/").replace("~0", "~")]
    return node


class Case:
    """One example exchange: the request built from the examples named `name`."""

    def __init__(self, op_id: str, method: str, path: str, name: str) -> None:
        self.op_id, self.method, self.path, self.name = op_id, method.upper(), path, name
        self.query: list[tuple[str, str]] = []
        self.body: bytes | None = None
        self.headers: dict[str, str] = {}
        self.server = "open"
        self.status = 204
        self.media: str | None = None
        self.example: dict = {}
        self.header_examples: dict[str, str] = {}

    def label(self) -> str:
        return f"{self.op_id} {self.status} {self.media or '-'} {self.name}"


def query_value(value) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return value
    return json.dumps(value)


def operation_cases(spec: dict, path: str, item: dict, method: str, op: dict) -> list[Case]:
    params: dict[tuple[str, str], dict] = {}
    for p in item.get("parameters", []) + op.get("parameters", []):
        p = resolve(spec, p)
        params[(p["name"], p["in"])] = p
    body_examples = {}
    if "requestBody" in op:
        content = resolve(spec, op["requestBody"])["content"]
        body_examples = {k: resolve(spec, v)
                         for k, v in content.get("application/json", {}).get("examples", {})
                         .items()}

    def request(name: str) -> Case:
        case = Case(op["operationId"], method, path, name)
        url_path = path
        for (pname, where), p in params.items():
            examples = p.get("examples", {})
            if name in examples:
                value = resolve(spec, examples[name])["value"]
            elif where == "path" and examples:
                value = resolve(spec, next(iter(examples.values())))["value"]
            elif p.get("required"):
                fail(f"{case.op_id}: required parameter {pname} has no example {name!r}")
            else:
                continue
            if where == "path":
                url_path = url_path.replace("{" + pname + "}", urllib.parse.quote(str(value)))
            elif where == "query":
                values = value if isinstance(value, list) else [value]
                case.query += [(pname, query_value(v)) for v in values]
            else:
                fail(f"{case.op_id}: parameter {pname} in {where} is not supported")
        case.path = url_path
        if name in body_examples:
            case.body = json.dumps(body_examples[name]["value"]).encode()
            case.headers["Content-Type"] = "application/json"
        elif method == "post":
            fail(f"{case.op_id}: no request body example {name!r}")
        return case

    cases = []
    answered = set()
    for status, response in op.get("responses", {}).items():
        response = resolve(spec, response)
        for media, content in response.get("content", {}).items():
            for name, example in content.get("examples", {}).items():
                example = resolve(spec, example)
                case = request(name)
                case.status, case.media, case.example = int(status), media, example
                if media in BINARY_TYPES:
                    case.headers["Accept"] = media
                extra = example.get("x-geoprox-request", {})
                case.server = extra.get("server", "open")
                case.headers.update(extra.get("headers", {}))
                for hname, header in response.get("headers", {}).items():
                    header = resolve(spec, header)
                    if name in header.get("examples", {}):
                        case.header_examples[hname] = str(header["examples"][name]["value"])
                cases.append(case)
                answered.add(name)
    for name in body_examples:
        if name not in answered:
            if "204" not in op.get("responses", {}):
                fail(f"{op['operationId']}: request example {name!r} has no response example")
            cases.append(request(name))
    if not cases:
        fail(f"{op['operationId']}: no example")
    return cases


def all_cases(spec: dict) -> list[Case]:
    cases = []
    for path, item in spec["paths"].items():
        for method in METHODS:
            if method in item:
                cases += operation_cases(spec, path, item, method, item[method])
    return cases


# ---- the daemons ----

def free_port() -> int:
    """A port free a moment ago (--http-port 0 turns HTTP off, as --admin-port 0 does admin)."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Daemon:
    """geoproxd on an ephemeral query port and a free HTTP port of 127.0.0.1, admin port off."""

    def __init__(self, binary: str, config: Path, root: Path, name: str, env: dict) -> None:
        self.name = name
        self.token = env.get("GEOPROX_QUERY_TOKEN")
        port_file = root / f"{name}.ports.json"
        self.log_path = root / f"{name}.log"
        self.log = open(self.log_path, "wb")
        self.process = subprocess.Popen(
            [binary, "--config", str(config), "--port", "0", "--admin-port", "0",
             "--http-port", str(free_port()), "--port-file", str(port_file)],
            stdout=self.log, stderr=subprocess.STDOUT, env=dict(os.environ, **env))
        deadline = time.monotonic() + 60
        while True:
            self.check_alive()
            try:
                self.http_port = int(json.loads(port_file.read_text())["http_port"])
                break
            except (OSError, ValueError, KeyError):
                if time.monotonic() > deadline:
                    fail(f"{name} wrote no port file with http_port within 60 s:\n"
                         f"{self.output()}")
                time.sleep(0.05)

    def output(self) -> str:
        self.log.flush()
        return self.log_path.read_text(errors="replace")[-4000:]

    def check_alive(self) -> None:
        if self.process.poll() is not None:
            fail(f"{self.name} exited with status {self.process.returncode}:\n{self.output()}")

    def request(self, method: str, target: str, body: bytes | None = None,
                headers: dict[str, str] | None = None) -> http.client.HTTPResponse:
        conn = http.client.HTTPConnection("127.0.0.1", self.http_port, timeout=60)
        conn.request(method, target, body=body, headers=headers or {})
        response = conn.getresponse()
        response.body = response.read()  # type: ignore[attr-defined]
        conn.close()
        return response

    def wait_ready(self, meshes: list[str]) -> None:
        headers = {"Authorization": f"Bearer {self.token}"} if self.token else {}
        deadline = time.monotonic() + READY_DEADLINE_S
        last = ""
        while time.monotonic() < deadline:
            self.check_alive()
            try:
                response = self.request("GET", "/v1/meshes", headers=headers)
                last = response.body.decode(errors="replace")
                if response.status == 200:
                    states = {m["id"]: m["state"] for m in json.loads(last)["meshes"]}
                    if "failed" in states.values():
                        fail(f"{self.name}: a mesh failed: {last}")
                    if all(states.get(m) == "ready" for m in meshes):
                        return
            except (OSError, http.client.HTTPException):
                pass
            time.sleep(0.2)
        fail(f"{self.name}: meshes not ready within {READY_DEADLINE_S} s: {last}\n"
             f"{self.output()}")

    def stop(self) -> None:
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGTERM)
            try:
                self.process.wait(timeout=30)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()
        self.log.close()


# ---- comparison ----

def close(a: float, b: float, rel: float) -> bool:
    if math.isnan(a) or math.isnan(b):
        return math.isnan(a) and math.isnan(b)
    return a == b or abs(a - b) <= max(rel * max(abs(a), abs(b)), ABS_TOL)


def json_diff(expected, actual, where: str = "$") -> str | None:
    """None when equal (numbers to REL_TOL, IGNORED_KEYS not compared), else where they differ."""
    number = (int, float)
    if isinstance(expected, bool) or isinstance(actual, bool):
        return None if expected is actual else f"{where}: got {actual!r}, example {expected!r}"
    if isinstance(expected, number) and isinstance(actual, number):
        if close(float(expected), float(actual), REL_TOL):
            return None
        return f"{where}: got {actual!r}, example {expected!r}"
    if isinstance(expected, dict) and isinstance(actual, dict):
        if expected.keys() != actual.keys():
            return f"{where}: got members {sorted(actual)}, example {sorted(expected)}"
        for key in expected:
            if key in IGNORED_KEYS:
                continue
            diff = json_diff(expected[key], actual[key], f"{where}.{key}")
            if diff:
                return diff
        return None
    if isinstance(expected, list) and isinstance(actual, list):
        if len(expected) != len(actual):
            return f"{where}: got {len(actual)} elements, example {len(expected)}"
        for i, (e, a) in enumerate(zip(expected, actual)):
            diff = json_diff(e, a, f"{where}[{i}]")
            if diff:
                return diff
        return None
    return None if expected == actual else f"{where}: got {actual!r}, example {expected!r}"


DTYPES = {"float64": ("d", 8, REL_TOL), "float32": ("f", 4, FLOAT32_REL_TOL),
          "uint32": ("I", 4, 0.0)}
NPY_DESCR = {"<f8": "float64", "<f4": "float32", "<u4": "uint32"}


def split_npy(data: bytes) -> tuple[str, bytes]:
    """(header text, array bytes) of a .npy 1.0 file."""
    if data[:8] != b"\x93NUMPY\x01\x00":
        raise ValueError(f"not a .npy 1.0 file: {data[:8]!r}")
    (length,) = struct.unpack("<H", data[8:10])
    return data[10:10 + length].decode("latin-1"), data[10 + length:]


def array_diff(expected: bytes, actual: bytes, dtype: str) -> str | None:
    if dtype not in DTYPES:
        return f"unknown dtype {dtype!r}"
    code, size, rel = DTYPES[dtype]
    if len(expected) != len(actual) or len(actual) % size:
        return f"got {len(actual)} bytes, example {len(expected)}"
    n = len(actual) // size
    exp, act = struct.unpack(f"<{n}{code}", expected), struct.unpack(f"<{n}{code}", actual)
    for i, (e, a) in enumerate(zip(exp, act)):
        if not (e == a if code == "I" else close(e, a, rel)):
            return f"element {i}: got {a!r}, example {e!r}"
    return None


def binary_diff(expected: bytes, actual: bytes, media: str, dtype: str) -> str | None:
    if media == "application/x-npy":
        try:
            exp_header, exp_data = split_npy(expected)
            act_header, act_data = split_npy(actual)
        except ValueError as e:
            return str(e)
        if exp_header != act_header:
            return f".npy header {act_header!r} != {exp_header!r}"
        descr = exp_header.split("'descr': '", 1)[1].split("'", 1)[0]
        if NPY_DESCR.get(descr) != dtype:
            return f".npy descr {descr} but X-Geoprox-Dtype {dtype}"
        return array_diff(exp_data, act_data, dtype)
    return array_diff(expected, actual, dtype)


def check(case: Case, daemon: Daemon, docs: Path, write_external: bool) -> str | None:
    """None when the exchange matches the example, else what differs."""
    target = case.path + ("?" + urllib.parse.urlencode(case.query) if case.query else "")
    response = daemon.request(case.method, target, case.body, case.headers)
    body = response.body  # type: ignore[attr-defined]
    shown = body[:600].decode(errors="replace")
    if response.status != case.status:
        return f"status {response.status} != {case.status}: {shown}"
    media = (response.getheader("Content-Type") or "").split(";")[0].strip().lower()
    if case.media is None:
        return None if not body else f"a body on {case.status}: {shown}"
    if media != case.media:
        return f"Content-Type {media!r} != {case.media!r}: {shown}"
    for name, value in case.header_examples.items():
        if name.lower() in IGNORED_HEADERS:
            continue
        if response.getheader(name) != value:
            return f"header {name}: {response.getheader(name)!r} != {value!r}"
    if "externalValue" in case.example:
        path = docs / case.example["externalValue"]
        if write_external:
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_bytes(body)
        if not path.exists():
            return f"no file {path}"
        expected_bytes = path.read_bytes()
    else:
        expected_bytes = None
    if case.media in BINARY_TYPES:
        if expected_bytes is None:
            return "a binary example needs an externalValue file"
        return binary_diff(expected_bytes, body, case.media,
                           response.getheader("X-Geoprox-Dtype") or "")
    text = body.decode()
    expected = case.example.get("value") if expected_bytes is None else expected_bytes.decode()
    if case.media == "application/json":
        if isinstance(expected, str) and expected_bytes is not None:
            expected = json.loads(expected)
        diff = json_diff(expected, json.loads(text))
        return None if diff is None else f"{diff}\n  body: {shown}"
    return None if text == expected else f"body {text!r} != {expected!r}"


def main() -> None:
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    write_external = "--write-external" in sys.argv[1:]
    if len(args) != 2:
        fail("usage: openapi_examples_test.py GEOPROXD SOURCE_DIR [--write-external]")
    geoproxd, source = args[0], Path(args[1]).resolve()
    if not shutil.which("node"):
        print("SKIP: node is not installed (Node.js >= 20.19 runs the Redocly CLI)")
        sys.exit(SKIP)
    root = Path(tempfile.mkdtemp(prefix="openapi-examples-"))
    daemons: list[Daemon] = []
    try:
        spec = load_spec(source)
        cases = all_cases(spec)
        config = json.loads((source / "configs" / "default.json").read_text())
        config.update(data_dir=str(source / "data"), graph_dir=str(root / "graphs"),
                      log_level="warn")
        config_path = root / "config.json"
        config_path.write_text(json.dumps(config))
        meshes = [m["id"] for m in config["meshes"]]
        open_daemon = Daemon(geoproxd, config_path, root, "open", {})
        daemons.append(open_daemon)
        open_daemon.wait_ready(meshes)
        token_daemon = Daemon(geoproxd, config_path, root, "query-token",
                              {"GEOPROX_QUERY_TOKEN": QUERY_TOKEN})
        daemons.append(token_daemon)
        token_daemon.wait_ready(meshes)
        by_name = {"open": open_daemon, "query-token": token_daemon}
        passed = failed = 0
        for case in cases:
            if case.server not in by_name:
                fail(f"{case.label()}: unknown x-geoprox-request server {case.server!r}")
            problem = check(case, by_name[case.server], source / "docs", write_external)
            if problem is None:
                passed += 1
                print(f"ok {case.label()}")
            else:
                failed += 1
                print(f"FAIL {case.label()}: {case.method} {case.path} {case.query}: {problem}")
        for daemon in daemons:
            daemon.check_alive()
        print(f"{passed} passed, {failed} failed")
        if failed:
            sys.exit(1)
    finally:
        for daemon in daemons:
            daemon.stop()
        shutil.rmtree(root, ignore_errors=True)


if __name__ == "__main__":
    main()
