// ipsd live view: the floor map (SVG in world metres, y up; 1 m grid, axes, scale bar, origin,
// a tooltip with the numbers of the marker or body under the pointer), the Markers table, the
// camera view and the health tables, fed by /layout.json, the /events stream (Server-Sent
// Events) and /camera/<name>.jpg|json. Plain JS, no framework, nothing from the internet;
// bodies are drawn by bodies.js. Every marker element carries its world position and id as
// data attributes (data-id, data-x, data-y, data-z, data-yaw, data-speed, data-cameras,
// data-sources, data-has-yaw, data-age) so that the tests read back what is drawn.
// ?updates=N: stop the stream after N marker updates and the camera view after 2 images
// (a still page that ends its connections: for screenshots, monitoring and the browser test).
// ?rejected=1: the "show rejected candidates" box ticked at start. ?camera=NAME: that camera.
'use strict';

const SVG = 'http://www.w3.org/2000/svg';
const params = new URLSearchParams(location.search);
const stopAfter = parseInt(params.get('updates') || '0', 10);
const TRAIL = 40;          // positions kept per marker
const STALE_S = 1.0;       // a marker not seen for this long is drawn grey
const COLORS = ['#e53935', '#757575', '#212121', '#43a047', '#1e88e5', '#fb8c00', '#8e24aa', '#00897b'];

const state = { layout: null, updates: 0, trails: new Map(), status: null, images: 0, camera: null };
const $ = (id) => document.getElementById(id);

function el(tag, attrs, parent) {
  const e = document.createElementNS(SVG, tag);
  for (const [k, v] of Object.entries(attrs || {})) e.setAttribute(k, v);
  if (parent) parent.appendChild(e);
  return e;
}
const fmt = (v, d) => (v === null || v === undefined || Number.isNaN(v)) ? '–' : Number(v).toFixed(d);

// ---------------------------------------------------------------- map
let view = null;  // current viewBox [x, y, w, h] in SVG units (x, -y)
let home = null;

function setView(v) {
  view = v;
  $('map').setAttribute('viewBox', v.map((n) => n.toFixed(4)).join(' '));
  drawScale();
}

// Metres per screen pixel of the current view ("meet": the larger of the two scales).
function unitsPerPx() {
  const r = $('map').getBoundingClientRect();
  if (!r.width || !r.height) return 0.01;
  return Math.max(view[2] / r.width, view[3] / r.height);
}

// The 1 m grid, the axes' tick labels along the left and bottom edges of what is visible, and
// the scale bar: redrawn with every view change so that labels keep their size on screen.
function drawScale() {
  const u = unitsPerPx();
  const grid = $('grid'), axes = $('axes');
  grid.textContent = '';
  axes.textContent = '';
  // What the SVG shows ("meet" centres the viewBox in a panel of another aspect).
  const r = $('map').getBoundingClientRect();
  const w = (r.width || 1) * u, h = (r.height || 1) * u;
  const sx0 = view[0] + view[2] / 2 - w / 2, sy0 = view[1] + view[3] / 2 - h / 2;
  const x0 = sx0, x1 = sx0 + w, y0 = -(sy0 + h), y1 = -sy0;  // world metres
  if (1 / u >= 6) {  // 1 m lines at least 6 px apart
    for (let x = Math.ceil(x0); x <= x1; x++)
      el('line', { class: x === 0 ? 'grid axis0' : 'grid', x1: x, y1: -y1, x2: x, y2: -y0 }, grid);
    for (let y = Math.ceil(y0); y <= y1; y++)
      el('line', { class: y === 0 ? 'grid axis0' : 'grid', x1: x0, y1: -y, x2: x1, y2: -y }, grid);
  }
  // Labels every 0.5, 1, 2, 5 or 10 m: at least 45 px apart.
  const step = [0.5, 1, 2, 5, 10, 20, 50].find((s) => s / u >= 45) || 100;
  const font = 11 * u, pad = 4 * u;
  const label = (text, x, y, anchor, cls) => {
    const t = el('text', { class: `tick ${cls}`, x, y, 'font-size': font, 'text-anchor': anchor, 'stroke-width': 3 * u },
                 axes);
    t.textContent = text;
  };
  const num = (v) => String(Math.round(v * 100) / 100);
  for (let x = Math.ceil(x0 / step) * step; x <= x1 - 2 * font; x += step)
    label(num(x), x, sy0 + h - pad, 'middle', 'tick-x');
  for (let y = Math.ceil((y0 + 2 * font) / step) * step; y <= y1; y += step)
    label(num(y), sx0 + pad, -y + font * 0.35, 'start', 'tick-y');
  label('x m →', sx0 + w - pad, sy0 + h - pad, 'end', 'axis-name');
  label('↑ y m', sx0 + pad, sy0 + font + pad, 'start', 'axis-name');
  // Scale bar: 0.1 .. 10 m, 60..150 px long.
  const len = [0.1, 0.2, 0.5, 1, 2, 5, 10].find((m) => m / u >= 60) || 20;
  const bar = $('scale-bar');
  bar.querySelector('.bar').style.width = `${(len / u).toFixed(1)}px`;
  bar.querySelector('span').textContent = len < 1 ? `${len * 100} cm` : `${len} m`;
  bar.dataset.metres = len;
}

