// The viewer's page: the map list, a map's views, the plan form and its result, errors in
// plain words, and the recent plans. Everything comes from the JSON API (api.js), which
// answers the gRPC API's messages.

import { ApiError, call, errorFromPlanError, setToken, token } from './api.js';
import { heatColor, heightColor, scaleCanvas } from './colors.js';
import { MapModel, metres } from './map_model.js';
import { OrbitView } from './orbit_view.js';
import { drawSvg, orbitItems, planDrawing } from './plan_overlay.js';
import { drawProfile } from './profile_view.js';
import { TopView } from './top_view.js';
import { Traffic } from './traffic.js';
import { polylineLength, sampleTrajectory } from './trajectory.js';

const $ = (id) => document.getElementById(id);
// Added to the ground's height when a click picks a point: about a robot's reference height,
// so that the z points at the ground clicked (Plan snaps it; README "Planning through the
// service").
const PICK_HEIGHT_M = 0.3;

const state = {
  maps: [],
  mapId: null,
  map: null,
  model: null,
  // storeys: the storeys shown (indices into the model's storeys); cutZ: surfaces above this
  // height [m] are cut away (Infinity: none).
  style: { storeys: new Set([0]), obstacles: true, color: 'height', components: null, cutZ: Infinity },
  view: 'top',
  shown: null,  // { request, response, error, samples }
  traffic: null,  // Traffic of the map shown, when it has reservations.
};

const topView = new TopView($('top-canvas'), $('overlay'), {
  onPick: (x, y) => pick(x, y),
  onHover: (x, y) => hover(x, y),
});
const orbitView = new OrbitView($('orbit-canvas'), $('orbit-labels'));

// ---- Formatting ----

function text(tag, content, attributes = {}) {
  const e = document.createElement(tag);
  if (content !== undefined) e.textContent = content;
  for (const [k, v] of Object.entries(attributes)) e.setAttribute(k, v);
  return e;
}

// Where a start or goal landed, from the point asked for: on it, or moved to a column's centre.
function snapped(state, asked) {
  if (!asked) return '';
  const moved = Math.hypot(state.position_m.x - asked.x, state.position_m.y - asked.y);
  return moved < 1e-3 ? '(as asked)' : `(moved ${fixed(moved)} m)`;
}

// An element holding `value` that may wrap after its _ - . / (a long map id in the list).
function breakable(tag, value, attributes = {}) {
  const e = text(tag, undefined, attributes);
  value.split(/(?<=[_\-./])/).forEach((part, i) => {
    if (i > 0) e.appendChild(document.createElement('wbr'));
    e.appendChild(document.createTextNode(part));
  });
  return e;
}

function fixed(value, digits = 2) {
  return Number(value || 0).toFixed(digits);
}

// 1st, 2nd, 3rd, 4th, ..., 11th, 12th, 13th, ..., 21st.
function ordinal(n) {
  const suffix = n % 100 >= 11 && n % 100 <= 13 ? 'th' : ['th', 'st', 'nd', 'rd'][n % 10] || 'th';
  return `${n}${suffix}`;
}

function point(v) {
  return `(${fixed(v.x)}, ${fixed(v.y)}, ${fixed(v.z)})`;
}

function figures(dl, rows) {
  dl.replaceChildren();
  for (const [name, value, id] of rows) {
    dl.appendChild(text('dt', name));
    dl.appendChild(text('dd', value, id ? { id } : {}));
  }
}

function parsePoint(value) {
  const parts = value.split(',').map((s) => Number(s.trim()));
  if (parts.length !== 3 || parts.some((n) => !Number.isFinite(n))) return null;
  return { x: parts[0], y: parts[1], z: parts[2] };
}

// ---- Maps ----

async function loadMaps() {
  const error = $('maps-error');
  let maps = [];
  try {
    maps = (await call('strata.v1.MapService/ListMaps', { page_size: 1000 })).maps;
    error.hidden = true;
  } catch (e) {
    error.hidden = false;
    error.textContent = plainWords(e);
  }
  showMaps(maps);
  // Poll while a map is being made.
  if (maps.some((m) => m.state === 'MAP_STATE_CREATING')) setTimeout(loadMaps, 2000);
}

