// The background recalibration in the real firmware: after a self-calibration, the Nunchuk's
// bias drifts (a step of a few counts over the first 2 s, as a warmed-up controller's), and the
// player only plays: the Nunchuk is put down in one orientation after another. No C + Z, no
// host upload: the adapter must notice, fit, adopt and store a better calibration by itself,
// and the error of its correction against the simulated truth must return near the floor.

import { writeFileSync } from 'node:fs';
import { join } from 'node:path';
import { PoseNunchuk, TRUTH, inverse3, mulberry32 } from './pose-nunchuk.js';
import { driftScenario } from './background-drift.js';

/** The drift: counts added to the truth's bias over the first DRIFT_S seconds. */
const DRIFT = [6, -5, 7];
const DRIFT_S = 2;
/** Rests of the play: each orientation reached in MOVE_MS and held REST_MS. */
const RESTS = 40;
const MOVE_MS = 400;
const REST_MS = 1800;
/** The first background fit is due after 60 s of play; a second chance comes at 120 s. */
const PLAY_LIMIT_MS = 135_000;

/** `n` directions spread over the sphere (Fibonacci lattice), in a shuffled order. */
function directions(n, seed) {
  const golden = Math.PI * (3 - Math.sqrt(5));
  const d = Array.from({ length: n }, (_, i) => {
    const z = 1 - (2 * (i + 0.5)) / n;
    const r = Math.sqrt(1 - z * z);
    return [r * Math.cos(golden * i), r * Math.sin(golden * i), z];
  });
  const rnd = mulberry32(seed);
  for (let i = n - 1; i > 0; i--) {
    const j = Math.floor(rnd() * (i + 1));
    [d[i], d[j]] = [d[j], d[i]];
  }
  return d;
}

/** RMS over the 26 cube directions of ‖K(m(a) − b) − a‖ (mg): `cal`'s error against a sensor
 * with bias `bias` and the truth's K (noise-free, unquantised). */
function errorMg(cal, bias) {
  const s = inverse3(TRUTH.matrix);
  let ss = 0;
  let n = 0;
  for (const x of [-1, 0, 1]) for (const y of [-1, 0, 1]) for (const z of [-1, 0, 1]) {
    if (!x && !y && !z) continue;
    const k = Math.hypot(x, y, z);
    const a = [x / k, y / k, z / k];
    const m = [0, 1, 2].map((i) => bias[i] + s[i][0] * a[0] + s[i][1] * a[1] + s[i][2] * a[2]);
    const c = [0, 1, 2].map((i) => cal.matrix[i].reduce((acc, v, j) => acc + v * (m[j] - cal.bias[j]), 0));
    ss += c.reduce((acc, v, i) => acc + (v - a[i]) ** 2, 0);
    n += 1;
  }
  return 1000 * Math.sqrt(ss / n);
}

/** The play: RESTS rests, then more until an adoption reaches the flash (or PLAY_LIMIT_MS of
 * play), or until the power is cut. Returns the number of rests. */
async function play(rig, ctl, t0) {
  const written = () => rig.board.flashSteps.some((s) => s.atNs > t0);
  const stop = () => rig.board.fault || rig.board.powerCut;
  let rests = 0;
  for (const d of directions(RESTS, 5)) {
    ctl.moveTo(d, MOVE_MS);
    await rig.board.run(MOVE_MS + REST_MS);
    rests += 1;
    if (stop()) return rests;
  }
  const extra = directions(12, 6);
  for (let i = 0; !written() && !stop() && (rig.board.nanos - t0) / 1e6 < PLAY_LIMIT_MS; i++) {
    ctl.moveTo(extra[i % extra.length], MOVE_MS);
    await rig.board.run(MOVE_MS + REST_MS);
    rests += 1;
  }
  return rests;
}

/** The drifting Nunchuk of the play (the same seed: the same readings in every run). */
const player = () => new PoseNunchuk({ seed: 31, drift: { counts: DRIFT, overS: DRIFT_S } });

