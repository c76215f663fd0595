// The teamscan browser view: connects to the ground station's /ws, keeps a copy of the fused map (binary
// voxel messages: the whole map first, then the changed voxels) and of the team (JSON state messages), and
// draws them with three.js: voxels as points (colour by robot, height or class), every robot's marker,
// track and 2σ covariance ellipse; the panel lists each robot's state. Protocol: docs/view.md.
// Read-only: the page sends nothing to the station.
import * as THREE from 'three';
import { OrbitControls } from 'three/examples/jsm/controls/OrbitControls.js';
import { radioText } from './radio.mjs';

const VOXEL_MAGIC = 0x58565354; // "TSVX" little-endian
const VOXEL_HEADER = 24;
const VOXEL_BYTES = 16;
const MARKER_Z_M = 0.3;          // robot markers float above the floor
const ELLIPSE_SIGMA = 2;         // covariance ellipse at 2σ
const HEIGHT_MIN_M = 0.0;
const HEIGHT_MAX_M = 2.5;

// 32 distinct robot colours (golden-angle hues).
function robotColour(id) {
  const c = new THREE.Color();
  if (!id) return c.setRGB(0.55, 0.55, 0.55);
  c.setHSL(((id - 1) * 0.381966) % 1, 0.75, 0.55);
  return c;
}

function heightColour(z, out) {
  const t = Math.min(1, Math.max(0, (z - HEIGHT_MIN_M) / (HEIGHT_MAX_M - HEIGHT_MIN_M)));
  return out.setHSL(0.7 * (1 - t), 0.85, 0.5);
}

const KEPT = new THREE.Color(0.75, 0.8, 0.88);
const GHOST = new THREE.Color(1.0, 0.2, 0.2);

// ---- the map: one THREE.Points with growable buffers, a voxel's slot found by its integer key.
class VoxelCloud {
  constructor(scene) {
    this.capacity = 0;
    this.count = 0;
    this.slots = new Map();
    this.mode = 'robot';
    this.hideRemoved = false; // the operator's choice: removed ghost voxels drawn or not
    this.resolution = 0.1;
    this.geometry = new THREE.BufferGeometry();
    this.material = new THREE.PointsMaterial({ size: 0.08, vertexColors: true, sizeAttenuation: true });
    this.points = new THREE.Points(this.geometry, this.material);
    this.points.frustumCulled = false;
    scene.add(this.points);
    this.grow(65536);
  }

  grow(capacity) {
    const pos = new Float32Array(capacity * 3); // as drawn (NaN: hidden)
    const at = new Float32Array(capacity * 3);  // the voxel's centre
    const col = new Float32Array(capacity * 3);
    const meta = new Int32Array(capacity * 2); // flags, robot
    if (this.capacity) {
      pos.set(this.pos);
      at.set(this.at);
      col.set(this.col);
      meta.set(this.meta);
    }
    this.pos = pos;
    this.at = at;
    this.col = col;
    this.meta = meta;
    this.capacity = capacity;
    this.geometry.setAttribute('position', new THREE.BufferAttribute(this.pos, 3).setUsage(THREE.DynamicDrawUsage));
    this.geometry.setAttribute('color', new THREE.BufferAttribute(this.col, 3).setUsage(THREE.DynamicDrawUsage));
    this.geometry.setDrawRange(0, this.count);
  }

  clear() {
    this.slots.clear();
    this.count = 0;
    this.geometry.setDrawRange(0, 0);
  }

  colourSlot(i, c) {
    const flags = this.meta[2 * i], robot = this.meta[2 * i + 1];
    if (this.mode === 'class') c.copy(flags & 1 ? GHOST : KEPT);
    else if (this.mode === 'height') heightColour(this.at[3 * i + 2], c);
    else c.copy(robotColour(robot));
    this.col[3 * i] = c.r;
    this.col[3 * i + 1] = c.g;
    this.col[3 * i + 2] = c.b;
  }

  // A hidden voxel (a removed ghost while hideRemoved) is drawn at NaN: WebGL discards the point.
  placeSlot(i) {
    const hide = this.hideRemoved && (this.meta[2 * i] & 1);
    for (let a = 0; a < 3; a++) this.pos[3 * i + a] = hide ? NaN : this.at[3 * i + a];
  }

