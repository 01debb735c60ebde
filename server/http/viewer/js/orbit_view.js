// The 3D view (WebGL 1): every surface as a square point at its height, coloured as in the top
// view, the plan's lines and markers with their labels, and x, y, z axes of a round length at
// the map's lowest corner as its scale; drag to orbit, wheel to zoom, shift-drag to pan. The
// surfaces above a height can be cut away, so that a climb under an upper deck stays in
// sight. A new map is fitted in the view, and stays fitted as the window changes until the
// user moves the view. While the view moves it draws every k-th cell each way, k cells wide
// (k >= 2, so that about MOVING_POINTS are drawn), and all of them once it rests: large maps
// stay interactive without a GPU (Chromium's software WebGL draws the spiral's 150,000 points
// at under 10 frames/s).

import { roundLength } from './lengths.js';
import { MAX_STOREYS } from './map_model.js';

// The shader shows and hides the storeys one by one (map_model.js findStoreys merges any beyond
// MAX_STOREYS into the top one); one more slot holds the plan's lines and markers and the
// axes, always shown, whatever the cut.
const OVERLAY_SLOT = MAX_STOREYS;
// Points drawn while the view moves, about (a quarter of the spiral's surfaces at 0.2 m).
const MOVING_POINTS = 40000;
const FOV_Y = 0.8;  // Vertical field of view [rad].
const EDGE_PX = 4;  // Labels keep this far inside the view.
const AXIS_COLORS = [[235, 85, 70], [90, 205, 95], [80, 145, 255]];  // x, y, z as RViz.

const VERTEX_SHADER = `
attribute vec3 position;
attribute vec3 color;
attribute float storey;
uniform mat4 matrix;
uniform float pointScale;
uniform float storeyVisible[${MAX_STOREYS + 1}];
uniform float cutZ;
varying vec3 vColor;
void main() {
  float visible = storeyVisible[int(min(storey, ${OVERLAY_SLOT}.0))];
  bool cut = storey < ${OVERLAY_SLOT}.0 && position.z > cutZ;
  gl_Position = visible > 0.5 && !cut ? matrix * vec4(position, 1.0) : vec4(2.0, 2.0, 2.0, 1.0);
  gl_PointSize = clamp(pointScale / gl_Position.w, 1.0, 48.0);
  vColor = color;
}`;

const FRAGMENT_SHADER = `
precision mediump float;
varying vec3 vColor;
void main() { gl_FragColor = vec4(vColor, 1.0); }`;

function compile(gl, type, source) {
  const shader = gl.createShader(type);
  gl.shaderSource(shader, source);
  gl.compileShader(shader);
  if (!gl.getShaderParameter(shader, gl.COMPILE_STATUS)) throw new Error(gl.getShaderInfoLog(shader));
  return shader;
}

function multiply(a, b) {
  const out = new Float32Array(16);
  for (let i = 0; i < 4; ++i) {
    for (let j = 0; j < 4; ++j) {
      let sum = 0;
      for (let k = 0; k < 4; ++k) sum += a[k * 4 + j] * b[i * 4 + k];
      out[i * 4 + j] = sum;
    }
  }
  return out;
}

function perspective(fovY, aspect, near, far) {
  const f = 1 / Math.tan(fovY / 2);
  return new Float32Array([f / aspect, 0, 0, 0, 0, f, 0, 0, 0, 0, (far + near) / (near - far), -1,
    0, 0, (2 * far * near) / (near - far), 0]);
}

function lookAt(eye, target, up) {
  const sub = (a, b) => a.map((v, i) => v - b[i]);
  const norm = (v) => { const l = Math.hypot(...v); return v.map((x) => x / l); };
  const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
  const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
  const z = norm(sub(eye, target));
  const x = norm(cross(up, z));
  const y = cross(z, x);
  return new Float32Array([x[0], y[0], z[0], 0, x[1], y[1], z[1], 0, x[2], y[2], z[2], 0,
    -dot(x, eye), -dot(y, eye), -dot(z, eye), 1]);
}

