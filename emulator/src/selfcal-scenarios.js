// End to end: the adapter calibrates the Nunchuk by itself, driven only by the
// simulated Nunchuk's buttons and poses, while the harness watches the status LED as a user
// would (led.js). The Nunchuk has a known truth (pose-nunchuk.js), so the calibration the
// adapter fits, stores and applies can be compared with it.

import { writeFileSync } from 'node:fs';
import { join } from 'node:path';
import { LedWatcher, LED } from './led.js';
import { PoseNunchuk, TRUTH } from './pose-nunchuk.js';

/** Gravity directions (sensor frame) after the starting pose [0, 0, 1]: six axes (the sixth
 * repeats the start, which the adapter must refuse with "move on"), then six cube diagonals;
 * 12 distinct poses meet the coverage rule (crates/core quality::CoverageRule::default). */
const POSES = [
  [1, 0, 0], [0, 1, 0], [0, 0, -1], [-1, 0, 0], [0, -1, 0], [0, 0, 1],
  [1, 1, 1], [-1, 1, -1], [1, -1, -1], [-1, -1, 1], [1, 1, -1], [-1, 1, 1],
];
/** Index (into the poses left: start, then POSES) of the one repeated orientation. */
const REPEAT = 6;
const REST = [1, -1, 1];
/** A pose is held this long (the detector needs ≥ 1 s of stillness); a move takes MOVE_MS. */
const STILL_MS = 1500;
const MOVE_MS = 400;
/** The adapter's self-calibration store region (firmware/README.md, storage). */
const STORE = [0x1fc000, 0x200000];
/** A short tour after a session, for the report checks (still, 120 ms each). */
const TOUR = [[0, 0, 1], [1, 0, 0], [0, 1, 0], [0, 0, -1], [-1, 0, 0], [0, -1, 0], [0.6, 0, 0.8]];

function maxGap(times) {
  let gap = 0;
  for (let i = 1; i < times.length; i++) gap = Math.max(gap, times[i] - times[i - 1]);
  return gap;
}

/** Plug-in with C + Z held: the LED must show arming, then "hold still"; then release. */
async function enterSession(rig, ctl, led) {
  if (!(await rig.board.runUntilTrue(() => led.shows(LED.arming), 3000))) {
    return 'the LED never showed the arming blink while C + Z were held after plug-in';
  }
  const armedNs = rig.board.nanos;
  if (!(await rig.board.runUntilTrue(() => led.shows(LED.waiting, armedNs), 5000))) {
    return 'no "hold still" double flash after holding C + Z for 3 s';
  }
  ctl.buttons(false);
  return null;
}

/**
 * Leaves the current still pose for `target` and waits for the LED's answer: `taken` (a
 * steady second), `repeat` (the 5 Hz "move on" blink) or `done` (one dark slot, then steady
 * for good); then holds `target` still for STILL_MS. Returns an error string or null.
 */
async function leavePose(rig, ctl, led, fromNs, target, expect) {
  const seen = () => ({ taken: led.poseTakenRuns(fromNs), moves: led.moveBlinks(fromNs), done: led.shows(LED.done, fromNs) });
  const before = seen();
  const start = rig.board.nanos;
  ctl.moveTo(target, MOVE_MS);
  const answered = () => {
    const now = seen();
    if (now.done) return 'done';
    if (now.moves > before.moves) return 'repeat';
    if (now.taken > before.taken) return 'taken';
    return null;
  };
  await rig.board.runUntilTrue(() => answered() !== null, expect === 'done' ? 6000 : 2500, 10);
  const got = answered();
  if (got !== expect) return `expected the LED to say ${expect}, it said ${got ?? 'nothing'} (slots ${led.slots(fromNs).slice(-40)})`;
  const stillEnd = start + (MOVE_MS + STILL_MS) * 1e6;
  if (rig.board.nanos < stillEnd) await rig.board.run((stillEnd - rig.board.nanos) / 1e6);
  return null;
}

async function tour(rig, ctl) {
  for (const d of TOUR) {
    ctl.moveTo(d, 20);
    await rig.board.run(120);
  }
}

/** `wiical device selfcal-status --json` (the adapter's GetStatus, wire protocol 2). */
async function status(rig) {
  const r = await rig.wiical(['selfcal-status', '--json']);
  if (r.code !== 0) return { error: `wiical device selfcal-status: exit ${r.code}: ${r.stderr.trim()}` };
  return JSON.parse(r.stdout);
}

/** Largest |a − b| over two lists of count triples. */
function maxDiff(a, b) {
  let m = 0;
  a.forEach((t, i) => t.forEach((v, j) => (m = Math.max(m, Math.abs(v - b[i][j])))));
  return m;
}

