// Evaluates a strata.v1.Trajectory exactly as proto/README.md defines it: piece i lasts
// pieces[i].duration_s; axis a at local time t is sum_k axes[a].coefficients[k] * t^k
// (lowest order first); axes x, y, z and, for dimension 4, the body height.

function polynomial(c, t) {
  let value = 0;
  for (let k = c.length - 1; k >= 0; --k) value = value * t + c[k];
  return value;
}

function derivative(c, t) {
  let value = 0;
  for (let k = c.length - 1; k >= 1; --k) value = value * t + k * c[k];
  return value;
}

// Samples about every `dt_s` (at least 8 per piece, and both ends of every piece): an array of
// { t, p: [x, y, z], v: [vx, vy, vz], speed (horizontal), body (dimension 4, else null) }.
export function sampleTrajectory(trajectory, dtS = 0.05) {
  const samples = [];
  const pieces = trajectory.pieces || [];
  let start = 0;
  pieces.forEach((piece, index) => {
    const duration = piece.duration_s;
    const steps = Math.max(8, Math.ceil(duration / dtS));
    for (let i = index === 0 ? 0 : 1; i <= steps; ++i) {
      const t = (duration * i) / steps;
      const axes = piece.axes.map((axis) => axis.coefficients);
      const p = [0, 1, 2].map((a) => polynomial(axes[a], t));
      const v = [0, 1, 2].map((a) => derivative(axes[a], t));
      samples.push({
        t: start + t,
        p,
        v,
        speed: Math.hypot(v[0], v[1]),
        body: trajectory.dimension === 4 ? polynomial(axes[3], t) : null,
      });
    }
    start += duration;
  });
  return samples;
}

// Length of the polyline through the samples' positions [m].
export function polylineLength(samples) {
  let length = 0;
  for (let i = 1; i < samples.length; ++i) {
    const a = samples[i - 1].p;
    const b = samples[i].p;
    length += Math.hypot(b[0] - a[0], b[1] - a[1], b[2] - a[2]);
  }
  return length;
}
