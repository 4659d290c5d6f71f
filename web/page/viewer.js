// corvid-view's page: shows the live frames (JPEG images or an H.264 stream) on a
// canvas, and sends input back: the camera (orbit, pan, zoom, keys), the sun, the
// settings; acknowledges each displayed frame (the renderer's credit) and reports
// motion-to-photon. The job panel starts a REST job (docs/gateway.md) of the scene
// with the page's camera and settings. Protocol: docs/live-view.md.
"use strict";

(function () {
  const HEADER_BYTES = 48;
  const MAGIC = 0x31465643; // "CVF1"
  const CODEC_JPEG = 1, CODEC_H264 = 2;
  const token = new URLSearchParams(location.search).get("token");
  const canvas = document.getElementById("frame");
  const ctx = canvas.getContext("2d", { alpha: false, willReadFrequently: true });
  const statsEl = document.getElementById("stats");
  const errorEl = document.getElementById("error");

  // What the tests (tests/web/) and the stats overlay read.
  const view = {
    connected: false, frames: 0, lastIndex: 0, lastInputSeq: 0, lastAccumulated: 0, lastCodec: 0,
    seq: 0, m2p: 0, m2pMax: 0, errors: [], stats: null, hello: null, decoder: "none",
    camera: null, jobRequest: null, job: null, jobScene: null,
  };
  window.corvidView = view;
  // A message as it is (the tests send a malformed one to see it refused).
  view.sendRaw = (text) => ws && ws.readyState === WebSocket.OPEN && ws.send(text);

  let ws = null;
  let camera = null; // {eye, target, fov}
  // Whether the view's camera and sun are set (else the scene's own, which a job takes by default).
  let cameraSet = false, sunSet = false, sun = null;
  const pageSettings = {}; // field -> {job: its name in a job's settings, value}
  const inputTime = new Map(); // seq -> performance.now() of the input event
  let shownSeq = 0;
  let drawnIndex = 0; // newest frame drawn (decodes may finish out of order)
  let received = []; // [time, bytes] of the last second, for bytes_per_s
  let decoder = null;

  function send(obj) {
    if (ws && ws.readyState === WebSocket.OPEN) ws.send(JSON.stringify(obj));
  }

  function authHeaders() {
    return token ? { Authorization: "Bearer " + token } : {};
  }

  // ---- vectors and the camera --------------------------------------------------------
  const sub = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
  const add = (a, b) => [a[0] + b[0], a[1] + b[1], a[2] + b[2]];
  const scale = (a, s) => [a[0] * s, a[1] * s, a[2] * s];
  const len = (a) => Math.hypot(a[0], a[1], a[2]);
  const norm = (a) => scale(a, 1 / (len(a) || 1));
  const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];

  // The renderer's camera looks from eye at target with up +y (settings camera_eye,
  // camera_target, camera_fov_degrees); orbit turns the eye about the target.
  function sendCamera() {
    cameraSet = true;
    view.seq += 1;
    const t = performance.now();
    inputTime.set(view.seq, t);
    if (inputTime.size > 256) inputTime.delete(inputTime.keys().next().value);
    send({ seq: view.seq, t: t, camera: { eye: camera.eye, target: camera.target, fov: camera.fov } });
  }

  function orbit(dx, dy) {
    const off = sub(camera.eye, camera.target);
    const r = len(off);
    let yaw = Math.atan2(off[0], off[2]);
    let pitch = Math.asin(Math.max(-1, Math.min(1, off[1] / r)));
    yaw -= dx * 0.008;
    pitch = Math.max(-1.5, Math.min(1.5, pitch + dy * 0.008));
    camera.eye = add(camera.target, [r * Math.cos(pitch) * Math.sin(yaw), r * Math.sin(pitch),
      r * Math.cos(pitch) * Math.cos(yaw)]);
  }

  function basis() {
    const fwd = norm(sub(camera.target, camera.eye));
    let right = cross(fwd, [0, 1, 0]);
    right = len(right) < 1e-6 ? [1, 0, 0] : norm(right);
    return { fwd: fwd, right: right, up: cross(right, fwd) };
  }

  function pan(dx, dy) {
    const b = basis();
    const dist = len(sub(camera.target, camera.eye));
    const k = dist * Math.tan((camera.fov * Math.PI) / 360) * 2 / canvas.clientHeight;
    const move = add(scale(b.right, -dx * k), scale(b.up, dy * k));
    camera.eye = add(camera.eye, move);
    camera.target = add(camera.target, move);
  }

  function zoom(delta) {
    const off = sub(camera.eye, camera.target);
    const f = Math.exp(delta * 0.001);
    const r = Math.max(1e-3, len(off) * f);
    camera.eye = add(camera.target, scale(norm(off), r));
  }

  function walk(forward, sideways) {
    const b = basis();
    const step = len(sub(camera.target, camera.eye)) * 0.05;
    const move = add(scale(b.fwd, forward * step), scale(b.right, sideways * step));
    camera.eye = add(camera.eye, move);
    camera.target = add(camera.target, move);
  }

  // ---- input -------------------------------------------------------------------------
  let drag = null;
  canvas.addEventListener("contextmenu", (e) => e.preventDefault());
  canvas.addEventListener("pointerdown", (e) => {
    if (!camera) return;
    canvas.setPointerCapture(e.pointerId);
    canvas.classList.add("dragging");
    drag = { x: e.clientX, y: e.clientY, pan: e.shiftKey || e.button === 2 || e.button === 1 };
    canvas.focus();
  });
  canvas.addEventListener("pointermove", (e) => {
    if (!drag) return;
    const dx = e.clientX - drag.x, dy = e.clientY - drag.y;
    if (!dx && !dy) return;
    drag.x = e.clientX;
    drag.y = e.clientY;
    if (drag.pan) pan(dx, dy);
    else orbit(dx, dy);
    sendCamera();
  });
  const endDrag = () => {
    drag = null;
    canvas.classList.remove("dragging");
  };
  canvas.addEventListener("pointerup", endDrag);
  canvas.addEventListener("pointercancel", endDrag);
  canvas.addEventListener("wheel", (e) => {
    if (!camera) return;
    e.preventDefault();
    zoom(e.deltaY);
    sendCamera();
  }, { passive: false });
  const KEYS = { KeyW: [1, 0], ArrowUp: [1, 0], KeyS: [-1, 0], ArrowDown: [-1, 0],
    KeyA: [0, -1], ArrowLeft: [0, -1], KeyD: [0, 1], ArrowRight: [0, 1] };
  // Anywhere on the page but in a control (whose own keys move sliders).
  document.addEventListener("keydown", (e) => {
    const k = KEYS[e.code];
    if (!k || !camera || e.target.closest("input, button, select, textarea")) return;
    e.preventDefault();
    walk(k[0], k[1]);
    sendCamera();
  });

  // ---- sun and settings ----------------------------------------------------------------
  const azimuth = document.getElementById("sun-azimuth");
  const elevation = document.getElementById("sun-elevation");

  function showValue(input) {
    const out = input.parentElement.querySelector("output");
    const v = Number(input.value);
    if (out) out.textContent = Number.isInteger(v) ? String(v) : v.toPrecision(3);
  }

  function sunFromSliders() {
    const az = (azimuth.value * Math.PI) / 180, el = (elevation.value * Math.PI) / 180;
    return [Math.cos(el) * Math.sin(az), Math.sin(el), Math.cos(el) * Math.cos(az)];
  }

  function setSunSliders(sun) {
    const s = norm(sun);
    azimuth.value = Math.round((Math.atan2(s[0], s[2]) * 180) / Math.PI);
    elevation.value = Math.max(1, Math.round((Math.asin(s[1]) * 180) / Math.PI));
    showValue(azimuth);
    showValue(elevation);
  }

  for (const input of [azimuth, elevation]) {
    input.addEventListener("input", () => {
      showValue(input);
      sunSet = true;
      sun = sunFromSliders();
      view.seq += 1;
      inputTime.set(view.seq, performance.now());
      send({ seq: view.seq, t: performance.now(), sun: sun });
    });
  }

  // One control per setting of hello.settings (name, range, kind from the renderer's table).
  function buildSettings(settings) {
    const box = document.getElementById("settings");
    box.querySelectorAll("label").forEach((l) => l.remove());
    for (const [field, s] of Object.entries(settings)) {
      const label = document.createElement("label");
      const input = document.createElement("input");
      input.id = "setting-" + field;
      label.append(s.name + (s.unit && s.unit !== "pixels" ? " (" + s.unit + ")" : "") + " ");
      if (s.kind === "on_off") {
        label.className = "check";
        input.type = "checkbox";
        input.checked = s.value;
      } else {
        input.type = "range";
        input.min = s.min;
        input.max = s.max;
        input.step = s.kind === "whole" ? 1 : "any";
        input.value = s.value;
      }
      label.append(input);
      if (s.kind !== "on_off") label.append(document.createElement("output"));
      box.append(label);
      showValue(input);
      pageSettings[field] = { job: s.job, value: s.value };
      input.addEventListener(s.kind === "on_off" ? "change" : "input", () => {
        let v = s.kind === "on_off" ? input.checked : Number(input.value);
        if (s.pow2 && v > 0) v = Math.pow(2, Math.round(Math.log2(v)));
        if (s.kind !== "on_off") {
          input.value = v;
          showValue(input);
        }
        pageSettings[field].value = v;
        view.seq += 1;
        inputTime.set(view.seq, performance.now());
        send({ seq: view.seq, t: performance.now(), settings: { [field]: v } });
      });
    }
  }

  // ---- frames ------------------------------------------------------------------------
  function linkRate(now, bytes) {
    received.push([now, bytes]);
    while (received.length && now - received[0][0] > 1000) received.shift();
    const span = Math.max(250, now - received[0][0]);
    return (received.reduce((a, r) => a + r[1], 0) * 1000) / span;
  }

  // A frame is on the canvas: its credit back, and motion-to-photon of a newer input.
  function displayed(h, bytesPerS) {
    view.frames += 1;
    view.lastIndex = h.index;
    view.lastInputSeq = h.inputSeq;
    view.lastAccumulated = h.accumulated;
    view.lastCodec = h.codec;
    const msg = { ack: h.index, bytes_per_s: Math.round(bytesPerS) };
    if (h.inputSeq > shownSeq) {
      shownSeq = h.inputSeq;
      const t0 = inputTime.get(h.inputSeq);
      if (t0 !== undefined) {
        view.m2p = performance.now() - t0;
        view.m2pMax = Math.max(view.m2pMax, view.m2p);
        msg.shown = h.inputSeq;
        msg.m2p = Math.round(view.m2p * 10) / 10;
      }
    }
    send(msg);
  }

  function draw(image, h, bytesPerS) {
    if (h.index <= drawnIndex) return; // a newer frame is already up
    drawnIndex = h.index;
    if (canvas.width !== h.width || canvas.height !== h.height) {
      canvas.width = h.width;
      canvas.height = h.height;
    }
    ctx.drawImage(image, 0, 0);
    displayed(h, bytesPerS);
  }

  function parseHeader(buf) {
    const d = new DataView(buf);
    if (buf.byteLength < HEADER_BYTES || d.getUint32(0, true) !== MAGIC) return null;
    const size = d.getUint16(6, true);
    return {
      codec: d.getUint8(4), keyframe: d.getUint8(5) === 1, headerBytes: size,
      index: Number(d.getBigUint64(8, true)), inputSeq: Number(d.getBigUint64(16, true)),
      width: d.getUint32(24, true), height: d.getUint32(28, true), accumulated: d.getUint32(32, true),
      serverMs: d.getFloat32(36, true), encodeMs: d.getFloat32(40, true),
    };
  }

  function h264Decoder() {
    const pending = new Map(); // timestamp (frame index) -> [header, bytes/s]
    const dec = new VideoDecoder({
      output: (frame) => {
        const p = pending.get(frame.timestamp);
        pending.delete(frame.timestamp);
        if (p) draw(frame, p[0], p[1]);
        frame.close();
      },
      error: (e) => {
        fail("H.264 decoder: " + e.message);
        decoder = null;
        send({ keyframe: true });
      },
    });
    // Constrained baseline, level 3.1; Annex B NAL units (no description).
    dec.configure({ codec: "avc1.42E01F", optimizeForLatency: true });
    return { dec: dec, pending: pending, started: false };
  }

  function onFrame(buf) {
    const h = parseHeader(buf);
    if (!h) return fail("a binary message without the frame header");
    const now = performance.now();
    const rate = linkRate(now, buf.byteLength);
    const payload = new Uint8Array(buf, h.headerBytes);
    if (h.codec === CODEC_JPEG) {
      view.decoder = "createImageBitmap";
      createImageBitmap(new Blob([payload], { type: "image/jpeg" }),
        { colorSpaceConversion: "none", premultiplyAlpha: "none" })
        .then((bmp) => { draw(bmp, h, rate); bmp.close(); })
        .catch((e) => fail("JPEG frame " + h.index + ": " + e.message));
    } else if (h.codec === CODEC_H264) {
      if (!decoder) decoder = h264Decoder();
      view.decoder = "VideoDecoder";
      if (!decoder.started && !h.keyframe) {
        send({ ack: h.index }); // nothing to show before a keyframe: the credit goes back
        return;
      }
      decoder.started = true;
      decoder.pending.set(h.index, [h, rate]);
      decoder.dec.decode(new EncodedVideoChunk({ type: h.keyframe ? "key" : "delta", timestamp: h.index,
        data: payload }));
    }
  }

  // ---- messages ----------------------------------------------------------------------
  function fail(text) {
    view.errors.push(text);
    if (view.errors.length > 20) view.errors.shift();
    errorEl.textContent = text;
  }

  function onHello(m) {
    view.hello = m;
    camera = { eye: m.camera.eye, target: m.camera.target, fov: m.camera.fov };
    view.camera = camera;
    canvas.width = m.width;
    canvas.height = m.height;
    setSunSliders(m.sun);
    cameraSet = m.camera_set;
    sunSet = m.sun_set;
    sun = m.sun;
    buildSettings(m.settings);
    jobDefaults(m);
    if (m.codec === "h264" && typeof VideoDecoder === "undefined") {
      fail("this browser has no WebCodecs VideoDecoder: asking for JPEG frames");
      send({ codec: "jpeg" });
    }
  }

  function showStats(s) {
    view.stats = s;
    const kb = (x) => (x / 1024).toFixed(1);
    const lines = [
      `fps ${s.fps.toFixed(1)}   ${s.codec} ${s.width}x${s.height}   accumulated ${s.accumulated}`,
      `render ${s.render_ms.toFixed(1)} ms  read ${s.read_ms.toFixed(1)} ms  encode ${s.encode_ms.toFixed(1)} ms`,
    ];
    for (const p of s.passes) lines.push(`  ${p.pass.padEnd(12)} ${p.device.padEnd(10)} ${p.ms.toFixed(2)} ms`);
    lines.push(`link ${kb(s.sent_bytes_per_s)} KiB/s sent, ${kb(s.received_bytes_per_s)} received, ` +
      `${kb(s.link_bytes_per_s)} estimated`);
    lines.push(`motion-to-photon ${view.m2p.toFixed(1)} ms (max ${view.m2pMax.toFixed(1)}; server ${s.input_age_ms.toFixed(1)} ms)`);
    lines.push(`spoiled ${s.spoiled}  replaced ${s.replaced}  ` +
      (s.codec === "h264" ? `bitrate ${s.bitrate_kbps} kbit/s` : `quality ${s.quality}`));
    if (s.error) lines.push("error: " + s.error);
    statsEl.textContent = lines.join("\n");
    // The live ended (a node died): said where it is seen, once.
    if (s.error && errorEl.textContent !== s.error) fail(s.error);
  }

  function onText(text) {
    let m;
    try { m = JSON.parse(text); } catch (e) { return fail("server sent bad JSON"); }
    if (m.type === "hello") onHello(m);
    else if (m.type === "stats") showStats(m);
    else if (m.type === "error") fail(m.error);
  }

  function connect() {
    const scheme = location.protocol === "https:" ? "wss://" : "ws://";
    ws = new WebSocket(scheme + location.host + "/ws" + (token ? "?token=" + encodeURIComponent(token) : ""));
    ws.binaryType = "arraybuffer";
    ws.onopen = () => { view.connected = true; errorEl.textContent = ""; };
    ws.onmessage = (e) => (typeof e.data === "string" ? onText(e.data) : onFrame(e.data));
    ws.onclose = () => {
      view.connected = false;
      statsEl.textContent = "disconnected: reconnecting...";
      if (decoder) { try { decoder.dec.close(); } catch (e) { /* already closed */ } decoder = null; }
      drawnIndex = 0;
      setTimeout(connect, 1000);
    };
  }

  // ---- saving ------------------------------------------------------------------------
  // The API's error message ({"error"}) of a refused request, else its status.
  async function apiError(r) {
    try { return (await r.json()).error || r.statusText; } catch (e) { return r.status + " " + r.statusText; }
  }

  // A file of the API saved through a link (the token goes in a header, which a plain link cannot send).
  async function download(path, name) {
    const r = await fetch(path, { headers: authHeaders() });
    if (!r.ok) throw new Error(await apiError(r));
    const url = URL.createObjectURL(await r.blob());
    const a = document.createElement("a");
    a.href = url;
    a.download = name;
    document.body.append(a);
    a.click();
    a.remove();
    setTimeout(() => URL.revokeObjectURL(url), 10000);
  }

  async function save(ext) {
    try {
      await download("api/v1/view/snapshot." + ext, "corvid-view." + ext);
      view.saved = (view.saved || 0) + 1;
    } catch (e) {
      fail("Save " + ext.toUpperCase() + ": " + e.message);
    }
  }
  document.getElementById("save-png").addEventListener("click", () => save("png"));
  document.getElementById("save-exr").addEventListener("click", () => save("exr"));

  // ---- the render job panel -------------------------------------------------------------
  const job = {
    frames: document.getElementById("job-frames"), width: document.getElementById("job-width"),
    height: document.getElementById("job-height"), start: document.getElementById("job-start"),
    cancel: document.getElementById("job-cancel"), progress: document.getElementById("job-progress"),
    state: document.getElementById("job-state"), error: document.getElementById("job-error"),
    result: document.getElementById("job-result"), image: document.getElementById("job-image"),
    png: document.getElementById("job-png"), exr: document.getElementById("job-exr"),
  };
  let jobId = 0, jobPoll = null, jobImageUrl = null;

  // The size fields start at the view's size; the scene is the view's, as the gateway knows it.
  async function jobDefaults(hello) {
    if (!job.width.value) job.width.value = hello.width;
    if (!job.height.value) job.height.value = hello.height;
    try {
      const r = await fetch("api/v1/view", { headers: authHeaders() });
      if (!r.ok) throw new Error(await apiError(r));
      const v = await r.json();
      view.jobScene = v.scene;
      job.start.disabled = !v.scene;
      if (!v.scene) job.state.textContent = "no jobs of this scene: " + v.note;
    } catch (e) {
      job.error.textContent = "job: " + e.message;
    }
  }

  // The job of what the page shows, as the live view renders it: the page's settings, and its
  // camera and sun where the view has them set (else the scene's own, as in the view).
  function jobRequest() {
    const number = (input) => (input.value.trim() === "" ? input.value : Number(input.value));
    const body = { scene: view.jobScene, width: number(job.width), height: number(job.height),
      frames: number(job.frames), settings: {} };
    if (cameraSet) body.camera = { eye: camera.eye, target: camera.target, fov_degrees: camera.fov };
    for (const [field, p] of Object.entries(pageSettings))
      if (field !== "sun_cone_degrees") body.settings[p.job] = p.value;
    // "sun" is the direction and the cone together: only with a set direction.
    const cone = pageSettings.sun_cone_degrees;
    if (sunSet && cone) body.settings.sun = sun.concat([cone.value]).join(",");
    return body;
  }

  function jobShow(j) {
    view.job = j;
    job.progress.max = j.frames || 1;
    job.progress.value = j.frames_done || 0;
    job.state.textContent = `job ${j.id}: ${j.state}${j.cancelling ? " (cancelling)" : ""}, ` +
      `${j.frames_done} of ${j.frames} frames`;
    if (j.error) job.error.textContent = `job ${j.id}: ${j.error}`;
    const ended = ["done", "failed", "cancelled"].includes(j.state);
    job.cancel.disabled = ended;
    job.start.disabled = !ended;
    return ended;
  }

  async function jobResult(j) {
    const r = await fetch(j.png, { headers: authHeaders() });
    if (!r.ok) throw new Error(await apiError(r));
    if (jobImageUrl) URL.revokeObjectURL(jobImageUrl);
    jobImageUrl = URL.createObjectURL(await r.blob());
    job.image.onload = () => { view.jobImageLoaded = j.id; };
    job.image.src = jobImageUrl;
    job.png.href = j.png.replace(/^\//, "");
    job.exr.href = j.exr.replace(/^\//, "");
    job.png.download = `corvid-job-${j.id}.png`;
    job.exr.download = `corvid-job-${j.id}.exr`;
    job.result.hidden = false;
  }

  async function jobFollow(id) {
    try {
      const r = await fetch("api/v1/jobs/" + id, { headers: authHeaders() });
      if (!r.ok) throw new Error(await apiError(r));
      const j = await r.json();
      if (id !== jobId) return; // a newer job took the panel
      if (!jobShow(j)) {
        jobPoll = setTimeout(() => jobFollow(id), 250);
        return;
      }
      if (j.state === "done") await jobResult(j);
    } catch (e) {
      job.error.textContent = `job ${id}: ${e.message}`;
      job.start.disabled = false;
    }
  }

  job.start.addEventListener("click", async () => {
    clearTimeout(jobPoll);
    job.error.textContent = "";
    job.result.hidden = true;
    view.jobImageLoaded = 0;
    const body = jobRequest();
    view.jobRequest = body;
    try {
      const r = await fetch("api/v1/jobs", { method: "POST", body: JSON.stringify(body),
        headers: Object.assign({ "Content-Type": "application/json" }, authHeaders()) });
      if (!r.ok) throw new Error(await apiError(r));
      jobId = (await r.json()).id;
      job.start.disabled = true;
      job.cancel.disabled = false;
      jobFollow(jobId);
    } catch (e) {
      job.error.textContent = "Start job: " + e.message;
      job.state.textContent = "";
    }
  });

  job.cancel.addEventListener("click", async () => {
    try {
      const r = await fetch("api/v1/jobs/" + jobId, { method: "DELETE", headers: authHeaders() });
      if (!r.ok) throw new Error(await apiError(r));
      jobShow(await r.json());
    } catch (e) {
      job.error.textContent = `Cancel job ${jobId}: ${e.message}`;
    }
  });

  for (const [link, ext] of [[job.png, "png"], [job.exr, "exr"]]) {
    link.addEventListener("click", (e) => {
      if (!token) return; // the plain link works
      e.preventDefault();
      download(link.getAttribute("href"), link.download).catch((err) => {
        job.error.textContent = `image.${ext}: ${err.message}`;
      });
    });
  }

  connect();
})();
