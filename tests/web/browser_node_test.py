#!/usr/bin/env python3
"""corvid-view through a corvid-node (--nodes) in a real browser (headless
Chromium through chromedriver, stdlib only).

Starts corvid-node on a free loopback port (2 virtual GPUs on lavapipe) and
corvid-view --nodes it (160x90, the size browser_view_test's tolerance was measured at), opens the page and checks that
  - frames arrive, rendered and JPEG-encoded on the node, and the canvas shows
    the view's own frame: the canvas against GET /api/v1/view/snapshot.png
    within browser_view_test's JPEG tolerance (mean error per channel <= 5 of
    255, 99.5% of the values within 48), before and after a drag;
  - when the node is killed (SIGKILL) and the view is moved, the live ends with
    an error the page shows (its error line: the stats' error, naming the
    node), and corvid-view keeps
    serving: GET /api/v1 and the page's assets answer 200.

usage: browser_node_test.py CORVID_VIEW CORVID_NODE
Exit 77 (ctest's SKIP_RETURN_CODE) when chromium or chromedriver is missing.
"""
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time

from browser_support import (Browser, Failure, check, compare_with_snapshot, http, settled, start_view, stop_view,
                             tools_missing, wait_for)

FRAMES = 4  # --frames of the view: a still view rests after this many


def start_node(binary, tmp):
    """corvid-node on 127.0.0.1, a port of its choice (--port-file): (process, port)."""
    port_file = os.path.join(tmp, "node.port")
    env = dict(os.environ, XDG_RUNTIME_DIR=os.environ.get("XDG_RUNTIME_DIR", "/tmp"))
    node = subprocess.Popen([binary, "--listen", "127.0.0.1:0", "--gpus", "2", "--virtual-gpus", "2", "--cache-dir",
                             os.path.join(tmp, "cache"), "--port-file", port_file],
                            stdout=subprocess.DEVNULL, stderr=open(os.path.join(tmp, "node.err"), "w"), env=env)

    def port():
        if node.poll() is not None:
            raise Failure("corvid-node exited %s: %s" % (node.returncode, open(os.path.join(tmp, "node.err")).read()))
        text = open(port_file).read().strip() if os.path.exists(port_file) else ""
        return int(text) if text.isdigit() else None
    return node, wait_for("corvid-node's port", port, 60)


def run(view_binary, node_binary, tmp):
    node, port = start_node(node_binary, tmp)
    view = None
    try:
        view, url = start_view(view_binary, ["--nodes", "127.0.0.1:%d" % port, "--width", "160", "--height", "90",
                                             "--frames", str(FRAMES)], tmp)
        api = url.rstrip("/") + "/api/v1"
        with Browser(tmp) as wd:
            wd.go(url)
            wait_for("the first frame", lambda: (wd.js("return window.corvidView") or {}).get("frames"), 40)
            settled(wd, api + "/view", FRAMES)
            compare_with_snapshot(wd, api + "/view", "jpeg", "through the node")
            wd.drag(wd.element("#frame"), 50, 10)
            settled(wd, api + "/view", FRAMES)
            compare_with_snapshot(wd, api + "/view", "jpeg", "through the node, after a drag")

            node.kill()
            node.wait(10)
            wd.drag(wd.element("#frame"), -50, 0)  # the live renders again: on a node that is gone
            stats = wait_for("the live to end with an error", lambda: (lambda s: s if s.get("error") else None)(
                json.loads(http("GET", api + "/view/stats")[1])), 60)
            err = wait_for("the page to show the live's error", lambda: (lambda t: t if t == stats["error"] else None)(
                wd.js("return document.getElementById('error').textContent")), 20)
            check("127.0.0.1:%d" % port in err, "the page shows the live's error, naming the node: %s" % err)
            check(http("GET", api)[0] == 200 and http("GET", url)[0] == 200,
                  "corvid-view keeps serving (GET /api/v1 and the page answer 200)")
    finally:
        if node.poll() is None:
            node.kill()
            node.wait(10)
        code = stop_view(view) if view else None
    check(code == 0, "corvid-view stops cleanly on SIGINT after its node died (exit %s)" % code)


def main():
    if len(sys.argv) != 3:
        print(__doc__)
        return 2
    missing = tools_missing()
    if missing:
        print("skipped: %s is missing" % missing)
        return 77
    tmp = tempfile.mkdtemp(prefix="corvid-browser-node-")
    t0 = time.monotonic()
    try:
        run(sys.argv[1], sys.argv[2], tmp)
    except Failure as e:
        print("FAILED:", e, flush=True)
        for name in ("view.err", "node.err"):
            path = os.path.join(tmp, name)
            if os.path.exists(path):
                print("%s:\n%s" % (name, open(path).read()[-3000:]))
        return 1
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    print("browser_node_test: passed in %.1f s" % (time.monotonic() - t0))
    return 0


if __name__ == "__main__":
    sys.exit(main())