  // Applies one voxel message; returns the number of voxel records in it.
  apply(buffer) {
    const dv = new DataView(buffer);
    if (buffer.byteLength < VOXEL_HEADER || dv.getUint32(0, true) !== VOXEL_MAGIC) throw new Error('bad voxel message');
    const kind = dv.getUint16(6, true);
    const n = dv.getUint32(12, true);
    const resMm = dv.getUint32(16, true);
    if (buffer.byteLength !== VOXEL_HEADER + n * VOXEL_BYTES) throw new Error('voxel message length');
    if (kind === 1) this.clear();
    if (resMm > 0) {
      this.resolution = resMm / 1000;
      this.material.size = this.resolution * 0.9;
    }
    while (this.count + n > this.capacity) this.grow(this.capacity * 2);
    const c = new THREE.Color();
    for (let k = 0; k < n; k++) {
      const o = VOXEL_HEADER + k * VOXEL_BYTES;
      const x = dv.getInt32(o, true), y = dv.getInt32(o + 4, true), z = dv.getInt32(o + 8, true);
      const flags = dv.getUint8(o + 14), robot = dv.getUint8(o + 15);
      const key = ((Math.floor(x / resMm) + 32768) * 65536 + (Math.floor(y / resMm) + 32768)) * 65536 + (Math.floor(z / resMm) + 32768);
      let i = this.slots.get(key);
      if (i === undefined) {
        i = this.count++;
        this.slots.set(key, i);
      }
      this.at[3 * i] = x / 1000;
      this.at[3 * i + 1] = y / 1000;
      this.at[3 * i + 2] = z / 1000;
      this.meta[2 * i] = flags;
      if (robot || !this.meta[2 * i + 1]) this.meta[2 * i + 1] = robot;
      this.placeSlot(i);
      this.colourSlot(i, c);
    }
    this.geometry.setDrawRange(0, this.count);
    this.geometry.attributes.position.needsUpdate = true;
    this.geometry.attributes.color.needsUpdate = true;
    return n;
  }

  setHideRemoved(hide) {
    this.hideRemoved = hide;
    for (let i = 0; i < this.count; i++) this.placeSlot(i);
    this.geometry.attributes.position.needsUpdate = true;
  }

  setMode(mode) {
    this.mode = mode;
    const c = new THREE.Color();
    for (let i = 0; i < this.count; i++) this.colourSlot(i, c);
    this.geometry.attributes.color.needsUpdate = true;
  }

  // What is drawn: per voxel in the draw range whose position is not hidden, its integer key (the
  // drawn centre divided by the voxel edge: the station's voxel indices), flags and robot, as flat
  // [i, j, k, flags, robot, ...]. For the browser test.
  drawn() {
    const pos = this.geometry.attributes.position.array;
    const n = Math.min(this.count, this.geometry.drawRange.count);
    const out = [];
    for (let i = 0; i < n; i++) {
      const x = pos[3 * i], y = pos[3 * i + 1], z = pos[3 * i + 2];
      if (Number.isNaN(x) || Number.isNaN(y) || Number.isNaN(z)) continue;
      out.push(Math.floor(x / this.resolution), Math.floor(y / this.resolution), Math.floor(z / this.resolution),
        this.meta[2 * i], this.meta[2 * i + 1]);
    }
    return out;
  }

  bounds() {
    const b = new THREE.Box3();
    for (let i = 0; i < this.count; i++) b.expandByPoint(new THREE.Vector3(this.at[3 * i], this.at[3 * i + 1], this.at[3 * i + 2]));
    return b;
  }
}

// ---- a robot: marker (cone pointing along its heading), track line, covariance ellipse.
class RobotGlyph {
  constructor(scene, id) {
    this.id = id;
    this.colour = robotColour(id);
    this.group = new THREE.Group();
    const cone = new THREE.Mesh(new THREE.ConeGeometry(0.18, 0.5, 16), new THREE.MeshBasicMaterial({ color: this.colour }));
    cone.rotation.z = -Math.PI / 2; // the cone's tip along +x (the robot's heading)
    this.cone = cone;
    this.group.add(cone);
    const ring = [];
    for (let k = 0; k < 64; k++) ring.push(new THREE.Vector3(Math.cos((k / 64) * 2 * Math.PI), Math.sin((k / 64) * 2 * Math.PI), 0));
    this.ellipse = new THREE.LineLoop(new THREE.BufferGeometry().setFromPoints(ring), new THREE.LineBasicMaterial({ color: this.colour }));
    scene.add(this.ellipse);
    scene.add(this.group);
    this.trackCapacity = 1024;
    this.trackCount = 0;
    this.trackPos = new Float32Array(this.trackCapacity * 3);
    this.trackGeometry = new THREE.BufferGeometry();
    this.trackGeometry.setAttribute('position', new THREE.BufferAttribute(this.trackPos, 3));
    this.track = new THREE.Line(this.trackGeometry, new THREE.LineBasicMaterial({ color: this.colour }));
    this.track.frustumCulled = false;
    scene.add(this.track);
    this.state = null;
  }

