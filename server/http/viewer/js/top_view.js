// The top view: the map drawn from above on a 2D canvas, one image per level (a pixel per
// display cell), lower levels first so upper levels hide them; pan by dragging, zoom with the
// wheel, click to pick a point. Plans are drawn over it in an SVG overlay (plan_overlay.js):
// lines in a group transformed like the map, markers placed in screen pixels.

const SVG_NS = 'http://www.w3.org/2000/svg';
const BACKGROUND = '#20242b';
const CLICK_SLOP_PX = 4;

export class TopView {
  // `handlers`: onPick(x, y) for a click, onHover(x, y) (null off the canvas).
  constructor(canvas, overlay, handlers) {
    this.canvas = canvas;
    this.context = canvas.getContext('2d');
    this.overlay = overlay;
    this.worldGroup = overlay.querySelector('#world');
    this.markerGroup = document.createElementNS(SVG_NS, 'g');
    overlay.appendChild(this.markerGroup);
    this.handlers = handlers;
    this.model = null;
    this.images = [];
    this.markers = [];
    this.scale = 10;  // Screen pixels per metre.
    this.centerX = 0;
    this.centerY = 0;
    this.frameRequested = false;
    this.listen();
    new ResizeObserver(() => this.requestRender()).observe(canvas);
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

  // Fits the whole map in the view.
  fit() {
    if (!this.model) return;
    const b = this.model.bounds();
    const [w, h] = this.size();
    this.scale = 0.95 * Math.min(w / (b.xMax - b.xMin), h / (b.yMax - b.yMin));
    this.centerX = (b.xMin + b.xMax) / 2;
    this.centerY = (b.yMin + b.yMax) / 2;
    this.requestRender();
  }

  // Redraws the level images for `style`: { levels: Set of visible levels, obstacles, color,
  // components }.
  setStyle(style) {
    this.style = style;
    if (!this.model) return;
    const m = this.model;
    const cells = m.nx * m.ny;
    this.images = [];
    for (let level = 0; level < m.maxLevels; ++level) {
      const top = new Float32Array(cells).fill(-Infinity);
      const rgba = new Uint8ClampedArray(4 * cells);
      const paint = (cell, z, [r, g, b]) => {
        if (z < top[cell]) return;
        top[cell] = z;
        rgba.set([r, g, b, 255], 4 * cell);
      };
      for (let i = 0; i < m.ground.z.length; ++i) {
        if (m.ground.level[i] === level) paint(m.ground.cell[i], m.ground.z[i], m.groundColor(i, style));
      }
      if (style.obstacles) {
        for (let i = 0; i < m.obstacle.z.length; ++i) {
          if (m.obstacle.level[i] === level) paint(m.obstacle.cell[i], m.obstacle.z[i], m.obstacleColor());
        }
      }
      const image = document.createElement('canvas');
      image.width = m.nx;
      image.height = m.ny;
      image.getContext('2d').putImageData(new ImageData(rgba, m.nx, m.ny), 0, 0);
      this.images.push(image);
    }
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
      this.images.forEach((image, level) => {
        if (this.style.levels.has(level)) {
          c.drawImage(image, m.originX, m.originY, m.nx * m.cellSize, m.ny * m.cellSize);
        }
      });
    }
    this.worldGroup.setAttribute('transform',
      `matrix(${this.scale} 0 0 ${-this.scale} ${w / 2 - this.centerX * this.scale} ${h / 2 + this.centerY * this.scale})`);
    this.renderMarkers();
  }

  renderMarkers() {
    this.markerGroup.replaceChildren();
    for (const marker of this.markers) {
      const [sx, sy] = this.toScreen(marker.x, marker.y);
      const g = document.createElementNS(SVG_NS, 'g');
      g.setAttribute('class', 'marker');
      if (marker.id) g.setAttribute('id', marker.id);
      const circle = document.createElementNS(SVG_NS, 'circle');
      circle.setAttribute('cx', sx);
      circle.setAttribute('cy', sy);
      circle.setAttribute('r', marker.hollow ? 7 : 5);
      circle.setAttribute('fill', marker.hollow ? 'none' : marker.color);
      // A requested point: a ring of its colour (a style property: it beats the stylesheet's
      // black outline, and the page's content security policy allows it, unlike an attribute).
      if (marker.hollow) circle.style.stroke = marker.color;
      g.appendChild(circle);
      if (marker.label) {
        const text = document.createElementNS(SVG_NS, 'text');
        text.setAttribute('x', sx + 9);
        text.setAttribute('y', sy - 7);
        text.textContent = marker.label;
        g.appendChild(text);
      }
      this.markerGroup.appendChild(g);
    }
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
