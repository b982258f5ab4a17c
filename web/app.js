// XPERSIF in the browser: the scene from the bridge once, then frames (binary: every dynamic node's pose),
// rendered here with three.js (the paper's TeleSimView: scene nodes, not images, go over the network).
// Everything shown comes from the scene message: names, shapes, sizes, colours, cameras. Nothing about a
// particular world is written here.
import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';

const params = new URLSearchParams(location.search);
const $ = (id) => document.getElementById(id);

// What tests and curious people can read from the console: window.xpersif.
const state = {
  scene: null, generation: 0, frames: 0, lastFrame: null, loop: {}, experiment: null, notions: [], curve: [],
  latencies: [], connected: false, rendered: 0,
};
window.xpersif = state;

// ---- three.js: one scene, an orbit view, and one view per scene camera ------------------------------------
const world = new THREE.Scene();
world.background = new THREE.Color(0x303030);
// Lights that give a face looking straight up exactly its own colour (0.55 + 0.45, times pi: three.js's Lambert
// BRDF divides by pi): the top view shows the scene's colours as they are, sides are darker.
world.add(new THREE.AmbientLight(0xffffff, 0.55 * Math.PI));
const sun = new THREE.DirectionalLight(0xffffff, 0.45 * Math.PI);
sun.position.set(0, 0, 10);
world.add(sun);

const orbitCanvas = $('orbit');
const orbitRenderer = new THREE.WebGLRenderer({ canvas: orbitCanvas, antialias: true });
const orbitCamera = new THREE.PerspectiveCamera(45, 1, 0.01, 100);
orbitCamera.up.set(0, 0, 1);  // ROS: z up
const controls = new OrbitControls(orbitCamera, orbitCanvas);

let nodes = new Map();       // scene node name -> Object3D
let frameObjects = [];       // frame order -> Object3D
let root = null;
const cameraViews = [];      // {name, camera, renderer, canvas}

function srgb(c) { return new THREE.Color().setRGB(c[0], c[1], c[2], THREE.SRGBColorSpace); }

function place(object, t, q) {
  object.position.set(t[0], t[1], t[2]);
  object.quaternion.set(q[0], q[1], q[2], q[3]);
}

function geometryOf(v) {
  if (v.type === 'box') return new THREE.BoxGeometry(v.size[0], v.size[1], v.size[2]);
  if (v.type === 'sphere') return new THREE.SphereGeometry(v.radius, 32, 16);
  if (v.type === 'cylinder') {
    const g = new THREE.CylinderGeometry(v.radius, v.radius, v.length, 32);
    g.rotateX(Math.PI / 2);  // three's cylinders run along y; the scene's along z
    return g;
  }
  return null;
}

// A projection matrix from pinhole intrinsics (fx, fy, cx, cy, pixels from the top-left), so the view shows
// exactly what the scene's camera sees, pixel for pixel.
function pinholeProjection(c, near, far) {
  const m = new THREE.Matrix4();
  m.set(2 * c.fx / c.width, 0, 1 - 2 * c.cx / c.width, 0,
        0, 2 * c.fy / c.height, 2 * c.cy / c.height - 1, 0,
        0, 0, -(far + near) / (far - near), -2 * far * near / (far - near),
        0, 0, -1, 0);
  return m;
}

function disposeScene() {
  if (root) {
    root.traverse((o) => {
      if (o.geometry) o.geometry.dispose();
      if (o.material) o.material.dispose();
    });
    world.remove(root);
  }
  for (const v of cameraViews) v.renderer.dispose();
  cameraViews.length = 0;
  $('cameras').replaceChildren();
  nodes = new Map();
  frameObjects = [];
}

function buildScene(s) {
  disposeScene();
  state.scene = s;
  state.generation = s.generation;
  root = new THREE.Group();
  world.add(root);
  for (const n of s.nodes) {
    const o = new THREE.Group();
    o.name = n.name;
    place(o, n.t, n.q);
    for (const v of n.visuals) {
      const g = geometryOf(v);
      if (!g) continue;
      const mat = new THREE.MeshLambertMaterial({ color: srgb(v.color) });
      if (v.color[3] < 1) { mat.transparent = true; mat.opacity = v.color[3]; }
      const mesh = new THREE.Mesh(g, mat);
      place(mesh, v.t, v.q);
      o.add(mesh);
    }
    const parent = n.parent === s.world_frame ? root : nodes.get(n.parent);
    (parent || root).add(o);
    nodes.set(n.name, o);
  }
  frameObjects = s.frame_nodes.map((name) => nodes.get(name));

  // The orbit view looks at the arena from its south-west, far enough to see all of it.
  const size = Math.max(s.arena[0], s.arena[1], 0.2);
  orbitCamera.position.set(-0.6 * size, -1.1 * size, 0.9 * size);
  controls.target.set(0, 0, 0);
  controls.update();

  for (const c of s.cameras) {
    const holder = nodes.get(c.frame);
    if (!holder) continue;
    const camera = new THREE.PerspectiveCamera();
    camera.quaternion.setFromAxisAngle(new THREE.Vector3(1, 0, 0), Math.PI);  // optical (z ahead, y down) -> three
    camera.projectionMatrix.copy(pinholeProjection(c, 0.005, 20));
    camera.projectionMatrixInverse.copy(camera.projectionMatrix).invert();
    camera.updateProjectionMatrix = () => {};  // keep the intrinsics
    holder.add(camera);
    const box = document.createElement('div');
    box.className = 'camera';
    const label = document.createElement('div');
    label.className = 'small';
    label.textContent = `${c.name} (${c.width} × ${c.height}, fx ${c.fx.toFixed(0)})`;
    const canvas = document.createElement('canvas');
    canvas.id = 'camera-' + c.name;
    canvas.dataset.camera = c.name;
    box.append(label, canvas);
    $('cameras').append(box);
    const renderer = new THREE.WebGLRenderer({ canvas, antialias: false, preserveDrawingBuffer: true });
    renderer.setPixelRatio(1);
    renderer.setSize(c.width, c.height, false);  // the camera's own pixels; CSS scales the element
    cameraViews.push({ name: c.name, camera, renderer, canvas });
  }
  $('stream-stats').textContent = `scene ${s.world_file}: ${s.nodes.length} nodes, ${s.frame_nodes.length} moving`;
}

