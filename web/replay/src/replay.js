// The replay page of a `rollstep sim` run (docs/REPLAY.md). Its data, window.ROLLSTEP_REPLAY,
// is written into the page by `rollstep view` / `rollstep report`: the model as drawn
// (replay.json), the log's columns and the MPC's plans. Bundled with three.js and uPlot by
// esbuild into one classic script: the page opens from file:// with no server.
import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
import uPlot from 'uplot';
import uPlotCss from 'uplot/dist/uPlot.min.css';

const data = window.ROLLSTEP_REPLAY;
const COLOURS = {
  force: 0xd62728, basePlan: 0xff7f0e, footPlan: 0x17becf, foothold: 0xe377c2,
  region: 0x2ca02c, barrier: 0xffbf00, cursor: '#d62728',
};
// Bits of the log's qp_active_<leg>[-] (the CBF-QP's barrier kinds of that foot).
const BARRIER_KINDS = ['foothold region', 'clearance', 'collision'];
const FORCE_SCALE = 0.002;  // [m/N]: arrow length per newton

function columns(table) {
  const out = {};
  if (!table) return out;
  table.names.forEach((n, i) => { out[n] = table.columns[i]; });
  return out;
}
// The plans come compact (docs/REPLAY.md): integers, each the difference from the same node
// of the previous solution (or the previous row), with a scale per column.
function planColumns(table) {
  const out = {};
  if (!table) return out;
  const reference = [];
  let start = 0, previous = 0;
  table.rows_per_solution.forEach((n, s) => {
    for (let k = 0; k < n; ++k) {
      if (s > 0 && k < previous) reference.push(start - previous + k);
      else reference.push(k > 0 ? start + k - 1 : -1);
    }
    start += n;
    previous = n;
  });
  table.names.forEach((name, i) => {
    const d = table.columns[i], scale = table.scales[i];
    const q = new Float64Array(d.length);
    for (let r = 0; r < d.length; ++r) q[r] = (reference[r] >= 0 ? q[reference[r]] : 0) + d[r];
    out[name] = Array.from(q, (v) => v / scale);
  });
  return out;
}
const log = columns(data.log);
const plan = planColumns(data.plan);
const maps = data.maps || [];  // elevation map snapshots (perception runs with a map log)
// Perception runs: every foothold terrain the controller used, by version; the log's
// terrain_version[-] says which one was in use at each frame.
const terrains = data.terrains || [];
const terrainVersion = log['terrain_version[-]'];
const times = log['time[s]'];
const frames = times.length;

// ---- page layout ----
document.head.insertAdjacentHTML('beforeend', `<style>${uPlotCss}
body { margin: 0; font: 14px sans-serif; color: #222; }
header { padding: 6px 10px; background: #eee; }
#view { position: relative; height: 58vh; }
#view canvas { display: block; }
#controls { display: flex; gap: 10px; align-items: center; padding: 6px 10px; }
#slider { flex: 1; }
#legend { padding: 0 10px; font-size: 13px; }
#legend span.swatch { display: inline-block; width: 14px; height: 10px; margin: 0 4px 0 12px; }
#plots { display: flex; flex-wrap: wrap; gap: 8px; padding: 6px 10px; }
</style>`);
document.body.insertAdjacentHTML('beforeend', `
<header><b>Replay: ${escapeHtml(data.title)}</b> &mdash; robot: ${escapeHtml(data.model.robot_file)}</header>
<div id="view"></div>
<div id="controls">
  <button id="play" title="space">Play</button>
  <label>speed <select id="speed"><option>0.1</option><option>0.25</option><option>0.5</option>
    <option selected>1</option><option>2</option><option>4</option></select></label>
  <input id="slider" type="range" min="0" max="${frames - 1}" value="0" step="1" aria-label="time">
  <span id="clock"></span>
</div>
<div id="legend">Keys: space play/pause, &larr; &rarr; one frame (shift: 10 frames).
  <span class="swatch" style="background:#d62728"></span>contact force on each wheel, from its contact point (${1 / FORCE_SCALE} N per m)
  <span class="swatch" style="background:#ff7f0e"></span>MPC plan: base path
  <span class="swatch" style="background:#17becf"></span>MPC plan: foot paths
  <span class="swatch" style="background:#e377c2"></span>MPC plan: footholds
  <span class="swatch" style="background:#2ca02c"></span>foothold regions in use (${regionsSource()})
  <span class="swatch" style="background:#ffbf00"></span>wheel with an active CBF-QP barrier (listed below)
  ${maps.length ? '<span class="swatch" style="background:linear-gradient(90deg,#3350cc,#ffe633)"></span>elevation map (perception; colour: height, low to high)'
    : terrains.length ? '<span id="no-map">elevation map: not logged by this run (rollstep sim --log-map DIR/map logs it; rollstep view DIR then draws it)</span>' : ''}
  <span class="swatch" style="background:#d62728;height:2px"></span>plot cursor: the slider's time
  <div id="status"></div>
</div>
<div id="plots"></div>`);

