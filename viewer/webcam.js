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
  people: 1,  // --people N; with N > 1 also: persons (by kata's person id), frames, cost (below)
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
  if (hook.people > 1) return onPeopleResult(r);
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
  if ((!last && !lastPeople) || !dirty) return;
  dirty = false;
  g.clearRect(0, 0, canvas.width, canvas.height);
  const parts = newest && newest.parts ? newest.parts : null;
  if (hook.people > 1) {
    drawPeople();
  } else if (last.landmarks) {
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

// ---- several people (kata coach --webcam --people N): MoveNet MultiPose finds the people and
// their boxes in the camera frame, MediaPipe Pose then runs on each person's crop (as MediaPipe's
// own multi-person graph: a detector, then a landmarker per region), the crop's landmarks mapped
// back onto the frame. Every pose of a frame goes to kata unnamed ("KWP1"); kata's people tracker
// says who each is (the POST's answer) and each person's results come on their own stream.
const PEOPLE_MAGIC = 0x3150574b;  // "KWP1": sdk/tools/coach/webcam.hpp
const MOVENET_SIZE = 256;         // the model's input: the frame letterboxed to 256 x 256
const MOVENET_MIN_SCORE = 0.25;   // a person's score below this is not a person
const CROP = 256;                 // each person's square crop, as MediaPipe's landmarker sees it
const PERSON_COLOURS = ["#e17055", "#0984e3", "#00b894", "#fdcb6e", "#6c5ce7", "#e84393"];
const personColour = (id) => PERSON_COLOURS[(id - 1) % PERSON_COLOURS.length];
const persons = {};      // kata's person id -> {newest result, scored, ...} (also hook.persons)
let peopleNewestSeq = -1;
let lastPeople = null;   // the newest frame's poses: {seq, poses: [{landmarks, world}], ids}

function loadScript(src) {
  return new Promise((ok, fail) => {
    const el = document.createElement("script");
    el.src = src;
    el.onload = ok;
    el.onerror = () => fail(new Error("cannot load " + src));
    document.head.appendChild(el);
  });
}

function sendPeopleFrame(poses, captureMs, landmarksMs, frame) {
  const n = poses.length, per = LANDMARKS * 6;
  const buf = new ArrayBuffer(48 + 4 * per * n);
  const v = new DataView(buf);
  v.setUint32(0, PEOPLE_MAGIC, true);
  v.setUint32(4, n, true);
  const s = seq++;
  v.setFloat64(8, s, true);
  v.setFloat64(16, captureMs + clockShift, true);
  v.setFloat64(24, landmarksMs + clockShift, true);
  poses.forEach((p, i) => {
    const at = 48 + 4 * per * i;
    for (let j = 0; j < LANDMARKS; ++j) {
      const w = p.world[j];
      v.setFloat32(at + 16 * j, w.x, true);
      v.setFloat32(at + 16 * j + 4, w.y, true);
      v.setFloat32(at + 16 * j + 8, w.z, true);
      v.setFloat32(at + 16 * j + 12, w.visibility === undefined ? 1 : w.visibility, true);
      // the landmark's place in the camera image, pixels: where the tracker follows the person
      v.setFloat32(at + 16 * LANDMARKS + 8 * j, p.landmarks[j].x * canvas.width, true);
      v.setFloat32(at + 16 * LANDMARKS + 8 * j + 4, p.landmarks[j].y * canvas.height, true);
    }
  });
  frame.seq = s;
  sent.set(s, { capture: captureMs, landmarks: landmarksMs });
  if (sent.size > 600) sent.delete(sent.keys().next().value);
  chain = chain.then(async () => {
    const t0 = performance.now();
    const r = await fetch("webcam/frame", { method: "POST", body: buf, headers: { "Content-Type": "application/octet-stream" } });
    const t1 = performance.now();
    if (!r.ok) { hook.errors.push("frame " + s + ": HTTP " + r.status); return; }
    const ack = await r.json();
    if (t1 - t0 < bestRtt) { bestRtt = t1 - t0; offset = ack.server_ms - (t0 + t1) / 2; }
    hook.framesSent++;
    frame.ids = ack.people;
    // For the test: each pose's person and where its hips are (pixels), per frame.
    hook.frames.push({ seq: s, ids: ack.people, hips: poses.map((p) => [
      (p.landmarks[23].x + p.landmarks[24].x) / 2 * canvas.width, (p.landmarks[23].y + p.landmarks[24].y) / 2 * canvas.height]) });
    if (hook.frames.length > 3000) hook.frames.shift();
    dirty = true;
    paint();
  }).catch((e) => { hook.errors.push(String(e)); });
}

function onPeopleResult(r) {
  hook.results++;
  if (r.person === undefined) {  // "not in frame": nobody this frame
    if (r.state === "not in frame") setState("not in frame");
    return;
  }
  const p = persons[r.person] || (persons[r.person] = { results: 0, scored: 0, scores: [], ghost: false, state: "", newest: null });
  p.results++;
  p.state = r.state;
  if (!p.newest || r.seq >= p.newest.seq) p.newest = r;
  if (r.reps) (p.reps || (p.reps = [])).push(...r.reps);
  if (r.score !== undefined) {
    hook.scored++;
    p.scored++;
    p.scores.push({ seq: r.seq, score: r.score, state: r.state });
    if (p.scores.length > 3000) p.scores.shift();
    if (r.ghost) p.ghost = true;
  }
  hook.persons[r.person] = { results: p.results, scored: p.scored, scores: p.scores, ghost: p.ghost, state: p.state,
                             fix: p.newest.fix, cue: p.newest.cue, rep: p.newest.rep, reps: (p.reps || []).length };
  if (r.seq > peopleNewestSeq) peopleNewestSeq = r.seq;
  if (resultWaiter && r.seq >= resultWaiter.seq) resultWaiter.done();
  const s = sent.get(r.seq);
  if (s && r.result_ms !== undefined) undrawn.push({ r, s });
  setState(Object.values(persons).some((q) => q.state === "tracking") ? "scored" : r.state);
  showPeople();
  dirty = true;
  paint();
}

// The side panel: a card per person (their colour and label, score, the part to fix and the cue,
// the part scores, the repetition counter).
function showPeople() {
  document.getElementById("people").innerHTML = Object.entries(persons).map(([id, p]) => {
    const r = p.newest;
    const score = r && r.score !== undefined ? Math.round(r.score) : "-";
    const fix = r && r.score !== undefined ? (r.fix ? "fix: " + r.fix.replace("_", " ") + (r.cue ? " - " + r.cue : "") : "looking good") : r ? r.state : "";
    const rep = r && r.rep ? `<div>repetition ${r.rep} (${Math.round(100 * r.rep_progress)}%)</div>` : "";
    const parts = r && r.parts ? r.parts.map((v, i) =>
      `<div class="part" style="background:${scoreColour(v)}"><span>${PARTS[i]}</span><span>${Math.round(v)}</span></div>`).join("") : "";
    return `<div class="person" data-person="${id}" style="border-left:6px solid ${personColour(+id)}">` +
      `<div class="who" style="color:${personColour(+id)}">person ${id}</div><div class="pscore">${score}</div>` +
      `<div class="pfix">${fix}</div>${rep}${parts}</div>`;
  }).join("");
}

function drawPeople() {
  if (!lastPeople) return;
  const ids = lastPeople.ids || [];
  lastPeople.poses.forEach((pose, i) => {
    const id = ids[i] || 0;
    const newestOf = id && persons[id] ? persons[id].newest : null;
    const parts = newestOf && newestOf.parts ? newestOf.parts : null;
    g.lineWidth = 5;
    for (const [a, b, part] of BONES) {
      const p = pose.landmarks[a], q = pose.landmarks[b];
      g.strokeStyle = parts ? scoreColour(parts[part]) : id ? personColour(id) : "rgb(120,170,255)";
      g.beginPath();
      g.moveTo(p.x * canvas.width, p.y * canvas.height);
      g.lineTo(q.x * canvas.width, q.y * canvas.height);
      g.stroke();
    }
    const proj = newestOf && newestOf.ghost ? fitProjection(pose.world, pose.landmarks) : null;
    if (proj) {
      g.lineWidth = 3;
      g.strokeStyle = "rgba(255,255,255,0.85)";
      const gh = newestOf.ghost;
      for (let k = 1; k < 16; ++k) {
        const pk = GPD_PARENTS[k];
        g.beginPath();
        g.moveTo(proj.a * gh[3 * pk] + proj.bx, proj.a * gh[3 * pk + 1] + proj.by);
        g.lineTo(proj.a * gh[3 * k] + proj.bx, proj.a * gh[3 * k + 1] + proj.by);
        g.stroke();
      }
    }
    if (id) {  // the label over the head, in the person's colour
      const head = pose.landmarks[0];
      const text = `person ${id}` + (newestOf && newestOf.score !== undefined ? " " + Math.round(newestOf.score) : "");
      g.font = "16px sans-serif";
      const w = g.measureText(text).width + 10;
      const x = Math.max(0, Math.min(canvas.width - w, head.x * canvas.width - w / 2)), y = Math.max(0, head.y * canvas.height - 40);
      g.fillStyle = personColour(id);
      g.fillRect(x, y, w, 22);
      g.fillStyle = "#111";
      g.fillText(text, x + 5, y + 16);
    }
  });
}

// MoveNet MultiPose on the frame: up to `n` people, the most confident, as boxes in frame pixels.
async function findPeople(movenet, n, detect, dg) {
  const W = canvas.width, H = canvas.height, s = MOVENET_SIZE / Math.max(W, H);
  const ox = (MOVENET_SIZE - W * s) / 2, oy = (MOVENET_SIZE - H * s) / 2;
  dg.fillStyle = "#000";
  dg.fillRect(0, 0, MOVENET_SIZE, MOVENET_SIZE);
  dg.drawImage(video, ox, oy, W * s, H * s);
  const out = tf.tidy(() => movenet.execute(tf.browser.fromPixels(detect).toInt().expandDims(0)));
  const a = await out.data();
  out.dispose();
  const found = [];
  for (let k = 0; k < a.length / 56; ++k) {
    const r = a.subarray(56 * k, 56 * k + 56);
    if (!(r[55] >= MOVENET_MIN_SCORE)) continue;
    const x0 = (r[52] * MOVENET_SIZE - ox) / s, y0 = (r[51] * MOVENET_SIZE - oy) / s;
    const x1 = (r[54] * MOVENET_SIZE - ox) / s, y1 = (r[53] * MOVENET_SIZE - oy) / s;
    if (x1 - x0 < 8 || y1 - y0 < 8) continue;
    found.push({ score: r[55], x0, y0, x1, y1 });
  }
  found.sort((p, q) => q.score - p.score);
  hook.found.push(found.length);
  if (hook.found.length > 3000) hook.found.shift();
  return found.slice(0, n);
}

// A person's square crop (their box, 25 % bigger, centred) into `crop`; the part outside the
// frame stays black. Returns the crop's place: frame pixels of its corner and its side.
function cropPerson(box, crop, cg) {
  const side = 1.25 * Math.max(box.x1 - box.x0, box.y1 - box.y0);
  const cx = (box.x0 + box.x1) / 2, cy = (box.y0 + box.y1) / 2;
  const x = cx - side / 2, y = cy - side / 2, k = CROP / side;
  const sx = Math.max(0, x), sy = Math.max(0, y);
  const ex = Math.min(canvas.width, x + side), ey = Math.min(canvas.height, y + side);
  cg.fillStyle = "#000";
  cg.fillRect(0, 0, CROP, CROP);
  if (ex > sx && ey > sy) cg.drawImage(video, sx, sy, ex - sx, ey - sy, (sx - x) * k, (sy - y) * k, (ex - sx) * k, (ey - sy) * k);
  return { x, y, side };
}

function costSummary() {
  const c = hook.cost;
  const p50 = (a) => +percentile(a, 0.5).toFixed(1), p95 = (a) => +percentile(a, 0.95).toFixed(1);
  return { frames: c.frame.length, movenet_ms: [p50(c.movenet), p95(c.movenet)],
           mediapipe_per_person_ms: [p50(c.person), p95(c.person)], frame_ms: [p50(c.frame), p95(c.frame)],
           people_per_frame: +(c.people.reduce((x, y) => x + y, 0) / Math.max(1, c.people.length)).toFixed(2) };
}

async function runPeople(n, complexity) {
  hook.persons = {};
  hook.frames = [];
  hook.found = [];
  hook.cost = { movenet: [], person: [], frame: [], people: [] };
  document.getElementById("single").style.display = "none";
  setState("loading MoveNet");
  await loadScript("vendor/tfjs/tf.min.js");
  await loadScript("vendor/tfjs/tf-backend-wasm.min.js");
  tf.wasm.setWasmPaths(new URL("vendor/tfjs/", location.href).href);
  await tf.setBackend("wasm");
  await tf.ready();
  hook.backend = tf.getBackend();
  const movenet = await tf.loadGraphModel("vendor/movenet/movenet-multipose.json");
  const detect = document.createElement("canvas");
  detect.width = detect.height = MOVENET_SIZE;
  const dg = detect.getContext("2d", { willReadFrequently: true });
  const crop = document.createElement("canvas");
  crop.width = crop.height = CROP;
  const cg = crop.getContext("2d");
  setState("loading MediaPipe");
  // One landmarker for every crop: each crop is a still (its own detection), no smoothing across
  // crops (consecutive crops are different people).
  const pose = new Pose({ locateFile: (f) => "vendor/mediapipe/pose/" + f });
  pose.setOptions({ modelComplexity: complexity, staticImageMode: true, smoothLandmarks: false, enableSegmentation: false });
  let answer = null;
  pose.onResults((r) => { answer = r; });
  await pose.initialize();
  connectEvents();
  requestAnimationFrame(draw);
  let lastTime = -1, logged = 0;
  for (;;) {
    if (video.readyState >= 2 && video.currentTime !== lastTime) {
      lastTime = video.currentTime;
      const captureMs = performance.now();
      const boxes = await findPeople(movenet, n, detect, dg);
      const t1 = performance.now();
      hook.cost.movenet.push(t1 - captureMs);
      const poses = [];
      for (const box of boxes) {
        const t = performance.now();
        const place = cropPerson(box, crop, cg);
        answer = null;
        await pose.send({ image: crop });
        hook.cost.person.push(performance.now() - t);
        const world = answer && answer.poseWorldLandmarks && answer.poseWorldLandmarks.length === LANDMARKS ? answer.poseWorldLandmarks : null;
        if (!world || !answer.poseLandmarks) continue;
        poses.push({ world, landmarks: answer.poseLandmarks.map((l) => ({
          x: (place.x + l.x * place.side) / canvas.width, y: (place.y + l.y * place.side) / canvas.height, visibility: l.visibility })) });
      }
      const landmarksMs = performance.now();
      hook.cost.frame.push(landmarksMs - captureMs);
      hook.cost.people.push(poses.length);
      for (const k in hook.cost) if (hook.cost[k].length > 3000) hook.cost[k].shift();
      hook.costSummary = costSummary();
      if (landmarksMs - logged > 10000) {  // the page's cost per frame and per person, now and then
        logged = landmarksMs;
        console.log("kata webcam people: " + JSON.stringify(hook.costSummary));
      }
      if (poses.length) {
        hook.personFrames++;
        if (hook.state === "loading MediaPipe" || hook.state === "not in frame") setState("calibrating");
      } else {
        setState("not in frame");
      }
      // Until kata's answer names them, each pose is drawn as the person whose hips were nearest in
      // the frame before (for the drawing only).
      lastPeople = { poses, ids: provisionalIds(poses, lastPeople) };
      dirty = true;
      sendPeopleFrame(poses, captureMs, landmarksMs, lastPeople);
      await resultOfPeople(seq - 1);
      await yieldToTasks();
    } else {
      await new Promise((ok) => setTimeout(ok, 5));
    }
  }
}

function provisionalIds(poses, before) {
  if (!before || !before.ids) return null;
  const hips = (p) => [(p.landmarks[23].x + p.landmarks[24].x) / 2, (p.landmarks[23].y + p.landmarks[24].y) / 2];
  const taken = new Set();
  return poses.map((p) => {
    const [x, y] = hips(p);
    let best = 0, bestD = Infinity;
    before.poses.forEach((q, i) => {
      const id = before.ids[i];
      if (!id || taken.has(id)) return;
      const [qx, qy] = hips(q), d = (qx - x) ** 2 + (qy - y) ** 2;
      if (d < bestD) { bestD = d; best = id; }
    });
    if (best) taken.add(best);
    return best;
  });
}

function resultOfPeople(s) {
  if (s < 0 || peopleNewestSeq >= s) return Promise.resolve();
  return new Promise((ok) => {
    const timer = setTimeout(() => { resultWaiter = null; ok(); }, RESULT_WAIT_MS);
    resultWaiter = { seq: s, done: () => { clearTimeout(timer); resultWaiter = null; ok(); } };
  });
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
  hook.people = Number(setup.people || 1);
  if (hook.people > 1) return runPeople(hook.people, complexity);
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