export function backgroundScenarios(h) {
  const { newRig, getState, fail, shared, work } = h;
  h.measurements ??= {};

  const backgroundPlay = async () => {
    if (!shared.selfCal) return fail('needs self-calibration');
    const ctl = player();
    const rig = newRig(shared.selfCal.image, { nunchuk: { motion: ctl.motion } });
    ctl.clock = () => rig.board.nanos;
    const drifted = TRUTH.bias.map((b, i) => b + DRIFT[i]);
    const start = shared.selfCal.fitted;
    const before = errorMg(start, drifted);
    const t0 = rig.board.nanos;
    const rests = await play(rig, ctl, t0);
    if (rig.board.fault) return fail(`firmware fault: ${rig.board.fault}`);
    const adoptNs = rig.board.flashSteps.find((s) => s.atNs > t0)?.atNs;
    await rig.board.run(200);
    const r = await rig.wiical(['selfcal-status', '--json']);
    if (r.code !== 0) return fail(`wiical device selfcal-status: exit ${r.code}: ${r.stderr.trim()}`);
    const bg = JSON.parse(r.stdout).background;
    if (!adoptNs || !bg?.last_adoption) {
      return fail(`no adoption after ${((rig.board.nanos - t0) / 1e9).toFixed(0)} s of play (${rests} rests): ${JSON.stringify(bg)}`);
    }
    const state = await getState(rig);
    if (state.error) return fail(state.error);
    const adopted = { bias: state.live.bias, matrix: state.live.matrix };
    const after = errorMg(adopted, drifted);
    // The floor: the self-calibration's own error against the truth before the drift.
    const floor = errorMg(start, TRUTH.bias);
    if (!(after < 0.3 * before) || !(after < floor + 3)) {
      return fail(`error against the truth ${before.toFixed(2)} → ${after.toFixed(2)} mg (floor ${floor.toFixed(2)} mg); adopted ${JSON.stringify(adopted)}; ${JSON.stringify({ ...bg, bin_moments: undefined, fresh_bins: undefined })}`);
    }
    if (bg.origin !== 'Background') return fail(`origin after the adoption: ${bg.origin}`);
    // The Wii Remote's reports after the adoption are the core's correction with the adopted
    // calibration.
    const path = join(work, 'background-adopted.json');
    writeFileSync(path, JSON.stringify(adopted));
    const fn = h.correctionBatch(path);
    h.prefill(fn, path, rig);
    const tour = [[0, 0, 1], [1, 0, 0], [0, 1, 0], [0, 0, -1], [-1, 0, 0], [0, -1, 0]];
    const tourNs = rig.board.nanos;
    for (const d of tour) {
      ctl.moveTo(d, 20);
      await rig.board.run(120);
    }
    const err = h.checkReports(rig, 1, fn, 40, (rep) => rep.tNs > tourNs);
    const steps = rig.board.flashSteps.filter((st) => st.atNs > t0).map((st) => st.kind);
    shared.background = { image: rig.board.flashImage(), adopted, drifted, steps };
    rig.close();
    if (err) return fail(`after the adoption: ${err}`);
    h.measurements.background = { before, after, floor, adoptS: (adoptNs - t0) / 1e9, rests };
    return `drift (${DRIFT.join(', ')}) counts over ${DRIFT_S} s: adopted at ${((adoptNs - t0) / 1e9).toFixed(1)} s of play (${rests} rests, held out ${bg.last_adoption.before_mg.toFixed(2)} → ${bg.last_adoption.after_mg.toFixed(2)} mg, ` +
      `${bg.candidate?.full_model ? 'full 9-parameter' : 'bias + scale'} model from ${bg.candidate?.training_bins} training and ${bg.candidate?.heldout_bins} held-out bins); ` +
      `error against the truth ${before.toFixed(2)} → ${after.toFixed(2)} mg (floor ${floor.toFixed(2)} mg); reports = core correction with the adopted calibration`;
  };

  const backgroundPowerCycle = async () => {
    if (!shared.background) return fail('needs background-play');
    const rig = newRig(shared.background.image);
    await rig.board.runUntilTrue(() => rig.remote.reports.length > 0, 2000);
    const state = await getState(rig);
    const r = await rig.wiical(['selfcal-status', '--json']);
    rig.close();
    if (state.error) return fail(state.error);
    if (!state.stored || !h.sameCal(state.live, shared.background.adopted)) return fail('the adopted calibration is not live after the power cycle');
    const bg = r.code === 0 ? JSON.parse(r.stdout).background : null;
    if (bg?.origin !== 'Background') return fail(`origin after the power cycle: ${JSON.stringify(bg)}`);
    return 'new emulator on the same flash: the adopted calibration is live, made by the background recalibration';
  };

  /** The same play, the power cut at each flash step of the adoption (before it, and half
   * way through it), then a new emulator on what the flash holds: the self-calibration or the
   * adopted calibration must be live and stored, never anything else. Each cut replays the
   * minute of play (≈ 35 s of wall time), so this scenario runs only when named. */
  const backgroundPowerCut = async () => {
    if (!shared.background) return fail('needs background-play');
    const { steps, adopted } = shared.background;
    const tally = { old: 0, new: 0 };
    const detail = [];
    for (let k = 0; k < steps.length; k++) {
      for (const done of [0, 0.5]) {
        const ctl = player();
        const rig = newRig(shared.selfCal.image, { nunchuk: { motion: ctl.motion } });
        ctl.clock = () => rig.board.nanos;
        const random = mulberry32(100 + k);
        rig.board.onFlashStep = (_step, index) => index === k && (done > 0 ? { done, random } : true);
        await play(rig, ctl, rig.board.nanos);
        rig.close();
        if (!rig.board.powerCut) return fail(`the play never reached flash step ${k} of the adoption`);
        const after = newRig(rig.board.flashImage());
        await after.board.runUntilTrue(() => after.remote.reports.length > 0, 2000);
        const state = await getState(after);
        after.close();
        if (state.error) return fail(`cut ${done ? 'half way into' : 'before'} step ${k} (${steps[k]}): ${state.error}`);
        const got = state.stored && h.sameCal(state.live, shared.selfCal.fitted) ? 'old'
          : state.stored && h.sameCal(state.live, adopted) ? 'new' : null;
        if (!got) return fail(`cut ${done ? 'half way into' : 'before'} step ${k} (${steps[k]}): neither the old nor the adopted calibration is live`);
        tally[got] += 1;
        detail.push(`${steps[k]} ${k} ${done ? 'half' : 'before'}: ${got}`);
      }
    }
    return `${2 * steps.length} cuts at the adoption's ${steps.length} flash steps (${steps.join(', ')}): ${tally.old} old, ${tally.new} new, 0 corrupt [${detail.join('; ')}]`;
  };

  return [
    ['background-play', backgroundPlay],
    ['background-power-cycle', backgroundPowerCycle],
    ['background-power-cut', backgroundPowerCut, { optIn: true }],
    ['background-drift', driftScenario(h, { scale: 40, name: 'background-drift' })],
    ['background-drift-2h', driftScenario(h, { scale: 1, name: 'background-drift-2h' }), { optIn: true }],
  ];
}
