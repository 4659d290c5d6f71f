#!/usr/bin/env python3
"""corvid-view in a real browser: headless Chromium driven through chromedriver
(the W3C WebDriver protocol, stdlib only).

Starts corvid-view on lavapipe (small image, 2 virtual GPUs), opens the page and
checks that
  - frames arrive and the canvas shows the server's own frame: the canvas pixels
    (getImageData) against GET /api/v1/view/snapshot.png (lossless) within the
    codec's tolerance (JPEG about q85, 4:2:0, measured 3.5 at 160x90: mean error
    per channel <= 5 of 255, 99.5% of the values within 48; H.264 (BT.601 4:2:0,
    measured 3 to 6): mean <= 10,
    99.5% within 72);
  - a drag on the canvas (WebDriver Actions: pointer down, moves, up) moves the
    camera: the page's input seq is reflected by the frames, the image differs
    from before by more than noise, and it matches the snapshot again;
  - keys move the camera (two W presses: two inputs, reflected by the frames);
  - "Save PNG" fetches the snapshot, snapshot.exr is an OpenEXR file, and the
    stats overlay shows fps and motion-to-photon figures;
  - a bad input message gets an error naming the field, and frames go on.

usage: browser_view_test.py CORVID_VIEW [--codec jpeg|h264] [--size WxH]
                            [--screenshot PATH]
Exit 77 (ctest's SKIP_RETURN_CODE) when chromium or chromedriver is missing.
"""
import argparse
import base64
import json
import os
import select
import shutil
import signal
import socket
import struct
import subprocess
import sys
import tempfile
import time
import urllib.error
import urllib.request
import zlib

CHROMIUM = "/usr/bin/chromium"
CHROMEDRIVER = "/usr/bin/chromedriver"
ELEMENT = "element-6066-11e4-a52e-4f735466cecf"
TOLERANCE = {"jpeg": (5.0, 48), "h264": (10.0, 72)}  # mean abs error, 99.5th percentile bound
NO_PROXY = urllib.request.build_opener(urllib.request.ProxyHandler({}))


class Failure(Exception):
    pass


def check(cond, what):
    if not cond:
        raise Failure(what)
    print("ok:", what, flush=True)


def http(method, url, body=None, timeout=30):
    data = json.dumps(body).encode() if body is not None else None
    req = urllib.request.Request(url, data=data, method=method, headers={"Content-Type": "application/json"})
    try:
        with NO_PROXY.open(req, timeout=timeout) as r:
            return r.status, r.read()
    except urllib.error.HTTPError as e:
        return e.code, e.read()