// The list of maps. A row keeps its size as its map is made (viewer.css reserves the columns'
// widths; the progress is a bar behind "creating", its figure in the tooltip), so that nothing
// below the list moves under a click when a map turns active.
function showMaps(maps) {
  state.maps = maps;
  const body = $('maps').tBodies[0];
  body.replaceChildren();
  for (const map of maps) {
    const row = text('tr', undefined, { 'data-map-id': map.id });
    row.appendChild(breakable('td', map.id, { class: 'id', title: map.id }));
    const stateCell = text('td', map.state.replace('MAP_STATE_', '').toLowerCase(),
      { class: `state state-${map.state}` });
    if (map.state === 'MAP_STATE_CREATING') {
      const done = Math.round(100 * (map.progress || 0));
      stateCell.style.setProperty('--done', `${done}%`);
      stateCell.title = `being made: ${done}% done`;
    }
    if (map.failure && map.failure.reason) stateCell.title = `${map.failure.reason}: ${map.failure.message}`;
    row.appendChild(stateCell);
    row.appendChild(text('td', Number(map.valid_ground_point_count).toLocaleString('en')));
    row.appendChild(text('td', map.max_levels));
    row.appendChild(text('td', fixed(Number(map.memory_bytes) / 1048576, 1)));
    row.appendChild(text('td', (map.version || '').slice(0, 8), { title: map.version || '' }));
    if (map.id === state.mapId) row.classList.add('selected');
    row.addEventListener('click', () => selectMap(map.id));
    body.appendChild(row);
  }
  $('server-note').textContent = `${maps.length} map${maps.length === 1 ? '' : 's'}`;
}

async function selectMap(id) {
  state.mapId = id;
  history.replaceState(null, '', `#map=${encodeURIComponent(id)}`);  // A link to this map.
  for (const row of $('maps').tBodies[0].rows) row.classList.toggle('selected', row.dataset.mapId === id);
  $('map-section').hidden = false;
  $('landing').hidden = true;
  $('map-title').textContent = id;
  $('geometry-note').textContent = 'loading…';
  let map;
  try {
    map = await call('strata.v1.MapService/GetMap', { map_id: id });
  } catch (e) {
    $('geometry-note').textContent = plainWords(e);
    return;
  }
  state.map = map;
  const b = map.bounds_m;
  const seconds = map.assessment_seconds;
  figures($('map-figures'), [
    ['state', map.state.replace('MAP_STATE_', '').toLowerCase()],
    ['version', map.version || '—'],
    ['bounds', b ? `${point(b.min_m)} – ${point(b.max_m)} m` : '—'],
    ['grid', `${map.grid_size.nx} × ${map.grid_size.ny} × ${map.grid_size.nz} at ${map.terrain.resolution_m} m`],
    ['points', `${Number(map.input_point_count).toLocaleString('en')} (valid ground ${Number(map.valid_ground_point_count).toLocaleString('en')})`],
    ['levels', `${map.max_levels} at most in a column (${Number(map.valid_surface_count).toLocaleString('en')} ground surfaces)`],
    ['memory', `${fixed(Number(map.memory_bytes) / 1048576, 1)} MiB (terrain model and the robot graphs cached so far)`],
    ['assessed in', `${fixed(seconds.total_s, 3)} s (load ${fixed(seconds.load_s, 3)} s)${map.from_saved_model ? ', saved model' : ''}`],
  ]);
  if (map.state !== 'MAP_STATE_ACTIVE') {
    $('geometry-note').textContent = map.failure && map.failure.reason
      ? `${map.failure.reason}: ${map.failure.message}` : 'not active yet';
    $('plan-section').hidden = true;
    return;
  }
  await loadGeometry(id);
  await loadTraffic(id);
}

// ---- Traffic: the robots' reservations, at the slider's time ----

function showTrafficAt(time) {
  const traffic = state.traffic;
  traffic.draw($('traffic'), time);
  const conflicts = Number($('traffic').dataset.conflicts);
  const replanned = traffic.robots.filter((r) => r.replannedFor).length;
  $('traffic-note').textContent = `${new Date(time * 1000).toISOString()}: ${traffic.robots.length} `
    + `robot(s)${conflicts ? `, ${conflicts} in conflict` : ''}`
    + `${replanned ? `, ${replanned} replanned to let another pass first (dashed)` : ''}`;
}

