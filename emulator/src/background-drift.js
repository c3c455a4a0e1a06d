// A two-hour play session with a temperature-driven drift, on the real firmware: after a
// self-calibration the controller warms up (22 → 34 °C over the session), the Nunchuk's bias
// follows the temperature and its scale changes slowly, and the player only plays (rests of
// random length in random orientations, turns with the jolt of a hand, shakes). The board's
// on-chip temperature sensor (ADC channel 4) reads the same temperature, so the firmware's
// temperature task feeds the background recalibration its covariate.
//
// Time scale: the session's drift runs `scale` times faster than the emulated clock (the
// default scenario: 2 h of drift in 180 s of play). The adapter's own clock is its reports
// (200 per emulated second), so before play its intervals are set over the wire
// (SetBackground), divided by the same scale: a fit attempt per 60/scale s and at most one
// commit per 1800/scale s of play, and the daily cap at its largest (16; a scaled day is far
// longer than the session). Everything is then scaled but the rests themselves (1.8–3 s of
// emulated time each: `scale` times fewer rests per minute of the session than at scale 1).
// The full session at scale 1 (two emulated hours, the adapter's default intervals) runs only
// when named.
//
// Output: the error of the Wii Remote's reports (what the firmware outputs) at every rest,
// against the simulator's truth (‖ā − a‖, the rest's mean output against the true gravity
// direction) and as ‖ā‖ − 1 g, per 10 minutes of the session; "without background
// recalibration" is the same session's raw counts corrected by the self-calibration with the
// core's correction (`xtask emulate-correct`): the calibration a firmware with adoption off
// would have kept; "floor" is the same measurement on the same session without drift (the
// raw counts the Nunchuk would have given at the same instants with the same noise, bias and
// scale constant), corrected the same way. A table (stdout and JSON) and an SVG plot go to
// target/emulate/.

import { mkdirSync, writeFileSync } from 'node:fs';
import { join } from 'node:path';
import { PoseNunchuk, TRUTH, inverse3, mulberry32 } from './pose-nunchuk.js';
import { decodeReport } from './nunchuk.js';
import { RawHost, RESPONSE, frame, REQUEST, setBackgroundFrame, decodeBackgroundHead } from './wire.js';

/** The session: its length (s of the session's own time), temperature and drift. */
const SESSION_S = 7200;
const WINDOW_S = 600;
/** °C at session time s: a controller warming from 22 °C by 12 °C with a 20-min constant. */
const temperatureAt = (s) => 22 + 12 * (1 - Math.exp(-s / 1200));
/** Bias against temperature, counts/°C per axis (≈ 20–25 mg over the warm-up). */
const BIAS_SLOPE = [0.35, -0.3, 0.42];
/** Scale change per hour of session, per axis (0.25–0.35 %/h). */
const SCALE_RATE = [0.003, -0.0025, 0.0035];
/** The Wii Remote's counts: 0 g = 512, 200 counts per g (the adapter's ideal scale). */
const IDEAL_ZERO = 512;
const IDEAL_PER_G = 200;
/** The poll period's cycles at 125 MHz (5 ms). */
const PERIOD_CYCLES = 625_000;
/** The acceptance, "near the floor": every window that starts after the first adoption has an
 * RMS error against the truth, with background recalibration, of at most FLOOR_FACTOR × the
 * no-drift floor's in that window + FLOOR_MG (docs/background-calibration.md says why). */
const FLOOR_FACTOR = 2;
const FLOOR_MG = 1;

/** The adapter's intervals divided by the time scale (its defaults at scale 1: a commit per
 * 1800 s, 8 a day, a fit per 60 s). */
export const scaledIntervals = (scale) => ({
  commitIntervalS: Math.round(1800 / scale),
  commitsPerDay: scale === 1 ? 8 : 16,
  fitIntervalMs: Math.round(60_000 / scale),
});

/** The 12-bit ADC reading of the RP2040's sensor at `celsius` (3.3 V reference): the
 * datasheet's T = 27 − (V − 0.706)/0.001721 solved for V. */
export const adcCounts = (celsius) => Math.round(((0.706 - (celsius - 27) * 0.001721) * 4096) / 3.3);

