// kata coach --webcam: the camera, MediaPipe Pose (in this page, WebAssembly), landmarks to kata
// over HTTP on localhost, results back as server-sent events, drawn over the video.
// Test hooks: window.kata.webcam (state, states seen, counts, scores, latency, errors).
"use strict";

const MAGIC = 0x3143574b;  // "KWC1": the frame format of sdk/tools/coach/webcam.hpp
const LANDMARKS = 33;
const PARTS = ["torso/head", "left arm", "right arm", "left leg", "right leg"];
// MediaPipe's landmark connections, each with the body part it belongs to (metric/parts.hpp).
const BONES = [
  [11, 12, 0], [11, 23, 0], [12, 24, 0], [23, 24, 0], [0, 7, 0], [0, 8, 0], [9, 10, 0],
  [11, 13, 1], [13, 15, 1], [15, 17, 1], [15, 19, 1], [15, 21, 1], [17, 19, 1],
  [12, 14, 2], [14, 16, 2], [16, 18, 2], [16, 20, 2], [16, 22, 2], [18, 20, 2],
  [23, 25, 3], [25, 27, 3], [27, 29, 3], [29, 31, 3], [27, 31, 3],
  [24, 26, 4], [26, 28, 4], [28, 30, 4], [30, 32, 4], [28, 32, 4],
];
const GPD_PARENTS = [-1, 0, 1, 2, 2, 4, 5, 2, 7, 8, 0, 10, 11, 0, 13, 14];

const hook = {
  state: "starting", states: [], framesSent: 0, personFrames: 0, results: 0, scored: 0,
  scores: [], events: [], lastResult: null, latency: {}, errors: [], complexity: 0, reps: [],
};
window.kata = Object.assign(window.kata || {}, { webcam: hook });

const canvas = document.getElementById("view");
const g = canvas.getContext("2d");
const video = document.getElementById("video");
const params = new URLSearchParams(location.search);
const select = document.getElementById("complexity");

function setState(s) {
  if (hook.state === s) return;
  hook.state = s;
  if (hook.states[hook.states.length - 1] !== s) hook.states.push(s);
  document.getElementById("state").textContent = s;
}

function scoreColour(score) {  // the viewer's and the report's map: red (0) -> amber (50) -> green (100)
  const s = Math.max(0, Math.min(1, score / 100));
  const r = s < 0.5 ? 220 : Math.round(220 - (s - 0.5) * 2 * 180);
  const gr = s < 0.5 ? Math.round(60 + s * 2 * 140) : 200;
  return `rgb(${r},${gr},60)`;
}

// ---- the clock offset (kata's steady clock - this page's performance.now()), from the POST
// round trips: the sample with the shortest round trip wins (error <= half of it).
let offset = 0, bestRtt = Infinity;
const sent = new Map();  // seq -> {capture, landmarks}
const samples = { "capture->landmarks": [], "landmarks->received": [], "received->result": [],
                  "result->drawn": [], "capture->drawn": [] };

function percentile(a, q) {
  if (!a.length) return 0;
  const s = a.slice().sort((x, y) => x - y);
  return s[Math.min(s.length - 1, Math.floor(q * (s.length - 1)))];
}

function latencySummary() {
  const stages = {};
  for (const [k, v] of Object.entries(samples)) stages[k] = [+percentile(v, 0.5).toFixed(2), +percentile(v, 0.95).toFixed(2)];
  return { frames: samples["capture->drawn"].length, stages };
}

function showLatency() {
  const t = document.getElementById("latency");
  const sum = latencySummary();
  hook.latency = sum;
  t.innerHTML = "<tr><th>latency (ms)</th><th>p50</th><th>p95</th></tr>" +
    Object.entries(sum.stages).map(([k, [a, b]]) => `<tr><td>${k}</td><td>${a.toFixed(1)}</td><td>${b.toFixed(1)}</td></tr>`).join("");
}

setInterval(() => {
  if (!samples["capture->drawn"].length) return;
  fetch("webcam/latency", { method: "POST", headers: { "Content-Type": "application/json" },
                            body: JSON.stringify(latencySummary()) }).catch(() => {});
}, 2000);