  setTrack(xy, append) {
    if (!append) this.trackCount = 0;
    const n = xy.length / 2;
    if (this.trackCount + n > this.trackCapacity) {
      while (this.trackCount + n > this.trackCapacity) this.trackCapacity *= 2;
      const p = new Float32Array(this.trackCapacity * 3);
      p.set(this.trackPos.subarray(0, this.trackCount * 3));
      this.trackPos = p;
      this.trackGeometry.setAttribute('position', new THREE.BufferAttribute(this.trackPos, 3));
    }
    for (let k = 0; k < n; k++) {
      const i = this.trackCount++;
      this.trackPos[3 * i] = xy[2 * k];
      this.trackPos[3 * i + 1] = xy[2 * k + 1];
      this.trackPos[3 * i + 2] = 0.02;
    }
    this.trackGeometry.setDrawRange(0, this.trackCount);
    this.trackGeometry.attributes.position.needsUpdate = true;
  }

  update(r) {
    this.state = r;
    this.group.position.set(r.x_m, r.y_m, MARKER_Z_M);
    this.group.rotation.z = r.yaw_rad;
    const colour = r.lost ? new THREE.Color(0.4, 0.4, 0.4) : this.colour;
    this.cone.material.color.copy(colour);
    this.ellipse.material.color.copy(colour);
    // Covariance ellipse: eigen-decomposition of the 2x2 position covariance.
    const a = r.cov_xx_m2, b = r.cov_xy_m2, c = r.cov_yy_m2;
    const mean = (a + c) / 2, d = Math.sqrt(((a - c) / 2) ** 2 + b * b);
    const l1 = Math.max(mean + d, 0), l2 = Math.max(mean - d, 0);
    const angle = 0.5 * Math.atan2(2 * b, a - c);
    this.ellipse.position.set(r.x_m, r.y_m, 0.03);
    this.ellipse.rotation.z = angle;
    this.ellipse.scale.set(Math.max(ELLIPSE_SIGMA * Math.sqrt(l1), 1e-3), Math.max(ELLIPSE_SIGMA * Math.sqrt(l2), 1e-3), 1);
    if (r.track) this.setTrack(r.track, false);
    else if (r.track_add) this.setTrack(r.track_add, true);
  }
}

// ---- page
const container = document.getElementById('scene');
const scene = new THREE.Scene();
scene.background = new THREE.Color(0x10141a);
const camera = new THREE.PerspectiveCamera(50, window.innerWidth / window.innerHeight, 0.05, 500);
camera.up.set(0, 0, 1);
camera.position.set(0, -11, 9);
let renderer = null;
let controls = null;
try {
  renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
  renderer.setPixelRatio(window.devicePixelRatio);
  renderer.setSize(window.innerWidth, window.innerHeight);
  container.appendChild(renderer.domElement);
  controls = new OrbitControls(camera, renderer.domElement);
  controls.target.set(0, 0, 0);
  controls.update();
} catch (e) {
  container.innerHTML = '<div class="error">WebGL is not available: ' + String(e.message || e) + '</div>';
}
const grid = new THREE.GridHelper(20, 20, 0x34495e, 0x223040);
grid.rotation.x = Math.PI / 2; // the XY plane (z up)
scene.add(grid);
scene.add(new THREE.AxesHelper(1));

const cloud = new VoxelCloud(scene);
const robots = new Map();
const view = {
  connected: false,
  stateSeq: 0,
  stateStamp: 0,
  mapRelease: 0,       // the fusion core's release the map shows (the newest state's map_release)
  voxelMessages: 0,
  voxelRecords: 0,
  stateMessages: 0,
  errors: 0,
  fitted: false,
  webgl: !!renderer,
  get voxels() { return cloud.count; },
  // For the browser test: the voxels as drawn now (VoxelCloud.drawn) with the release they show.
  drawnMap() { return { release: view.mapRelease, resolution_m: cloud.resolution, voxels: cloud.drawn() }; },
  // For the browser test: every robot's marker position as drawn (the three.js object), with its state.
  robots() {
    return [...robots.values()].map((g) => ({
      id: g.id,
      lost: !!(g.state && g.state.lost),
      x_m: g.state ? g.state.x_m : null,
      y_m: g.state ? g.state.y_m : null,
      marker_x_m: g.group.position.x,
      marker_y_m: g.group.position.y,
      track_points: g.trackCount,
      row_text: (document.getElementById('robot-' + g.id) || {}).textContent || '',
      radio_text: (document.getElementById('radio-' + g.id) || {}).textContent || '',
    }));
  },
};
window.teamscanView = view;

const removedSelect = document.getElementById('removed');
removedSelect.addEventListener('change', () => cloud.setHideRemoved(removedSelect.value === 'hide'));