function regionsSource() {
  if (terrains.length && terrainVersion) return 'perception: the terrain version in use at that time';
  if (maps.length) return 'perception: the map log\'s snapshot at that time';
  return escapeHtml(data.model.regions_source);
}

function escapeHtml(s) {
  return String(s).replace(/&/g, '&amp;').replace(/</g, '&lt;').replace(/>/g, '&gt;');
}

// ---- 3D scene ----
THREE.Object3D.DEFAULT_UP.set(0, 0, 1);
const view = document.getElementById('view');
const renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
renderer.setPixelRatio(window.devicePixelRatio || 1);
view.appendChild(renderer.domElement);
const scene = new THREE.Scene();
scene.background = new THREE.Color(0xdde6ee);
const camera = new THREE.PerspectiveCamera(45, 1, 0.02, 100);
scene.add(new THREE.HemisphereLight(0xffffff, 0x667788, 2.0));
const sun = new THREE.DirectionalLight(0xffffff, 1.5);
sun.position.set(2, -3, 5);
scene.add(sun);
const controls = new OrbitControls(camera, renderer.domElement);

function quat(q) { return new THREE.Quaternion(q[1], q[2], q[3], q[0]); }  // MuJoCo: w x y z
function vec3(v) { return new THREE.Vector3(v[0], v[1], v[2]); }

function geometryOf(g) {
  const s = g.size;
  switch (g.type) {
    case 'box': return new THREE.BoxGeometry(2 * s[0], 2 * s[1], 2 * s[2]);
    case 'sphere': return new THREE.SphereGeometry(s[0], 24, 16);
    case 'ellipsoid': return new THREE.SphereGeometry(1, 24, 16).scale(s[0], s[1], s[2]);
    case 'capsule': return new THREE.CapsuleGeometry(s[0], 2 * s[1], 6, 16).rotateX(Math.PI / 2);
    case 'cylinder':
      return new THREE.CylinderGeometry(s[0], s[0], 2 * s[1], 24).rotateX(Math.PI / 2);
    case 'plane': {
      const w = s[0] > 0 ? 2 * s[0] : 20, h = s[1] > 0 ? 2 * s[1] : 20;
      return new THREE.PlaneGeometry(w, h);
    }
    case 'mesh': {
      const m = data.model.meshes[g.mesh];
      const geometry = new THREE.BufferGeometry();
      geometry.setAttribute('position', new THREE.Float32BufferAttribute(m.vertices, 3));
      geometry.setIndex(m.faces);
      geometry.computeVertexNormals();
      return geometry;
    }
    default: return null;
  }
}

