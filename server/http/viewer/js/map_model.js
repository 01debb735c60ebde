// A map's geometry (strata.v1.MapGeometry) in typed arrays, with the queries the views need:
// the topmost visible ground under a point (clicks), the ground and the ceiling along a
// trajectory (the side profile), each surface's colour, and the heights each level spans.

import {
  GOAL_COMPONENT_COLOR, OBSTACLE_COLOR, OTHER_COMPONENT_COLOR, START_COMPONENT_COLOR,
  heatColor, heightColor,
} from './colors.js';

export class MapModel {
  constructor(geometry) {
    this.geometry = geometry;
    this.nx = geometry.nx;
    this.ny = geometry.ny;
    this.cellSize = geometry.cell_size_m;
    this.originX = geometry.origin_m.x;
    this.originY = geometry.origin_m.y;
    this.maxLevels = Math.max(1, geometry.max_levels);
    this.ground = {
      cell: Uint32Array.from(geometry.ground_cell),
      z: Float32Array.from(geometry.ground_z_m),
      level: Uint32Array.from(geometry.ground_level),
      safety: Float32Array.from(geometry.ground_safety || []),
      component: Int32Array.from(geometry.ground_component || []),
    };
    this.obstacle = {
      cell: Uint32Array.from(geometry.obstacle_cell),
      z: Float32Array.from(geometry.obstacle_z_m),
      level: Uint32Array.from(geometry.obstacle_level),
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
    // The heights each level spans (levels are numbered per column, 0 the lowest ground of its
    // column, so one level may hold a whole ramp): [{ zMin, zMax }] for the level controls.
    this.levelRanges = Array.from({ length: this.maxLevels }, () => ({ zMin: Infinity, zMax: -Infinity }));
    for (let i = 0; i < this.ground.z.length; ++i) {
      const range = this.levelRanges[Math.min(this.ground.level[i], this.maxLevels - 1)];
      range.zMin = Math.min(range.zMin, this.ground.z[i]);
      range.zMax = Math.max(range.zMax, this.ground.z[i]);
    }
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

  // The highest ground at (x, y) that `visible(level, z)` accepts: { z, level } or null.
  topGround(x, y, visible) {
    const cell = this.cellAt(x, y);
    if (cell < 0) return null;
    for (let i = this.groundStart[cell + 1]; i-- > this.groundStart[cell];) {
      if (visible(this.ground.level[i], this.ground.z[i])) return { z: this.ground.z[i], level: this.ground.level[i] };
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