// ---- frames to kata
// A page reloaded into a running lesson continues kata's stream (setup: next_seq and
// last_capture_ms): numbered after kata's frames, its capture times shifted past the last one.
let seq = 0, clockShift = 0, chain = Promise.resolve();
function sendFrame(world, captureMs, landmarksMs) {
  const n = world ? LANDMARKS : 0;
  const buf = new ArrayBuffer(48 + 16 * n);
  const v = new DataView(buf);
  v.setUint32(0, MAGIC, true);
  v.setUint32(4, n, true);
  const s = seq++;
  v.setFloat64(8, s, true);
  v.setFloat64(16, captureMs + clockShift, true);
  v.setFloat64(24, landmarksMs + clockShift, true);
  for (let j = 0; j < n; ++j) {
    const p = world[j];
    v.setFloat32(48 + 16 * j, p.x, true);
    v.setFloat32(52 + 16 * j, p.y, true);
    v.setFloat32(56 + 16 * j, p.z, true);
    v.setFloat32(60 + 16 * j, p.visibility === undefined ? 1 : p.visibility, true);
  }
  sent.set(s, { capture: captureMs, landmarks: landmarksMs });
  if (sent.size > 600) sent.delete(sent.keys().next().value);
  // In order: kata's stream wants increasing capture times, so each POST waits for the previous.
  chain = chain.then(async () => {
    const t0 = performance.now();
    const r = await fetch("webcam/frame", { method: "POST", body: buf, headers: { "Content-Type": "application/octet-stream" } });
    const t1 = performance.now();
    if (!r.ok) { hook.errors.push("frame " + s + ": HTTP " + r.status); return; }
    const ack = await r.json();
    if (t1 - t0 < bestRtt) { bestRtt = t1 - t0; offset = ack.server_ms - (t0 + t1) / 2; }
    hook.framesSent++;
  }).catch((e) => { hook.errors.push(String(e)); });
}

// ---- results from kata
let setup = null, newest = null, undrawn = [];
function onResult(e) {
  const r = JSON.parse(e.data);
  hook.results++;
  hook.lastResult = r;
  hook.events.push({ seq: r.seq, state: r.state, score: r.score, capture_ms: r.capture_ms, time: r.time, ghost: !!r.ghost });
  if (hook.events.length > 5000) hook.events.shift();
  if (r.score !== undefined) {
    hook.scored++;
    hook.scores.push({ seq: r.seq, score: r.score, state: r.state });
    if (hook.scores.length > 5000) hook.scores.shift();
  }
  // The newest word wins; "not in frame" is also said here at once (below), from MediaPipe.
  if (!newest || r.seq >= newest.seq) newest = r;
  if (resultWaiter && r.seq >= resultWaiter.seq) resultWaiter.done();
  const s = sent.get(r.seq);
  if (s && r.result_ms !== undefined) undrawn.push({ r, s });
  dirty = true;
  if (r.state !== "not in frame" || !hook.personFrames) setState(r.state === "tracking" ? "scored" : r.state);
  // The repetition counter (docs/coach/repetitions.md): the one in progress and how far through the
  // teacher's section; the newest one's tempo, score and depth. hook.reps keeps every one sent.
  if (r.reps) hook.reps.push(...r.reps);
  if (r.rep) {
    const last = hook.reps[hook.reps.length - 1];
    document.getElementById("reps").textContent = `repetition ${r.rep} (${Math.round(100 * r.rep_progress)}%)` +
      (last ? ` - last: ${last.partial ? "partial, " : ""}tempo ${last.tempo.toFixed(2)}, score ${Math.round(last.score)}, ` +
              `depth ${Math.round(last.depth)} of ${Math.round(last.teacher_depth)} deg` : "");
  }
  if (r.score !== undefined) {
    document.getElementById("score").textContent = Math.round(r.score);
    // The part to fix and the correction cue ("left knee: bend 30 deg more").
    document.getElementById("fix").textContent = r.fix ? "fix: " + r.fix.replace("_", " ") + (r.cue ? " - " + r.cue : "") : "looking good";
    document.getElementById("parts").innerHTML = r.parts.map((p, i) =>
      `<div class="part" style="background:${scoreColour(p)}"><span>${PARTS[i]}</span><span>${Math.round(p)}</span></div>`).join("");
  }
  paint();
}

