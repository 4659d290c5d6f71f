#!/usr/bin/env python3
"""A REST job driven from corvid-view's page in a real browser (headless
Chromium through chromedriver, stdlib only): the gateway on the view's port.

Starts corvid-view on lavapipe (96x54, 2 virtual GPUs), drags the view once (so
the camera is not the scene's) and moves the exposure slider, waits until the
view has accumulated its 4 frames, then through the page's job panel:
  - "Start job" with 4 frames: the progress reaches done and the page shows the
    job's PNG; the <img> pixels (drawn on a canvas, getImageData) equal the
    PNG's bytes fetched by urllib and decoded here, exactly (a PNG is lossless);
  - the job took what the page showed: its PNG equals the view's own frame
    (snapshot.png after the same 4 frames) within 1 LSB (the GPU tone map of
    the live frame against the job's CPU one; measured: equal); the request
    the page sent carries the page's camera and exposure; the same request sent by urllib renders the same image
    exactly, and the same without the camera (the scene's) renders a different
    one (mean difference > 2 of 255), so the check cannot pass by accident;
  - "Cancel" on a long job (4000 frames) ends it cancelled; a second cancel by
    urllib gets 409;
  - an out-of-range frames value typed in the panel shows the gateway's error,
    which names the field.

usage: browser_job_test.py CORVID_VIEW
Exit 77 (ctest's SKIP_RETURN_CODE) when chromium or chromedriver is missing.
"""
import base64
import json
import shutil
import sys
import tempfile
import time

from browser_support import (Browser, Failure, check, decode_png, http, rgb_errors, settled, start_view, stats_of,
                             stop_view, tools_missing, wait_for)

FRAMES = 4  # --frames of the view: a still view rests after this many

IMAGE_JS = """
const img = document.getElementById('job-image');
const c = document.createElement('canvas');
c.width = img.naturalWidth;
c.height = img.naturalHeight;
const g = c.getContext('2d', { willReadFrequently: true });
g.drawImage(img, 0, 0);
const d = g.getImageData(0, 0, c.width, c.height).data;
let s = '';
for (let i = 0; i < d.length; i += 8192) s += String.fromCharCode.apply(null, d.subarray(i, i + 8192));
return [c.width, c.height, btoa(s)];
"""


# The exposure slider moved to +0.5 EV as a user's input event does (a setting a job must carry).
SET_EXPOSURE_JS = """
const e = document.getElementById('setting-exposure');
e.value = '0.5';
e.dispatchEvent(new Event('input'));
"""


def job_of_page(wd):
    return wd.js("return window.corvidView.job") or {}


def wait_job(base, job_id, timeout=60):
    """Polls a job started by urllib until it has ended: its last state."""
    def ended():
        j = json.loads(http("GET", "%s/jobs/%d" % (base, job_id))[1])
        return j if j["state"] in ("done", "failed", "cancelled") else None
    return wait_for("job %d to end" % job_id, ended, timeout)


def job_png(base, job_id):
    st, png = http("GET", "%s/jobs/%d/image.png" % (base, job_id))
    check(st == 200, "GET /api/v1/jobs/%d/image.png is 200" % job_id)
    return decode_png(png)


def submit(base, request):
    st, body = http("POST", base + "/jobs", request)
    check(st == 201, "POST /api/v1/jobs by urllib is 201 (%s)" % body[:200])
    j = wait_job(base, json.loads(body)["id"])
    check(j["state"] == "done", "job %d is done" % j["id"])
    return job_png(base, j["id"])


def start_from_page(wd, frames):
    wd.type(wd.element("#job-frames"), str(frames))
    wd.click(wd.element("#job-start"))


def run_job(wd, base):
    """A 4-frame job from the page; the page's image against the job's PNG."""
    start_from_page(wd, 4)
    j = wait_for("the page's job to be done and shown", lambda: (lambda j: j if j.get("state") == "done" and
                 wd.js("return window.corvidView.jobImageLoaded") == j["id"] else None)(job_of_page(wd)), 60)
    progress = wd.js("const p = document.getElementById('job-progress'); return [p.value, p.max];")
    check(progress == [4, 4], "the progress bar reached 4 of 4 frames (%s)" % progress)
    links = wd.js("return [document.getElementById('job-png').getAttribute('href'), "
                  "document.getElementById('job-exr').getAttribute('href')];")
    check(links == ["api/v1/jobs/%d/image.png" % j["id"], "api/v1/jobs/%d/image.exr" % j["id"]],
          "the page links image.png and image.exr (%s)" % links)
    w, h, b64 = wd.js(IMAGE_JS)
    shown = base64.b64decode(b64)
    pw, ph, ch, png = job_png(base, j["id"])
    check((w, h) == (pw, ph) == (96, 54), "the <img> is the job's %dx%d" % (pw, ph))
    worst = max(rgb_errors(shown, png, ch, w * h))
    check(worst == 0, "the <img> pixels equal the job's PNG exactly (largest difference %d)" % worst)
    return j, png, ch