// The world origin: a dot with the x (red) and y (green) axes, 0.4 m long.
function drawOrigin() {
  const g = $('origin');
  g.textContent = '';
  el('line', { class: 'origin-x', x1: 0, y1: 0, x2: 0.4, y2: 0 }, g);
  el('line', { class: 'origin-y', x1: 0, y1: 0, x2: 0, y2: -0.4 }, g);
  el('circle', { class: 'origin-dot', r: 0.035 }, g);
  for (const [text, x, y] of [['x', 0.44, 0.04], ['y', 0.03, -0.44], ['0', -0.11, 0.12]]) {
    const t = el('text', { class: 'origin-label', x, y }, g);
    t.textContent = text;
  }
}

function buildMap() {
  const L = state.layout;
  const pts = [];
  if (L.floor) {
    const [x0, y0, x1, y1] = L.floor;
    el('rect', { class: 'floor', x: x0, y: -y1, width: x1 - x0, height: y1 - y0,
                 'data-floor': L.floor.join(',') }, $('floor'));
    pts.push([x0, y0], [x1, y1]);
  }
  L.cameras.forEach((c, i) => {
    const color = COLORS[i % COLORS.length];
    if (c.footprint.length > 2) {
      el('polygon', { class: 'footprint', fill: color, stroke: color, 'data-camera': c.name,
                      points: c.footprint.map(([x, y]) => `${x},${-y}`).join(' ') }, $('footprints'));
      if (!L.floor) c.footprint.forEach((p) => pts.push(p));
    }
    if (c.position) {
      const [x, y] = c.position;
      el('rect', { class: 'camera-pos', fill: color, x: x - 0.06, y: -y - 0.06, width: 0.12, height: 0.12,
                   'data-camera': c.name, 'data-x': x, 'data-y': y }, $('footprints'));
      const t = el('text', { class: 'camera-label', x: x + 0.09, y: -y - 0.09 }, $('footprints'));
      t.textContent = c.name;
      pts.push([x, y]);
    }
  });
  if (pts.length === 0) pts.push([-1, -1], [5, 5]);
  const xs = pts.map((p) => p[0]), ys = pts.map((p) => p[1]);
  const pad = 0.3;
  const x0 = Math.min(...xs) - pad, x1 = Math.max(...xs) + pad;
  const y0 = Math.min(...ys) - pad, y1 = Math.max(...ys) + pad;
  home = [x0, -y1, x1 - x0, y1 - y0];
  drawOrigin();
  setView(home.slice());
  enablePanZoom($('map'));
  enableTooltip($('map'));
  window.addEventListener('resize', () => setView(view));
}