// One group per body; geoms attached in the body frame.
const bodies = data.model.bodies.map(() => new THREE.Group());
bodies.forEach((b) => { b.matrixAutoUpdate = false; scene.add(b); });
let drawnGeoms = 0;
for (const g of data.model.geoms) {
  const geometry = geometryOf(g);
  if (!geometry) continue;
  ++drawnGeoms;
  const [r, gr, b, a] = g.rgba;
  const material = new THREE.MeshStandardMaterial({
    color: new THREE.Color(r, gr, b), transparent: a < 1, opacity: a, roughness: 0.8,
    side: g.type === 'plane' ? THREE.DoubleSide : THREE.FrontSide,
  });
  const mesh = new THREE.Mesh(geometry, material);
  mesh.position.copy(vec3(g.pos));
  mesh.quaternion.copy(quat(g.quat));
  bodies[g.body].add(mesh);
}

// Forward kinematics of the logged configuration: MuJoCo's body tree, joints in order.
const baseColumns = ['base_x[m]', 'base_y[m]', 'base_z[m]', 'base_qw[-]', 'base_qx[-]',
  'base_qy[-]', 'base_qz[-]'];
function pose(frame) {
  const world = [];
  data.model.bodies.forEach((b, i) => {
    const m = new THREE.Matrix4();
    if (i === 0) { world.push(m); return; }
    m.copy(world[b.parent]);
    m.multiply(new THREE.Matrix4().compose(vec3(b.pos), quat(b.quat), new THREE.Vector3(1, 1, 1)));
    for (const j of b.joints) {
      if (j.type === 'free') {
        const v = baseColumns.map((c) => (log[c] ? log[c][frame] : 0));
        m.compose(new THREE.Vector3(v[0], v[1], v[2]), new THREE.Quaternion(v[4], v[5], v[6], v[3]),
          new THREE.Vector3(1, 1, 1));
      } else if (j.column && log[j.column]) {
        const q = log[j.column][frame] || 0;
        const axis = vec3(j.axis).normalize();
        const p = vec3(j.pos);
        const t = j.type === 'hinge'
          ? new THREE.Matrix4().makeTranslation(p.x, p.y, p.z)
            .multiply(new THREE.Matrix4().makeRotationAxis(axis, q))
            .multiply(new THREE.Matrix4().makeTranslation(-p.x, -p.y, -p.z))
          : new THREE.Matrix4().makeTranslation(axis.x * q, axis.y * q, axis.z * q);
        m.multiply(t);
      }
    }
    world.push(m);
  });
  return world;
}

// Foothold regions: those in use at the start, or with a map log those of its snapshot.
const regionGroup = new THREE.Group();
scene.add(regionGroup);
function drawRegions(polygons) {
  regionGroup.children.forEach((c) => c.geometry.dispose());
  regionGroup.clear();
  for (const polygon of polygons) {
    const points = polygon.map((p) => new THREE.Vector3(p[0], p[1], p[2] + 0.003));
    points.push(points[0].clone());
    regionGroup.add(new THREE.Line(new THREE.BufferGeometry().setFromPoints(points),
      new THREE.LineBasicMaterial({ color: COLOURS.region })));
  }
}
drawRegions(data.model.regions);

// The elevation map of perception runs (the map log's snapshots): cells as points coloured
// by height, blue (low) to yellow (high).
const mapPoints = new THREE.Points(new THREE.BufferGeometry(),
  new THREE.PointsMaterial({ size: 0.03, vertexColors: true }));
