"""What the browser tests of tests/web/ share: a stdlib WebDriver client for
headless Chromium through chromedriver, a small PNG decoder, pixel error
figures, HTTP through urllib (no proxy), waiting on conditions, and starting
and stopping corvid-view and the browser."""
import base64
import json
import os
import select
import signal
import socket
import subprocess
import time
import urllib.error
import urllib.request
import zlib
import struct

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


def http(method, url, body=None, timeout=30, raw=None):
    """(status, body bytes); body is sent as JSON, raw as it is."""
    data = json.dumps(body).encode() if body is not None else raw
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

    def type(self, eid, text):
        """Clears an input and types text into it, as a user."""
        self.cmd("POST", self.s("/element/%s/clear" % eid), {})
        self.cmd("POST", self.s("/element/%s/value" % eid), {"text": text})

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


def settled(wd, api, frames, quiet_s=0.5):
    """Waits until the view is still: the page's newest frame has the newest input and has
    accumulated `frames` frames (corvid-view --frames) (the live then rests), and the server renders no more."""
    def still():
        v = wd.js("return window.corvidView")
        if not v or not v["frames"] or v["lastInputSeq"] < v["seq"] or v["lastAccumulated"] < frames:
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


def _up(port):
    try:
        with socket.create_connection(("127.0.0.1", port), timeout=0.5):
            return True
    except OSError:
        return False




def tools_missing():
    """The first of chromium and chromedriver that is missing (the tests then skip: exit 77), else None."""
    for tool in (CHROMIUM, CHROMEDRIVER):
        if not os.access(tool, os.X_OK):
            return tool
    return None


class Browser:
    """chromedriver on a free port and a headless Chromium session: `with Browser(tmp) as wd: ...`."""

    def __init__(self, tmp):
        self.tmp = tmp

    def __enter__(self):
        port = free_port()
        self.driver = subprocess.Popen([CHROMEDRIVER, "--port=%d" % port], stdout=subprocess.DEVNULL,
                                       stderr=subprocess.DEVNULL)
        self.wd = WebDriver(port)
        try:
            wait_for("chromedriver", lambda: http("GET", self.wd.base + "/status")[0] == 200 if _up(port) else False,
                     20)
            self.wd.start(["--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
                           "--no-proxy-server", "--window-size=1100,720",
                           "--user-data-dir=" + os.path.join(self.tmp, "profile")])
        except BaseException:
            self.__exit__(None, None, None)
            raise
        return self.wd

    def __exit__(self, *exc):
        self.wd.quit()
        self.driver.terminate()
        self.driver.wait(10)
        return False


def start_view(binary, args, tmp):
    """corvid-view with `args` (and --port 0 --quiet): (process, the printed URL)."""
    cmd = [binary, "--port", "0", "--quiet"] + list(args)
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



def stop_view(proc):
    """SIGINT, as a user's Ctrl-C: the exit code (None if it had to be killed)."""
    proc.send_signal(signal.SIGINT)
    try:
        return proc.wait(30)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()
        return None