// Hovering a marker or body on the map shows its numbers (from the element's data attributes,
// i.e. the last stream message).
function enableTooltip(svg) {
  const tip = $('tip');
  const show = (e) => {
    const g = e.target.closest && e.target.closest('g.marker, g.body');
    if (!g) { tip.hidden = true; return; }
    const d = g.dataset;
    const isBody = g.classList.contains('body');
    const name = isBody ? d.name : (state.layout.markers[d.id] || '');
    const yaw = isBody && d.hasYaw !== '1' ? '–' : `${fmt(Number(d.yaw) * 180 / Math.PI, 1)}°`;
    const rows = [
      [isBody ? 'body' : 'marker', isBody ? name : `${d.id}${name ? ' ' + name : ''}`],
      ['x, y, z', `${fmt(Number(d.x), 3)}, ${fmt(Number(d.y), 3)}, ${fmt(Number(d.z), 3)} m`],
      ['yaw', yaw],
      ['speed', d.speed === undefined || d.speed === '' ? '–' : `${fmt(Number(d.speed), 2)} m/s`],
    ];
    if (isBody) rows.push(['markers', d.ids.replaceAll(',', ' ')]);
    rows.push(['cameras', d.cameras.replaceAll(',', ' ') || '–'], ['age', `${fmt(Number(d.age), 1)} s`]);
    tip.textContent = '';
    for (const [k, v] of rows) {
      const line = document.createElement('div');
      const b = document.createElement('b');
      b.textContent = `${k} `;
      line.append(b, v);
      tip.appendChild(line);
    }
    const r = svg.getBoundingClientRect();
    tip.style.left = `${e.clientX - r.left + 14}px`;
    tip.style.top = `${e.clientY - r.top + 14}px`;
    tip.dataset.for = isBody ? `body:${d.name}` : `marker:${d.id}`;
    tip.hidden = false;
  };
  svg.addEventListener('pointermove', show);
  svg.addEventListener('pointerover', show);
  svg.addEventListener('pointerleave', () => { tip.hidden = true; });
}

function enablePanZoom(svg) {
  let drag = null;
  const toUnits = (dxPx, dyPx) => {
    const r = svg.getBoundingClientRect();
    const s = Math.max(view[2] / r.width, view[3] / r.height);  // "meet": the larger scale
    return [dxPx * s, dyPx * s];
  };
  svg.addEventListener('pointerdown', (e) => { drag = [e.clientX, e.clientY]; svg.setPointerCapture(e.pointerId); });
  svg.addEventListener('pointermove', (e) => {
    if (!drag) return;
    const [dx, dy] = toUnits(e.clientX - drag[0], e.clientY - drag[1]);
    drag = [e.clientX, e.clientY];
    setView([view[0] - dx, view[1] - dy, view[2], view[3]]);
  });
  svg.addEventListener('pointerup', () => { drag = null; });
  svg.addEventListener('wheel', (e) => {
    e.preventDefault();
    const k = e.deltaY > 0 ? 1.15 : 1 / 1.15;
    const r = svg.getBoundingClientRect();
    const [ux, uy] = toUnits(e.clientX - r.left - r.width / 2, e.clientY - r.top - r.height / 2);
    const cx = view[0] + view[2] / 2 + ux, cy = view[1] + view[3] / 2 + uy;
    const w = view[2] * k, h = view[3] * k;
    setView([cx - ux * k - w / 2, cy - uy * k - h / 2, w, h]);
  }, { passive: false });
  svg.addEventListener('dblclick', () => setView(home.slice()));
}

// Who placed a marker, for people: its cameras' names, plus the other sources that took part
// ("ranges", "inside-out": the robot's own camera), alone where no camera sees it; "–" for nothing.
function placedBy(cams, sources) {
  const others = sources.filter((s) => s !== 'camera').join(' + ');
  if (!cams.length) return others || '–';
  return cams.join(' ') + (others ? ` + ${others}` : '');
}

function cameraNames(mask) {
  const names = [];
  state.layout.cameras.forEach((c) => { if (mask & (1 << c.index)) names.push(c.name); });
  return names;
}

