#!/usr/bin/env python3
"""The REST gateway over HTTP: the corvid-gateway program (argv[1]) on loopback with a bearer token,
driven with urllib only. 401 without the token or with a wrong one, 200 with it; every operation
docs/openapi.yaml lists answers (no 404 "no such endpoint", no 405); a model uploaded by PUT, known on
HEAD, a job rendered on it and its PNG and EXR fetched; bad JSON, an unknown field, an out-of-range
setting, oversize bodies (the gateway's 413 and the server's), an unknown scene, cancel twice; a
non-loopback address without a token refused at start; SIGTERM stops it with a job running.

usage: gateway_http_test.py <corvid-gateway> <source root>"""
import base64
import hashlib
import json
import os
import shutil
import signal
import ssl
import struct
import subprocess
import sys
import tempfile
import time
import urllib.error
import urllib.request

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from openapi_routes_test import document_routes  # noqa: E402

FAILURES = []
CHECKS = [0]
TOKEN = "gateway-test-token"
MAX_SCENE = 65536


def check(cond, what):
    CHECKS[0] += 1
    if not cond:
        FAILURES.append(what)
        print("FAILED:", what, flush=True)


def model():
    """A floor and an upright triangle, glTF with its buffer embedded (as tests/gateway's C tests)."""
    pos = [(-2, 0, -2), (2, 0, -2), (2, 0, 2), (-2, 0, 2), (-0.5, 0, 0), (0.5, 0, 0), (0, 1.5, 0)]
    buf = b"".join(struct.pack("<3f", *p) for p in pos) + struct.pack("<9H", 0, 2, 1, 0, 3, 2, 4, 5, 6) + b"\0\0"
    doc = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
           "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
           "buffers": [{"byteLength": len(buf),
                        "uri": "data:application/octet-stream;base64," + base64.b64encode(buf).decode()}],
           "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 84},
                           {"buffer": 0, "byteOffset": 84, "byteLength": 18}],
           "accessors": [{"bufferView": 0, "componentType": 5126, "count": 7, "type": "VEC3",
                          "min": [-2, 0, -2], "max": [2, 1.5, 2]},
                         {"bufferView": 1, "componentType": 5123, "count": 9, "type": "SCALAR"}]}
    return json.dumps(doc).encode()