export class OrbitView {
  // `labelBox`: an element over the canvas, of its size, for the labels.
  constructor(canvas, labelBox) {
    this.canvas = canvas;
    this.labelBox = labelBox;
    this.gl = canvas.getContext('webgl', { antialias: true, preserveDrawingBuffer: true });
    this.available = Boolean(this.gl);
    this.yaw = -0.6;
    this.pitch = 0.75;
    this.distance = 50;
    this.target = [0, 0, 0];
    this.batches = {};
    this.storeys = new Set([0]);
    this.cutZ = Infinity;
    this.labels = [];  // [{ text, p: [x, y, z], element }]: the axes' and the markers'.
    this.fitted = false;  // Whether the view shows the whole map as fit() left it.
    this.frameRequested = false;
    this.moving = false;
    this.restTimer = null;
    if (!this.available) return;
    const gl = this.gl;
    this.program = gl.createProgram();
    gl.attachShader(this.program, compile(gl, gl.VERTEX_SHADER, VERTEX_SHADER));
    gl.attachShader(this.program, compile(gl, gl.FRAGMENT_SHADER, FRAGMENT_SHADER));
    gl.linkProgram(this.program);
    this.attributes = ['position', 'color', 'storey'].map((n) => gl.getAttribLocation(this.program, n));
    this.uniforms = {
      matrix: gl.getUniformLocation(this.program, 'matrix'),
      pointScale: gl.getUniformLocation(this.program, 'pointScale'),
      storeyVisible: gl.getUniformLocation(this.program, 'storeyVisible'),
      cutZ: gl.getUniformLocation(this.program, 'cutZ'),
    };
    this.listen();
    new ResizeObserver(() => {
      if (this.fitted) this.fit();
      else this.requestRender();
    }).observe(canvas);
  }

  listen() {
    let down = null;
    this.canvas.addEventListener('pointerdown', (e) => {
      down = { x: e.clientX, y: e.clientY, yaw: this.yaw, pitch: this.pitch, target: [...this.target], pan: e.shiftKey };
      this.fitted = false;
      this.canvas.setPointerCapture(e.pointerId);
    });
    this.canvas.addEventListener('pointermove', (e) => {
      if (!down) return;
      const dx = e.clientX - down.x;
      const dy = e.clientY - down.y;
      if (down.pan) {
        // Drag the ground: right along the screen's right, down towards the viewer.
        const k = this.distance / (this.canvas.clientHeight || 1);
        const c = Math.cos(this.yaw);
        const s = Math.sin(this.yaw);
        this.target[0] = down.target[0] + k * (dx * s - dy * c);
        this.target[1] = down.target[1] - k * (dx * c + dy * s);
      } else {
        this.yaw = down.yaw - dx * 0.008;
        this.pitch = Math.min(1.55, Math.max(0.05, down.pitch + dy * 0.008));
      }
      this.moved();
      this.requestRender();
    });
    this.canvas.addEventListener('pointerup', () => { down = null; });
    this.canvas.addEventListener('wheel', (e) => {
      e.preventDefault();
      this.distance *= Math.exp(e.deltaY * 0.0015);
      this.fitted = false;
      this.moved();
      this.requestRender();
    }, { passive: false });
  }

  // Uploads a batch of vertices: positions [x, y, z], colours [r, g, b] in 0..255, storeys
  // (OVERLAY_SLOT: always shown); its points are `pointFactor` cells wide. `kind`: 'map' (the
  // surfaces and axes, replaced by setModel) or 'overlay' (replaced by setOverlay).
  setBatch(name, kind, mode, { positions, colors, storeys }, pointFactor = 1) {
    if (!this.available) return;
    const gl = this.gl;
    const old = this.batches[name];
    if (old) old.buffers.forEach((b) => gl.deleteBuffer(b));
    const data = [new Float32Array(positions), new Float32Array(colors.map((c) => c / 255)), new Float32Array(storeys)];
    const buffers = data.map((array) => {
      const buffer = gl.createBuffer();
      gl.bindBuffer(gl.ARRAY_BUFFER, buffer);
      gl.bufferData(gl.ARRAY_BUFFER, array, gl.STATIC_DRAW);
      return buffer;
    });
    this.batches[name] = { kind, mode, buffers, count: positions.length / 3, pointFactor };
    this.requestRender();
  }