function drawMarkers(msg) {
  const layer = $('markers'), trails = $('trails');
  const seen = new Set();
  for (const m of msg.markers) {
    const id = String(m.id);
    seen.add(id);
    let g = layer.querySelector(`g.marker[data-id="${id}"]`);
    if (!g) {
      g = el('g', { class: 'marker', 'data-id': id }, layer);
      el('circle', { r: 0.08 }, g);
      el('line', { x1: 0, y1: 0, x2: 0.22, y2: 0 }, g);
      el('text', { class: 'label', x: 0.11, y: -0.1 }, g);
      el('text', { class: 'sub', x: 0.11, y: 0.17 }, g);
      el('polyline', { class: 'trail', 'data-id': id }, trails);
    }
    const yawDeg = -m.yaw * 180 / Math.PI;  // world y up, SVG y down: angles flip
    g.setAttribute('transform', `translate(${m.x.toFixed(4)} ${(-m.y).toFixed(4)})`);
    g.querySelector('line').setAttribute('transform', `rotate(${yawDeg.toFixed(2)})`);
    const cams = cameraNames(m.cameras);
    const speed = m.vx === null || m.vx === undefined || m.vy === null ? null : Math.hypot(m.vx, m.vy);
    // What placed it: another source alone (no overhead camera sees it) draws dashed; ranges
    // alone hold the heading.
    const sources = m.sources || ['camera'];
    Object.assign(g.dataset, { x: m.x, y: m.y, z: m.z, yaw: m.yaw, speed: speed === null ? '' : speed, age: m.age,
                               cameras: cams.join(','), sources: sources.join(','),
                               hasYaw: m.has_yaw === false ? 'false' : 'true' });
    g.classList.toggle('stale', m.age > STALE_S);
    g.classList.toggle('ranged', !sources.includes('camera'));
    g.classList.toggle('held', m.has_yaw === false);  // the heading tick: the last measured, held
    const name = state.layout.markers[id];
    g.querySelector('text.label').textContent = name ? `${id} ${name}` : id;
    g.querySelector('text.sub').textContent = `${placedBy(cams, sources)} · ${fmt(m.age, 1)} s`;
    const trail = state.trails.get(id) || [];
    const last = trail[trail.length - 1];
    if (!last || Math.hypot(last[0] - m.x, last[1] - m.y) > 0.005) trail.push([m.x, m.y]);
    if (trail.length > TRAIL) trail.shift();
    state.trails.set(id, trail);
    trails.querySelector(`polyline[data-id="${id}"]`)
      .setAttribute('points', trail.map(([x, y]) => `${x.toFixed(3)},${(-y).toFixed(3)}`).join(' '));
    drawMarkerRow(m, name, cams, speed, sources);
  }
  for (const g of [...layer.querySelectorAll('g.marker')]) {
    if (seen.has(g.dataset.id)) continue;
    const row = $('markers-table').querySelector(`tr[data-marker="${g.dataset.id}"]`);
    if (row) row.remove();
    g.remove();
    const t = trails.querySelector(`polyline[data-id="${g.dataset.id}"]`);
    if (t) t.remove();
    state.trails.delete(g.dataset.id);
  }
  $('markers').dataset.update = msg.update;
}

// The Markers table: one row per marker on the stream, sorted by id. Cells carry data-field
// (marker_*) and the unrounded value in data-value, as the Bodies and Health tables do.
function drawMarkerRow(m, name, cams, speed, sources) {
  const body = $('markers-table').querySelector('tbody');
  const id = String(m.id);
  let tr = body.querySelector(`tr[data-marker="${id}"]`);
  if (!tr) {
    tr = document.createElement('tr');
    tr.dataset.marker = id;
    const after = [...body.children].find((r) => Number(r.dataset.marker) > m.id);
    body.insertBefore(tr, after || null);
  }
  tr.textContent = '';
  tr.classList.toggle('stale', m.age > STALE_S);
  cell(tr, 'marker_id', id, id, true);
  cell(tr, 'marker_name', name || '', name || '');
  cell(tr, 'marker_x', m.x, fmt(m.x, 3), true);
  cell(tr, 'marker_y', m.y, fmt(m.y, 3), true);
  cell(tr, 'marker_z', m.z, fmt(m.z, 3), true);
  const held = m.has_yaw === false ? ' held' : '';
  cell(tr, 'marker_yaw_deg', m.yaw * 180 / Math.PI, fmt(m.yaw * 180 / Math.PI, 1) + held, true);
  cell(tr, 'marker_speed', speed, fmt(speed, 2), true);
  cell(tr, 'marker_cameras', cams.join(','), placedBy(cams, sources));
  cell(tr, 'marker_age', m.age, fmt(m.age, 1), true);
}