mapPoints.frustumCulled = false;
scene.add(mapPoints);
let shownMap = -1;
function drawMap(t) {
  let k = -1;
  for (let i = 0; i < maps.length && maps[i].time <= t + 1e-9; ++i) k = i;
  if (k === shownMap) return;
  shownMap = k;
  if (k < 0) {
    mapPoints.visible = false;
    if (!terrains.length) drawRegions(data.model.regions);
    return;
  }
  const m = maps[k];
  const positions = [], colours = [];
  const finite = m.heights.filter((h) => h !== null);
  const lo = Math.min(...finite), hi = Math.max(...finite);
  const colour = new THREE.Color();
  m.heights.forEach((h, i) => {
    if (h === null) return;
    const r = Math.floor(i / m.size), c = i % m.size;
    positions.push(m.origin[0] + (c + 0.5) * m.resolution, m.origin[1] + (r + 0.5) * m.resolution, h + 0.002);
    const u = hi > lo ? (h - lo) / (hi - lo) : 0;
    colour.setRGB(0.2 + 0.8 * u, 0.3 + 0.6 * u, 0.8 - 0.6 * u);
    colours.push(colour.r, colour.g, colour.b);
  });
  mapPoints.geometry.dispose();  // a new geometry: the number of cells changes
  mapPoints.geometry = new THREE.BufferGeometry();
  mapPoints.geometry.setAttribute('position', new THREE.Float32BufferAttribute(positions, 3));
  mapPoints.geometry.setAttribute('color', new THREE.Float32BufferAttribute(colours, 3));
  mapPoints.visible = true;
  if (!terrains.length) drawRegions(m.regions);
}

// The foothold terrain in use at a frame (perception runs with terrains.csv).
let shownTerrain = null;
function drawTerrain(f) {
  if (!terrains.length || !terrainVersion) return null;
  const v = terrainVersion[f];
  let t = terrains[0];
  for (const candidate of terrains) if (candidate.version === v) t = candidate;
  if (t !== shownTerrain) { shownTerrain = t; drawRegions(t.regions); }
  return t.version;
}

// Contact forces: 3D, from each wheel's contact point (older logs: vertical, from its centre).
const arrows = data.model.contacts.map(() => {
  const a = new THREE.ArrowHelper(new THREE.Vector3(0, 0, 1), new THREE.Vector3(), 0.1,
    COLOURS.force, 0.04, 0.025);
  // Drawn over the robot: an arrow may run inside its wheel.
  a.line.material.depthTest = false;
  a.cone.material.depthTest = false;
  a.renderOrder = 10;
  scene.add(a);
  return a;
});

// The MPC's plans: rows grouped by the solution they belong to.
const solutions = [];
if (plan['solution_time[s]']) {
  const st = plan['solution_time[s]'];
  for (let r = 0; r < st.length; ++r) {
    if (r === 0 || st[r] !== st[r - 1] || plan['sequence[-]'][r] !== plan['sequence[-]'][r - 1]) {
      solutions.push({ time: st[r], first: r, end: r + 1 });
    } else {
      solutions[solutions.length - 1].end = r + 1;
    }
  }
}
const feetNames = data.model.contacts.map((c) => c.name);
const planFeet = Object.keys(plan).filter((n) => n.endsWith('_x[m]') && n.startsWith('foot_'))
  .map((n) => n.slice(5, -5));
// New points for a line or a point cloud. Not setFromPoints on the geometry it has: that
// rewrites the old buffer in place, keeping its size (stale points stay drawn, extra ones are
// dropped), and the number of footholds changes from plan to plan.
function setPoints(object, points) {
  object.geometry.dispose();
  object.geometry = new THREE.BufferGeometry().setFromPoints(points);
}
function line(colour) {
  // Drawn over the robot: the planned base path runs inside the body.
  const l = new THREE.Line(new THREE.BufferGeometry(),
    new THREE.LineBasicMaterial({ color: colour, depthTest: false }));
  l.frustumCulled = false;
  l.renderOrder = 5;
  scene.add(l);
  return l;
}
const basePath = line(COLOURS.basePlan);
const footPaths = planFeet.map(() => line(COLOURS.footPlan));
// Drawn over the robot: a foothold is a wheel centre, inside its wheel.
const footholds = new THREE.Points(new THREE.BufferGeometry(),
  new THREE.PointsMaterial({ color: COLOURS.foothold, size: 0.05, depthTest: false }));
footholds.frustumCulled = false;
footholds.renderOrder = 6;
scene.add(footholds);