  // The map's surfaces under `style` (as TopView.setStyle): all of them, and the subset drawn
  // while the view moves.
  setModel(model, style) {
    this.model = model;
    this.storeys = style.storeys;
    // While moving: every step-th cell each way, step cells wide, at most about
    // MOVING_POINTS points.
    const step = Math.max(2, Math.ceil(Math.sqrt(model.surfaceCount / MOVING_POINTS)));
    for (const coarse of [false, true]) {
      const batch = { positions: [], colors: [], storeys: [] };
      const shift = coarse ? 0.5 * (step - 1) * model.cellSize : 0;
      const add = (cell, z, storey, color) => {
        if (coarse && ((cell % model.nx) % step !== 0 || Math.floor(cell / model.nx) % step !== 0)) return;
        const [x, y] = model.cellCenter(cell);
        batch.positions.push(x + shift, y + shift, z);
        batch.colors.push(...color);
        batch.storeys.push(storey);
      };
      for (let i = 0; i < model.ground.z.length; ++i) {
        add(model.ground.cell[i], model.ground.z[i], model.ground.storey[i], model.groundColor(i, style));
      }
      if (style.obstacles) {
        for (let i = 0; i < model.obstacle.z.length; ++i) {
          add(model.obstacle.cell[i], model.obstacle.z[i], model.obstacle.storey[i], model.obstacleColor());
        }
      }
      this.setBatch(coarse ? 'surfaces-moving' : 'surfaces', 'map', 'POINTS', batch, coarse ? step : 1);
    }
    this.setAxes(model);
  }

  // Axes x, y, z from the map's lowest corner, of a round length (about a third of the map's
  // width), as lines with points along them (WebGL draws lines one pixel wide), labelled with
  // their length.
  setAxes(model) {
    const b = model.bounds();
    const length = roundLength(0.3 * Math.max(b.xMax - b.xMin, b.yMax - b.yMin));
    const origin = [b.xMin, b.yMin, model.zMin];
    const ends = [0, 1, 2].map((axis) => origin.map((v, i) => (i === axis ? v + length : v)));
    const lines = { positions: [], colors: [], storeys: [] };
    const points = { positions: [], colors: [], storeys: [] };
    const add = (batch, p, color) => {
      batch.positions.push(...p);
      batch.colors.push(...color);
      batch.storeys.push(OVERLAY_SLOT);
    };
    const steps = 40;
    ends.forEach((end, axis) => {
      add(lines, origin, AXIS_COLORS[axis]);
      add(lines, end, AXIS_COLORS[axis]);
      for (let k = 0; k <= steps; ++k) {
        add(points, origin.map((v, i) => v + ((end[i] - v) * k) / steps), AXIS_COLORS[axis]);
      }
    });
    this.setBatch('axes', 'map', 'LINES', lines);
    this.setBatch('axes-points', 'map', 'POINTS', points, (length / steps / model.cellSize) * 0.8);
    this.setLabels('axis', ends.map((p, axis) => ({ text: `${'xyz'[axis]} ${length} m`, p, className: 'axis' })));
  }

  // Replaces the labels of `group` ('axis' or 'marker') by `labels`: [{ text, p: [x, y, z],
  // className }].
  setLabels(group, labels) {
    for (const label of this.labels) if (label.group === group) label.element.remove();
    this.labels = this.labels.filter((label) => label.group !== group);
    if (!this.labelBox) return;
    for (const label of labels) {
      const element = document.createElement('span');
      element.className = label.className;
      element.textContent = label.text;
      this.labelBox.appendChild(element);
      this.labels.push({ ...label, group, element });
    }
    this.requestRender();
  }

  // Cuts away the surfaces (ground and obstacle tops) above `z` [m] (Infinity: none).
  setCut(z) {
    this.cutZ = z;
    this.requestRender();
  }

  // Marks the view as moving: the coarse points until 200 ms after the last call.
  moved() {
    this.moving = true;
    clearTimeout(this.restTimer);
    this.restTimer = setTimeout(() => {
      this.moving = false;
      this.requestRender();
    }, 200);
  }

