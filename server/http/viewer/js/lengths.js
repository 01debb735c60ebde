// Lengths for scales: the top view's scale bar and the 3D view's axes.

// The longest of 1, 2 or 5 times a power of ten that is no longer than `most` [m] (> 0).
export function roundLength(most) {
  const power = 10 ** Math.floor(Math.log10(most));
  const length = [5, 2, 1].map((k) => k * power).find((l) => l <= most) || power;
  return Number(length.toPrecision(1));
}
