// A map's geometry (strata.v1.MapGeometry) in typed arrays, with the queries the views need:
// the topmost visible ground under a point (clicks), the ground and the ceiling along a
// trajectory (the side profile), each surface's colour, and the map's storeys: the height
// bands the views show and hide one by one.

import {
  GOAL_COMPONENT_COLOR, OBSTACLE_COLOR, OTHER_COMPONENT_COLOR, START_COMPONENT_COLOR,
  heatColor, heightColor,
} from './colors.js';

// Storeys are found from the ground's heights alone. A floor is flat ground: its heights gather
// in a narrow window, where a ramp's or a hillside's spread out; a floor holds a large patch of
// one piece, where parked cars' roofs are many small ones and a wall's top is a thin line.

// Height window a floor's ground falls in [m]: a flat floor's display cells lie within a few
// centimetres of each other; a quarter metre takes a gentle fall (a deck's drainage slope)
// and stays well under the smallest step between floors a person names (a platform 1 m over
// the tracks, abandoned_station).
const FLOOR_WINDOW_M = 0.25;
// The window slides by this [m] (a fine histogram summed over FLOOR_WINDOW_M), so that a floor
// is found whole wherever fixed bins would have cut it (a floor at 0 m: heights -0.01 and 0.00).
const FLOOR_STEP_M = 0.05;
// A floor's largest flat patch holds at least this share of all ground surfaces [-]: the
// spiral's top deck holds 6 %, parking_garage's decks 11 % or more, two_level_ramp's deck
// 30 %; the roofs of outdoor_site's sheds and containers (under 3 %) and one parked car's
// (parking_garage, 0.2 %) are no storeys, nor is the reference map scene20.2's small hollow
// deck (under 4 %: the cut slider shows what lies under it).
const FLOOR_MIN_SHARE = 0.05;
// A floor's window holds at least this many times the ground of the window just below it and
// of the one just above it [-]: the heights of a floor make a spike (parking_garage's deck at
// 2.8 m: 13 % of the ground, 5 % just below it), those of rolling terrain a hump
// (uneven_forest's most common heights: 23 % of the ground, 13 % just below).
const FLOOR_CONTRAST = 2;
// A band's edge between two floors lies at their midpoint, unless ground gathers there: then
// it moves up, by this at most [m] (and a quarter of their gap), past it, so that what stands
// half way up a storey stays whole, with the floor it stands on (parking_garage: cars' roofs
// at 1.4 m, on the floor at 0 m with the next deck at 2.8 m).
const BAND_SHIFT_M = 0.5;
// Storeys the 3D view's shader shows and hides one by one (orbit_view.js): floors beyond
// these are merged into the top storey.
export const MAX_STOREYS = 16;

// A height to the decimetre, as labels give it ("0.0", never "-0.0").
export function metres(z) {
  return (Math.round(10 * z) / 10 + 0).toFixed(1);
}

// The largest 4-connected patch of display cells with ground in [lo, hi) whose four
// neighbours have ground there too (this erosion drops lines one or two cells wide: wall tops,
// kerbs, a ramp's edge), in cells. `mark`: scratch, one byte per display cell.
function largestFlatPatch(z, cell, nx, ny, lo, hi, mark) {
  const IN = 1;
  const COUNTED = 2;
  mark.fill(0);
  for (let i = 0; i < z.length; ++i) {
    if (z[i] >= lo && z[i] < hi) mark[cell[i]] = IN;
  }
  const interior = (c) => mark[c] === IN && mark[c - 1] && mark[c + 1] && mark[c - nx] && mark[c + nx];
  const stack = new Int32Array(nx * ny);
  let best = 0;
  // Cells on the grid's border have no four neighbours: the loops skip them, and so every
  // neighbour of an interior cell lies on the grid, c - 1 and c + 1 on its row.
  for (let cy = 1; cy + 1 < ny; ++cy) {
    for (let cx = 1; cx + 1 < nx; ++cx) {
      const start = cx + nx * cy;
      if (!interior(start)) continue;
      mark[start] = COUNTED;
      let top = 0;
      stack[top++] = start;
      let size = 0;
      while (top > 0) {
        const c = stack[--top];
        ++size;
        for (const next of [c - 1, c + 1, c - nx, c + nx]) {
          const x = next % nx;
          if (x > 0 && x + 1 < nx && next >= nx && next < nx * (ny - 1) && interior(next)) {
            mark[next] = COUNTED;
            stack[top++] = next;
          }
        }
      }
      best = Math.max(best, size);
    }
  }
  return best;
}