async function loadTraffic(id) {
  let listing;
  try {
    listing = await call('strata.v1.TrafficService/ListReservations', { map_id: id });
  } catch (e) {
    $('traffic-section').hidden = false;
    $('traffic-note').textContent = plainWords(e);
    return;
  }
  if (id !== state.mapId) return;
  $('traffic').replaceChildren();
  $('traffic-section').hidden = false;
  const slider = $('traffic-time');
  if (!(listing.reservations || []).length) {
    state.traffic = null;
    slider.hidden = true;
    $('traffic-note').textContent = 'no reservations on this map';
    return;
  }
  state.traffic = new Traffic(listing);
  slider.hidden = false;
  slider.min = state.traffic.from;
  slider.max = state.traffic.until;
  slider.value = Math.min(Math.max(Date.now() / 1000, state.traffic.from), state.traffic.until);
  showTrafficAt(Number(slider.value));
}

async function loadGeometry(id, robot = null) {
  const request = { map_id: id, include_safety: true };
  if (robot) request.profile_name = robot;
  const started = performance.now();
  const geometry = await call('strata.v1.MapService/GetMapGeometry', request);
  if (state.mapId !== id) return null;
  const model = new MapModel(geometry);
  state.model = model;
  if (!robot) {
    state.style.storeys = new Set(model.storeys.keys());
    state.style.color = $('show-safety').checked ? 'safety' : 'height';
    state.style.components = null;
    buildStoreyControls(model);
    buildCutControl(model);
    clearPlan();
  }
  $('geometry-note').textContent =
    `${model.surfaceCount.toLocaleString('en')} surfaces, display cell ${fixed(geometry.cell_size_m, 2)} m` +
    `${geometry.stride > 1 ? ` (${geometry.stride} × ${geometry.stride} grid columns)` : ''}, ` +
    `loaded in ${Math.round(performance.now() - started)} ms`;
  topView.setModel(model, Boolean(robot));
  orbitView.setModel(model, state.style);
  if (!robot) orbitView.fit();
  restyle();
  $('plan-section').hidden = false;
  // Marks the first frame with the map drawn (bench/viewer_bench.py reads it).
  requestAnimationFrame(() => requestAnimationFrame(() => {
    performance.mark(`strata-map-drawn:${id}`);
    document.body.dataset.mapDrawn = id;
  }));
  return model;
}

// A box per storey (map_model.js findStoreys), named by its floor's height; its tooltip gives
// the heights it holds. Unticking one hides exactly those heights, ground and obstacle tops, in
// both views, and from what a click picks and what the plan is drawn dotted under.
function buildStoreyControls(model) {
  const box = $('storeys');
  box.replaceChildren(text('span', 'storeys'));
  model.storeys.forEach((storey, s) => {
    // The band: from the lowest surface (in the lowest storey) to the highest (in the top one).
    const next = model.storeys[s + 1];
    const from = s === 0 ? storey.zMin : storey.from;
    const to = next ? next.from : storey.zMax;
    const band = from <= to ? `${metres(from)} … ${metres(to)} m` : 'no surface';
    const label = text('label', undefined, {
      title: storey.floorZ === null
        ? `every height (${band}): no floor stands out among the ground's heights`
        : `${band}: the floor at ${metres(storey.floorZ)} m with the ramps and obstacle tops at these heights`,
    });
    const input = text('input', undefined, { type: 'checkbox', 'data-storey': s });
    input.checked = true;
    input.addEventListener('change', () => {
      if (input.checked) state.style.storeys.add(s);
      else state.style.storeys.delete(s);
      topView.requestRender();
      orbitView.storeys = state.style.storeys;
      orbitView.requestRender();
      // What a storey covers changes with it.
      if (state.shown && state.shown.response) showPlan(state.shown.request, state.shown.response);
    });
    label.append(input, ` ${storey.name}`);
    box.appendChild(label);
  });
}

// The "cut above" slider: from the map's lowest ground to its highest (no cut), by 0.1 m.
function buildCutControl(model) {
  const slider = $('cut');
  slider.min = (Math.floor(model.zMin * 10) / 10).toFixed(1);
  slider.max = (Math.ceil(model.zMax * 10) / 10).toFixed(1);
  slider.value = slider.max;
  applyCut();
}