/** The drifting sensor at session time s: bias (counts) and sensitivity (counts per g). */
function sensorAt(s) {
  const s0 = inverse3(TRUTH.matrix);
  const dT = temperatureAt(s) - temperatureAt(0);
  const h = s / 3600;
  return {
    bias: TRUTH.bias.map((b, i) => b + BIAS_SLOPE[i] * dT),
    s: s0.map((row, i) => row.map((v) => v * (1 + SCALE_RATE[i] * h))),
  };
}

const unit = (v) => {
  const n = Math.hypot(...v);
  return v.map((x) => x / n);
};

/** A uniformly random direction. */
function randomDirection(rnd) {
  const z = 2 * rnd() - 1;
  const phi = 2 * Math.PI * rnd();
  const r = Math.sqrt(1 - z * z);
  return [r * Math.cos(phi), r * Math.sin(phi), z];
}

/** Plays until `endNs`: a 0.4 s turn to a random orientation, a rest of 1.8–3 s; every
 * sixth turn a 0.7–1.4 s shake first. After a rest in which the adapter wrote its flash (an
 * adoption's commit), `afterCommit()` runs (it asks for the adoption's numbers). Returns the
 * rests: { fromNs, toNs, a }. */
async function play(rig, ctl, endNs, seed, afterCommit) {
  const rnd = mulberry32(seed);
  const rests = [];
  let steps = rig.board.flashSteps.length;
  for (let k = 0; rig.board.nanos < endNs && !rig.board.fault; k++) {
    if (k % 6 === 5) {
      const shakes = 6 + Math.floor(rnd() * 6);
      for (let i = 0; i < shakes; i++) {
        ctl.moveTo(randomDirection(rnd), 120);
        await rig.board.run(120);
      }
    }
    const a = unit(randomDirection(rnd));
    const restMs = 1800 + Math.floor(rnd() * 1200);
    ctl.moveTo(a, 400);
    const fromNs = rig.board.nanos + 650e6;
    await rig.board.run(400 + restMs);
    rests.push({ fromNs, toNs: rig.board.nanos - 20e6, a });
    if (rig.board.flashSteps.length !== steps) {
      await afterCommit();
      steps = rig.board.flashSteps.length;
    }
  }
  return rests;
}

/** Mean of count triples, as g on the ideal scale. */
function meanG(counts) {
  const m = [0, 0, 0];
  for (const c of counts) for (let i = 0; i < 3; i++) m[i] += c[i];
  return m.map((v) => (v / counts.length - IDEAL_ZERO) / IDEAL_PER_G);
}

/** The entries of `list` (sorted by tNs) within [fromNs, toNs], from index `*at` on. */
function within(list, at, fromNs, toNs, pick) {
  while (at.i < list.length && list[at.i].tNs < fromNs) at.i++;
  const out = [];
  for (let j = at.i; j < list.length && list[j].tNs <= toNs; j++) out.push(pick(list[j]));
  return out;
}

/** Per rest: the mean output with and without the background recalibration, and of the
 * no-drift control corrected like "without"; errors in mg. */
function restErrors(rig, rests, fixed, control) {
  const [ri, si, ci] = [{ i: 0 }, { i: 0 }, { i: 0 }];
  const rows = [];
  for (const r of rests) {
    const out = within(rig.remote.reports, ri, r.fromNs, r.toNs, (x) => decodeReport(x.bytes).accel);
    const raw = within(rig.nunchuk.served, si, r.fromNs, r.toNs, (x) => x.raw.accel);
    const still = within(control, ci, r.fromNs, r.toNs, (x) => x.accel);
    if (out.length < 50 || raw.length < 50 || still.length < 50) continue;
    const errs = (g) => ({ truth: 1000 * Math.hypot(...g.map((v, i) => v - r.a[i])), still: 1000 * (Math.hypot(...g) - 1) });
    rows.push({ toNs: r.toNs, with: errs(meanG(out)), without: errs(meanG(raw.map(fixed))), floor: errs(meanG(still.map(fixed))) });
  }
  return rows;
}

const rms = (xs) => (xs.length ? Math.sqrt(xs.reduce((a, b) => a + b * b, 0) / xs.length) : NaN);