  // Fits the whole map in the view from the current direction: the camera backs off along its
  // axis until every corner of the map's bounding box lies within the field of view (a corner
  // at r right, u up and d towards the camera from the target needs a distance of at least
  // d + max(|r| / tan(fovX / 2), |u| / tan(fovY / 2))), then the target moves to the middle of
  // the corners on screen, and again (the box seen in perspective is not centred on its
  // centre); while the canvas is hidden (no size), as soon as it shows.
  fit() {
    this.fitted = true;
    const w = this.canvas.clientWidth;
    const h = this.canvas.clientHeight;
    if (!this.model || !w || !h) return;
    const b = this.model.bounds();
    const corners = [];
    for (const x of [b.xMin, b.xMax]) {
      for (const y of [b.yMin, b.yMax]) {
        for (const z of [this.model.zMin, this.model.zMax]) corners.push([x, y, z]);
      }
    }
    this.target = [(b.xMin + b.xMax) / 2, (b.yMin + b.yMax) / 2, (this.model.zMin + this.model.zMax) / 2];
    const axes = this.cameraAxes();
    const tanY = Math.tan(FOV_Y / 2);
    const tanX = tanY * (w / h);
    for (let pass = 0; pass < 3; ++pass) {
      // Each corner's [right, up, towards the camera] from the target.
      const local = corners.map((c) => axes.map((a) => a[0] * (c[0] - this.target[0]) +
        a[1] * (c[1] - this.target[1]) + a[2] * (c[2] - this.target[2])));
      this.distance = Math.max(this.model.cellSize,
        ...local.map(([r, u, d]) => d + Math.max(Math.abs(r) / tanX, Math.abs(u) / tanY)));
      if (pass === 2) break;
      // Where the corners fall on screen, as tangents of their angle off the axis.
      const tx = local.map(([r, , d]) => r / (this.distance - d));
      const ty = local.map(([, u, d]) => u / (this.distance - d));
      const mx = 0.5 * (Math.min(...tx) + Math.max(...tx)) * this.distance;
      const my = 0.5 * (Math.min(...ty) + Math.max(...ty)) * this.distance;
      this.target = this.target.map((v, i) => v + mx * axes[0][i] + my * axes[1][i]);
    }
    this.distance *= 1.05;
    this.requestRender();
  }

  // Draws the view just unhidden. A fitted view is fitted to its size first: fit() did nothing
  // while the canvas had none, and the first frame must not show the old camera.
  show() {
    if (this.fitted) this.fit();
    else this.requestRender();
  }

  // The camera's right, up and backward (target to eye) unit vectors, as lookAt builds them.
  cameraAxes() {
    const cp = Math.cos(this.pitch);
    const sp = Math.sin(this.pitch);
    const back = [cp * Math.cos(this.yaw), cp * Math.sin(this.yaw), sp];
    const right = [-Math.sin(this.yaw), Math.cos(this.yaw), 0];  // (0, 0, 1) x back, normalised.
    const up = [back[1] * right[2] - back[2] * right[1], back[2] * right[0] - back[0] * right[2],
      back[0] * right[1] - back[1] * right[0]];
    return [right, up, back];
  }

  // Lines and markers of a plan: [{ name, mode: 'LINE_STRIP' | 'POINTS', points: [[x, y, z]],
  // colors: [[r, g, b]], pointFactor (points' width in cells, default 1), labels (one per
  // point, may be empty) }]; always drawn, whatever the storeys shown and the cut.
  setOverlay(items) {
    for (const [name, batch] of Object.entries(this.batches)) {
      if (batch.kind === 'overlay') {
        batch.buffers.forEach((b) => this.gl.deleteBuffer(b));
        delete this.batches[name];
      }
    }
    const labels = [];
    for (const item of items) {
      this.setBatch(item.name, 'overlay', item.mode, {
        positions: item.points.flat(),
        colors: item.colors.flat(),
        storeys: item.points.map(() => OVERLAY_SLOT),
      }, item.pointFactor || 1);
      (item.labels || []).forEach((text, i) => {
        if (text) labels.push({ text, p: item.points[i], className: 'marker' });
      });
    }
    this.setLabels('marker', labels);
  }

  requestRender() {
    if (this.frameRequested || !this.available) return;
    this.frameRequested = true;
    requestAnimationFrame(() => {
      this.frameRequested = false;
      this.render();
    });
  }