export function selfCalScenarios(h) {
  const { newRig, getState, fail, shared, work } = h;
  h.measurements ??= {};

  const selfCalibration = async () => {
    const ctl = new PoseNunchuk({ held: true });
    const rig = newRig(null, { nunchuk: { motion: ctl.motion } });
    ctl.clock = () => rig.board.nanos;
    const led = new LedWatcher(rig.board);
    const e = await enterSession(rig, ctl, led);
    if (e) return fail(e);
    const sessionNs = rig.board.nanos;
    const hsAtSession = rig.remote.handshakes.length;
    await rig.board.run(STILL_MS);
    const targets = [...POSES, REST];
    let lastLeaveNs = 0;
    for (let i = 0; i < targets.length; i++) {
      lastLeaveNs = rig.board.nanos;
      const expect = i === targets.length - 1 ? 'done' : i === REPEAT ? 'repeat' : 'taken';
      const err = await leavePose(rig, ctl, led, sessionNs, targets[i], expect);
      if (err) return fail(`leaving pose ${i}: ${err}`);
      if (rig.board.fault) return fail(`firmware fault: ${rig.board.fault}`);
    }
    const doneNs = rig.board.nanos;
    const ok = await rig.board.runUntilTrue(() => rig.remote.handshakes.length > hsAtSession, 1000);
    if (!ok) return fail('the Wii Remote did not re-read the calibration block after the session');
    const hs = rig.remote.handshakes[rig.remote.handshakes.length - 1];
    if (!h.sameBytes(hs.block, h.IDEAL_BLOCK)) return fail('after the session the block is not the ideal one');
    // While the session ran the Wii Remote kept reading pass-through reports.
    const commitNs = rig.board.flashSteps.find((s) => s.atNs > sessionNs)?.atNs ?? doneNs;
    const during = rig.remote.reports.filter((r) => r.tNs > sessionNs && r.tNs < commitNs);
    const gap = maxGap(during.map((r) => r.tNs));
    if (during.length < 200 || gap > 20e6) return fail(`during the session the Wii Remote read ${during.length} reports, max gap ${(gap / 1e6).toFixed(1)} ms`);
    // Cost of the on-device fit: it runs in the Nunchuk task, so it shows as the longest
    // poll interval between leaving the last pose and the commit's first flash step.
    const polls = rig.nunchuk.pollTimes.filter((t) => t >= lastLeaveNs && t <= commitNs + 5e6);
    const around = rig.remote.reports.filter((r) => r.tNs > sessionNs && r.tNs < commitNs + 1e9);
    h.measurements.selfCal = { pollGapNs: maxGap(polls), remoteGapNs: gap, commitGapNs: maxGap(around.map((r) => r.tNs)), fitToCommitNs: commitNs - lastLeaveNs };
    const passErr = h.checkReports(rig, hsAtSession, (a) => a, 200, (r) => r.tNs > sessionNs && r.tNs < commitNs);
    if (passErr) return fail(`during the session: ${passErr}`);
    await tour(rig, ctl);
    const state = await getState(rig);
    if (state.error) return fail(state.error);
    if (!state.stored) return fail('wiical device get: the self-calibration is not stored');
    const fitted = { bias: state.live.bias, matrix: state.live.matrix };
    const fittedPath = join(work, 'selfcal-fitted.json');
    writeFileSync(fittedPath, JSON.stringify(fitted));
    const truthPath = join(work, 'selfcal-truth.json');
    writeFileSync(truthPath, JSON.stringify(TRUTH));
    const biasErr = Math.max(...fitted.bias.map((b, i) => Math.abs(b - TRUTH.bias[i])));
    let kErr = 0;
    fitted.matrix.forEach((row, i) => row.forEach((v, j) => (kErr = Math.max(kErr, Math.abs(v - TRUTH.matrix[i][j]) / TRUTH.matrix[i][i]))));
    if (biasErr > 0.5 || kErr > 0.003) return fail(`fitted calibration off the truth: bias ${biasErr.toFixed(3)} counts, K ${(kErr * 100).toFixed(3)} %`);
    // Reports after the re-handshake: exactly the core's correction with the fitted
    // calibration, and that correction within a count of the truth's.
    const fn = h.correctionBatch(fittedPath);
    h.prefill(fn, fittedPath, rig);
    const reportErr = h.checkReports(rig, rig.remote.handshakes.length, fn);
    if (reportErr) return fail(`after the session: ${reportErr}`);
    const raws = [...new Set(rig.nunchuk.served.filter((s) => s.tNs > hs.tNs).map((s) => s.raw.accel.join(' ')))].map((k) => k.split(' ').map(Number));
    const truthCounts = h.expectedCounts(truthPath, raws);
    const fitCounts = h.expectedCounts(fittedPath, raws);
    const dev = maxDiff(truthCounts, fitCounts);
    if (dev > 1) return fail(`the fitted correction is ${dev} counts off the truth's`);
    const st = await status(rig);
    const done = st.last_result;
    if (st.error || !done?.ok || done.poses !== 12 || !(done.rms_mg < 5)) return fail(`selfcal-status: ${JSON.stringify(st)}`);
    shared.selfCal = { image: rig.board.flashImage(), fitted, fittedPath };
    rig.close();
    const exact = truthCounts.filter((t, i) => t.every((v, j) => v === fitCounts[i][j])).length;
    return `C+Z 3 s, 12 poses + 1 repeat (LED: taken ×11, move on ×1, done), fit vs truth: bias ${biasErr.toFixed(3)} counts, K ${(kErr * 100).toFixed(3)} %; ` +
      `reports = core correction; vs truth ≤ ${dev} count (${exact}/${raws.length} exact); selfcal-status: done, ${done.poses} poses, fit RMS ${done.rms_mg.toFixed(2)} mg`;
  };

  const selfCalPowerCycle = async () => {
    if (!shared.selfCal) return fail('needs self-calibration');
    const rig = newRig(shared.selfCal.image);
    await rig.board.runUntilTrue(() => rig.remote.reports.length > 0, 2000);
    if (!rig.remote.handshakes.length || !h.sameBytes(rig.remote.handshakes[0].block, h.IDEAL_BLOCK)) {
      return fail('after the power cycle the block is not the calibrated one');
    }
    await rig.board.run(500);
    const fn = h.correctionBatch(shared.selfCal.fittedPath);
    h.prefill(fn, shared.selfCal.fittedPath, rig);
    const err = h.checkReports(rig, 1, fn);
    const state = await getState(rig);
    rig.close();
    if (state.error) return fail(state.error);
    if (!state.stored || !h.sameCal(state.live, shared.selfCal.fitted)) return fail('the self-calibration is not live after the power cycle');
    return err ? fail(err) : 'new emulator on the same flash: the self-calibration is live, reports corrected';
  };

  const selfCalFail = async () => {
    if (!shared.committedA) return fail('needs commit-live');
    const ctl = new PoseNunchuk({ held: true, seed: 7 });
    const rig = newRig(shared.committedA, { nunchuk: { motion: ctl.motion } });
    ctl.clock = () => rig.board.nanos;
    const led = new LedWatcher(rig.board);
    const e = await enterSession(rig, ctl, led);
    if (e) return fail(e);
    const sessionNs = rig.board.nanos;
    await rig.board.run(STILL_MS);
    // Four poses, all in the y-z plane: x never points up or down.
    for (const target of [[0, 1, 0], [0, 0, -1], [0, -1, 0]]) {
      const err = await leavePose(rig, ctl, led, sessionNs, target, 'taken');
      if (err) return fail(err);
    }
    await rig.board.run(600);
    // Cancel: hold C + Z for 3 s. The session must fail (LED) and keep calibration A.
    ctl.buttons(true);
    const cancelNs = rig.board.nanos;
    if (!(await rig.board.runUntilTrue(() => led.shows(LED.failed, cancelNs), 5000, 10))) {
      return fail(`no "failed" LED pattern after the cancel hold (slots ${led.slots(sessionNs).slice(-40)})`);
    }
    ctl.buttons(false);
    if (led.shows(LED.done, sessionNs)) return fail('the LED showed "done" for a one-plane session');
    const written = rig.board.flashSteps.filter((s) => s.atNs > sessionNs).length;
    const before = shared.committedA.subarray(...STORE);
    const after = rig.board.flashImage().subarray(...STORE);
    if (written || !h.sameBytes(before, after)) return fail(`the failed session wrote flash (${written} steps)`);
    await tour(rig, ctl);
    const fn = h.correctionBatch(h.calA);
    h.prefill(fn, h.calA, rig);
    const err = h.checkReports(rig, 1, fn);
    const state = await getState(rig);
    const st = await status(rig);
    rig.close();
    if (state.error) return fail(state.error);
    if (!state.stored || !h.sameCal(state.live, h.CAL_A)) return fail('the old calibration is not live and stored after the failed session');
    if (st.error || st.last_result?.ok !== false || !/cancelled/.test(st.last_result.message)) return fail(`selfcal-status: ${JSON.stringify(st)}`);
    if (err) return fail(err);
    return `4 poses in one plane, then C+Z 3 s: LED failed, flash untouched, calibration A still live, reports corrected with it; selfcal-status: "${st.last_result.message}"`;
  };

  return [
    ['self-calibration', selfCalibration],
    ['self-calibration-power-cycle', selfCalPowerCycle],
    ['self-calibration-fail', selfCalFail],
  ];
}
