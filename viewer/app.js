// kata coach's live viewer: server-sent events from the coach (/events) -> the student's skeleton
// in 3D (three.js) with the teacher's ghost over it, each body part coloured by its own score
// (red 0, amber 50, green 100), score timeline, part to fix, state (calibrating, tracking, tracking
// lost, teacher finished). Reconnects by itself after a dropped connection and resumes after the
// last frame it received. window.kata exposes counters for tests (frames, states seen, ...).
import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
import uPlot from 'uplot';

const kata = (window.kata = { frames: 0, connected: false, reconnects: 0, drawn: 0, lastId: -1, ended: false, mode: '',
  states: {}, state: '', partColours: [] });
const $ = (id) => document.getElementById(id);

let setup = null;          // the "setup" event
let latest = null;         // the newest frame event
const scores = [];         // per frame index: score or null
let scoreSum = 0, scoreCount = 0;

// Colour of a 0-100 score: red (0) -> amber (50) -> green (100); the report uses the same map.
function scoreColour(score) {
  const s = Math.max(0, Math.min(1, score / 100));
  const r = s < 0.5 ? 220 : Math.round(220 - (s - 0.5) * 2 * 180);
  const g = s < 0.5 ? Math.round(60 + s * 2 * 140) : 200;
  return `rgb(${r},${g},60)`;
}
const unscoredColour = '#8a929c';  // calibrating / tracking lost: no part score to show

// ---- 3D scene (three.js), or a 2D front view when WebGL is unavailable -----------------------
const sceneDiv = $('scene');
let renderer = null, scene, camera, controls, studentBones = [], ghostBones = [];
try {
  renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
} catch (e) {
  renderer = null;
}
let ctx2d = null;
if (renderer) {
  kata.mode = '3d';
  renderer.setPixelRatio(window.devicePixelRatio);
  sceneDiv.appendChild(renderer.domElement);
  scene = new THREE.Scene();
  scene.background = new THREE.Color(0x1e2227);
  camera = new THREE.PerspectiveCamera(45, 1, 0.5, 2000);
  camera.position.set(0, 22, 52);
  controls = new OrbitControls(camera, renderer.domElement);
  controls.target.set(0, 15, 0);
  scene.add(new THREE.HemisphereLight(0xffffff, 0x333344, 2.2));
  const sun = new THREE.DirectionalLight(0xffffff, 1.5);
  sun.position.set(30, 60, 40);
  scene.add(sun);
  const grid = new THREE.GridHelper(200, 40, 0x555b63, 0x383d44);
  scene.add(grid);
} else {
  kata.mode = '2d';
  $('mode').textContent = '(WebGL unavailable: 2D front view)';
  const c = document.createElement('canvas');
  sceneDiv.appendChild(c);
  ctx2d = c.getContext('2d');
}

const boneGeometry = new THREE.CylinderGeometry(1, 1, 1, 8);
function makeBones(count, material) {
  const bones = [];
  for (let k = 0; k < count; ++k) {
    const m = new THREE.Mesh(boneGeometry, material.clone());
    m.visible = false;
    scene.add(m);
    bones.push(m);
  }
  return bones;
}

function buildSkeletons() {
  if (!renderer) return;
  for (const b of [...studentBones, ...ghostBones]) scene.remove(b);
  studentBones = makeBones(setup.joints, new THREE.MeshStandardMaterial({ color: 0x5b9bff, roughness: 0.6 }));
  ghostBones = makeBones(setup.ghost_sources.length,
    new THREE.MeshStandardMaterial({ color: 0xd6c4ff, transparent: true, opacity: 0.5, roughness: 0.6 }));
}