// Wheels with an active CBF-QP barrier: a ring around the wheel.
const barrierRings = data.model.contacts.map(() => {
  const ring = new THREE.Mesh(new THREE.TorusGeometry(0.11, 0.012, 8, 32),
    new THREE.MeshBasicMaterial({ color: COLOURS.barrier, depthTest: false }));
  ring.renderOrder = 11;
  ring.visible = false;
  scene.add(ring);
  return ring;
});
function columnAt(name, f) { return log[name] ? log[name][f] : null; }
function activeBarrierText(f) {
  const parts = [];
  data.model.contacts.forEach((c) => {
    const bits = columnAt(`qp_active_${c.name}[-]`, f);
    if (!bits) return;
    parts.push(`${c.name}: ${BARRIER_KINDS.filter((k, b) => (bits >> b) & 1).join(', ')}`);
  });
  const joints = columnAt('qp_active_joints[-]', f), support = columnAt('qp_active_support[-]', f);
  if (joints) parts.push(`joint limits: ${joints}`);
  if (support) parts.push(`support polygon edges: ${support}`);
  return parts.join('; ');
}

function solutionAt(t) {
  let lo = -1;
  for (let i = 0; i < solutions.length && solutions[i].time <= t + 1e-9; ++i) lo = i;
  return lo >= 0 ? solutions[lo] : null;
}

function drawPlan(t) {
  const s = solutionAt(t);
  if (!s) {
    basePath.visible = false; footholds.visible = false;
    footPaths.forEach((p) => { p.visible = false; });
    return null;
  }
  const rows = [];
  for (let r = s.first; r < s.end; ++r) rows.push(r);
  basePath.visible = true;
  setPoints(basePath, rows.map((r) =>
    new THREE.Vector3(plan['base_x[m]'][r], plan['base_y[m]'][r], plan['base_z[m]'][r])));
  const holds = [];
  planFeet.forEach((f, i) => {
    const x = plan[`foot_${f}_x[m]`], y = plan[`foot_${f}_y[m]`], z = plan[`foot_${f}_z[m]`];
    footPaths[i].visible = true;
    setPoints(footPaths[i], rows.map((r) => new THREE.Vector3(x[r], y[r], z[r])));
    rows.forEach((r, k) => {
      const stance = (plan['mode[-]'][r] >> i) & 1;
      const before = k > 0 && ((plan['mode[-]'][rows[k - 1]] >> i) & 1);
      if (stance && (k === 0 || !before)) holds.push(new THREE.Vector3(x[r], y[r], z[r]));
    });
  });
  footholds.visible = true;
  setPoints(footholds, holds);
  return s;
}

// ---- time ----
let frame = 0, playing = false, last = null;
const slider = document.getElementById('slider');
const clock = document.getElementById('clock');
const status = document.getElementById('status');
const cameraOffset = new THREE.Vector3(-1.2, -2.0, 1.1);
camera.position.copy(cameraOffset);