// ---------------------------------------------------------------- health
function cell(tr, field, value, text, num) {
  const td = document.createElement('td');
  td.dataset.field = field;
  if (value !== undefined && value !== null) td.dataset.value = value;
  td.textContent = text;
  if (num) td.className = 'num';
  tr.appendChild(td);
}

function drawHealth(s) {
  const body = $('health-cameras').querySelector('tbody');
  body.textContent = '';
  for (const c of s.cameras) {
    const tr = document.createElement('tr');
    tr.dataset.camera = c.name;
    tr.dataset.state = c.state;
    cell(tr, 'name', c.name, c.name);
    cell(tr, 'state', c.state, c.state);
    cell(tr, 'fps', c.fps, fmt(c.fps, 1), true);
    cell(tr, 'drops', c.drops, String(c.drops), true);
    cell(tr, 'detect_ms', c.detect_ms, fmt(c.detect_ms, 1), true);
    cell(tr, 'frames', c.frames, String(c.frames), true);
    cell(tr, 'last_error', c.last_error, c.last_error || '');
    body.appendChild(tr);
  }
  const f = $('health-fusion').querySelector('tbody');
  f.textContent = '';
  const rows = [
    ['updates_per_s', 'fusion updates/s', s.updates_per_s, fmt(s.updates_per_s, 1)],
    ['processing_p50', 'processing latency p50 ms', s.processing_latency_ms.p50, fmt(s.processing_latency_ms.p50, 1)],
    ['processing_p99', 'processing latency p99 ms', s.processing_latency_ms.p99, fmt(s.processing_latency_ms.p99, 1)],
    ['capture_p50', 'capture latency p50 ms', s.capture_latency_ms.p50, fmt(s.capture_latency_ms.p50, 1)],
    ['queue_drops', 'queue drops', s.queue_drops, String(s.queue_drops)],
    ['fusion_late', 'late observations', s.fusion_late, String(s.fusion_late)],
  ];
  if (s.web) rows.push(['web_dropped', 'web: updates dropped (slow browsers)', s.web.dropped, String(s.web.dropped)],
                       ['web_clients', 'web: live streams', s.web.clients, String(s.web.clients)]);
  for (const [field, label, value, text] of rows) {
    const tr = document.createElement('tr');
    tr.dataset.row = field;
    cell(tr, 'label', null, label);
    cell(tr, 'value', value, text, true);
    f.appendChild(tr);
  }
  const o = $('health-outputs').querySelector('tbody');
  o.textContent = '';
  for (const out of s.outputs) {
    const tr = document.createElement('tr');
    tr.dataset.output = out.output;
    cell(tr, 'output', out.output, out.output);
    cell(tr, 'datagrams', out.datagrams, String(out.datagrams), true);
    cell(tr, 'send_errors', out.send_errors, String(out.send_errors), true);
    o.appendChild(tr);
  }
  drawCameraStats();
}

// ---------------------------------------------------------------- camera view
function drawCameraStats() {
  const t = $('camera-stats');
  const name = state.camera;
  if (!name) return;
  const c = state.layout.cameras.find((x) => x.name === name) || {};
  const s = state.status ? state.status.cameras.find((x) => x.name === name) : null;
  const ctl = c.controls || {};
  const rows = [
    ['state', s ? s.state : '–'],
    ['fps', s ? fmt(s.fps, 1) : '–'],
    ['drops', s ? String(s.drops) : '–'],
    ['detect ms', s ? fmt(s.detect_ms, 1) : '–'],
    ['markers per frame', s ? fmt(s.markers, 1) : '–'],
    ['exposure', ctl.auto_exposure === true ? 'automatic'
                 : ctl.exposure_s !== undefined ? `${fmt(ctl.exposure_s * 1000, 1)} ms` : 'not set (device default)'],
    ['gain', ctl.gain !== undefined ? String(ctl.gain) : 'not set'],
    ['model', c.mapper || '–'],
  ];
  if (state.frameInfo) rows.push(['frame', `#${state.frameInfo.sequence}: ${state.frameInfo.detections.length} detected, ${state.frameInfo.rejected.length} rejected candidates`]);
  if (s && s.last_error) rows.push(['last error', s.last_error]);
  t.textContent = '';
  for (const [k, v] of rows) {
    const tr = document.createElement('tr');
    const a = document.createElement('th'); a.textContent = k;
    const b = document.createElement('td'); b.textContent = v;
    tr.append(a, b);
    t.appendChild(tr);
  }
}