const up = new THREE.Vector3(0, 1, 0), a = new THREE.Vector3(), b = new THREE.Vector3(), dir = new THREE.Vector3();
function placeBones(bones, parents, xyz, radius) {
  for (let j = 1; j < parents.length; ++j) {
    const p = parents[j], m = bones[j];
    if (p < 0 || !xyz) { m.visible = false; continue; }
    a.set(xyz[3 * p], xyz[3 * p + 1], xyz[3 * p + 2]);
    b.set(xyz[3 * j], xyz[3 * j + 1], xyz[3 * j + 2]);
    dir.subVectors(b, a);
    const len = dir.length();
    if (len < 1e-6) { m.visible = false; continue; }
    m.visible = true;
    m.position.addVectors(a, b).multiplyScalar(0.5);
    m.quaternion.setFromUnitVectors(up, dir.divideScalar(len));
    m.scale.set(radius, len, radius);
  }
}

function resize() {
  const w = sceneDiv.clientWidth, h = sceneDiv.clientHeight;
  if (renderer) {
    renderer.setSize(w, h, false);
    camera.aspect = w / Math.max(h, 1);
    camera.updateProjectionMatrix();
  } else {
    ctx2d.canvas.width = w; ctx2d.canvas.height = h;
  }
  if (timeline) timeline.setSize(timelineSize());
}
window.addEventListener('resize', resize);

function draw2d() {
  const c = ctx2d.canvas, g = ctx2d;
  g.fillStyle = '#1e2227'; g.fillRect(0, 0, c.width, c.height);
  if (!latest || !setup) return;
  const scale = c.height / 45, cx = c.width / 2, root = latest.joints;
  const line = (xyz, parents, colour, width) => {
    g.lineWidth = width; g.lineCap = 'round';
    for (let j = 1; j < parents.length; ++j) {
      const p = parents[j];
      if (p < 0) continue;
      g.strokeStyle = typeof colour === 'function' ? colour(j) : colour;
      g.beginPath();
      g.moveTo(cx + (xyz[3 * p] - root[0]) * scale, c.height * 0.92 - xyz[3 * p + 1] * scale);
      g.lineTo(cx + (xyz[3 * j] - root[0]) * scale, c.height * 0.92 - xyz[3 * j + 1] * scale);
      g.stroke();
    }
  };
  line(latest.joints, setup.parents, (j) => partColour(setup.joint_part[j]), 6);
  if (latest.ghost) line(latest.ghost, setup.ghost_parents, 'rgba(214,196,255,0.6)', 4);
}

function partColour(part) {
  return latest && latest.part_scores ? scoreColour(latest.part_scores[part]) : unscoredColour;
}

function render() {
  requestAnimationFrame(render);
  if (!setup) return;
  if (renderer) {
    if (latest) {
      placeBones(studentBones, setup.parents, latest.joints, 0.45);
      for (let j = 0; j < studentBones.length; ++j) studentBones[j].material.color.set(partColour(setup.joint_part[j]));
      placeBones(ghostBones, setup.ghost_parents, latest.ghost, 0.32);
      // Follow the student: the orbit target moves with the root, the camera keeps its offset.
      const root = new THREE.Vector3(latest.joints[0], latest.joints[1], latest.joints[2]);
      const shift = root.clone().sub(controls.target);
      controls.target.add(shift);
      camera.position.add(shift);
    }
    controls.update();
    renderer.render(scene, camera);
  } else {
    draw2d();
  }
  kata.drawn++;
}

// ---- panel and timeline -------------------------------------------------------------------------
function buildPanel() {
  $('title').textContent = `${setup.student} following ${setup.teacher} (${setup.source}, ${setup.speed}x)`;
  const parts = $('parts');
  parts.innerHTML = '';
  setup.part_labels.forEach((label, p) => {
    const d = document.createElement('div');
    d.className = 'part';
    d.innerHTML = `${label} <span id="share${p}"></span><div class="bar"><div id="bar${p}" style="width:0"></div></div>`;
    parts.appendChild(d);
  });
}