function show(f) {
  frame = Math.max(0, Math.min(frames - 1, f));
  slider.value = String(frame);
  const world = pose(frame);
  bodies.forEach((b, i) => { b.matrix.copy(world[i]); b.matrixWorldNeedsUpdate = true; });
  // The camera follows the base, keeping the user's view direction.
  const base = new THREE.Vector3().setFromMatrixPosition(world[Math.min(1, world.length - 1)]);
  const offset = camera.position.clone().sub(controls.target);
  controls.target.copy(base);
  camera.position.copy(base).add(offset);
  controls.update();
  data.model.contacts.forEach((c, i) => {
    const force = new THREE.Vector3(columnAt(`fx_${c.name}[N]`, frame) || 0,
      columnAt(`fy_${c.name}[N]`, frame) || 0, columnAt(`fz_${c.name}[N]`, frame) || 0);
    const centre = new THREE.Vector3().setFromMatrixPosition(world[c.body]);
    const point = log[`contact_point_x_${c.name}[m]`]
      ? new THREE.Vector3(log[`contact_point_x_${c.name}[m]`][frame],
        log[`contact_point_y_${c.name}[m]`][frame], log[`contact_point_z_${c.name}[m]`][frame])
      : centre;
    const magnitude = force.length();
    arrows[i].visible = magnitude > 1;
    if (magnitude > 1) {
      arrows[i].position.copy(point);
      arrows[i].setDirection(force.clone().divideScalar(magnitude));
      arrows[i].setLength(Math.max(0.05, magnitude * FORCE_SCALE), 0.04, 0.025);
    }
    const bits = columnAt(`qp_active_${c.name}[-]`, frame);
    barrierRings[i].visible = !!bits;
    if (bits) {
      // Around the wheel, in the plane of its spin (the wheel body's x-z plane).
      barrierRings[i].position.copy(centre);
      barrierRings[i].quaternion.setFromRotationMatrix(world[c.body])
        .multiply(new THREE.Quaternion().setFromAxisAngle(new THREE.Vector3(1, 0, 0), Math.PI / 2));
    }
  });
  const t = times[frame];
  drawMap(t);
  const version = drawTerrain(frame);
  const s = drawPlan(t);
  clock.textContent = `t = ${t.toFixed(2)} s`;
  const active = columnAt('qp_active[-]', frame);
  const which = activeBarrierText(frame);
  status.textContent = (s ? `MPC plan in use: solved at t = ${s.time.toFixed(2)} s. `
    : (solutions.length ? 'No MPC plan yet. ' : 'No MPC plan in this run. ')) +
    (version !== null ? `Foothold terrain version ${version}. ` : '') +
    (active !== null ? `CBF-QP active barriers: ${active}${which ? ` (${which})` : ''}.` : '');
  // The plots' legends give the values at the slider's time (a pointer over a plot, its own).
  plots.forEach((u) => { u.setLegend({ idx: frame }); u.redraw(false); });
  render();
}

function render() { renderer.render(scene, camera); }

function resize() {
  const w = view.clientWidth, h = view.clientHeight;
  renderer.setSize(w, h);
  camera.aspect = w / Math.max(1, h);
  camera.updateProjectionMatrix();
  render();
}

let playTime = 0;  // [s] run time being shown while playing (between log frames)
function tick(now) {
  if (playing) {
    const speed = Number(document.getElementById('speed').value);
    if (last === null) {
      playTime = times[frame];
    } else {
      playTime += speed * (now - last) / 1000;
      let f = frame;
      while (f + 1 < frames && times[f + 1] <= playTime) ++f;
      if (f === frames - 1) playing = false;
      if (f !== frame) show(f);
    }
    last = now;
  } else {
    last = null;
  }
  document.getElementById('play').textContent = playing ? 'Pause' : 'Play';
  requestAnimationFrame(tick);
}

function toggle() {
  if (!playing && frame === frames - 1) show(0);
  playing = !playing;
}
// The button gives the focus back: space on a focused button would click it a second time.
document.getElementById('play').addEventListener('click', (e) => { toggle(); e.currentTarget.blur(); });
slider.addEventListener('input', () => show(Number(slider.value)));
controls.addEventListener('change', render);
window.addEventListener('resize', resize);
window.addEventListener('keydown', (e) => {
  if (e.key === ' ') {
    if (e.target instanceof HTMLButtonElement) return;  // its click toggles
    toggle();
    e.preventDefault();
  }
  else if (e.key === 'ArrowRight') { playing = false; show(frame + (e.shiftKey ? 10 : 1)); e.preventDefault(); }
  else if (e.key === 'ArrowLeft') { playing = false; show(frame - (e.shiftKey ? 10 : 1)); e.preventDefault(); }
});