// OpenCV's rejected candidates (from /camera/<name>.json, JPEG pixels) over the image, only
// while "show rejected candidates" is ticked: most are harmless (the white border around a
// detected marker), and drawn by default they alarmed new users.
function drawRejected() {
  const svg = $('camera-overlay');
  svg.textContent = '';
  const info = state.frameInfo;
  const show = $('show-rejected').checked;
  svg.dataset.show = show ? '1' : '0';
  svg.dataset.rejected = 0;
  if (!info) return;
  svg.setAttribute('viewBox', `0 0 ${info.width} ${info.height}`);
  if (!show) return;
  for (const r of info.rejected) {
    el('polygon', { class: 'rejected', points: r.map(([x, y]) => `${x.toFixed(1)},${y.toFixed(1)}`).join(' ') }, svg);
  }
  svg.dataset.rejected = info.rejected.length;
}

function nextImage() {
  const name = state.camera;
  if (!name) return;
  if (stopAfter && state.images >= 2) return;
  if (document.visibilityState !== 'visible') { setTimeout(nextImage, 500); return; }
  const img = $('camera-img');
  img.dataset.camera = name;
  img.src = `/camera/${encodeURIComponent(name)}.jpg?n=${Date.now()}`;
}

function startCameraView() {
  const sel = $('camera-select');
  for (const c of state.layout.cameras) {
    const o = document.createElement('option');
    o.value = o.textContent = c.name;
    sel.appendChild(o);
  }
  const img = $('camera-img');
  const period = 1000 / (state.layout.camera_fps || 5);
  img.addEventListener('load', async () => {
    state.images++;
    img.dataset.loaded = state.images;
    try {
      state.frameInfo = await (await fetch(`/camera/${encodeURIComponent(state.camera)}.json`)).json();
      img.dataset.sequence = state.frameInfo.sequence;
    } catch (e) { state.frameInfo = null; }
    drawRejected();
    drawCameraStats();
    setTimeout(nextImage, period);
  });
  img.addEventListener('error', () => setTimeout(nextImage, 1000));
  sel.addEventListener('change', () => {
    state.camera = sel.value;
    state.frameInfo = null;
    drawRejected();
    drawCameraStats();
  });
  const box = $('show-rejected');
  box.addEventListener('change', drawRejected);
  if (params.get('rejected') === '1') { box.checked = true; box.dispatchEvent(new Event('change')); }
  state.camera = params.get('camera') || (state.layout.cameras[0] || {}).name;
  sel.value = state.camera;
  nextImage();
}

// ---------------------------------------------------------------- stream
function connect() {
  const es = new EventSource('/events');
  let count = 0, t0 = performance.now();
  es.addEventListener('open', () => { $('conn').dataset.state = 'live'; $('conn').textContent = 'live'; });
  es.addEventListener('error', () => { $('conn').dataset.state = 'lost'; $('conn').textContent = 'reconnecting…'; });
  es.addEventListener('markers', (e) => {
    const msg = JSON.parse(e.data);
    drawMarkers(msg);
    drawBodies(msg);  // bodies.js
    state.updates++;
    count++;
    const dt = (performance.now() - t0) / 1000;
    if (dt > 2) { $('rate').textContent = `${fmt(count / dt, 1)} updates/s`; count = 0; t0 = performance.now(); }
    document.body.dataset.updates = state.updates;
    if (stopAfter && state.updates >= stopAfter) { es.close(); document.body.dataset.done = '1'; }
  });
  es.addEventListener('status', (e) => {
    state.status = JSON.parse(e.data);
    drawHealth(state.status);
  });
}

async function start() {
  state.layout = await (await fetch('/layout.json')).json();
  buildMap();
  startCameraView();
  connect();
}
start();