function applyCut() {
  const slider = $('cut');
  const value = Number(slider.value);
  state.style.cutZ = value >= Number(slider.max) ? Infinity : value;
  $('cut-value').textContent = Number.isFinite(state.style.cutZ) ? `${fixed(value, 1)} m` : 'none';
  orbitView.setCut(state.style.cutZ);
  if (!state.model) return;
  // The top view's images and what the plan passes under follow the cut: once a frame while
  // the slider moves.
  if (applyCut.frame) return;
  applyCut.frame = requestAnimationFrame(() => {
    applyCut.frame = null;
    topView.setStyle(state.style);
    if (state.shown && state.shown.response) showPlan(state.shown.request, state.shown.response);
  });
}

function restyle() {
  if (!state.model) return;
  topView.setStyle(state.style);
  orbitView.setModel(state.model, state.style);
  drawLegend();
}

function drawLegend() {
  const legend = $('legend');
  legend.replaceChildren();
  const row = (title, colorOf, low, high) => {
    legend.appendChild(text('div', title));
    legend.appendChild(scaleCanvas(colorOf));
    const ends = text('div', undefined, { class: 'ends' });
    ends.append(text('span', low), text('span', high));
    legend.appendChild(ends);
  };
  const m = state.model;
  if (state.style.color === 'components') {
    legend.appendChild(text('div', "start's ground: green · goal's ground: orange · other: grey"));
  } else if (state.style.color === 'safety') {
    row("safety field S'", heatColor, '0', fixed(m.safetyMax, 2));
  } else {
    row('ground height [m]', heightColor, fixed(m.zMin, 1), fixed(m.zMax, 1));
  }
  if (state.shown && state.shown.response) {
    row('speed [m/s]', heatColor, '0', fixed(state.shown.response.profile.max_speed_horizontal_mps, 1));
  }
}

// ---- Picking ----

// Whether ground at height z [m] is drawn: its storey ticked and not cut away.
function shownGround(z) {
  return state.style.storeys.has(state.model.storeyOf(z)) && z <= state.style.cutZ;
}

// Whether ground drawn lies over the reference point (x, y, z) in its column: more than half
// a metre above it, so the robot's own ground never counts.
function covered(x, y, z) {
  const ground = state.model ? state.model.topGround(x, y, shownGround) : null;
  return ground !== null && ground.z > z + 0.5;
}

function pick(x, y) {
  if (!state.model) return;
  const ground = state.model.topGround(x, y, shownGround);
  if (!ground) return;
  const which = document.querySelector('input[name=pick]:checked').value;
  $(which).value = `${fixed(x)},${fixed(y)},${fixed(ground.z + PICK_HEIGHT_M)}`;
  if (which === 'start') document.querySelector('input[name=pick][value=goal]').checked = true;
  showRequested();
}

function hover(x, y) {
  const cursor = $('cursor');
  if (x === null || !state.model) {
    cursor.textContent = '';
    return;
  }
  // The storey, and the ground's place in its column (the level a plan's snapped state names).
  const ground = state.model.topGround(x, y, shownGround);
  cursor.textContent = `x ${fixed(x)}  y ${fixed(y)}` + (ground
    ? `  ground ${fixed(ground.z)} m (storey "${state.model.storeys[ground.storey].name}", ${ordinal(ground.level + 1)} ground of its column)`
    : '');
}

// The start and goal typed or clicked, before a plan.
function showRequested() {
  const request = { start: { position_m: parsePoint($('start').value) }, goal: { position_m: parsePoint($('goal').value) } };
  if (!request.start.position_m) delete request.start.position_m;
  if (!request.goal.position_m) delete request.goal.position_m;
  showDrawing(planDrawing({ request }));
}

// ---- Plans ----

function clearPlan() {
  state.shown = null;
  $('plan-result').replaceChildren();
  showDrawing(planDrawing({}));
  drawProfile($('profile'), [], null, null);
}

function showDrawing(drawing) {
  drawSvg($('plan-layer'), drawing);
  topView.setMarkers(drawing.markers);
  orbitView.setOverlay(orbitItems(drawing));
}