/** An SVG plot of the per-window errors (mg) over the session (min). */
export function svgPlot(table, adoptionsMin, title) {
  const W = 760;
  const H = 470;
  const L = 64;
  const R = 20;
  const T = 40;
  const B = 126;
  const ymax = Math.max(5, ...table.flatMap((r) => [r.withoutTruth, r.withTruth, r.withoutStill, r.withStill, r.floorTruth].filter(Number.isFinite))) * 1.1;
  const x = (min) => L + ((W - L - R) * min) / (SESSION_S / 60);
  const y = (mg) => H - B - ((H - T - B) * mg) / ymax;
  const line = (key, colour, dash) => {
    const pts = table.filter((r) => Number.isFinite(r[key])).map((r) => `${x(r.minute - WINDOW_S / 120).toFixed(1)},${y(r[key]).toFixed(1)}`);
    return `<polyline fill="none" stroke="${colour}" stroke-width="2.5"${dash ? ' stroke-dasharray="7,5"' : ''} points="${pts.join(' ')}"/>`;
  };
  const parts = [
    `<svg xmlns="http://www.w3.org/2000/svg" width="${W}" height="${H}" font-family="sans-serif" font-size="13">`,
    `<rect width="${W}" height="${H}" fill="white"/>`,
    `<text x="${W / 2}" y="22" text-anchor="middle" font-size="15">${title}</text>`,
  ];
  const step = ymax > 40 ? 10 : 5;
  for (let v = 0; v <= ymax; v += step) {
    parts.push(`<line x1="${L}" x2="${W - R}" y1="${y(v)}" y2="${y(v)}" stroke="#ddd"/>`, `<text x="${L - 6}" y="${y(v) + 4}" text-anchor="end">${v}</text>`);
  }
  for (let m = 0; m <= SESSION_S / 60; m += 20) {
    parts.push(`<text x="${x(m)}" y="${H - B + 18}" text-anchor="middle">${m}</text>`);
  }
  parts.push(
    `<line x1="${L}" x2="${W - R}" y1="${H - B}" y2="${H - B}" stroke="black"/>`,
    `<line x1="${L}" x2="${L}" y1="${T}" y2="${H - B}" stroke="black"/>`,
    `<text x="${(L + W - R) / 2}" y="${H - B + 38}" text-anchor="middle">minutes of the session (each 10-min window at its middle)</text>`,
    `<text transform="translate(18,${(T + H - B) / 2}) rotate(-90)" text-anchor="middle">RMS error per 10 min (mg)</text>`,
  );
  for (const m of adoptionsMin) {
    parts.push(`<line x1="${x(m)}" x2="${x(m)}" y1="${T}" y2="${H - B}" stroke="#2a7" stroke-dasharray="3,3"/>`, `<text x="${x(m) + 4}" y="${T + 14}" fill="#2a7">adopted</text>`);
  }
  parts.push(
    line('withoutTruth', '#c33', false),
    line('withoutStill', '#c33', true),
    line('withTruth', '#35c', false),
    line('withStill', '#35c', true),
    line('floorTruth', '#777', false),
  );
  const legend = [
    ['#c33', false, 'without background recalibration: against the truth'],
    ['#c33', true, 'without: ‖a‖ − 1 g at the rests'],
    ['#35c', false, 'with background recalibration: against the truth'],
    ['#35c', true, 'with: ‖a‖ − 1 g at rests'],
    ['#777', false, 'floor: the same session without drift, against the truth'],
  ];
  legend.forEach(([c, dash, text], i) => {
    const lx = L - 40 + (i % 2) * 400;
    const ly = H - B + 60 + 20 * Math.floor(i / 2);
    parts.push(`<line x1="${lx}" x2="${lx + 30}" y1="${ly}" y2="${ly}" stroke="${c}" stroke-width="2.5"${dash ? ' stroke-dasharray="7,5"' : ''}/>`, `<text x="${lx + 36}" y="${ly + 4}">${text}</text>`);
  });
  parts.push('</svg>');
  return parts.join('\n');
}

/** Busy cycles per poll period (between two Nunchuk report reads), with the periods that hold
 * a flash step (an adoption's commit) apart. */
function cycleStats(polls, flashNs) {
  const near = (t0, t1) => flashNs.some((f) => f >= t0 - 1e6 && f <= t1 + 1e6);
  const report = [];
  const commit = [];
  for (let i = 1; i < polls.length; i++) {
    const [t0, c0] = polls[i - 1];
    const [t1, c1] = polls[i];
    (near(t0, t1) ? commit : report).push({ cycles: c1 - c0, tNs: t0 });
  }
  const sorted = report.map((p) => p.cycles).sort((a, b) => a - b);
  const worst = report.reduce((w, p) => (p.cycles > w.cycles ? p : w), { cycles: 0, tNs: 0 });
  return {
    periods: report.length,
    median: sorted[sorted.length >> 1],
    p999: sorted[Math.floor(sorted.length * 0.999)],
    worst: worst.cycles,
    worstAtNs: worst.tNs,
    commitPeriods: commit.length,
    commitWorst: Math.max(0, ...commit.map((p) => p.cycles)),
  };
}

