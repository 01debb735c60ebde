// A plan drawn over the map: the trajectory coloured by horizontal speed (dotted where ground
// drawn lies over it), the A* path dashed, the requested and snapped start and goal with their
// ground's height; in the top view's SVG overlay and as the 3D view's lines and points.

import { heatColor, css } from './colors.js';
import { metres } from './map_model.js';

const SVG_NS = 'http://www.w3.org/2000/svg';
const START_COLOR = [60, 200, 90];
const GOAL_COLOR = [235, 80, 70];
const NEAREST_COLOR = [250, 210, 60];

function svg(name, attributes) {
  const e = document.createElementNS(SVG_NS, name);
  for (const [k, v] of Object.entries(attributes)) e.setAttribute(k, v);
  return e;
}

function position(v) {
  return [v.x || 0, v.y || 0, v.z || 0];
}

// What to draw for a plan: `samples` (sampleTrajectory), `response` (PlanResponse, or null for
// a failed plan), `request` (PlanRequest), `nearest` ({ point: [x, y, z], ground: its ground's
// height [m] or null, which }) for an off-ground start or goal; `covered(x, y, z)` tells whether
// ground drawn in the top view (its storey shown, not cut away) lies over a point in its
// column (segments there are drawn dotted: the trajectory passes under it).
export function planDrawing({
  samples = [], response = null, request = null, nearest = null, length = 0, covered = () => false,
}) {
  const maxSpeed = response ? response.profile.max_speed_horizontal_mps : 1;
  const segments = [];
  for (let i = 1; i < samples.length; ++i) {
    const speed = 0.5 * (samples[i - 1].speed + samples[i].speed);
    const a = samples[i - 1].p;
    const b = samples[i].p;
    segments.push({
      a, b, color: heatColor(speed / maxSpeed), covered: covered((a[0] + b[0]) / 2, (a[1] + b[1]) / 2, (a[2] + b[2]) / 2),
    });
  }
  const path = response ? (response.search_path_m || []).map(position) : [];
  const markers = [];
  const requested = (state, color, label) => {
    if (state && state.position_m) {
      const [x, y, z] = position(state.position_m);
      markers.push({ x, y, z, color: css(color), rgb: color, hollow: true, label: response ? '' : label });
    }
  };
  if (request) {
    requested(request.start, START_COLOR, 'start');
    requested(request.goal, GOAL_COLOR, 'goal');
  }
  if (response) {
    for (const [which, color] of [['start', START_COLOR], ['goal', GOAL_COLOR]]) {
      const snapped = response[which];
      const [x, y, z] = position(snapped.position_m);
      markers.push({ x, y, z, color: css(color), rgb: color, id: `${which}-marker`, label: `${which} · ground ${metres(snapped.ground_height_m ?? 0)} m` });
    }
  }
  if (nearest) {
    const [x, y, z] = nearest.point;
    markers.push({ x, y, z, color: css(NEAREST_COLOR), rgb: NEAREST_COLOR, id: 'nearest-marker', label: `nearest valid ${nearest.which}${nearest.ground === null ? '' : ` · ground ${metres(nearest.ground)} m`}` });
  }
  return { segments, path, markers, maxSpeed, length };
}

// Into the top view's world group (lines keep their width at every zoom).
export function drawSvg(worldGroup, drawing) {
  worldGroup.replaceChildren();
  if (drawing.path.length > 1) {
    worldGroup.appendChild(svg('polyline', {
      id: 'search-path',
      class: 'path',
      'vector-effect': 'non-scaling-stroke',
      points: drawing.path.map(([x, y]) => `${x},${y}`).join(' '),
    }));
  }
  if (drawing.segments.length > 0) {
    const group = svg('g', {
      id: 'trajectory',
      class: 'trajectory',
      'data-length-m': drawing.length.toFixed(4),
      'data-segments': drawing.segments.length,
    });
    for (const { a, b, color, covered } of drawing.segments) {
      const line = svg('line', {
        x1: a[0], y1: a[1], x2: b[0], y2: b[1], stroke: css(color), 'vector-effect': 'non-scaling-stroke',
      });
      if (covered) line.setAttribute('class', 'covered');
      group.appendChild(line);
    }
    worldGroup.appendChild(group);
  }
}

// As the 3D view's overlay items.
export function orbitItems(drawing) {
  const items = [];
  if (drawing.segments.length > 0) {
    const points = [drawing.segments[0].a, ...drawing.segments.map((s) => s.b)];
    const colors = [drawing.segments[0].color, ...drawing.segments.map((s) => s.color)];
    items.push({ name: 'trajectory', mode: 'LINE_STRIP', points, colors });
    // WebGL draws lines one pixel wide: points along them make the trajectory stand out.
    items.push({ name: 'trajectory-points', mode: 'POINTS', points, colors, pointFactor: 1.5 });
  }
  if (drawing.path.length > 1) {
    items.push({ name: 'path', mode: 'LINE_STRIP', points: drawing.path, colors: drawing.path.map(() => [255, 255, 255]) });
  }
  if (drawing.markers.length > 0) {
    items.push({
      name: 'markers',
      mode: 'POINTS',
      points: drawing.markers.map((m) => [m.x, m.y, m.z]),
      colors: drawing.markers.map((m) => m.rgb),
      labels: drawing.markers.map((m) => m.label),
      pointFactor: 6,
    });
  }
  return items;
}
