// ipsd live view, rigid bodies (docs/bodies.md): each body on the floor map as its markers'
// plates seen from above (from /layout.json), turned by the body's yaw, with a heading arrow,
// its name, its markers and cameras, and a trail; plus the "Bodies" table. A body known by
// position only (no yaw: e.g. a lone cube side seen without the top) is drawn as a dashed ring
// without plates or arrow. Each body is a <g class="body" data-name data-x data-y data-z
// data-yaw data-has-yaw data-ids data-cameras data-age data-speed> so that tools and tests
// can read back what is drawn. Uses app.js's helpers (el, $, fmt, cell, state, cameraNames); loaded first,
// called only from app.js.
'use strict';

const BODY_TRAIL = 60;  // positions kept per body
const bodyViews = new Map();  // name -> { g, trail, points, row }; names may hold any character

function bodyShape(name) {
  return (state.layout.bodies || []).find((b) => b.name === name) || { markers: [] };
}

function newBodyView(name) {
  const g = el('g', { class: 'body' }, $('bodies'));
  g.dataset.name = name;
  const shape = el('g', { class: 'shape' }, g);
  for (const m of bodyShape(name).markers) {
    const p = el('polygon', { class: 'plate', points: m.outline.map(([x, y]) => `${x},${-y}`).join(' ') }, shape);
    p.dataset.id = m.id;
  }
  el('line', { class: 'heading', x1: 0, y1: 0, x2: 0.32, y2: 0 }, shape);
  el('circle', { class: 'origin', r: 0.045 }, g);
  el('circle', { class: 'unknown-yaw', r: 0.16 }, g);
  el('text', { class: 'label', x: 0.16, y: -0.16 }, g);
  el('text', { class: 'sub', x: 0.16, y: 0.22 }, g);
  const trail = el('polyline', { class: 'body-trail' }, $('trails'));
  trail.dataset.body = name;
  const row = document.createElement('tr');
  row.dataset.body = name;
  $('bodies-table').querySelector('tbody').appendChild(row);
  const v = { g, trail, points: [], row };
  bodyViews.set(name, v);
  return v;
}

function drawBodyRow(tr, b, cams) {
  tr.textContent = '';
  cell(tr, 'name', b.name, b.name);
  cell(tr, 'x', b.x, fmt(b.x, 3), true);
  cell(tr, 'y', b.y, fmt(b.y, 3), true);
  cell(tr, 'z', b.z, fmt(b.z, 3), true);
  // Ranges alone: the last measured heading, held (shown in brackets).
  const held = !b.has_yaw && (b.sources || []).includes('ranges');
  const yawText = b.has_yaw ? fmt(b.yaw * 180 / Math.PI, 1) : held ? `(${fmt(b.yaw * 180 / Math.PI, 1)})` : '–';
  cell(tr, 'yaw_deg', b.has_yaw || held ? b.yaw * 180 / Math.PI : null, yawText, true);
  const speed = b.vx === undefined ? null : Math.hypot(b.vx, b.vy);
  cell(tr, 'speed', speed, fmt(speed, 2), true);
  cell(tr, 'ids', b.ids.join(','), b.ids.join(' ') + (b.id_count > b.ids.length ? ' …' : ''));
  cell(tr, 'cameras', cams.join(','), placedBy(cams, b.sources || ['camera']));
  cell(tr, 'age', b.age, fmt(b.age, 1), true);
}

function drawBodies(msg) {
  const bodies = msg.bodies || [];
  $('bodies-panel').hidden = bodies.length === 0 && (state.layout.bodies || []).length === 0;
  const seen = new Set();
  for (const b of bodies) {
    seen.add(b.name);
    const v = bodyViews.get(b.name) || newBodyView(b.name);
    const cams = cameraNames(b.cameras);
    v.g.setAttribute('transform', `translate(${b.x.toFixed(4)} ${(-b.y).toFixed(4)})`);
    // World y up, SVG y down: a turn by yaw in the world is a turn by -yaw on the map.
    v.g.querySelector('g.shape').setAttribute('transform', `rotate(${(-b.yaw * 180 / Math.PI).toFixed(2)})`);
    const speed = b.vx === undefined ? '' : Math.hypot(b.vx, b.vy);
    const sources = b.sources || ['camera'];
    Object.assign(v.g.dataset, { x: b.x, y: b.y, z: b.z, yaw: b.yaw, hasYaw: b.has_yaw ? 1 : 0,
                                 ids: b.ids.join(','), cameras: cams.join(','), sources: sources.join(','),
                                 age: b.age, speed });
    v.g.classList.toggle('ranged', !sources.includes('camera'));
    v.g.classList.toggle('stale', b.age > STALE_S);
    v.g.classList.toggle('no-yaw', !b.has_yaw);
    v.g.querySelector('text.label').textContent = b.name;
    v.g.querySelector('text.sub').textContent =
        `markers ${b.ids.join(' ') || '–'} · ${placedBy(cams, sources)} · ${fmt(b.age, 1)} s`;
    const last = v.points[v.points.length - 1];
    if (!last || Math.hypot(last[0] - b.x, last[1] - b.y) > 0.005) v.points.push([b.x, b.y]);
    if (v.points.length > BODY_TRAIL) v.points.shift();
    v.trail.setAttribute('points', v.points.map(([x, y]) => `${x.toFixed(3)},${(-y).toFixed(3)}`).join(' '));
    drawBodyRow(v.row, b, cams);
  }
  for (const [name, v] of [...bodyViews]) {
    if (seen.has(name)) continue;  // the daemon's stream forgets a body 10 s after its last update
    v.g.remove();
    v.trail.remove();
    v.row.remove();
    bodyViews.delete(name);
  }
}