// The storeys of a map from its ground surfaces (heights `z` [m], display cells `cell` of an
// nx x ny grid): [{ floorZ, from, name }], lowest first, each from its `from` [m] (-Infinity
// for the lowest) up to the next one's. The floors are the heights where a large flat patch
// of ground lies (above); the bands between them split at the midpoints (or just above:
// BAND_SHIFT_M). A map with one floor (a yard among hills) or none (rugged terrain: floorZ
// null) has one storey.
export function findStoreys(z, cell, nx, ny) {
  const n = z.length;
  if (n === 0) return [{ floorZ: null, from: -Infinity, name: 'ground' }];
  let zMin = Infinity;
  let zMax = -Infinity;
  for (const h of z) {
    zMin = Math.min(zMin, h);
    zMax = Math.max(zMax, h);
  }
  // A fine histogram: count[k] ground surfaces at heights from zMin + k * FLOOR_STEP_M, below[k]
  // under that; ground(k): the window of FLOOR_WINDOW_M from there.
  const width = Math.round(FLOOR_WINDOW_M / FLOOR_STEP_M);
  const bins = Math.floor((zMax - zMin) / FLOOR_STEP_M) + 1;
  const count = new Uint32Array(bins);
  for (const h of z) count[Math.floor((h - zMin) / FLOOR_STEP_M)] += 1;
  const below = new Uint32Array(bins + 1);
  for (let k = 0; k < bins; ++k) below[k + 1] = below[k] + count[k];
  const clamp = (k) => Math.min(Math.max(k, 0), bins);
  const ground = (k) => below[clamp(k + width)] - below[clamp(k)];
  const binZ = (k) => zMin + k * FLOOR_STEP_M;

  // The floors: windows by the ground they hold, most first, each tested unless it lies within
  // two widths of a floor found (it holds part of that floor, or has it beside it).
  const floors = [];
  const taken = [];
  const mark = new Uint8Array(nx * ny);
  const candidates = Array.from({ length: bins }, (_, k) => k)
    .filter((k) => ground(k) >= FLOOR_MIN_SHARE * n)
    .sort((a, b) => ground(b) - ground(a));
  for (const k of candidates) {
    if (taken.some((t) => Math.abs(t - k) < 2 * width)) continue;
    if (ground(k) < FLOOR_CONTRAST * Math.max(ground(k - width), ground(k + width))) continue;
    const lo = binZ(k);
    const hi = binZ(k + width);
    if (largestFlatPatch(z, cell, nx, ny, lo, hi, mark) < FLOOR_MIN_SHARE * n) continue;
    taken.push(k);
    // Its height: the median of the ground in its window.
    const heights = Float32Array.from(z.filter((h) => h >= lo && h < hi)).sort();
    floors.push(heights[heights.length >> 1]);
  }
  if (floors.length === 0) return [{ floorZ: null, from: -Infinity, name: 'ground' }];
  floors.sort((a, b) => a - b);

  // Where the band below floor `upper` ends: at the midpoint, or, when ground gathers there
  // (its bin holds more than twice the median bin from there up to BAND_SHIFT_M above, or a
  // quarter of the gap), at the first bin above where it does not.
  const edge = (upper) => {
    const mid = 0.5 * (floors[upper - 1] + floors[upper]);
    const top = mid + Math.min(BAND_SHIFT_M, 0.25 * (floors[upper] - floors[upper - 1]));
    const first = Math.floor((mid - zMin) / FLOOR_STEP_M);
    const last = Math.min(Math.floor((top - zMin) / FLOOR_STEP_M), bins - 1);
    const range = count.slice(first, last + 1).sort();
    const median = range[range.length >> 1];
    let k = first;
    while (k < last && count[k] > 2 * median) ++k;
    return k === first ? mid : binZ(k);
  };
  // Too many floors for the shader: the top storey takes every floor from its own up.
  const storeys = floors.slice(0, MAX_STOREYS).map((floorZ, s) => ({
    floorZ,
    from: s === 0 ? -Infinity : edge(s),
    name: `${s === 0 ? 'ground' : 'deck'} ${metres(floorZ)} m`,
  }));
  if (floors.length > MAX_STOREYS) {
    const top = storeys[MAX_STOREYS - 1];
    top.name = `decks ${metres(top.floorZ)} … ${metres(floors[floors.length - 1])} m`;
  }
  return storeys;
}

