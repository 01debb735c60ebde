// The side profile of a plan, along its arc length: the ground the robot follows (the
// reference point less the profile's reference height), the reference point, the top of the
// body (the commanded body height for an active-height robot) and the ceiling above, where
// the map has one within reach.

const SVG_NS = 'http://www.w3.org/2000/svg';
const MARGIN = { left: 46, right: 12, top: 12, bottom: 22 };
const CEILING_REACH_M = 3;  // Ceilings higher above the body than this are left out.

function element(name, attributes, text) {
  const e = document.createElementNS(SVG_NS, name);
  for (const [k, v] of Object.entries(attributes)) e.setAttribute(k, v);
  if (text !== undefined) e.textContent = text;
  return e;
}

// Draws into `svg`; `samples` from sampleTrajectory, `profile` the response's RobotProfile,
// `model` the MapModel (for ceilings; may be null). Empty samples clear it.
export function drawProfile(svg, samples, profile, model) {
  svg.replaceChildren();
  if (!samples || samples.length < 2) return;
  const w = svg.clientWidth || 600;
  const h = svg.clientHeight || 190;
  const rows = [];
  let s = 0;
  samples.forEach((sample, i) => {
    if (i > 0) {
      const a = samples[i - 1].p;
      const b = sample.p;
      s += Math.hypot(b[0] - a[0], b[1] - a[1], b[2] - a[2]);
    }
    const ground = sample.p[2] - profile.reference_height_m;
    const body = ground + (sample.body ?? profile.body_height_m);
    const ceiling = model ? model.ceilingAbove(sample.p[0], sample.p[1], sample.p[2]) : null;
    rows.push({ s, ref: sample.p[2], ground, body, ceiling: ceiling !== null && ceiling < body + CEILING_REACH_M ? ceiling : null });
  });
  const zLow = Math.min(...rows.map((r) => r.ground)) - 0.3;
  const zHigh = Math.max(...rows.map((r) => (r.ceiling ?? r.body))) + 0.3;
  const x = (v) => MARGIN.left + ((w - MARGIN.left - MARGIN.right) * v) / s;
  const y = (z) => h - MARGIN.bottom - ((h - MARGIN.top - MARGIN.bottom) * (z - zLow)) / (zHigh - zLow);
  const line = (key) => rows.map((r) => `${x(r.s).toFixed(1)},${y(r[key]).toFixed(1)}`).join(' ');

  svg.appendChild(element('polygon', {
    class: 'ground',
    points: `${x(0)},${y(zLow)} ${line('ground')} ${x(s)},${y(zLow)}`,
  }));
  // Ceilings: a filled band from each ceiling run up to the top.
  let run = [];
  const flush = () => {
    if (run.length > 1) {
      const top = y(zHigh);
      const pts = run.map((r) => `${x(r.s).toFixed(1)},${y(r.ceiling).toFixed(1)}`).join(' ');
      svg.appendChild(element('polygon', { class: 'ceiling', points: `${x(run[0].s)},${top} ${pts} ${x(run[run.length - 1].s)},${top}` }));
    }
    run = [];
  };
  rows.forEach((r) => (r.ceiling === null ? flush() : run.push(r)));
  flush();
  svg.appendChild(element('polyline', { class: 'body', points: line('body') }));
  svg.appendChild(element('polyline', { class: 'reference', points: line('ref') }));

  svg.appendChild(element('line', { class: 'axis', x1: MARGIN.left, y1: h - MARGIN.bottom, x2: w - MARGIN.right, y2: h - MARGIN.bottom }));
  svg.appendChild(element('line', { class: 'axis', x1: MARGIN.left, y1: MARGIN.top, x2: MARGIN.left, y2: h - MARGIN.bottom }));
  svg.appendChild(element('text', { x: MARGIN.left, y: h - 6 }, '0 m'));
  svg.appendChild(element('text', { x: w - MARGIN.right, y: h - 6, 'text-anchor': 'end' }, `${s.toFixed(1)} m along the trajectory`));
  svg.appendChild(element('text', { x: 4, y: y(zHigh) + 10 }, `${zHigh.toFixed(1)} m`));
  svg.appendChild(element('text', { x: 4, y: y(zLow) }, `${zLow.toFixed(1)} m`));
  svg.appendChild(element('text', { x: MARGIN.left + 8, y: MARGIN.top + 10 },
    'ground (filled), reference point (blue), top of the body (orange), ceiling (dark)'));
}