async function plan(event) {
  event.preventDefault();
  const start = parsePoint($('start').value);
  const goal = parsePoint($('goal').value);
  if (!start || !goal) {
    showError(new ApiError({ code: 'INVALID_ARGUMENT', reason: 'INVALID_INPUT', message: 'give start and goal as x,y,z in metres (or click the map)' }), null);
    return;
  }
  const request = {
    map_id: state.mapId,
    profile_name: $('robot').value,
    start: { position_m: start },
    goal: { position_m: goal },
    options: { return_search_path: true },
  };
  const budget = Number($('budget').value);
  if ($('budget').value.trim() !== '' && Number.isFinite(budget)) request.options.time_budget_s = budget;
  const button = $('plan');
  button.disabled = true;
  $('plan-result').replaceChildren(text('p', 'planning…', { class: 'note' }));
  try {
    const response = await call('strata.v1.PlannerService/Plan', request);
    showPlan(request, response);
  } catch (e) {
    showError(e, request);
  } finally {
    button.disabled = false;
    loadRecent();
  }
}

function showPlan(request, response) {
  const samples = sampleTrajectory(response.trajectory);
  const drawnLength = polylineLength(samples);
  state.shown = { request, response, samples };
  if (state.style.color === 'components') {
    state.style.color = $('show-safety').checked ? 'safety' : 'height';
    restyle();
  }
  showDrawing(planDrawing({ samples, response, request, length: drawnLength, covered }));
  const s = response.stats;
  const t = s.timings;
  const result = $('plan-result');
  result.replaceChildren();
  const dl = text('dl', undefined, { class: 'figures', id: 'plan-figures' });
  figures(dl, [
    ['length', `${fixed(s.length_m)} m`, 'plan-length'],
    ['duration', `${fixed(s.duration_s)} s`],
    ['start', `${point(response.start.position_m)} ground ${fixed(response.start.ground_height_m ?? 0)} m ${snapped(response.start, request.start.position_m)}`],
    ['goal', `${point(response.goal.position_m)} ground ${fixed(response.goal.ground_height_m ?? 0)} m ${snapped(response.goal, request.goal.position_m)}`],
    ['max speed', `${fixed(s.max_speed_horizontal_mps)} m/s horizontal, ${fixed(s.max_speed_vertical_mps)} vertical`],
    ['max accel.', `${fixed(s.max_accel_horizontal_mps2)} m/s² horizontal, ${fixed(s.max_accel_vertical_mps2)} vertical`],
    ['mean curvature', `${fixed(s.mean_curvature_per_m, 3)} 1/m`],
    ['clearance', `${fixed(s.min_obstacle_distance_m)} m to obstacles, ${s.min_headroom_m === undefined ? 'no ceiling' : `${fixed(s.min_headroom_m)} m headroom`}`],
    ['body height', response.trajectory.dimension === 4 ? `${fixed(s.min_body_height_m)} m at its lowest (commanded)` : `${fixed(response.profile.body_height_m)} m (fixed)`],
    ['pieces', `${s.pieces}, ${s.search_expansions} A* expansions, ${s.optimizer_iterations} L-BFGS iterations`],
    ['planned in', `${fixed(t.total_s * 1000, 1)} ms (queue ${fixed(t.queue_s * 1000, 1)}, graph ${fixed(t.graph_s * 1000, 1)}, snap ${fixed(t.snap_s * 1000, 1)}, search ${fixed(t.search_s * 1000, 1)}, optimise ${fixed(t.optimize_s * 1000, 1)}, verify ${fixed(t.verify_s * 1000, 1)})`],
    ['map version', response.map_version.slice(0, 12)],
  ]);
  dl.dataset.lengthM = s.length_m;
  result.appendChild(dl);
  redrawProfile();
  drawLegend();
}

// The side profile of the plan shown, at the profile's size (again when it changes).
function redrawProfile() {
  const shown = state.shown;
  if (shown && shown.response) drawProfile($('profile'), shown.samples, shown.response.profile, state.model);
  else drawProfile($('profile'), [], null, null);
}

// The ground under the nearest point an off-ground start or goal could take (its reference
// point, ErrorInfo's nearest_x_m, ...) [m], or null.
function nearestGround(m) {
  if (!state.model) return null;
  return state.model.groundBelow(Number(m.nearest_x_m), Number(m.nearest_y_m), Number(m.nearest_z_m));
}