// ---- linked plots with a cursor at the slider's time ----
const plots = [];
function plot(title, names) {
  const present = names.filter((n) => log[n]);
  if (!present.length) return;
  const palette = ['#1f77b4', '#ff7f0e', '#2ca02c', '#9467bd', '#8c564b', '#e377c2', '#7f7f7f'];
  const cursorLine = {
    hooks: {
      draw: [(u) => {
        const x = Math.round(u.valToPos(times[frame], 'x', true));
        const ctx = u.ctx;
        ctx.save();
        ctx.strokeStyle = COLOURS.cursor;
        ctx.lineWidth = 2;
        ctx.beginPath();
        ctx.moveTo(x, u.bbox.top);
        ctx.lineTo(x, u.bbox.top + u.bbox.height);
        ctx.stroke();
        ctx.restore();
      }],
    },
  };
  const div = document.createElement('div');
  document.getElementById('plots').appendChild(div);
  const u = new uPlot({
    title, width: Math.max(320, Math.floor((window.innerWidth - 40) / 3)), height: 200,
    plugins: [cursorLine],
    scales: { x: { time: false } },
    series: [{ label: 't [s]' }, ...present.map((n, i) => ({ label: n, stroke: palette[i % 7] }))],
  }, [times, ...present.map((n) => log[n])], div);
  u.over.addEventListener('click', () => {
    if (u.cursor.idx !== null && u.cursor.idx !== undefined) show(u.cursor.idx);
  });
  plots.push(u);
}
plot('Base', ['base_z[m]', 'base_vx[m/s]', 'base_wy[rad/s]']);
plot('Contact normal forces [N]', data.model.contacts.map((c) => `fz_${c.name}[N]`));
plot('Contact forces, horizontal [N]', data.model.contacts.flatMap((c) => [`fx_${c.name}[N]`, `fy_${c.name}[N]`]));
plot('Joints', Object.keys(log).filter((n) => n.startsWith('q_')));
// Apart: a handful of barriers next to corrections of tens of m/s^2.
plot('CBF-QP active barriers', ['qp_active[-]']);
plot('CBF-QP correction', ['qp_correction[m/s^2]']);

resize();
show(0);
requestAnimationFrame(tick);

// For the browser tests (and the console): the page's state.
window.replay = {
  frames, get frame() { return frame; }, get time() { return times[frame]; }, show, solutions: solutions.length,
  terrains: terrains.length, maps: maps.length, get status() { return status.textContent; },
  /** The model's geoms (replay.json) and how many of them the page drew. */
  geoms: data.model.geoms.length, drawnGeoms, robotFile: data.model.robot_file,
  /** The planned footholds drawn now, [[x, y, z], ...]. */
  footholdsDrawn() {
    const p = footholds.geometry.getAttribute('position');
    const out = [];
    for (let i = 0; footholds.visible && p && i < p.count; ++i) out.push([p.getX(i), p.getY(i), p.getZ(i)]);
    return out;
  },
  /** The plans' columns as the page decoded them (by name). */
  planColumn(name) { return plan[name] || null; },
  /** Distinct colours and non-background pixels of the 3D view, sampled. */
  canvasStats() {
    render();
    const gl = renderer.getContext();
    const w = gl.drawingBufferWidth, h = gl.drawingBufferHeight;
    const pixels = new Uint8Array(w * h * 4);
    gl.readPixels(0, 0, w, h, gl.RGBA, gl.UNSIGNED_BYTE, pixels);
    const colours = new Set();
    let nonBackground = 0;
    const bg = scene.background.getHex();  // sRGB, as drawn
    const bgRgb = [(bg >> 16) & 255, (bg >> 8) & 255, bg & 255];
    for (let i = 0; i < pixels.length; i += 4 * 7) {
      colours.add((pixels[i] << 16) | (pixels[i + 1] << 8) | pixels[i + 2]);
      if (Math.abs(pixels[i] - bgRgb[0]) + Math.abs(pixels[i + 1] - bgRgb[1]) +
          Math.abs(pixels[i + 2] - bgRgb[2]) > 12) ++nonBackground;
    }
    return { width: w, height: h, colours: colours.size, nonBackground };
  },
};