def check_request(wd, base, png, ch):
    """The job was the page's view: its request, replayed by urllib, and without the camera."""
    req = wd.js("return window.corvidView.jobRequest")
    cam = wd.js("return window.corvidView.camera")
    hello = wd.js("return window.corvidView.hello.camera")
    check(req["camera"] == {"eye": cam["eye"], "target": cam["target"], "fov_degrees": cam["fov"]}
          and cam["eye"] != hello["eye"] and req["settings"]["exposure"] == 0.5,
          "the page's job carries the page's camera, moved by the drag, and exposure: %s" % req["camera"])
    pixels = 96 * 54
    _, _, ch2, again = submit(base, req)
    worst = max(rgb_errors(_rgba(png, ch), again, ch2, pixels))
    check(worst == 0, "the same request by urllib renders the same image exactly (largest difference %d)" % worst)
    other = dict(req)
    del other["camera"]
    _, _, ch3, scene_cam = submit(base, other)
    diff, _ = stats_of(rgb_errors(_rgba(png, ch), scene_cam, ch3, pixels))
    check(diff > 2, "without the page's camera the image differs (mean difference %.1f > 2)" % diff)


def _rgba(pixels, channels):
    if channels == 4:
        return pixels
    out = bytearray()
    for p in range(len(pixels) // 3):
        out += pixels[3 * p:3 * p + 3] + b"\xff"
    return bytes(out)


def check_cancel(wd, base):
    start_from_page(wd, 4000)
    wait_for("the long job to start", lambda: job_of_page(wd).get("state") in ("queued", "running"), 30)
    j = job_of_page(wd)
    wd.click(wd.element("#job-cancel"))
    wait_for("the job to end cancelled", lambda: job_of_page(wd).get("state") == "cancelled", 30)
    check(True, "Cancel ended job %d cancelled" % j["id"])
    st, body = http("DELETE", "%s/jobs/%d" % (base, j["id"]))
    check(st == 409, "a second cancel by urllib gets 409 (%s)" % body.decode()[:120])


def check_refusal(wd):
    start_from_page(wd, 100000)
    err = wait_for("the gateway's error", lambda: wd.js("return document.getElementById('job-error').textContent"),
                   20)
    check("frames" in err and "100000" in err, "an out-of-range frames value shows the gateway's error: %s" % err)


def run(view_binary, tmp):
    view, url = start_view(view_binary, ["--width", "96", "--height", "54", "--gpus", "2", "--frames", str(FRAMES)],
                           tmp)
    base = url.rstrip("/") + "/api/v1"
    try:
        with Browser(tmp) as wd:
            wd.go(url)
            wait_for("the first frame and the job scene", lambda: wd.js(
                "const v = window.corvidView; return v && v.frames > 0 && v.jobScene;"), 40)
            check(wd.js("return window.corvidView.jobScene") == "default"
                  and wd.js("return document.getElementById('job-width').value") == "96",
                  "the job panel starts from the view's scene (the gateway's \"default\") and size")
            wd.drag(wd.element("#frame"), 60, 16)
            wd.js(SET_EXPOSURE_JS)
            settled(wd, base + "/view", FRAMES)
            st, snap = http("GET", base + "/view/snapshot.png")
            check(st == 200, "the view's snapshot after %d accumulated frames" % FRAMES)
            j, png, ch = run_job(wd, base)
            sw, sh, sch, snap = decode_png(snap)
            worst = max(rgb_errors(_rgba(png, ch), snap, sch, 96 * 54))
            check(worst <= 1, "the job's image is the view's own frame after the same %d frames (largest difference "
                  "%d <= 1: the GPU and CPU tone maps agree within 1 LSB)" % (FRAMES, worst))
            check_request(wd, base, png, ch)
            check_cancel(wd, base)
            check_refusal(wd)
    finally:
        code = stop_view(view)
    check(code == 0, "corvid-view stops cleanly on SIGINT (exit %s)" % code)


def main():
    if len(sys.argv) != 2:
        print(__doc__)
        return 2
    missing = tools_missing()
    if missing:
        print("skipped: %s is missing" % missing)
        return 77
    tmp = tempfile.mkdtemp(prefix="corvid-browser-job-")
    t0 = time.monotonic()
    try:
        run(sys.argv[1], tmp)
    except Failure as e:
        print("FAILED:", e, flush=True)
        return 1
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    print("browser_job_test: passed in %.1f s" % (time.monotonic() - t0))
    return 0


if __name__ == "__main__":
    sys.exit(main())