// An error in plain words: what went wrong and what to do, from its reason and details.
function plainWords(error) {
  const m = error.metadata || {};
  switch (error.reason) {
    case 'START_OFF_GROUND':
    case 'GOAL_OFF_GROUND': {
      const which = error.reason === 'START_OFF_GROUND' ? 'start' : 'goal';
      if (m.nearest_x_m === undefined) return `The ${which} is not on ground this robot can stand on, and the map has none for it.`;
      const ground = nearestGround(m);
      return `The ${which} is not on ground this robot can stand on. The nearest point it can reach is ` +
        `(${fixed(m.nearest_x_m)}, ${fixed(m.nearest_y_m)}, ${fixed(m.nearest_z_m)})` +
        `${ground === null ? '' : ` over ground ${metres(ground)} m`}, ${fixed(m.nearest_distance_m)} m away (marked in yellow).`;
    }
    case 'GOAL_UNREACHABLE':
      if (m.zones_in_the_way) return `Keep-out zones close every way from the start to the goal: ${m.zones_in_the_way}.`;
      if (m.start_component !== undefined) {
        return `The start and the goal lie on ground that does not connect for this robot: the start's ` +
          `region (${Number(m.start_component_nodes).toLocaleString('en')} cells, green) and the goal's ` +
          `(${Number(m.goal_component_nodes).toLocaleString('en')} cells, orange) are shown.`;
      }
      return 'The goal cannot be reached from the start.';
    case 'START_IN_KEEP_OUT':
    case 'GOAL_IN_KEEP_OUT':
      return `The robot would ${error.reason === 'START_IN_KEEP_OUT' ? 'start' : 'end'} inside a keep-out zone.`;
    case 'TIME_BUDGET_EXCEEDED': return 'The plan ran out of time: allow a larger time budget.';
    case 'SERVER_BUSY': return 'Every planning slot of the server is busy: try again in a moment.';
    case 'MAP_NOT_ACTIVE': return 'The map is not ready (still being made, or it failed).';
    case 'MAP_NOT_FOUND': return 'The map is gone (deleted since the list was loaded).';
    case 'UNAUTHENTICATED': return 'This server needs a token: enter it at the top right.';
    case 'PERMISSION_DENIED': return "This token's role may not do that.";
    case 'PROFILE_MISMATCH': return 'The map was assessed for a smaller robot or gentler slopes than this robot needs.';
    case 'OPTIMIZATION_FAILED': return 'No trajectory passed the final check; the message names the first violation.';
    case 'UNREACHABLE': return 'The server does not answer.';
    default: return 'The server refused the request.';
  }
}

function showError(error, request) {
  state.shown = { request, error };
  if (state.style.color === 'components') {
    // An earlier unreachable goal's colouring says nothing about this error.
    state.style.color = $('show-safety').checked ? 'safety' : 'height';
    restyle();
  }
  const result = $('plan-result');
  result.replaceChildren();
  const box = text('div', undefined, { class: 'error', id: 'plan-error', 'data-reason': error.reason });
  box.appendChild(text('p', plainWords(error), { class: 'words' }));
  const detail = text('p');
  detail.append(text('span', error.reason, { class: 'reason' }), ` (${error.code}): ${error.message}`);
  box.appendChild(detail);
  for (const v of error.violations || []) box.appendChild(text('p', `${v.field}: ${v.description}`));
  result.appendChild(box);
  const m = error.metadata || {};
  let nearest = null;
  if (m.nearest_x_m !== undefined) {
    nearest = {
      point: [Number(m.nearest_x_m), Number(m.nearest_y_m), Number(m.nearest_z_m)],
      ground: nearestGround(m),
      which: error.reason === 'START_OFF_GROUND' ? 'start' : 'goal',
    };
    const use = text('button', `use the nearest ${nearest.which}`, { type: 'button' });
    use.addEventListener('click', () => {
      $(nearest.which).value = nearest.point.map((v) => fixed(v)).join(',');
      showRequested();
    });
    box.appendChild(use);
  }
  showDrawing(planDrawing({ request, nearest }));
  drawProfile($('profile'), [], null, null);
  if (error.reason === 'GOAL_UNREACHABLE' && m.start_component !== undefined && request) {
    showComponents(request.profile_name, Number(m.start_component), Number(m.goal_component));
  }
}

