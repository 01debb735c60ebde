// The top view: the map drawn from above on a 2D canvas, one image per storey (a pixel per
// display cell), lower storeys first so upper storeys hide them, without the surfaces cut away
// above the style's height; pan by dragging, zoom with the wheel, click to pick a point. Plans
// are drawn over it in an SVG overlay (plan_overlay.js): lines in a group transformed like the
// map, markers and the scale bar placed in screen pixels. The view follows its canvas's size,
// and keeps the map fitted as the window changes until the user pans or zooms.

import { roundLength } from './lengths.js';

const SVG_NS = 'http://www.w3.org/2000/svg';
const BACKGROUND = '#20242b';
const CLICK_SLOP_PX = 4;
const SCALE_BAR_MAX_PX = 120;  // The scale bar's longest length on screen.
const EDGE_PX = 4;  // Labels keep this far inside the view.

function svgElement(name, attributes, text) {
  const e = document.createElementNS(SVG_NS, name);
  for (const [k, v] of Object.entries(attributes)) e.setAttribute(k, v);
  if (text !== undefined) e.textContent = text;
  return e;
}

export class TopView {
  // `handlers`: onPick(x, y) for a click, onHover(x, y) (null off the canvas).
  constructor(canvas, overlay, handlers) {
    this.canvas = canvas;
    this.context = canvas.getContext('2d');
    this.overlay = overlay;
    this.worldGroup = overlay.querySelector('#world');
    this.markerGroup = document.createElementNS(SVG_NS, 'g');
    overlay.appendChild(this.markerGroup);
    this.scaleBar = svgElement('g', { id: 'scale-bar', class: 'scale-bar' });
    overlay.appendChild(this.scaleBar);
    this.handlers = handlers;
    this.model = null;
    this.images = [];
    this.markers = [];
    this.scale = 10;  // Screen pixels per metre.
    this.centerX = 0;
    this.centerY = 0;
    this.fitted = false;  // Whether the view shows the whole map as fit() left it.
    this.frameRequested = false;
    this.listen();
    new ResizeObserver(() => {
      if (this.fitted) this.fit();
      else this.requestRender();
    }).observe(canvas);
  }

  listen() {
    let down = null;
    this.canvas.addEventListener('pointerdown', (e) => {
      down = { x: e.clientX, y: e.clientY, cx: this.centerX, cy: this.centerY, moved: false };
      this.canvas.setPointerCapture(e.pointerId);
    });
    this.canvas.addEventListener('pointermove', (e) => {
      const [x, y] = this.toWorld(e.offsetX, e.offsetY);
      this.handlers.onHover(x, y);
      if (!down) return;
      const dx = e.clientX - down.x;
      const dy = e.clientY - down.y;
      if (Math.hypot(dx, dy) > CLICK_SLOP_PX) down.moved = true;
      if (!down.moved) return;
      this.fitted = false;
      this.centerX = down.cx - dx / this.scale;
      this.centerY = down.cy + dy / this.scale;
      this.requestRender();
    });
    this.canvas.addEventListener('pointerup', (e) => {
      if (down && !down.moved) {
        const [x, y] = this.toWorld(e.offsetX, e.offsetY);
        this.handlers.onPick(x, y);
      }
      down = null;
    });
    this.canvas.addEventListener('pointerleave', () => this.handlers.onHover(null, null));
    this.canvas.addEventListener('wheel', (e) => {
      e.preventDefault();
      const [x, y] = this.toWorld(e.offsetX, e.offsetY);
      this.scale *= Math.exp(-e.deltaY * 0.0015);
      this.fitted = false;
      // Keep the point under the cursor where it is.
      const [x2, y2] = this.toWorld(e.offsetX, e.offsetY);
      this.centerX += x - x2;
      this.centerY += y - y2;
      this.requestRender();
    }, { passive: false });
  }

  size() {
    return [this.canvas.clientWidth || 1, this.canvas.clientHeight || 1];
  }

  toWorld(sx, sy) {
    const [w, h] = this.size();
    return [this.centerX + (sx - w / 2) / this.scale, this.centerY - (sy - h / 2) / this.scale];
  }

  toScreen(x, y) {
    const [w, h] = this.size();
    return [(x - this.centerX) * this.scale + w / 2, h / 2 - (y - this.centerY) * this.scale];
  }

  // Shows `model`, fitted in the view unless `keepView` (the same map again).
  setModel(model, keepView = false) {
    this.model = model;
    if (!keepView) this.fit();
  }

  // Fits the whole map in the view; while the canvas is hidden (no size), as soon as it shows.
  fit() {
    this.fitted = true;
    if (!this.model || !this.canvas.clientWidth || !this.canvas.clientHeight) return;
    const b = this.model.bounds();
    const [w, h] = this.size();
    this.scale = 0.95 * Math.min(w / (b.xMax - b.xMin), h / (b.yMax - b.yMin));
    this.centerX = (b.xMin + b.xMax) / 2;
    this.centerY = (b.yMin + b.yMax) / 2;
    this.requestRender();
  }