const stateClass = { 'tracking': 'tracking', 'calibrating': 'calibrating', 'tracking lost': 'lost', 'teacher finished': 'finished' };
// What the big label over the 3D view says in each state (nothing while tracking).
const stateBanner = {
  'calibrating': 'calibrating: hold on, scoring starts in a moment',
  'tracking lost': 'tracking lost: the body is not fully visible',
  'teacher finished': 'teacher finished: the teacher\'s clip is over',
};
// The repetition counter (docs/coach/repetitions.md): the repetition in progress and how far
// through the teacher's section it is; the newest repetition's tempo, score and depth (knee range
// against the teacher's). kata.reps keeps every repetition the lesson sent; at the end (f.ended:
// the end event, which carries the repetition the lesson's end closed and the summary's count)
// the counter shows the completed ones, kata.repsDone.
kata.reps = [];
kata.repsDone = 0;
function showRepetitions(f) {
  if (f.reps) kata.reps.push(...f.reps);
  kata.repsDone = kata.reps.filter((r) => !r.partial).length;
  if (!f.rep && !kata.reps.length) return;
  $('reps').style.display = '';
  if (f.ended) {
    $('rep-label').textContent = 'repetitions';
    $('rep-count').textContent = f.reps_done !== undefined ? f.reps_done : kata.repsDone;
    $('rep-progress').textContent = f.reps_partial ? `(${f.reps_partial} partial)` : '';
  } else if (f.rep) {
    $('rep-label').textContent = 'repetition';
    $('rep-count').textContent = f.rep;
    $('rep-progress').textContent = Math.round(100 * f.rep_progress) + '%' + (kata.repsDone ? `, ${kata.repsDone} done` : '');
  }
  const last = kata.reps[kata.reps.length - 1];
  if (last)
    $('rep-last').textContent = `last: ${last.partial ? 'partial, ' : ''}tempo ${last.tempo.toFixed(2)}, score ` +
      `${last.score.toFixed(0)}, depth ${last.depth.toFixed(0)} of ${last.teacher_depth.toFixed(0)} deg`;
}
function showFrame(f) {
  showRepetitions(f);
  const st = $('state');
  st.textContent = f.state;
  st.className = 'badge ' + (stateClass[f.state] || '');
  kata.state = f.state;
  kata.states[f.state] = (kata.states[f.state] || 0) + 1;
  const banner = $('banner');
  banner.textContent = stateBanner[f.state] || '';
  banner.className = stateClass[f.state] || '';
  $('frames').textContent = kata.frames;
  if (f.score !== undefined) {
    $('score').textContent = f.score.toFixed(0);
    $('score').style.color = scoreColour(f.score);
    $('mean').textContent = (scoreSum / Math.max(scoreCount, 1)).toFixed(1);
    // The part to fix and, with it, the correction cue ("left knee: bend 30 deg more").
    $('fix').textContent = f.fix >= 0 ? setup.part_labels[f.fix] + (f.cue ? ' - ' + f.cue : '') : 'nothing: well done';
    $('fix').style.color = f.fix >= 0 ? scoreColour(f.part_scores[f.fix]) : '';
    $('matched').textContent = f.matched;
    $('matched-time').textContent = f.matched_time !== undefined ? f.matched_time.toFixed(2) : '-';
    $('latency').textContent = (f.latency_us / 1000).toFixed(2) + ' ms';
    f.part_scores.forEach((s, p) => {
      $('share' + p).textContent = s.toFixed(0);
      const bar = $('bar' + p);
      bar.style.width = Math.max(0, Math.min(100, s)).toFixed(0) + '%';
      bar.style.background = scoreColour(s);
    });
  } else {
    $('score').textContent = '-';
    $('score').style.color = '';
    $('fix').textContent = '-';
    $('fix').style.color = '';
  }
  kata.partColours = setup.part_labels.map((_, p) => partColour(p));
}