def decode_png(data):
    """8-bit RGB or RGBA, non-interlaced PNG -> (width, height, channels, bytes)."""
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        raise Failure("not a PNG")
    pos, idat, hdr = 8, b"", None
    while pos < len(data):
        n, kind = struct.unpack(">I4s", data[pos:pos + 8])
        chunk = data[pos + 8:pos + 8 + n]
        pos += 12 + n
        if kind == b"IHDR":
            hdr = struct.unpack(">IIBBBBB", chunk)
        elif kind == b"IDAT":
            idat += chunk
    w, h, depth, ctype, _, _, interlace = hdr
    if depth != 8 or ctype not in (2, 6) or interlace:
        raise Failure("PNG of depth %d, colour type %d, interlace %d not read here" % (depth, ctype, interlace))
    ch = 3 if ctype == 2 else 4
    raw, stride, out, prev = zlib.decompress(idat), w * ch, bytearray(), bytearray(w * ch)
    for y in range(h):
        f, line = raw[y * (stride + 1)], bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        for i in range(stride):
            a = line[i - ch] if i >= ch else 0
            b, c = prev[i], prev[i - ch] if i >= ch else 0
            if f == 1:
                line[i] = (line[i] + a) & 255
            elif f == 2:
                line[i] = (line[i] + b) & 255
            elif f == 3:
                line[i] = (line[i] + (a + b) // 2) & 255
            elif f == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                line[i] = (line[i] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
        out += line
        prev = line
    return w, h, ch, bytes(out)


def rgb_errors(a_rgba, b, b_channels, pixels):
    """Absolute differences of R, G, B of every pixel: a is RGBA, b RGB or RGBA."""
    errs = []
    for p in range(pixels):
        for c in range(3):
            errs.append(abs(a_rgba[4 * p + c] - b[b_channels * p + c]))
    return errs


def stats_of(errs):
    s = sorted(errs)
    return sum(errs) / len(errs), s[int(len(s) * 0.995)]


class WebDriver:
    def __init__(self, port):
        self.base = "http://127.0.0.1:%d" % port
        self.sid = None

    def cmd(self, method, path, body=None):
        st, data = http(method, self.base + path, body, timeout=60)
        value = json.loads(data or b"{}").get("value")
        if st != 200:
            raise Failure("webdriver %s %s: %s %s" % (method, path, st, value))
        return value

    def start(self, args):
        caps = {"capabilities": {"alwaysMatch": {"browserName": "chrome", "goog:chromeOptions": {
            "binary": CHROMIUM, "args": args}}}}
        self.sid = self.cmd("POST", "/session", caps)["sessionId"]

    def s(self, path):
        return "/session/%s%s" % (self.sid, path)

    def go(self, url):
        self.cmd("POST", self.s("/url"), {"url": url})

    def js(self, script, *args):
        return self.cmd("POST", self.s("/execute/sync"), {"script": script, "args": list(args)})

    def element(self, css):
        return self.cmd("POST", self.s("/element"), {"using": "css selector", "value": css})[ELEMENT]

    def click(self, eid):
        self.cmd("POST", self.s("/element/%s/click" % eid), {})

    def drag(self, eid, dx, dy, steps=8):
        moves = [{"type": "pointerMove", "duration": 0, "origin": {ELEMENT: eid}, "x": 0, "y": 0},
                 {"type": "pointerDown", "button": 0}]
        for _ in range(steps):
            moves.append({"type": "pointerMove", "duration": 30, "origin": "pointer", "x": dx // steps,
                          "y": dy // steps})
        moves.append({"type": "pointerUp", "button": 0})
        self.cmd("POST", self.s("/actions"), {"actions": [
            {"type": "pointer", "id": "mouse", "parameters": {"pointerType": "mouse"}, "actions": moves}]})
        self.cmd("DELETE", self.s("/actions"))

    def keys(self, text):
        acts = []
        for ch in text:
            acts += [{"type": "keyDown", "value": ch}, {"type": "keyUp", "value": ch}]
        self.cmd("POST", self.s("/actions"), {"actions": [{"type": "key", "id": "keyboard", "actions": acts}]})
        self.cmd("DELETE", self.s("/actions"))

    def screenshot(self):
        return base64.b64decode(self.cmd("GET", self.s("/screenshot")))

    def quit(self):
        if self.sid:
            http("DELETE", self.base + "/session/" + self.sid)


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def wait_for(what, fn, timeout):
    end = time.monotonic() + timeout
    while True:
        v = fn()
        if v:
            return v
        if time.monotonic() > end:
            raise Failure("timed out after %.0f s waiting for %s" % (timeout, what))
        time.sleep(0.1)


CANVAS_JS = """
const c = document.getElementById('frame');
const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
let s = '';
for (let i = 0; i < d.length; i += 8192) s += String.fromCharCode.apply(null, d.subarray(i, i + 8192));
return [c.width, c.height, btoa(s)];
"""


def canvas(wd):
    w, h, b64 = wd.js(CANVAS_JS)
    return w, h, base64.b64decode(b64)


FRAMES = 4  # --frames: a still view rests after this many


def settled(wd, api, quiet_s=0.5):
    """Waits until the view is still: the page's newest frame has the newest input and has
    accumulated FRAMES frames (the live then rests), and the server renders no more."""
    def still():
        v = wd.js("return window.corvidView")
        if not v or not v["frames"] or v["lastInputSeq"] < v["seq"] or v["lastAccumulated"] < FRAMES:
            return False
        a = json.loads(http("GET", api + "/stats")[1])
        time.sleep(quiet_s)
        b = json.loads(http("GET", api + "/stats")[1])
        v2 = wd.js("return window.corvidView")
        return a["rendered"] == b["rendered"] and v2["lastIndex"] == v["lastIndex"] and v2
    return wait_for("a still view", still, 40)


def compare_with_snapshot(wd, api, codec, what):
    w, h, pixels = canvas(wd)
    st, png = http("GET", api + "/snapshot.png")
    check(st == 200, "%s: GET snapshot.png is 200" % what)
    sw, sh, sch, snap = decode_png(png)
    check((w, h) == (sw, sh), "%s: canvas %dx%d is the frame's size %dx%d" % (what, w, h, sw, sh))
    mean, p995 = stats_of(rgb_errors(pixels, snap, sch, w * h))
    st = json.loads(http("GET", api + "/stats")[1])
    print("  (%s: quality %d, bitrate %d kbit/s, accumulated %d)" % (what, st["quality"], st["bitrate_kbps"],
                                                                   st["accumulated"]))
    bound_mean, bound_p = TOLERANCE[codec]
    check(mean <= bound_mean and p995 <= bound_p,
          "%s: canvas matches the server's frame (%s: mean error %.2f <= %.1f, 99.5%% within %d <= %d)"
          % (what, codec, mean, bound_mean, p995, bound_p))
    return pixels


def start_view(binary, codec, size, tmp):
    w, h = size.split("x")
    cmd = [binary, "--port", "0", "--width", w, "--height", h, "--gpus", "2", "--frames", str(FRAMES),
           "--codec", codec, "--quiet"]
    env = dict(os.environ, XDG_RUNTIME_DIR=os.environ.get("XDG_RUNTIME_DIR", "/tmp"))
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=open(os.path.join(tmp, "view.err"), "w"),
                            env=env, text=True)
    ready, _, _ = select.select([proc.stdout], [], [], 60)
    line = proc.stdout.readline() if ready else ""
    if "open http" not in line:
        proc.kill()
        raise Failure("corvid-view did not print its URL: %r; stderr: %s" %
                      (line, open(os.path.join(tmp, "view.err")).read()))
    return proc, line.split("open ", 1)[1].strip()


def run(args, tmp):
    view, url = start_view(args.view, args.codec, args.size, tmp)
    api = url.rstrip("/") + "/api/v1/view"
    dport = free_port()
    driver = subprocess.Popen([CHROMEDRIVER, "--port=%d" % dport], stdout=subprocess.DEVNULL,
                              stderr=subprocess.DEVNULL)
    wd = WebDriver(dport)
    try:
        wait_for("chromedriver", lambda: http("GET", wd.base + "/status")[0] == 200 if _up(dport) else False, 20)
        wd.start(["--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage", "--no-proxy-server",
                  "--window-size=1100,720", "--user-data-dir=" + os.path.join(tmp, "profile")])
        wd.go(url)
        wait_for("the first frame", lambda: (wd.js("return window.corvidView") or {}).get("frames"), 30)
        v = settled(wd, api)
        check(v["lastCodec"] == (1 if args.codec == "jpeg" else 2), "frames arrive as %s (decoder %s)"
              % (args.codec, v["decoder"]))
        before = compare_with_snapshot(wd, api, args.codec, "first view")

        canvas_el = wd.element("#frame")
        seq0 = v["seq"]
        wd.drag(canvas_el, 60, 16)
        v = settled(wd, api)
        check(v["seq"] > seq0 and v["lastInputSeq"] == v["seq"],
              "the drag sent input (seq %d -> %d) and the newest frame reflects it" % (seq0, v["seq"]))
        after = compare_with_snapshot(wd, api, args.codec, "after the drag")
        moved, _ = stats_of(rgb_errors(before, after, 4, len(after) // 4))
        check(moved > 8, "the orbit changed the image (mean difference %.1f > 8)" % moved)

        seq1 = v["seq"]
        wd.keys("ww")
        v = settled(wd, api)
        check(v["seq"] == seq1 + 2 and v["lastInputSeq"] == v["seq"], "the W key moved the camera twice (seq %d)"
              % v["seq"])

        saved = (wd.js("return window.corvidView.saved") or 0)
        wd.click(wd.element("#save-png"))
        wait_for("Save PNG", lambda: (wd.js("return window.corvidView.saved") or 0) > saved, 20)
        check(True, "Save PNG fetched the snapshot")
        st, exr = http("GET", api + "/snapshot.exr")
        check(st == 200 and exr[:4] == b"\x76\x2f\x31\x01", "GET snapshot.exr gives an OpenEXR file (%d bytes)"
              % len(exr))

        text = wait_for("stats with motion-to-photon", lambda: (lambda t: t if "fps" in t and "motion-to-photon"
                        in t else None)(wd.js("return document.getElementById('stats').textContent")), 10)
        m2p = wd.js("return window.corvidView.m2p")
        check(m2p > 0, "the stats overlay shows fps and motion-to-photon (%.1f ms measured by the page)" % m2p)
        print(text, flush=True)

        if args.screenshot:
            settled(wd, api)
            with open(args.screenshot, "wb") as f:
                f.write(wd.screenshot())
            print("wrote", args.screenshot)

        n = wd.js("return window.corvidView.frames")
        errors = len(wd.js("return window.corvidView.errors"))
        _send_raw(wd, '{"seq": 999999, "colour": 1}')
        wait_for("the error message", lambda: len(wd.js("return window.corvidView.errors")) > errors, 10)
        err = wd.js("return window.corvidView.errors.slice(-1)[0]")
        check("colour" in err, "a bad input is refused naming the field: %s" % err)
        wd.drag(canvas_el, -40, 0)
        wait_for("frames after the error", lambda: wd.js("return window.corvidView.frames") > n, 20)
        check(True, "frames go on after the refused input")

    finally:
        wd.quit()
        driver.terminate()
        driver.wait(10)
        view.send_signal(signal.SIGINT)
        try:
            code = view.wait(30)
        except subprocess.TimeoutExpired:
            view.kill()
            code = None
    check(code == 0, "corvid-view stops cleanly on SIGINT (exit %s)" % code)


def _up(port):
    try:
        with socket.create_connection(("127.0.0.1", port), timeout=0.5):
            return True
    except OSError:
        return False


def _send_raw(wd, text):
    """Sends a message through the page's WebSocket as the page would (the test's bad input)."""
    wd.js("window.corvidView.sendRaw(arguments[0]);", text)


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("view")
    p.add_argument("--codec", default="jpeg", choices=["jpeg", "h264"])
    p.add_argument("--size", default="160x90")
    p.add_argument("--screenshot")
    args = p.parse_args()
    for tool in (CHROMIUM, CHROMEDRIVER):
        if not os.access(tool, os.X_OK):
            print("skipped: %s is missing" % tool)
            return 77
    tmp = tempfile.mkdtemp(prefix="corvid-browser-")
    t0 = time.monotonic()
    try:
        run(args, tmp)
    except Failure as e:
        print("FAILED:", e, flush=True)
        err = os.path.join(tmp, "view.err")
        if os.path.exists(err):
            print("corvid-view's stderr:\n" + open(err).read())
        return 1
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    print("browser_view_test (%s): passed in %.1f s" % (args.codec, time.monotonic() - t0))
    return 0


if __name__ == "__main__":
    sys.exit(main())