function applyFrame(buffer) {
  const v = new DataView(buffer);
  if (v.byteLength < 36 || v.getUint8(0) !== 0x58 || v.getUint8(3) !== 0x31) return;  // "XPF1"
  const generation = v.getUint32(4, true);
  if (!state.scene || generation !== state.generation) return;  // a frame of another scene
  const seq = Number(v.getBigUint64(8, true));
  const simTime = v.getFloat64(16, true);
  const wallTime = v.getFloat64(24, true);
  const n = v.getUint32(32, true);
  if (v.byteLength !== 36 + 28 * n || n !== frameObjects.length) return;
  for (let i = 0; i < n; ++i) {
    const o = frameObjects[i];
    if (!o) continue;
    const b = 36 + 28 * i;
    o.position.set(v.getFloat32(b, true), v.getFloat32(b + 4, true), v.getFloat32(b + 8, true));
    o.quaternion.set(v.getFloat32(b + 12, true), v.getFloat32(b + 16, true), v.getFloat32(b + 20, true),
                     v.getFloat32(b + 24, true));
  }
  state.frames += 1;
  state.lastFrame = { seq, simTime, wallTime };
  const latency = Date.now() / 1000 - wallTime;
  state.latencies.push(latency);
  if (state.latencies.length > 200) state.latencies.shift();
}

// ---- panels --------------------------------------------------------------------------------------------
function text(id, value) { $(id).textContent = value === undefined || value === null || value === '' ? '–' : value; }

function showLoop(m) {
  Object.assign(state.loop, m);
  const l = state.loop;
  text('loop-state', l.state || 'waiting for LOOPMODEL');
  text('loop-run', l.run);
  text('loop-design', l.design);
  if (l.experiment !== undefined) {
    text('experiment-number', String(l.experiment));
    $('experiment-number').dataset.experiment = String(l.experiment);
  }
  if (l.surprise !== undefined && !state.motivation) text('surprise', `${l.surprise.toFixed(3)} m`);
  $('loop-last').textContent = l.last ? 'last: ' + l.last : '';
}

function showExperiment(m) {
  state.experiment = m;
  let line = `${m.experiment}: ${m.state}`;
  if (m.phase) line += `, phase ${m.phase_number} of ${m.phases} (${m.phase}, ${m.kind}), experiment ${m.experiments_done} of ${m.experiments}`;
  if (m.seconds_left >= 0) line += `, about ${Math.round(m.seconds_left)} s left`;
  $('experiment-line').textContent = line;
}

function showMotivation(m) {
  state.motivation = m;
  text('surprise', `${m.surprise.toFixed(3)} m (${m.normalized_surprise.toFixed(1)} sd)`);
  text('curious', m.most_curious);
}

function showNotions(m) {
  state.notions = m.notions;
  $('notion-count').textContent = `${m.notions.length}, from ${m.samples} samples`;
  $('notions').replaceChildren(...m.notions.map((n) => {
    const li = document.createElement('li');
    li.textContent = n.text || `${n.subject} ${n.predicate}`;
    return li;
  }));
}

const designColours = { curiosity: '#f5a623', random: '#7fb3ff', grid: '#9be39b', hand: '#e07be0', goal: '#ffffff' };