  // Redraws the storey images for `style`: { storeys: Set of visible storeys (indices into the
  // model's), obstacles, color, components, cutZ: surfaces above this height [m] are left out }.
  setStyle(style) {
    this.style = style;
    if (!this.model) return;
    const m = this.model;
    const cells = m.nx * m.ny;
    const cut = style.cutZ ?? Infinity;
    const tops = [];
    const pixels = [];
    for (let s = 0; s < m.storeys.length; ++s) {
      tops.push(new Float32Array(cells).fill(-Infinity));
      pixels.push(new Uint8ClampedArray(4 * cells));
    }
    // The highest surface of each cell in each storey.
    const paint = (storey, cell, z, [r, g, b]) => {
      if (z < tops[storey][cell]) return;
      tops[storey][cell] = z;
      pixels[storey].set([r, g, b, 255], 4 * cell);
    };
    for (let i = 0; i < m.ground.z.length; ++i) {
      if (m.ground.z[i] <= cut) paint(m.ground.storey[i], m.ground.cell[i], m.ground.z[i], m.groundColor(i, style));
    }
    if (style.obstacles) {
      for (let i = 0; i < m.obstacle.z.length; ++i) {
        if (m.obstacle.z[i] <= cut) paint(m.obstacle.storey[i], m.obstacle.cell[i], m.obstacle.z[i], m.obstacleColor());
      }
    }
    this.images = pixels.map((rgba) => {
      const image = document.createElement('canvas');
      image.width = m.nx;
      image.height = m.ny;
      image.getContext('2d').putImageData(new ImageData(rgba, m.nx, m.ny), 0, 0);
      return image;
    });
    this.requestRender();
  }

  // Markers in screen space: [{ x, y, color, label, id }].
  setMarkers(markers) {
    this.markers = markers;
    this.requestRender();
  }

  requestRender() {
    if (this.frameRequested) return;
    this.frameRequested = true;
    requestAnimationFrame(() => {
      this.frameRequested = false;
      this.render();
    });
  }

  render() {
    const ratio = window.devicePixelRatio || 1;
    const [w, h] = this.size();
    if (this.canvas.width !== Math.round(w * ratio) || this.canvas.height !== Math.round(h * ratio)) {
      this.canvas.width = Math.round(w * ratio);
      this.canvas.height = Math.round(h * ratio);
    }
    const c = this.context;
    c.setTransform(1, 0, 0, 1, 0, 0);
    c.fillStyle = BACKGROUND;
    c.fillRect(0, 0, this.canvas.width, this.canvas.height);
    if (this.model && this.style) {
      const m = this.model;
      // World to device pixels, y up; image row cy lies at y = origin + cy * cell.
      c.setTransform(this.scale * ratio, 0, 0, -this.scale * ratio,
        (w / 2 - this.centerX * this.scale) * ratio, (h / 2 + this.centerY * this.scale) * ratio);
      c.imageSmoothingEnabled = false;
      this.images.forEach((image, storey) => {
        if (this.style.storeys.has(storey)) {
          c.drawImage(image, m.originX, m.originY, m.nx * m.cellSize, m.ny * m.cellSize);
        }
      });
    }
    this.worldGroup.setAttribute('transform',
      `matrix(${this.scale} 0 0 ${-this.scale} ${w / 2 - this.centerX * this.scale} ${h / 2 + this.centerY * this.scale})`);
    this.renderMarkers();
    this.renderScaleBar();
  }

  renderMarkers() {
    this.markerGroup.replaceChildren();
    const [w, h] = this.size();
    for (const marker of this.markers) {
      const [sx, sy] = this.toScreen(marker.x, marker.y);
      const g = svgElement('g', { class: 'marker' });
      if (marker.id) g.setAttribute('id', marker.id);
      const circle = svgElement('circle', {
        cx: sx, cy: sy, r: marker.hollow ? 7 : 5, fill: marker.hollow ? 'none' : marker.color,
      });
      // A requested point: a ring of its colour (a style property: it beats the stylesheet's
      // black outline, and the page's content security policy allows it, unlike an attribute).
      if (marker.hollow) circle.style.stroke = marker.color;
      g.appendChild(circle);
      this.markerGroup.appendChild(g);
      // A label beside its point (right and above it, else where it fits), kept inside the
      // view; none for a point off the view.
      if (!marker.label || sx < 0 || sy < 0 || sx > w || sy > h) continue;
      const text = svgElement('text', {}, marker.label);
      g.appendChild(text);
      const width = text.getComputedTextLength() || 7 * marker.label.length;
      const x = sx + 9 + width <= w - EDGE_PX ? sx + 9 : sx - 9 - width;
      const y = sy - 7 - 12 >= EDGE_PX ? sy - 7 : sy + 19;
      text.setAttribute('x', Math.min(Math.max(x, EDGE_PX), w - EDGE_PX - width));
      text.setAttribute('y', Math.min(Math.max(y, EDGE_PX + 12), h - EDGE_PX));
    }
  }

  // A bar of a round length in metres at the bottom left, above the cursor's coordinates.
  renderScaleBar() {
    this.scaleBar.replaceChildren();
    if (!this.model) return;
    const length = roundLength(SCALE_BAR_MAX_PX / this.scale);
    const px = length * this.scale;
    const [, h] = this.size();
    const x = 12;
    const y = h - 30;
    this.scaleBar.dataset.lengthM = length;
    this.scaleBar.dataset.widthPx = px.toFixed(2);
    this.scaleBar.append(
      svgElement('path', { d: `M${x},${y - 5}V${y}H${x + px}V${y - 5}` }),
      svgElement('text', { x: x + px / 2, y: y - 6, 'text-anchor': 'middle' }, `${length} m`));
  }

  // Pans in a circle for `seconds`, drawing every animation frame; resolves to frames/s.
  measureFrames(seconds) {
    return new Promise((resolve) => {
      const x0 = this.centerX;
      const y0 = this.centerY;
      const radius = 40 / this.scale;
      let frames = 0;
      const start = performance.now();
      const step = (now) => {
        const t = (now - start) / 1000;
        this.centerX = x0 + radius * Math.cos(t * 2);
        this.centerY = y0 + radius * Math.sin(t * 2);
        this.render();
        ++frames;
        if (t < seconds) {
          requestAnimationFrame(step);
        } else {
          this.centerX = x0;
          this.centerY = y0;
          this.render();
          resolve(frames / t);
        }
      };
      requestAnimationFrame(step);
    });
  }
}