  render() {
    if (!this.available || this.canvas.hidden) return;
    const gl = this.gl;
    const ratio = window.devicePixelRatio || 1;
    const w = Math.max(1, Math.round(this.canvas.clientWidth * ratio));
    const h = Math.max(1, Math.round(this.canvas.clientHeight * ratio));
    if (this.canvas.width !== w || this.canvas.height !== h) {
      this.canvas.width = w;
      this.canvas.height = h;
    }
    gl.viewport(0, 0, w, h);
    gl.clearColor(0.125, 0.14, 0.17, 1);
    gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
    gl.enable(gl.DEPTH_TEST);
    gl.useProgram(this.program);
    const eye = [
      this.target[0] + this.distance * Math.cos(this.pitch) * Math.cos(this.yaw),
      this.target[1] + this.distance * Math.cos(this.pitch) * Math.sin(this.yaw),
      this.target[2] + this.distance * Math.sin(this.pitch),
    ];
    const fov = FOV_Y;
    const matrix = multiply(perspective(fov, w / h, this.distance / 100, this.distance * 10),
      lookAt(eye, this.target, [0, 0, 1]));
    gl.uniformMatrix4fv(this.uniforms.matrix, false, matrix);
    // A point covers its cell (with some overlap, so no gaps show): cell size in pixels at
    // unit depth.
    const cell = this.model ? this.model.cellSize : 0.2;
    const pointScale = (1.5 * cell * h) / (2 * Math.tan(fov / 2));
    const visible = new Float32Array(OVERLAY_SLOT + 1);
    for (let s = 0; s < OVERLAY_SLOT; ++s) visible[s] = this.storeys.has(s) ? 1 : 0;
    visible[OVERLAY_SLOT] = 1;
    gl.uniform1fv(this.uniforms.storeyVisible, visible);
    gl.uniform1f(this.uniforms.cutZ, Math.min(this.cutZ, 1e30));
    for (const [name, batch] of Object.entries(this.batches)) {
      if (name === (this.moving ? 'surfaces' : 'surfaces-moving')) continue;
      gl.uniform1f(this.uniforms.pointScale, pointScale * batch.pointFactor);
      batch.buffers.forEach((buffer, i) => {
        gl.bindBuffer(gl.ARRAY_BUFFER, buffer);
        gl.enableVertexAttribArray(this.attributes[i]);
        gl.vertexAttribPointer(this.attributes[i], i === 2 ? 1 : 3, gl.FLOAT, false, 0, 0);
      });
      gl.drawArrays(gl[batch.mode], 0, batch.count);
    }
    this.placeLabels(matrix);
  }

  // Puts each label beside its point's place on screen, inside the view; hides those behind
  // the camera or off the view.
  placeLabels(matrix) {
    const w = this.canvas.clientWidth;
    const h = this.canvas.clientHeight;
    for (const { p, element } of this.labels) {
      const clip = [0, 1, 2, 3].map((r) => matrix[r] * p[0] + matrix[4 + r] * p[1] + matrix[8 + r] * p[2] + matrix[12 + r]);
      const sx = (0.5 + (0.5 * clip[0]) / clip[3]) * w;
      const sy = (0.5 - (0.5 * clip[1]) / clip[3]) * h;
      element.hidden = !(clip[3] > 0 && sx >= 0 && sy >= 0 && sx <= w && sy <= h);
      if (element.hidden) continue;
      const width = element.offsetWidth;
      const height = element.offsetHeight;
      const x = sx + 6 + width <= w - EDGE_PX ? sx + 6 : sx - 6 - width;
      const y = sy - 4 - height >= EDGE_PX ? sy - 4 - height : sy + 4;
      element.style.left = `${Math.min(Math.max(x, EDGE_PX), w - EDGE_PX - width)}px`;
      element.style.top = `${Math.min(Math.max(y, EDGE_PX), h - EDGE_PX - height)}px`;
    }
  }

  // Orbits for `seconds`, drawing every animation frame (as the view moves: the coarse
  // points); resolves to frames/s.
  measureFrames(seconds) {
    return new Promise((resolve) => {
      const yaw0 = this.yaw;
      let frames = 0;
      const start = performance.now();
      const step = (now) => {
        const t = (now - start) / 1000;
        this.yaw = yaw0 + t * 0.8;
        this.moved();
        this.render();
        ++frames;
        if (t < seconds) {
          requestAnimationFrame(step);
        } else {
          this.yaw = yaw0;
          this.render();
          resolve(frames / t);
        }
      };
      requestAnimationFrame(step);
    });
  }
}