/** Raw counts of a sensor { s, bias } for a gravity reading g (in g) with the given noise
 * (counts per axis), rounded and clamped to 10 bits as the Nunchuk's. */
const rawCounts = ({ s, bias }, g, noise) =>
  [0, 1, 2].map((i) => Math.max(0, Math.min(1023, Math.round(bias[i] + s[i][0] * g[0] + s[i][1] * g[1] + s[i][2] * g[2] + noise[i]))));

/** Sets the adapter's intervals over the wire (SetBackground after a Hello), then reads
 * them back; returns the host for later requests, or a reason. */
async function setIntervals(rig, intervals) {
  await rig.board.runUntilTrue(() => rig.usb.configured, 500);
  const host = new RawHost(rig);
  if (!(await host.hello(6))) return { error: 'no Hello answer' };
  const ack = await host.request(setBackgroundFrame(intervals));
  if (ack?.tag !== RESPONSE.ack) return { error: `SetBackground ${JSON.stringify(intervals)} answered ${JSON.stringify(ack)}` };
  const back = await host.request(frame([REQUEST.getBackgroundStatus]));
  if (back?.tag !== RESPONSE.background) return { error: 'no answer to GetBackgroundStatus' };
  const got = decodeBackgroundHead(back.body).settings;
  if (got.commitIntervalS !== intervals.commitIntervalS || got.commitsPerDay !== intervals.commitsPerDay || got.fitIntervalMs !== intervals.fitIntervalMs) {
    return { error: `the adapter reports ${JSON.stringify(got)} after SetBackground ${JSON.stringify(intervals)}` };
  }
  return { host };
}

/** Per-window RMS errors (mg) of the rows, by the session time of each rest's end. */
function windows(rows, sessionS) {
  const table = [];
  for (let w = 0; w < SESSION_S / WINDOW_S; w++) {
    const inW = rows.filter((x) => Math.floor(sessionS(x.toNs) / WINDOW_S) === w);
    const col = (k, e) => rms(inW.map((x) => x[k][e]));
    table.push({
      minute: ((w + 1) * WINDOW_S) / 60,
      celsius: temperatureAt((w + 1) * WINDOW_S),
      rests: inW.length,
      withoutTruth: col('without', 'truth'),
      withoutStill: col('without', 'still'),
      withTruth: col('with', 'truth'),
      withStill: col('with', 'still'),
      floorTruth: col('floor', 'truth'),
      floorStill: col('floor', 'still'),
    });
  }
  return table;
}

/** The session's Nunchuk: drifting counts served to the firmware, and beside each served
 * report the counts the same instant and noise would give without drift (`control`). */
function drivenNunchuk(rig, ctl, sessionS, control, polls) {
  const still = sensorAt(0);
  ctl.counts = (g, tNs) => {
    const noise = [0, 1, 2].map(() => ctl.noise * ctl.gaussian());
    ctl.lastControl = rawCounts(still, g, noise);
    return rawCounts(sensorAt(sessionS(tNs)), g, noise);
  };
  // Busy cycles at every report read (the poll period's CPU load).
  const motion = ctl.motion;
  rig.nunchuk.motion = (tNs) => {
    polls.push([tNs, rig.board.busyCycles]);
    const m = motion(tNs);
    control.push({ tNs, accel: ctl.lastControl });
    return m;
  };
}

/**
 * The scenario at time scale `scale` (session seconds per emulated second). `name` names the
 * output files in target/emulate/.
 */