function drawCurve() {
  const canvas = $('curve');
  const g = canvas.getContext('2d');
  const W = canvas.width, H = canvas.height, L = 40, B = 20, T = 8, R = 8;
  g.clearRect(0, 0, W, H);
  const pts = state.curve;
  g.strokeStyle = '#666';
  g.strokeRect(L, T, W - L - R, H - T - B);
  g.fillStyle = '#aaa';
  g.font = '10px sans-serif';
  if (!pts.length) {
    g.fillText('no experiments yet', L + 8, T + 16);
    return;
  }
  const ymax = Math.max(0.01, ...pts.map((p) => p[3])) * 1.1;
  const x = (i) => L + (W - L - R) * (pts.length === 1 ? 0.5 : i / (pts.length - 1));
  const y = (s) => T + (H - T - B) * (1 - s / ymax);
  g.fillText(ymax.toFixed(3), 2, T + 8);
  g.fillText('0', 28, H - B);
  g.fillText(`experiments: ${pts.length}`, L + 4, H - 6);
  pts.forEach((p, i) => {
    g.fillStyle = designColours[p[2]] || '#ccc';
    g.fillRect(x(i) - 1.5, y(p[3]) - 1.5, 3, 3);
  });
  // A running mean over 8 experiments: the learning curve's trend.
  g.strokeStyle = '#fff';
  g.beginPath();
  let sum = 0;
  pts.forEach((p, i) => {
    sum += p[3];
    if (i >= 8) sum -= pts[i - 8][3];
    const mean = sum / Math.min(i + 1, 8);
    if (i === 0) g.moveTo(x(i), y(mean)); else g.lineTo(x(i), y(mean));
  });
  g.stroke();
  let lx = W - R - 4;
  for (const d of [...new Set(pts.map((p) => p[2]))].reverse()) {
    const w = g.measureText(d).width;
    lx -= w + 6;
    g.fillStyle = designColours[d] || '#ccc';
    g.fillText(d, lx, T + 12);
  }
}

// ---- the socket ----------------------------------------------------------------------------------------
let socket = null;
let framesAtLastTick = 0;

function send(message) {
  if (socket && socket.readyState === WebSocket.OPEN) socket.send(JSON.stringify(message));
}

function rateValue() {
  const r = $('rate').value;
  return r === 'full' ? 'full' : Number(r);
}

function connect() {
  const url = `${location.protocol === 'https:' ? 'wss' : 'ws'}://${location.host}/`;
  socket = new WebSocket(url);
  socket.binaryType = 'arraybuffer';
  socket.onopen = () => {
    state.connected = true;
    $('connection').textContent = 'connected';
    send({ type: 'config', rate: rateValue() });
  };
  socket.onclose = (e) => {
    state.connected = false;
    $('connection').textContent = `disconnected (${e.code}${e.reason ? ': ' + e.reason : ''}); reconnecting…`;
    setTimeout(connect, 2000);
  };
  socket.onmessage = (e) => {
    if (e.data instanceof ArrayBuffer) {
      applyFrame(e.data);
      return;
    }
    let m;
    try { m = JSON.parse(e.data); } catch { return; }
    switch (m.type) {
      case 'scene': buildScene(m); break;
      case 'loop': showLoop(m); break;
      case 'experiment': showExperiment(m); break;
      case 'motivation': showMotivation(m); break;
      case 'notions': showNotions(m); break;
      case 'curve': state.curve = m.points; drawCurve(); break;
      case 'command_result':
        $('command-result').textContent = `${m.command}: ${m.success ? 'done' : 'refused'}: ${m.message}`;
        break;
      default: break;
    }
  };
}

$('rate').addEventListener('change', () => send({ type: 'config', rate: rateValue() }));
if (params.has('control')) {
  $('control').hidden = false;
  for (const b of document.querySelectorAll('#control button')) {
    b.addEventListener('click', () => send({ type: 'command', command: b.dataset.command, token: $('token').value }));
  }
}
const wanted = params.get('rate');
if (wanted && [...$('rate').options].some((o) => o.value === wanted)) $('rate').value = wanted;

setInterval(() => {
  const fps = state.frames - framesAtLastTick;
  framesAtLastTick = state.frames;
  const lat = [...state.latencies].sort((a, b) => a - b);
  const p50 = lat.length ? (1000 * lat[Math.floor(lat.length / 2)]).toFixed(1) : '–';
  const sim = state.lastFrame ? state.lastFrame.simTime.toFixed(2) : '–';
  if (state.scene) {
    $('stream-stats').textContent = `${fps} frames/s, latency p50 ${p50} ms, simulated time ${sim} s, ` +
      `${state.frames} frames since the page opened`;
  }
}, 1000);

// ---- drawing -------------------------------------------------------------------------------------------
function resize() {
  const w = orbitCanvas.clientWidth, h = orbitCanvas.clientHeight;
  if (orbitCanvas.width !== w || orbitCanvas.height !== h) {
    orbitRenderer.setSize(w, h, false);
    orbitCamera.aspect = w / Math.max(1, h);
    orbitCamera.updateProjectionMatrix();
  }
}

let tick = 0;
function animate() {
  requestAnimationFrame(animate);
  resize();
  controls.update();
  orbitRenderer.render(world, orbitCamera);
  // The camera views at a third of the display's rate: they are small, and software GL is slow.
  if (tick++ % 3 === 0) for (const v of cameraViews) v.renderer.render(world, v.camera);
  state.rendered += 1;
}

drawCurve();
connect();
animate();