class Gateway:
    def __init__(self, binary, args, scheme="http"):
        self.proc = subprocess.Popen([binary] + args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        line = self.proc.stdout.readline()
        check(f"serving {scheme}://127.0.0.1:" in line, f"the program prints where it serves: {line!r}")
        self.base = line.strip().split("serving ")[-1]

    def stop(self):
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                self.proc.wait(timeout=60)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()

    def call(self, method, path, body=None, token=TOKEN, content_type="application/json", context=None):
        req = urllib.request.Request(self.base.replace("/api/v1", "") + path, data=body, method=method)
        if token:
            req.add_header("Authorization", "Bearer " + token)
        if body is not None:
            req.add_header("Content-Type", content_type)
        try:
            with urllib.request.urlopen(req, timeout=60, context=context) as r:
                return r.status, r.headers.get("Content-Type", ""), r.read()
        except urllib.error.HTTPError as e:
            return e.code, e.headers.get("Content-Type", ""), e.read()

    def json(self, method, path, body=None, **kw):
        status, _, data = self.call(method, path, body, **kw)
        try:
            return status, json.loads(data) if data else {}
        except ValueError:
            return status, {"raw": data[:200]}

    def wait_job(self, job_id, states=("done", "failed", "cancelled"), seconds=120):
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            status, job = self.json("GET", f"/api/v1/jobs/{job_id}")
            if job.get("state") in states:
                return job
            time.sleep(0.05)  # HTTP has no wait: a short poll with a deadline
        return {}


def test_token(g):
    check(g.call("GET", "/api/v1", token=None)[0] == 401, "no token: 401")
    check(g.call("GET", "/api/v1", token="wrong")[0] == 401, "a wrong token: 401")
    status, info = g.json("GET", "/api/v1")
    check(status == 200 and info.get("version") == 1, f"with the token: 200, version 1 ({status} {info})")


def test_scene_and_job(g):
    body = model()
    sha = hashlib.sha256(body).hexdigest()
    check(g.call("HEAD", f"/api/v1/scenes/{sha}")[0] == 404, "HEAD of an unknown model: 404")
    status, stored = g.json("PUT", f"/api/v1/scenes/{sha}", body, content_type="model/gltf+json")
    check(status == 201 and stored.get("scene") == sha, f"PUT the model: 201 ({status} {stored})")
    check(g.call("HEAD", f"/api/v1/scenes/{sha}")[0] == 200, "HEAD of the model: 200")
    job_body = json.dumps({"scene": sha, "width": 64, "height": 48, "frames": 2,
                           "settings": {"ao-samples": 2}}).encode()
    status, job = g.json("POST", "/api/v1/jobs", job_body)
    check(status == 201 and job.get("id"), f"POST a job: 201 ({status} {job})")
    done = g.wait_job(job.get("id"))
    check(done.get("state") == "done" and done.get("frames_done") == 2, f"the job is done: {done}")
    status, ctype, png = g.call("GET", f"/api/v1/jobs/{job.get('id')}/image.png")
    check(status == 200 and ctype.startswith("image/png") and png[:8] == b"\x89PNG\r\n\x1a\n", "the PNG")
    status, ctype, exr = g.call("GET", f"/api/v1/jobs/{job.get('id')}/image.exr")
    check(status == 200 and exr[:4] == b"\x76\x2f\x31\x01", "the EXR")
    status, err = g.json("DELETE", f"/api/v1/jobs/{job.get('id')}")
    check(status == 409 and "has ended (done)" in err.get("error", ""), f"cancel a done job: 409 ({err})")
    return sha, job.get("id")


def test_every_operation(g, root, sha, job_id):
    """Every operation of the document answers (its path routed, its method taken)."""
    for method, path in sorted(document_routes(root + "/docs/openapi.yaml")):
        concrete = path.replace("{sha256}", sha).replace("{id}", str(job_id))
        body = model() if method == "PUT" else (b"{}" if method == "POST" and path.endswith("jobs") else None)
        if method == "POST" and path.endswith("scenes"):
            body = model()
        if method == "DELETE":
            continue  # cancels: test_refusals
        status, _, data = g.call(method, concrete, body)
        check(status not in (404, 405) or (method == "HEAD" and status == 404),
              f"{method} {concrete}: {status} {data[:120]!r}")


def test_refusals(g):
    cases = [
        (b"{\"width\": 64,", 400, "body: not valid JSON"),
        (b"{\"colour\": 1}", 400, "unknown field 'colour'"),
        (b"{\"settings\": {\"ao-samples\": 40}}", 400, "settings.ao-samples"),
        (b"{\"scene\": \"" + b"0" * 64 + b"\"}", 404, "no stored model"),
    ]
    for body, want, needle in cases:
        status, err = g.json("POST", "/api/v1/jobs", body)
        check(status == want and needle in err.get("error", ""), f"POST {body[:40]!r}: {status} {err}")
    status, err = g.json("POST", "/api/v1/scenes", b"x" * (MAX_SCENE + 1), content_type="model/gltf-binary")
    check(status == 413 and "limit" in err.get("error", ""), f"a model over --max-scene-bytes: 413 ({status} {err})")
    status, _, _ = g.call("POST", "/api/v1/scenes", b"x" * (4 * MAX_SCENE), content_type="model/gltf-binary")
    check(status == 413, f"a body over the server's limit: 413 ({status})")
    status, job = g.json("POST", "/api/v1/jobs", b"{\"width\": 64, \"height\": 48, \"frames\": 4096}")
    running = g.wait_job(job.get("id"), ("running",))
    check(running.get("state") == "running", f"a long job runs: {running}")
    check(g.call("DELETE", f"/api/v1/jobs/{job.get('id')}")[0] == 200, "cancel: 200")
    check(g.call("DELETE", f"/api/v1/jobs/{job.get('id')}")[0] == 409, "cancel twice: 409")
    ended = g.wait_job(job.get("id"))
    check(ended.get("state") == "cancelled", f"the cancelled job ends cancelled: {ended}")


def test_stop_with_a_job_running(g):
    status, job = g.json("POST", "/api/v1/jobs", b"{\"width\": 64, \"height\": 48, \"frames\": 4096}")
    g.wait_job(job.get("id"), ("running",))
    g.proc.send_signal(signal.SIGTERM)
    try:
        code = g.proc.wait(timeout=60)
    except subprocess.TimeoutExpired:
        g.proc.kill()
        code = None
    check(code == 0, f"SIGTERM: it stops, exit 0 ({code})")
    check("stopping" in g.proc.stderr.read(), "it says it stops")


def test_tls(binary, tmp, token_file):
    """With a certificate and key it serves HTTPS (the token still required)."""
    if not shutil.which("openssl"):
        print("gateway_http: no openssl program: the TLS check is not run")
        return
    cert, key = os.path.join(tmp, "cert.pem"), os.path.join(tmp, "key.pem")
    subprocess.run(["openssl", "req", "-x509", "-newkey", "rsa:2048", "-nodes", "-keyout", key, "-out", cert,
                    "-days", "1", "-subj", "/CN=127.0.0.1"], check=True, capture_output=True, timeout=60)
    g = Gateway(binary, ["--port", "0", "--token-file", token_file, "--tls-cert", cert, "--tls-key", key],
                scheme="https")
    try:
        context = ssl.create_default_context(cafile=cert)
        context.check_hostname = False
        status, _, data = g.call("GET", "/api/v1", context=context)
        check(status == 200 and b'"version":1' in data, f"HTTPS with the token: 200 ({status} {data[:80]!r})")
        check(g.call("GET", "/api/v1", token=None, context=context)[0] == 401, "HTTPS without the token: 401")
    finally:
        g.stop()


def main():
    binary, root = sys.argv[1], sys.argv[2]
    with tempfile.TemporaryDirectory() as tmp:
        token_file = os.path.join(tmp, "token")
        with open(token_file, "w") as f:
            f.write(TOKEN + "\n")
        refused = subprocess.run([binary, "--host", "0.0.0.0", "--port", "0"], capture_output=True, text=True,
                                 timeout=60)
        check(refused.returncode != 0 and "token" in refused.stderr,
              f"a non-loopback address without a token is refused: {refused.returncode} {refused.stderr!r}")
        bad = subprocess.run([binary, "--jobs", "0"], capture_output=True, text=True, timeout=60)
        check(bad.returncode == 2 and "--jobs" in bad.stderr, f"a bad option is named: {bad.stderr!r}")
        g = Gateway(binary, ["--port", "0", "--token-file", token_file, "--max-scene-bytes", str(MAX_SCENE),
                             "--jobs", "2"])
        try:
            test_token(g)
            sha, job_id = test_scene_and_job(g)
            test_every_operation(g, root, sha, job_id)
            test_refusals(g)
            test_stop_with_a_job_running(g)
        finally:
            if g.proc.poll() is None:
                g.proc.kill()
                g.proc.wait()
        test_tls(binary, tmp, token_file)
    print(f"gateway_http: {CHECKS[0] - len(FAILURES)} passed, {len(FAILURES)} failed")
    return 1 if FAILURES else 0


if __name__ == "__main__":
    sys.exit(main())
