// Colour scales: heights (dark to light, so upper decks stand out), speed and the safety
// field S' (cool to hot), and the two components of an unreachable goal.

function lerp(a, b, f) {
  return a + (b - a) * f;
}

// Piecewise-linear scale through `stops` ([r, g, b] in 0..255) for f in [0, 1].
function scale(stops, f) {
  const x = Math.min(1, Math.max(0, f)) * (stops.length - 1);
  const i = Math.min(stops.length - 2, Math.floor(x));
  const g = x - i;
  return [0, 1, 2].map((c) => Math.round(lerp(stops[i][c], stops[i + 1][c], g)));
}

const HEIGHT_STOPS = [[52, 62, 84], [62, 110, 140], [96, 160, 128], [190, 196, 120], [236, 232, 214]];
const HEAT_STOPS = [[40, 60, 160], [40, 170, 200], [120, 200, 80], [240, 200, 40], [220, 50, 40]];

export function heightColor(f) {
  return scale(HEIGHT_STOPS, f);
}

export function heatColor(f) {
  return scale(HEAT_STOPS, f);
}

export const OBSTACLE_COLOR = [150, 70, 70];
export const START_COMPONENT_COLOR = [60, 200, 90];
export const GOAL_COMPONENT_COLOR = [230, 120, 40];
export const OTHER_COMPONENT_COLOR = [85, 90, 100];

export function css([r, g, b]) {
  return `rgb(${r},${g},${b})`;
}

// A canvas holding the scale as a horizontal gradient, for legends.
export function scaleCanvas(colorOf, width = 160) {
  const canvas = document.createElement('canvas');
  canvas.width = width;
  canvas.height = 1;
  const context = canvas.getContext('2d');
  const image = context.createImageData(width, 1);
  for (let x = 0; x < width; ++x) {
    const [r, g, b] = colorOf(x / (width - 1));
    image.data.set([r, g, b, 255], 4 * x);
  }
  context.putImageData(image, 0, 0);
  return canvas;
}