// The score over the lesson (uPlot, served from vendor/uplot): seconds of the student's clip
// across the whole lesson, 0-100 up, gaps where a frame has no score.
let timeline = null;
function timelineSize() {
  const d = $('timeline');
  return { width: Math.max(d.clientWidth, 100), height: Math.max(d.clientHeight, 60) };
}
function buildTimeline() {
  const axis = { stroke: '#9aa3ad', grid: { stroke: '#3a4048', width: 1 }, ticks: { stroke: '#3a4048', width: 1 },
    font: '11px system-ui', labelFont: '11px system-ui' };
  timeline = new uPlot({
    ...timelineSize(), legend: { show: false }, cursor: { show: false },
    scales: { x: { time: false, range: () => [0, Math.max((setup.frames - 1) * setup.frame_time, 1e-3)] },
              y: { range: [0, 100] } },
    axes: [{ ...axis, label: 'score over the lesson', labelSize: 16, size: 34, values: (u, ticks) => ticks.map((t) => t + ' s') },
           { ...axis, size: 40, splits: () => [0, 50, 100] }],
    series: [{}, { label: 'score', stroke: '#e8e8e8', width: 1.5, points: { show: false } }],
  }, [[], []], $('timeline'));
  kata.timeline = timeline;
}
function drawTimeline() {
  if (!setup) return;
  if (!timeline) buildTimeline();
  const times = [], values = [];
  for (let i = 0; i < scores.length; ++i) {
    times.push(i * setup.frame_time);
    values.push(scores[i] === undefined ? null : scores[i]);
  }
  timeline.setData([times, values]);
}
let timelineDirty = false;
setInterval(() => { if (timelineDirty) { drawTimeline(); timelineDirty = false; } }, 200);

// ---- the event stream, with reconnection ----------------------------------------------------------
let source = null;
function connect() {
  const url = kata.lastId >= 0 ? `/events?last=${kata.lastId}` : '/events';
  source = new EventSource(url);
  source.addEventListener('open', () => {
    kata.connected = true;
    $('connection').textContent = 'connected';
    $('connection').className = 'badge tracking';
  });
  source.addEventListener('setup', (e) => {
    const s = JSON.parse(e.data);
    const fresh = !setup || JSON.stringify(s.parents) !== JSON.stringify(setup.parents) || s.frames !== setup.frames;
    if (setup && s.lesson !== setup.lesson && kata.lastId < 0) { scores.length = 0; scoreSum = 0; scoreCount = 0; kata.reps.length = 0; }
    setup = s;
    if (fresh) { buildSkeletons(); buildPanel(); resize(); }
  });
  source.addEventListener('frame', (e) => {
    const f = JSON.parse(e.data);
    kata.lastId = Number(e.lastEventId);
    kata.frames++;
    latest = f;
    kata.latest = f;
    if (f.score !== undefined) { scores[f.i] = f.score; scoreSum += f.score; scoreCount++; } else scores[f.i] = null;
    timelineDirty = true;
    showFrame(f);
  });
  source.addEventListener('end', (e) => {
    const s = JSON.parse(e.data);
    kata.ended = true;
    if (s.reps) showRepetitions({ ...s, ended: true });
    const st = $('state');
    st.textContent = `lesson over: mean score ${s.mean_score.toFixed(1)}`;
    st.className = 'badge finished';
    source.close();
    kata.connected = false;
    $('connection').textContent = 'lesson over';
    watchForNewLesson();
  });
  source.addEventListener('error', () => {
    kata.connected = false;
    $('connection').textContent = 'reconnecting';
    $('connection').className = 'badge off';
    // EventSource retries by itself while readyState is CONNECTING; once CLOSED (e.g. an HTTP
    // error from a server that was starting), open a new one after a second.
    if (source.readyState === EventSource.CLOSED) {
      source.close();
      setTimeout(() => { kata.reconnects++; $('reconnects').textContent = kata.reconnects; connect(); }, 1000);
    } else {
      kata.reconnects++;
      $('reconnects').textContent = kata.reconnects;
    }
  });
}

// After the end, a new coach on the same port (another lesson or replay) is picked up.
function watchForNewLesson() {
  const timer = setInterval(async () => {
    try {
      const r = await fetch('/status', { cache: 'no-store' });
      const s = await r.json();
      if (s.lesson !== setup.lesson) { clearInterval(timer); kata.ended = false; kata.lastId = -1; connect(); }
    } catch (e) { /* server down: keep watching */ }
  }, 2000);
}

resize();
render();
connect();