export function driftScenario(h, { scale, name }) {
  const { newRig, fail, shared, work } = h;
  return async () => {
    if (!shared.selfCal) return fail('needs self-calibration');
    const ctl = new PoseNunchuk({ seed: 47 });
    const rig = newRig(shared.selfCal.image, { nunchuk: { motion: ctl.motion } });
    ctl.clock = () => rig.board.nanos;
    // The session starts after the settings are set; until then it is at its start.
    let t0 = Infinity;
    const sessionS = (tNs) => (Math.max(0, tNs - t0) / 1e9) * scale;
    // The chip's sensor follows the session's temperature (read at each conversion), from
    // power-up: a moment binned while the ADC read the emulator's default (an implausible
    // temperature, so none) would keep its bin without a temperature, and a fit that trains on
    // that bin without the slope.
    const adc = rig.board.rp2040.adc;
    const convert = adc.onADCRead;
    adc.onADCRead = (channel) => {
      adc.channelValues[4] = adcCounts(temperatureAt(sessionS(rig.board.nanos)));
      convert(channel);
    };
    const intervals = scaledIntervals(scale);
    const { host, error } = await setIntervals(rig, intervals);
    if (error) return fail(error);
    t0 = rig.board.nanos;
    const [polls, control] = [[], []];
    drivenNunchuk(rig, ctl, sessionS, control, polls);
    // Each adoption's held-out numbers, asked for after the rest in which it was stored.
    const adoptions = [];
    const afterCommit = async () => {
      const reply = await host.request(frame([REQUEST.getBackgroundStatus]));
      const st = reply?.tag === RESPONSE.background ? decodeBackgroundHead(reply.body) : null;
      const a = st?.lastAdoption;
      // The last candidate then: the adopted one unless another fit ran since.
      if (a && !adoptions.some((x) => x.atS === a.atS)) adoptions.push({ ...a, candidate: st.candidate, playS: st.playS });
    };
    const endNs = t0 + (SESSION_S / scale) * 1e9;
    const wall = Date.now();
    const rests = await play(rig, ctl, endNs, 91, afterCommit);
    if (rig.board.fault) return fail(`firmware fault: ${rig.board.fault}`);
    const playWallS = (Date.now() - wall) / 1000;
    const r = await rig.wiical(['selfcal-status', '--json']);
    if (r.code !== 0) return fail(`wiical device selfcal-status: exit ${r.code}: ${r.stderr.trim()}`);
    const bg = JSON.parse(r.stdout).background;
    rig.close();
    const flashNs = rig.board.flashSteps.filter((s) => s.atNs > t0).map((s) => s.atNs);
    // Adoptions: the first flash step of each commit (steps more than 1 s apart).
    const adoptNs = flashNs.filter((t, i) => i === 0 || t - flashNs[i - 1] > 1e9);

    const fixedPath = join(work, `${name}-fixed.json`);
    writeFileSync(fixedPath, JSON.stringify(shared.selfCal.fitted));
    const fn = h.correctionBatch(fixedPath);
    h.prefill(fn, fixedPath, rig);
    const uniq = [...new Set(control.map((c) => c.accel.join(' ')))].map((k) => k.split(' ').map(Number));
    h.expectedCounts(fixedPath, uniq).forEach((v, i) => fn.memoSet(uniq[i], v));
    const table = windows(restErrors(rig, rests, fn, control), sessionS);
    const adoptionsMin = adoptNs.map((t) => sessionS(t) / 60);
    const adopted = adoptionsMin.map((minute, i) => ({ minute, ...adoptions[i] }));
    const cycles = cycleStats(polls, flashNs);
    const outDir = join(process.cwd(), '..', 'target', 'emulate');
    mkdirSync(outDir, { recursive: true });
    const title = `Real firmware in rp2040js: 2-hour play session with drift (time scale ${scale}×)`;
    writeFileSync(join(outDir, `${name}.svg`), svgPlot(table, adoptionsMin, title));
    writeFileSync(join(outDir, `${name}.json`), JSON.stringify({ scale, intervals, table, adoptions: adopted, cycles, status: { ...bg, bin_moments: undefined }, rests: rests.length }, null, 1));
    const fmt = (v) => (Number.isFinite(v) ? v.toFixed(2) : '–');
    console.log(`table ${name}: | minute | °C | rests | without: truth | without: ‖a‖−1 | with: truth | with: ‖a‖−1 | floor: truth | floor: ‖a‖−1 |`);
    for (const t of table) {
      console.log(`table ${name}: | ${t.minute} | ${t.celsius.toFixed(1)} | ${t.rests} | ${fmt(t.withoutTruth)} | ${fmt(t.withoutStill)} | ${fmt(t.withTruth)} | ${fmt(t.withStill)} | ${fmt(t.floorTruth)} | ${fmt(t.floorStill)} |`);
    }
    for (const a of adopted) console.log(`adoption ${name}: minute ${a.minute.toFixed(1)}, held out ${fmt(a.beforeMg)} → ${fmt(a.afterMg)} mg; last candidate at ${a.playS} s of play: ${JSON.stringify(a.candidate)}`);
    h.measurements[name] = { scale, cycles, playWallS, emulatedS: (rig.board.nanos - t0) / 1e9 };
    return verdict({ name, scale, bg, rig, rests, table, adopted, cycles, playWallS, intervals, sessionS, adoptNs, fail });
  };
}