function connectEvents() {
  const es = new EventSource("webcam/events");
  es.addEventListener("result", onResult);
  es.onerror = () => {};  // EventSource reconnects by itself
}

// ---- drawing: the video, the student in part colours, the ghost projected over the video
let last = null;  // {image, landmarks, world}
function fitProjection(world, image) {
  // image (pixels) ~= a * world (x, y) + b over the visible landmarks (least squares, one scale).
  const pts = [];
  for (let j = 0; j < LANDMARKS; ++j)
    if ((world[j].visibility === undefined || world[j].visibility > 0.5))
      pts.push([world[j].x, world[j].y, image[j].x * canvas.width, image[j].y * canvas.height]);
  if (pts.length < 4) return null;
  const m = pts.reduce((s, p) => s.map((v, i) => v + p[i] / pts.length), [0, 0, 0, 0]);
  let num = 0, den = 0;
  for (const p of pts) {
    num += (p[0] - m[0]) * (p[2] - m[2]) + (p[1] - m[1]) * (p[3] - m[3]);
    den += (p[0] - m[0]) ** 2 + (p[1] - m[1]) ** 2;
  }
  if (!(den > 0)) return null;
  const a = num / den;
  return { a, bx: m[2] - a * m[0], by: m[3] - a * m[1] };
}

// The video element shows the camera; this canvas over it is redrawn when something new is there
// to show (a camera frame's landmarks, a result). (A hidden video element stalls MediaPipe's
// texture upload in headless Chromium: the video stays on screen.)
let dirty = false;
function draw() {
  requestAnimationFrame(draw);
  paint();
}
// Also called as a result arrives: on a slow machine the next animation frame may wait for the
// next MediaPipe run (a second without a GPU), and "result -> drawn" would measure that wait.
function paint() {
  if (!last || !dirty) return;
  dirty = false;
  g.clearRect(0, 0, canvas.width, canvas.height);
  const parts = newest && newest.parts ? newest.parts : null;
  if (last.landmarks) {
    g.lineWidth = 5;
    for (const [i, j, part] of BONES) {
      const p = last.landmarks[i], q = last.landmarks[j];
      g.strokeStyle = parts ? scoreColour(parts[part]) : "rgb(120,170,255)";
      g.beginPath();
      g.moveTo(p.x * canvas.width, p.y * canvas.height);
      g.lineTo(q.x * canvas.width, q.y * canvas.height);
      g.stroke();
    }
    const proj = newest && newest.ghost && last.world ? fitProjection(last.world, last.landmarks) : null;
    if (proj) {
      g.lineWidth = 3;
      g.strokeStyle = "rgba(255,255,255,0.85)";
      const gh = newest.ghost;
      for (let k = 1; k < 16; ++k) {
        const pk = GPD_PARENTS[k];
        g.beginPath();
        g.moveTo(proj.a * gh[3 * pk] + proj.bx, proj.a * gh[3 * pk + 1] + proj.by);
        g.lineTo(proj.a * gh[3 * k] + proj.bx, proj.a * gh[3 * k + 1] + proj.by);
        g.stroke();
      }
    }
  }
  g.fillStyle = "rgba(0,0,0,0.55)";
  g.fillRect(0, 0, 260, 34);
  g.fillStyle = "#fff";
  g.font = "20px sans-serif";
  g.fillText(hook.state + (hook.state === "scored" && newest && newest.score !== undefined ? " " + Math.round(newest.score) : ""), 8, 24);
  const now = performance.now();
  for (const { r, s } of undrawn) {
    samples["capture->landmarks"].push(s.landmarks - s.capture);
    samples["landmarks->received"].push(r.received_ms - offset - s.landmarks);
    samples["received->result"].push(r.result_ms - r.received_ms);
    samples["result->drawn"].push(now - (r.result_ms - offset));
    samples["capture->drawn"].push(now - s.capture);
    for (const k in samples) if (samples[k].length > 3000) samples[k].shift();
  }
  if (undrawn.length) { undrawn = []; showLatency(); }
}