export class MapModel {
  constructor(geometry) {
    this.geometry = geometry;
    this.nx = geometry.nx;
    this.ny = geometry.ny;
    this.cellSize = geometry.cell_size_m;
    this.originX = geometry.origin_m.x;
    this.originY = geometry.origin_m.y;
    this.ground = {
      cell: Uint32Array.from(geometry.ground_cell),
      z: Float32Array.from(geometry.ground_z_m),
      level: Uint32Array.from(geometry.ground_level),  // Its index in its column, 0 the lowest.
      safety: Float32Array.from(geometry.ground_safety || []),
      component: Int32Array.from(geometry.ground_component || []),
    };
    this.obstacle = {
      cell: Uint32Array.from(geometry.obstacle_cell),
      z: Float32Array.from(geometry.obstacle_z_m),
    };
    this.hasSafety = this.ground.safety.length === this.ground.z.length && this.ground.z.length > 0;
    let zMin = Infinity;
    let zMax = -Infinity;
    for (const z of this.ground.z) {
      zMin = Math.min(zMin, z);
      zMax = Math.max(zMax, z);
    }
    this.zMin = Number.isFinite(zMin) ? zMin : 0;
    this.zMax = Number.isFinite(zMax) ? Math.max(zMax, this.zMin + 0.5) : 1;
    // S' colours saturate at the 98th percentile: a few cells by walls would squash the rest.
    this.safetyMax = 1;
    if (this.hasSafety) {
      const sorted = Float32Array.from(this.ground.safety).sort();
      this.safetyMax = Math.max(1e-3, sorted[Math.floor(0.98 * (sorted.length - 1))]);
    }
    // The first ground and obstacle surface of every cell (both lists are ordered by cell).
    this.groundStart = MapModel.cellStarts(this.ground.cell, this.nx * this.ny);
    this.obstacleStart = MapModel.cellStarts(this.obstacle.cell, this.nx * this.ny);
    // The storeys (findStoreys, with the heights of the surfaces in each: zMin, zMax [m]), and
    // each surface's; an obstacle top's by its own height, as the cut goes, so that a storey
    // shows and hides exactly the heights in its band.
    this.storeys = findStoreys(this.ground.z, this.ground.cell, this.nx, this.ny)
      .map((storey) => ({ ...storey, zMin: Infinity, zMax: -Infinity }));
    this.ground.storey = Uint8Array.from(this.ground.z, (z) => this.storeyOf(z));
    this.obstacle.storey = Uint8Array.from(this.obstacle.z, (z) => this.storeyOf(z));
    for (const [z, storey] of [[this.ground.z, this.ground.storey], [this.obstacle.z, this.obstacle.storey]]) {
      z.forEach((height, i) => {
        const s = this.storeys[storey[i]];
        s.zMin = Math.min(s.zMin, height);
        s.zMax = Math.max(s.zMax, height);
      });
    }
  }