const colourSelect = document.getElementById('colour');
colourSelect.addEventListener('change', () => {
  cloud.setMode(colourSelect.value);
  drawLegend();
});

function drawLegend() {
  const legend = document.getElementById('legend');
  const sw = (c) => `<span class="swatch" style="background:#${c.getHexString()}"></span>`;
  if (cloud.mode === 'class') legend.innerHTML = `<span>${sw(KEPT)}kept</span><span>${sw(GHOST)}ghost (removed)</span>`;
  else if (cloud.mode === 'height') {
    const c = new THREE.Color();
    legend.innerHTML = [0, 0.5, 1, 1.5, 2, 2.5].map((z) => `<span>${sw(heightColour(z, c))}${z} m</span>`).join('');
  } else legend.innerHTML = [...robots.keys()].sort((a, b) => a - b).map((id) => `<span>${sw(robotColour(id))}robot ${id}</span>`).join('');
}

function fmt(v, digits) {
  return typeof v === 'number' ? v.toFixed(digits) : '–';
}

function updateTable() {
  const body = document.querySelector('#robots tbody');
  const ids = [...robots.keys()].sort((a, b) => a - b);
  let html = '';
  for (const id of ids) {
    const r = robots.get(id).state;
    if (!r) continue;
    const c = robotColour(id).getHexString();
    html += `<tr id="robot-${id}" class="${r.lost ? 'lost' : ''}"><td><span class="swatch" style="background:#${c}"></span></td>` +
      `<td>robot ${id}</td><td>${r.lost ? 'LOST' : 'alive'}</td><td>${fmt(r.scan_rate_hz, 1)}</td><td>${r.scans_lost}</td>` +
      `<td>${fmt(r.latency_ms, 1)} ms</td><td>${r.ghosts_removed}</td></tr>`;
    // Its radio: in a shadow, back-filling after it, whole again (docs/radio.md "What the operator sees").
    const radio = radioText(r, view.stateStamp);
    if (radio) html += `<tr id="radio-${id}" class="radio"><td></td><td colspan="6">${radio}</td></tr>`;
  }
  body.innerHTML = html;
}

function onState(s) {
  view.stateSeq = s.seq;
  view.stateStamp = s.stamp_ns;
  if (typeof s.map_release === 'number') view.mapRelease = s.map_release;
  view.stateMessages++;
  let added = false;
  for (const r of s.robots) {
    let g = robots.get(r.id);
    if (!g) {
      g = new RobotGlyph(scene, r.id);
      robots.set(r.id, g);
      added = true;
    }
    g.update(r);
  }
  document.getElementById('mapinfo').textContent =
    `map: ${s.map_voxels} voxels (${cloud.count} shown, ${(s.resolution_m * 100).toFixed(0)} cm) · state #${s.seq}`;
  updateTable();
  if (added) drawLegend();
}

function fitView() {
  if (view.fitted || cloud.count < 200 || !controls) return;
  const b = cloud.bounds();
  const centre = b.getCenter(new THREE.Vector3());
  const size = b.getSize(new THREE.Vector3());
  const r = Math.max(size.x, size.y, 4);
  controls.target.set(centre.x, centre.y, 0);
  camera.position.set(centre.x, centre.y - 0.9 * r, 0.85 * r);
  controls.update();
  view.fitted = true;
}

function connect() {
  const ws = new WebSocket((location.protocol === 'https:' ? 'wss://' : 'ws://') + location.host + '/ws');
  ws.binaryType = 'arraybuffer';
  const conn = document.getElementById('conn');
  ws.onopen = () => {
    view.connected = true;
    conn.textContent = 'live';
    conn.className = 'good';
  };
  ws.onmessage = (ev) => {
    try {
      if (typeof ev.data === 'string') {
        const m = JSON.parse(ev.data);
        if (m.type === 'state') onState(m);
        else if (m.type === 'error') view.errors++;
      } else {
        view.voxelRecords += cloud.apply(ev.data);
        view.voxelMessages++;
        fitView();
      }
    } catch (e) {
      view.errors++;
      console.error(e);
    }
  };
  ws.onclose = () => {
    view.connected = false;
    conn.textContent = 'disconnected (retrying)';
    conn.className = 'bad';
    setTimeout(connect, 1000);
  };
}

window.addEventListener('resize', () => {
  camera.aspect = window.innerWidth / window.innerHeight;
  camera.updateProjectionMatrix();
  if (renderer) renderer.setSize(window.innerWidth, window.innerHeight);
});

function frame() {
  requestAnimationFrame(frame);
  if (controls) controls.update();
  if (renderer) renderer.render(scene, camera);
}

drawLegend();
connect();
frame();
