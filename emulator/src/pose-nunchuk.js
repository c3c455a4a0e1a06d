// A Nunchuk whose accelerometer has a known truth, held by a simulated person: still poses
// with sensor noise, smooth moves between them (with the jolt of a hand), and the C / Z
// buttons pressed or released on cue. Used by the self-calibration scenarios, which compare
// what the adapter fits and applies with this truth.
//
// Sensor model (counts): raw = bias + K⁻¹·g + noise, with g the gravity reading in g (unit
// vector at rest), K the correction the core fits (wiical_core::multipos: upper-triangular K,
// g per count) and noise Gaussian with `noiseCounts` standard deviation, rounded to whole
// counts and clamped to the 10-bit range. Still poses only see ‖K·(m − b)‖, which fixes K up
// to a rotation; the upper-triangular K with a positive diagonal is the unique one among
// them, and the truth's K is of that form, so the fit can recover it and "the truth's
// correction" is a fair expectation.

/** The simulated Nunchuk's truth: zero-g counts and upper-triangular K (g per count). */
export const TRUTH = {
  bias: [503.0, 521.0, 516.0],
  matrix: [
    [1 / 196, 0.00004, -0.00003],
    [0, 1 / 207, 0.00005],
    [0, 0, 1 / 201],
  ],
};

/** Inverse of a 3×3 matrix (adjugate / determinant). */
export function inverse3(m) {
  const [[a, b, c], [d, e, f], [g, h, i]] = m;
  const A = e * i - f * h;
  const B = -(d * i - f * g);
  const C = d * h - e * g;
  const det = a * A + b * B + c * C;
  return [
    [A / det, -(b * i - c * h) / det, (b * f - c * e) / det],
    [B / det, (a * i - c * g) / det, -(a * f - c * d) / det],
    [C / det, -(a * h - b * g) / det, (a * e - b * d) / det],
  ];
}

/** Deterministic uniform [0, 1) generator (mulberry32). */
export function mulberry32(seed) {
  let s = seed >>> 0;
  return () => {
    s = (s + 0x6d2b79f5) >>> 0;
    let t = s;
    t = Math.imul(t ^ (t >>> 15), t | 1);
    t ^= t + Math.imul(t ^ (t >>> 7), t | 61);
    return ((t ^ (t >>> 14)) >>> 0) / 4294967296;
  };
}

const unit = (v) => {
  const n = Math.hypot(...v);
  return v.map((x) => x / n);
};

export class PoseNunchuk {
  /**
   * Starts still in direction `start`, with C and Z pressed if `held` (plugged in with the
   * buttons down). `clock()` gives the emulated time in ns (set it once the board exists).
   */
  constructor({ truth = TRUTH, noiseCounts = 0.6, seed = 12, start = [0, 0, 1], held = false, drift = null } = {}) {
    this.truth = truth;
    /** Bias drift { counts: [x, y, z], overS }: the bias moves by `counts`, linearly over the
     * first `overS` seconds of emulated time, then stays (a controller warming up). */
    this.drift = drift;
    /** Optional `(tNs) => { s, bias }`: the sensitivity (counts per g, 3×3) and bias at time t,
     * for a sensor whose scale drifts too (replaces `drift`). */
    this.sensorAt = null;
    this.sensitivity = inverse3(truth.matrix);
    this.noise = noiseCounts;
    this.random = mulberry32(seed);
    this.clock = () => 0;
    /** Segments in time order: { startNs, from, to, durNs, c, z, pose }. */
    this.segments = [{ startNs: 0, from: unit(start), to: unit(start), durNs: 0, c: held, z: held, pose: 0 }];
    this.motion = (tNs) => this.sample(tNs);
  }

  get current() {
    return this.segments[this.segments.length - 1];
  }

  /** Presses or releases both buttons now, in place. */
  buttons(pressed) {
    const { to } = this.current;
    this.segments.push({ startNs: this.clock(), from: to, to, durNs: 0, c: pressed, z: pressed, pose: this.current.pose });
  }

  /** Turns the Nunchuk to `direction` over `ms` (then holds it still there). */
  moveTo(direction, ms) {
    const cur = this.current;
    this.segments.push({ startNs: this.clock(), from: cur.to, to: unit(direction), durNs: ms * 1e6, c: cur.c, z: cur.z, pose: cur.pose + 1 });
  }

  gaussian() {
    const u = Math.max(this.random(), 1e-12);
    return Math.sqrt(-2 * Math.log(u)) * Math.cos(2 * Math.PI * this.random());
  }

  /** The accelerometer reading (g) at time t: the pose's gravity, or a move with its jolt. */
  gravity(seg, tNs) {
    const u = seg.durNs ? Math.min(1, Math.max(0, (tNs - seg.startNs) / seg.durNs)) : 1;
    const d = unit(seg.from.map((f, i) => f + (seg.to[i] - f) * u));
    const jolt = Math.sin(Math.PI * u) * 0.35;
    return [d[0] + jolt, d[1] - 0.6 * jolt, d[2] + 0.8 * jolt];
  }

  /** The true bias at time t (ns): the truth's, moved by the drift. */
  biasAt(tNs) {
    if (!this.drift) return this.truth.bias;
    const f = Math.min(1, tNs / (this.drift.overS * 1e9));
    return this.truth.bias.map((b, i) => b + f * this.drift.counts[i]);
  }

  /** Raw counts for a gravity reading g (in g) at time t (ns), with noise. */
  counts(g, tNs = 0) {
    const { s, bias } = this.sensorAt ? this.sensorAt(tNs) : { s: this.sensitivity, bias: this.biasAt(tNs) };
    return [0, 1, 2].map((i) => {
      const v = bias[i] + s[i][0] * g[0] + s[i][1] * g[1] + s[i][2] * g[2] + this.noise * this.gaussian();
      return Math.max(0, Math.min(1023, Math.round(v)));
    });
  }

  sample(tNs) {
    let seg = this.segments[0];
    for (const s of this.segments) {
      if (s.startNs <= tNs) seg = s;
      else break;
    }
    return { accel: this.counts(this.gravity(seg, tNs), tNs), stick: [0x80, 0x80], c: seg.c, z: seg.z, pose: seg.pose };
  }
}