  // The storey holding height z [m]: its index in `storeys`, 0 the lowest.
  storeyOf(z) {
    let s = 0;
    while (s + 1 < this.storeys.length && z >= this.storeys[s + 1].from) ++s;
    return s;
  }

  static cellStarts(cells, cellCount) {
    const starts = new Uint32Array(cellCount + 1);
    for (const c of cells) starts[c + 1] += 1;
    for (let c = 0; c < cellCount; ++c) starts[c + 1] += starts[c];
    return starts;
  }

  get surfaceCount() {
    return this.ground.z.length + this.obstacle.z.length;
  }

  bounds() {
    return {
      xMin: this.originX,
      yMin: this.originY,
      xMax: this.originX + this.nx * this.cellSize,
      yMax: this.originY + this.ny * this.cellSize,
    };
  }

  // The display cell holding (x, y), or -1 outside the map.
  cellAt(x, y) {
    const cx = Math.floor((x - this.originX) / this.cellSize);
    const cy = Math.floor((y - this.originY) / this.cellSize);
    if (cx < 0 || cy < 0 || cx >= this.nx || cy >= this.ny) return -1;
    return cx + this.nx * cy;
  }

  cellCenter(cell) {
    return [
      this.originX + ((cell % this.nx) + 0.5) * this.cellSize,
      this.originY + (Math.floor(cell / this.nx) + 0.5) * this.cellSize,
    ];
  }

  // The highest ground at (x, y) that `visible(z)` accepts: { z, storey, level } (level: its
  // index among the grounds of its column, 0 the lowest) or null.
  topGround(x, y, visible) {
    const cell = this.cellAt(x, y);
    if (cell < 0) return null;
    for (let i = this.groundStart[cell + 1]; i-- > this.groundStart[cell];) {
      const z = this.ground.z[i];
      if (visible(z)) return { z, storey: this.ground.storey[i], level: this.ground.level[i] };
    }
    return null;
  }

  // The highest ground at (x, y) no higher than z + 0.5 m, or null.
  groundBelow(x, y, z) {
    const cell = this.cellAt(x, y);
    if (cell < 0) return null;
    for (let i = this.groundStart[cell + 1]; i-- > this.groundStart[cell];) {
      if (this.ground.z[i] <= z + 0.5) return this.ground.z[i];
    }
    return null;
  }

  // The lowest surface (ground or obstacle top) above z at (x, y): the ceiling, or null.
  ceilingAbove(x, y, z) {
    const cell = this.cellAt(x, y);
    if (cell < 0) return null;
    let best = null;
    for (let i = this.groundStart[cell]; i < this.groundStart[cell + 1]; ++i) {
      if (this.ground.z[i] > z && (best === null || this.ground.z[i] < best)) best = this.ground.z[i];
    }
    for (let i = this.obstacleStart[cell]; i < this.obstacleStart[cell + 1]; ++i) {
      if (this.obstacle.z[i] > z && (best === null || this.obstacle.z[i] < best)) best = this.obstacle.z[i];
    }
    return best;
  }

  // Colour of ground surface i under `style`: { color: 'height' | 'safety' | 'components',
  // components: { start, goal } }.
  groundColor(i, style) {
    if (style.color === 'components' && this.ground.component.length === this.ground.z.length) {
      const c = this.ground.component[i];
      if (c === style.components.start) return START_COMPONENT_COLOR;
      if (c === style.components.goal) return GOAL_COMPONENT_COLOR;
      return OTHER_COMPONENT_COLOR;
    }
    if (style.color === 'safety' && this.hasSafety) {
      return heatColor(this.ground.safety[i] / this.safetyMax);
    }
    return heightColor((this.ground.z[i] - this.zMin) / (this.zMax - this.zMin));
  }

  obstacleColor() {
    return OBSTACLE_COLOR;
  }
}