// ---- the camera and MediaPipe
async function main() {
  setup = await (await fetch("webcam/setup")).json();
  hook.mode = setup.mode;
  seq = setup.next_seq || 0;
  if (setup.last_capture_ms >= 0) clockShift = Math.max(0, setup.last_capture_ms + 1 - performance.now());
  const complexity = Number(params.get("complexity") ?? setup.complexity ?? 0);
  hook.complexity = complexity;
  select.value = String(complexity);
  select.onchange = () => { params.set("complexity", select.value); location.search = params.toString(); };
  setState("waiting for the camera");
  const stream = await navigator.mediaDevices.getUserMedia({ video: true, audio: false });
  video.srcObject = stream;
  await video.play();
  canvas.width = video.videoWidth || 640;
  canvas.height = video.videoHeight || 480;
  video.width = canvas.width;
  video.height = canvas.height;
  setState("loading MediaPipe");
  const pose = new Pose({ locateFile: (f) => "vendor/mediapipe/pose/" + f });
  pose.setOptions({ modelComplexity: complexity, smoothLandmarks: true, enableSegmentation: false });
  let pending = null;
  pose.onResults((r) => {
    const landmarksMs = performance.now();
    const world = r.poseWorldLandmarks && r.poseWorldLandmarks.length === LANDMARKS ? r.poseWorldLandmarks : null;
    last = { landmarks: world ? r.poseLandmarks : null, world };
    dirty = true;
    if (world) {
      hook.personFrames++;
      if (hook.state === "loading MediaPipe" || hook.state === "not in frame")
        setState(setup.mode === "record-teacher" ? "recording" : "calibrating");
    } else {
      setState("not in frame");
    }
    sendFrame(world, pending, landmarksMs);
  });
  await pose.initialize();
  connectEvents();
  requestAnimationFrame(draw);
  let lastTime = -1;
  for (;;) {
    if (video.readyState >= 2 && video.currentTime !== lastTime) {
      lastTime = video.currentTime;
      pending = performance.now();  // the frame is grabbed now (capture time on this page's clock)
      await pose.send({ image: video });
      await resultOf(seq - 1);
      // pose.send's promise settles through microtasks only, so `await pose.send` in a loop never
      // returns to the event loop: no fetch answer, server-sent event, drawing or WebDriver call
      // would run again (the page froze after its first frame where MediaPipe is slow: headless,
      // no GPU). Let every waiting task run before the next camera frame.
      await yieldToTasks();
    } else {
      await new Promise((ok) => setTimeout(ok, 5));
    }
  }
}

// Waits (at most RESULT_WAIT_MS) for kata's answer to frame `s`, so that it is drawn before the
// next MediaPipe run takes the main thread (without a GPU that run is a second: "result -> drawn"
// was that second). The answer takes a few ms on localhost; during calibration none comes.
const RESULT_WAIT_MS = 100;
let resultWaiter = null;
function resultOf(s) {
  if (s < 0 || (newest && newest.seq >= s)) return Promise.resolve();
  return new Promise((ok) => {
    const timer = setTimeout(() => { resultWaiter = null; ok(); }, RESULT_WAIT_MS);
    resultWaiter = { seq: s, done: () => { clearTimeout(timer); resultWaiter = null; ok(); } };
  });
}

// Resolves once the tasks waiting now have run: a background-priority task runs after them
// (Chromium's scheduler.postTask); elsewhere a timer, which at least lets one task in.
function yieldToTasks() {
  if (window.scheduler && typeof scheduler.postTask === "function")
    return scheduler.postTask(() => {}, { priority: "background" });
  return new Promise((ok) => setTimeout(ok, 0));
}

main().catch((e) => {
  hook.errors.push(String(e && e.stack || e));
  setState("error: " + (e && e.message || e));
  console.error("kata webcam:", e);
});
