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
import json
import os
import shutil
import sys
import tempfile
import time

from browser_support import (Browser, Failure, check, compare_with_snapshot, http, rgb_errors, settled, start_view,
                             stats_of, stop_view, tools_missing, wait_for)

FRAMES = 4  # --frames: a still view rests after this many


def run(args, tmp):
    w, h = args.size.split("x")
    view, url = start_view(args.view, ["--width", w, "--height", h, "--gpus", "2", "--frames", str(FRAMES),
                                       "--codec", args.codec], tmp)
    api = url.rstrip("/") + "/api/v1/view"
    try:
        with Browser(tmp) as wd:
            _check_page(wd, url, api, args)
    finally:
        code = stop_view(view)
    check(code == 0, "corvid-view stops cleanly on SIGINT (exit %s)" % code)


def _check_page(wd, url, api, args):
    wd.go(url)
    wait_for("the first frame", lambda: (wd.js("return window.corvidView") or {}).get("frames"), 30)
    v = settled(wd, api, FRAMES)
    check(v["lastCodec"] == (1 if args.codec == "jpeg" else 2), "frames arrive as %s (decoder %s)"
          % (args.codec, v["decoder"]))
    before = compare_with_snapshot(wd, api, args.codec, "first view")

    canvas_el = wd.element("#frame")
    seq0 = v["seq"]
    wd.drag(canvas_el, 60, 16)
    v = settled(wd, api, FRAMES)
    check(v["seq"] > seq0 and v["lastInputSeq"] == v["seq"],
          "the drag sent input (seq %d -> %d) and the newest frame reflects it" % (seq0, v["seq"]))
    after = compare_with_snapshot(wd, api, args.codec, "after the drag")
    moved, _ = stats_of(rgb_errors(before, after, 4, len(after) // 4))
    check(moved > 8, "the orbit changed the image (mean difference %.1f > 8)" % moved)

    seq1 = v["seq"]
    wd.keys("ww")
    v = settled(wd, api, FRAMES)
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
        settled(wd, api, FRAMES)
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
    missing = tools_missing()
    if missing:
        print("skipped: %s is missing" % missing)
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