/** The pass conditions and the scenario's line. */
function verdict({ scale, bg, rig, rests, table, adopted, cycles, playWallS, intervals, sessionS, adoptNs, fail }) {
  const fmt = (v) => (Number.isFinite(v) ? v.toFixed(2) : '–');
  if (!adoptNs.length || !bg?.last_adoption) return fail(`no adoption in ${SESSION_S / scale} s of play (${rests.length} rests): ${JSON.stringify({ ...bg, bin_moments: undefined })}`);
  if (bg.commit_interval_s !== intervals.commitIntervalS || bg.commits_per_day !== intervals.commitsPerDay || Math.round(bg.fit_interval_s * 1000) !== intervals.fitIntervalMs) {
    return fail(`selfcal-status shows ${bg.commit_interval_s} s, ${bg.commits_per_day} a day, a fit every ${bg.fit_interval_s} s; set ${JSON.stringify(intervals)}`);
  }
  const tEnd = temperatureAt(sessionS(rig.board.nanos));
  if (!(Math.abs((bg.temperature_c ?? NaN) - tEnd) < 1.5)) return fail(`the firmware reads ${bg.temperature_c} °C, the session is at ${tEnd.toFixed(1)} °C`);
  // The windows that start after the first adoption.
  const after = table.filter((t) => t.minute * 60 > sessionS(adoptNs[0]) + WINDOW_S);
  const over = after.filter((t) => !(t.withTruth <= FLOOR_FACTOR * t.floorTruth + FLOOR_MG));
  if (!after.length || over.length) {
    return fail(`after the first adoption (minute ${(sessionS(adoptNs[0]) / 60).toFixed(1)}), windows over ${FLOOR_FACTOR} × the floor + ${FLOOR_MG} mg: ${over.map((t) => `minute ${t.minute}: ${fmt(t.withTruth)} mg, floor ${fmt(t.floorTruth)} mg`).join('; ') || 'no window'}`);
  }
  if (!(cycles.worst < PERIOD_CYCLES)) return fail(`a poll period used ${cycles.worst} cycles (period ${PERIOD_CYCLES})`);
  const c = bg.candidate;
  const near = after.length;
  const worst = after.reduce((w, t) => (t.withTruth - t.floorTruth > w.withTruth - w.floorTruth ? t : w), after[0]);
  return `${SESSION_S / scale} s of play (2 h of drift at ${scale}×, intervals ${intervals.commitIntervalS} s / ${intervals.commitsPerDay} a day / fit ${intervals.fitIntervalMs / 1000} s, ${rests.length} rests, ${playWallS.toFixed(0)} s wall): ` +
    `${adopted.length} adoptions at minute ${adopted.map((a) => `${a.minute.toFixed(1)} (${fmt(a.beforeMg)} → ${fmt(a.afterMg)} mg)`).join(', ')} of the session (last candidate ${c?.full_model ? '9 parameters' : 'bias + scale'}${c?.temperature ? ' + temperature slope' : ''}); ` +
    `error against the truth at the end ${fmt(table.at(-1).withTruth)} mg with, ${fmt(table.at(-1).withoutTruth)} mg without, floor ${fmt(table.at(-1).floorTruth)} mg; near the floor (≤ ${FLOOR_FACTOR} × floor + ${FLOOR_MG} mg) in all ${near} windows after the first adoption (farthest above the floor: minute ${worst.minute}, ${fmt(worst.withTruth)} mg, floor ${fmt(worst.floorTruth)} mg); ` +
    `firmware reads ${bg.temperature_c.toFixed(1)} °C (session ${tEnd.toFixed(1)} °C); ` +
    `busy cycles per 5-ms poll period: median ${cycles.median}, worst ${cycles.worst} (${((100 * cycles.worst) / PERIOD_CYCLES).toFixed(1)} %), commit periods worst ${cycles.commitWorst}`;
}