// Colours the two components of an unreachable goal (the robot's graph, from GetMapGeometry).
async function showComponents(robot, start, goal) {
  try {
    await loadGeometry(state.mapId, robot);
  } catch (e) {
    return;
  }
  state.style.color = 'components';
  state.style.components = { start, goal };
  restyle();
}

// ---- Recent plans ----

async function loadRecent() {
  let response;
  try {
    response = await call('strata.v1.PlannerService/ListRecentPlans', { max_plans: 20 });
  } catch (e) {
    return;
  }
  const list = $('recent');
  list.replaceChildren();
  for (const recent of response.plans) {
    const r = recent.request;
    const when = new Date(recent.time).toLocaleTimeString();
    const robot = r.profile_name || (r.profile && r.profile.name) || 'inline profile';
    const outcome = recent.response
      ? `${fixed(recent.response.stats.length_m, 1)} m, ${fixed(recent.response.stats.duration_s, 1)} s`
      : recent.error.reason;
    const item = text('li', `${when} ${r.map_id} ${robot} via ${recent.transport}: ${outcome}${recent.trimmed ? ' (trimmed)' : ''}`,
      recent.error ? { class: 'failed' } : {});
    item.addEventListener('click', () => showRecent(recent));
    list.appendChild(item);
  }
}

async function showRecent(recent) {
  const r = recent.request;
  if (r.map_id !== state.mapId) await selectMap(r.map_id);
  if (r.start && r.start.position_m) $('start').value = [r.start.position_m.x, r.start.position_m.y, r.start.position_m.z].map((v) => fixed(v)).join(',');
  if (r.goal && r.goal.position_m) $('goal').value = [r.goal.position_m.x, r.goal.position_m.y, r.goal.position_m.z].map((v) => fixed(v)).join(',');
  if (r.profile_name) $('robot').value = r.profile_name;
  if (recent.response && recent.response.trajectory) showPlan(r, recent.response);
  else if (recent.error) showError(errorFromPlanError(recent.error), r);
}

// ---- Wiring ----

$('plan-form').addEventListener('submit', plan);
$('start').addEventListener('change', showRequested);
$('goal').addEventListener('change', showRequested);
$('refresh-maps').addEventListener('click', loadMaps);
$('refresh-recent').addEventListener('click', loadRecent);
$('refresh-traffic').addEventListener('click', () => { if (state.mapId) loadTraffic(state.mapId); });
$('traffic-time').addEventListener('input', (e) => { if (state.traffic) showTrafficAt(Number(e.target.value)); });
$('show-obstacles').addEventListener('change', (e) => {
  state.style.obstacles = e.target.checked;
  restyle();
});
$('cut').addEventListener('input', applyCut);
new ResizeObserver(redrawProfile).observe($('profile'));
$('show-safety').addEventListener('change', (e) => {
  state.style.color = e.target.checked ? 'safety' : 'height';
  restyle();
});
for (const radio of document.querySelectorAll('input[name=view]')) {
  radio.addEventListener('change', () => {
    state.view = radio.value;
    const orbit = state.view === 'orbit';
    $('orbit-canvas').hidden = !orbit;
    $('orbit-labels').hidden = !orbit;
    $('top-canvas').hidden = orbit;
    $('overlay').style.visibility = orbit ? 'hidden' : 'visible';
    if (orbit) orbitView.show();
    else topView.requestRender();
  });
}
$('token').value = token();
$('token-form').addEventListener('submit', (e) => {
  e.preventDefault();
  setToken($('token').value.trim());
  loadMaps();
  loadRecent();
});
if (!orbitView.available) document.querySelector('input[name=view][value=orbit]').disabled = true;

// `#map=ID` in the address opens that map (a link to it; bench/viewer_bench.py times it).
async function start() {
  await Promise.all([loadMaps(), loadRecent()]);
  const wanted = new URLSearchParams(location.hash.slice(1)).get('map');
  if (wanted && state.maps.some((m) => m.id === wanted)) await selectMap(wanted);
}

// For tests and benchmarks (tests/server/viewer_browser_test.py, bench/viewer_bench.py).
window.strataViewer = {
  ready: start(),
  selectMap,
  showMaps,
  loadTraffic,
  measureFrames: (view, seconds) => (view === 'orbit' ? orbitView : topView).measureFrames(seconds),
  state,
  views: { top: topView, orbit: orbitView },
};
