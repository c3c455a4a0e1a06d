#!/usr/bin/env node
// Scenarios for the real RP2040 firmware in rp2040js (see README.md and firmware/README.md).
// usage: node run.js --elf FIRMWARE.elf [--uf2 FIRMWARE.uf2] --wiical target/debug/wiical
//                    --expect XTASK [NAME…]
// With --uf2 every scenario's board boots from the UF2 file (the file a user drops on the
// Pico's drive, read into flash as the boot ROM writes it) instead of the ELF's segments.
// Prints one `ok|FAIL <name>: <detail>` line per scenario, measurements, and a closing
// `N passed, M failed`; exits non-zero when a scenario failed.

import { readFileSync, writeFileSync, mkdtempSync, rmSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join } from 'node:path';
import { spawnSync } from 'node:child_process';
import { Rig } from './src/rig.js';
import { Board, FLASH_SIZE } from './src/board.js';
import { parseElf } from './src/elf.js';
import { parseUf2, Uf2Error } from './src/uf2.js';
import { decodeReport, calibrationBlock } from './src/nunchuk.js';
import { crc32, decodeMotionPlusReport, decodePassthroughNunchuk } from './src/motionplus.js';
import { selfCalScenarios } from './src/selfcal-scenarios.js';
import { backgroundScenarios } from './src/background-scenarios.js';
import { motionplusDriftScenarios } from './src/motionplus-drift.js';
import { mulberry32 } from './src/pose-nunchuk.js';
import { decodeFrames, unitRequestFrame, REQUEST, RESPONSE, RawHost, frame, putFrame, startStreamFrame, decodeGyroSample } from './src/wire.js';

const args = process.argv.slice(2);
function option(name) {
  const i = args.indexOf(name);
  if (i < 0 || i + 1 >= args.length) throw new Error(`missing ${name}`);
  const v = args[i + 1];
  args.splice(i, 2);
  return v;
}
const elfBytes = readFileSync(option('--elf'));
const uf2Path = args.includes('--uf2') ? option('--uf2') : null;
const uf2Bytes = uf2Path ? readFileSync(uf2Path) : null;
const wiical = option('--wiical');
const expectBin = option('--expect');
const only = args;
const work = mkdtempSync(join(tmpdir(), 'wiical-emu-'));
const link = join(work, 'ttyACM0');

/** Two user calibrations (as `wiical fit --out` writes them): bias in counts, K in g/count. */
const CAL_A = {
  bias: [509.5, 515.25, 521.0],
  matrix: [[1 / 203, -0.00006, 0.00002], [0.00003, 1 / 199, 0], [0.00005, 0, 1 / 205]],
};
const CAL_B = {
  bias: [507.0, 517.5, 519.0],
  matrix: [[1 / 206, 0, 0], [0, 1 / 201, 0.00004], [0, -0.00003, 1 / 202]],
};
function writeCal(name, cal) {
  const path = join(work, `${name}.json`);
  writeFileSync(path, JSON.stringify(cal));
  return path;
}
const calA = writeCal('a', CAL_A);
const calB = writeCal('b', CAL_B);
/**
 * A calibration with orientation-dependent cross terms (calibration file version 2):
 * per output axis the coefficients of the degree-2 monomials other than its own square, in the
 * order x², y², z², xy, xz, yz (1/g), and of the degree-3 ones other than its own cube, in the
 * order x³, y³, z³, x²y, x²z, xy², y²z, xz², yz², xyz (1/g²); large enough to move the
 * Wii Remote's counts by several counts away from the axes. Plus a drift term, which the
 * adapter must leave alone (no clock origin).
 */
const CAL_X = {
  schema: 'wiical-calibration/2',
  ...CAL_A,
  effects: {
    quadratic: [0.004, 0, -0.003],
    bias_drift: [0.05, 0, 0],
    cross_quadratic: [[0, 0, 0.03, 0, -0.02], [0.01, 0, 0, 0.025, 0], [0, -0.015, 0.04, 0, 0.01]],
    cross_cubic: [
      [0, 0, 0, 0.01, 0, 0, 0, 0, -0.02],
      [0, 0, 0, 0, 0, 0.015, 0, 0, 0],
      [-0.01, 0, 0, 0, 0, 0, 0, 0, 0.03],
    ],
  },
};
const calX = writeCal('x', CAL_X);

/** Expected Wii Remote counts for raw triples, from the core (xtask emulate-correct). */
function expectedCounts(calPath, raws) {
  const input = raws.map((r) => r.join(' ')).join('\n') + '\n';
  const r = spawnSync(expectBin, ['emulate-correct', calPath], { input, encoding: 'utf8' });
  if (r.status !== 0) throw new Error(`emulate-correct failed: ${r.stderr}`);
  return r.stdout.trim().split('\n').map((l) => l.split(' ').map(Number));
}

const ID = [0x00, 0x00, 0xa4, 0x20, 0x00, 0x00];
const IDEAL_BLOCK = calibrationBlock([512, 512, 512], [712, 712, 712], [0xe0, 0x20, 0x80], [0xe0, 0x20, 0x80]);

/**
 * Checks the reports the Wii Remote read after handshake `fromHandshake` against the Nunchuk's
 * raw reports: each must equal `transform(raw)` (accel), with stick and buttons unchanged, for
 * one of the last three raw reports the adapter polled before the read. `keep(report)` narrows
 * the reports checked. Returns a detail string on failure, null when all match.
 */
function checkReports(rig, fromHandshake, transform, minReports = 40, keep = () => true) {
  const reports = rig.remote.reports.filter((r) => r.handshake >= fromHandshake && keep(r));
  if (reports.length < minReports) return `only ${reports.length} reports read by the Wii Remote`;
  const served = rig.nunchuk.served;
  const poses = new Set();
  let bad = 0;
  let firstBad = null;
  for (const rep of reports) {
    const got = decodeReport(rep.bytes);
    let idx = served.findIndex((s) => s.tNs > rep.tNs) - 1;
    if (idx < -1) idx = served.length - 1;
    const candidates = served.slice(Math.max(0, idx - 2), idx + 1);
    const hit = candidates.find((s) => {
      const want = transform(s.raw.accel);
      return want.every((v, i) => v === got.accel[i]) && s.raw.stick[0] === got.stick[0] &&
        s.raw.stick[1] === got.stick[1] && s.raw.c === got.c && s.raw.z === got.z;
    });
    if (hit) poses.add(hit.raw.pose);
    else {
      bad += 1;
      if (!firstBad) firstBad = { got, want: candidates.map((s) => transform(s.raw.accel)) };
    }
  }
  if (bad) return `${bad}/${reports.length} reports differ, first: got ${JSON.stringify(firstBad.got.accel)} want one of ${JSON.stringify(firstBad.want)}`;
  if (poses.size < 4) return `the reports cover only ${poses.size} poses`;
  return null;
}

/** How often the Wii Remote addressed a read while its pointer write was still unread (the
 * firmware late after a read that ended inside a piece): the race the first report after a
 * re-handshake is exposed to. */
function overtaken(rig) {
  const n = rig.board.i2c1.lateReads;
  return `${n} read${n === 1 ? '' : 's'} addressed with the pointer write before ${n === 1 ? 'it' : 'them'} unread`;
}

/** Batch-fills the memo of `correction` for all raws served so far (one helper call). */
function prefill(fn, calPath, rig) {
  const raws = [...new Set(rig.nunchuk.served.map((s) => s.raw.accel.join(' ')))].map((k) => k.split(' ').map(Number));
  const out = expectedCounts(calPath, raws);
  raws.forEach((r, i) => fn.memoSet?.(r, out[i]));
}
function correctionBatch(calPath) {
  const memo = new Map();
  const fn = (raw) => {
    const key = raw.join(' ');
    if (!memo.has(key)) memo.set(key, expectedCounts(calPath, [raw])[0]);
    return memo.get(key);
  };
  fn.memoSet = (raw, v) => memo.set(raw.join(' '), v);
  return fn;
}

/** `ErrorCode::BadFrame` (crates/wire messages.rs; serialized as its u8). */
const ERROR_BAD_FRAME = 2;
const sameBytes = (a, b) => a.length === b.length && a.every((v, i) => v === b[i]);
const f32eq = (a, b) => Math.fround(a) === Math.fround(b);
function sameCal(live, cal) {
  return live && cal.bias.every((v, i) => f32eq(v, live.bias[i])) &&
    cal.matrix.every((row, i) => row.every((v, j) => f32eq(v, live.matrix[i][j])));
}
async function getState(rig) {
  const r = await rig.wiical(['get', '--json']);
  if (r.code !== 0) return { error: `wiical device get: exit ${r.code}: ${r.stderr.trim()}` };
  return JSON.parse(r.stdout);
}
function newRig(flashImage = null, options = {}) {
  return new Rig({ elfBytes, uf2Bytes, flashImage, wiical, link, ...options });
}
async function putCommit(rig, calPath, extra = []) {
  const put = await rig.wiical(['put', calPath, ...extra]);
  if (put.code !== 0) return `wiical device put: exit ${put.code}: ${put.stderr.trim()}`;
  // A staged upload belongs to its session (wire protocol 2): `commit FILE` uploads again,
  // verifies and commits within one session.
  const commit = await rig.wiical(['commit', calPath, ...extra]);
  if (commit.code !== 0) return `wiical device commit: exit ${commit.code}: ${commit.stderr.trim()}`;
  return null;
}

/**
 * Commits `next` over the calibration in `image` (through the wire protocol, without the CLI:
 * fast), cutting the power at flash step `k` (`done`: the fraction of the step completed, 0 =
 * before it), then boots a new emulator on what the flash holds and asks the real CLI.
 * Returns 'old' / 'new' (the live, stored calibration is `old` / `next`), or what went wrong.
 */
async function cutCommitAt(image, old, next, k, done, seed) {
  const rig = newRig(image);
  await rig.board.runUntilTrue(() => rig.usb.configured, 500);
  const host = new RawHost(rig);
  if (!(await host.hello())) return 'no Hello answer before the commit';
  const random = mulberry32(seed);
  rig.board.onFlashStep = (_step, index) => index === k && (done > 0 ? { done, random } : true);
  await host.putCommit(next);
  rig.close();
  if (!rig.board.powerCut) return `the commit finished without reaching flash step ${k}`;
  const after = newRig(rig.board.flashImage());
  await after.board.runUntilTrue(() => after.remote.reports.length > 0, 1000);
  const state = await getState(after);
  after.close();
  if (after.board.fault) return `firmware fault ${after.board.fault}`;
  if (!after.remote.reports.length) return 'no report served to the Wii Remote after the reboot';
  if (state.error) return state.error;
  if (state.stored && sameCal(state.live, old)) return 'old';
  if (state.stored && sameCal(state.live, next)) return 'new';
  return `the live calibration is neither the old nor the new one (stored: ${state.stored})`;
}

/**
 * Commits A and B alternately over `image` until a commit erases a sector (the store's
 * sectors fill up and it reclaims one). Returns the image just before that commit, the
 * calibration live in it and the one that commit stores, or null.
 */
async function fillUntilErase(image, live, maxCommits = 300) {
  const rig = newRig(image);
  await rig.board.runUntilTrue(() => rig.usb.configured, 500);
  const host = new RawHost(rig);
  let found = null;
  if (await host.hello()) {
    for (let i = 0; i < maxCommits && !found; i++) {
      const next = live === CAL_A ? CAL_B : CAL_A;
      const before = rig.board.flashImage();
      const n = rig.board.flashSteps.length;
      if (!(await host.putCommit(next))) break;
      if (rig.board.flashSteps.slice(n).some((s) => s.kind === 'erase')) found = { image: before, old: live, next, commits: i };
      live = next;
    }
  }
  rig.close();
  return found;
}

/**
 * A calibration produced by the pipeline rather than written by hand: a Nunchuk
 * recording with an undeclared cross-quadratic effect from `wiical simulate` (fixed seed),
 * analysed blind by `wiical analyze --out`. Returns the calibration file's path and contents,
 * analyze's JSON report and the simulator's truth, or `{ error }`.
 */
const ANALYZED = { device: 'nunchuk', effect: 'cross-quadratic', magnitudeMg: 20, seed: 1 };
function analyzedCalibration() {
  const rec = join(work, 'analyzed.csv');
  const calPath = join(work, 'analyzed-cal.json');
  const sim = spawnSync(wiical, ['simulate', '--out', rec, '--device', ANALYZED.device, '--effect', ANALYZED.effect,
    '--magnitude', String(ANALYZED.magnitudeMg), '--seed', String(ANALYZED.seed)], { encoding: 'utf8' });
  if (sim.status !== 0) return { error: `wiical simulate: exit ${sim.status}: ${sim.stderr.trim()}` };
  const an = spawnSync(wiical, ['analyze', rec, '--out', calPath, '--json'], { encoding: 'utf8' });
  if (an.status !== 0) return { error: `wiical analyze: exit ${an.status}: ${an.stderr.trim()}` };
  return {
    calPath,
    cal: JSON.parse(readFileSync(calPath, 'utf8')),
    report: JSON.parse(an.stdout),
    truth: JSON.parse(readFileSync(`${rec}.truth.json`, 'utf8')),
  };
}

/** The degree-2 monomials of a cross_quadratic row of output axis `axis` (its own square left out). */
const crossQuadMonomials = (axis) => ['x²', 'y²', 'z²', 'x·y', 'x·z', 'y·z'].filter((_, k) => k !== axis);

/**
 * Checks the analysed calibration against what analyze reported and the simulator's truth:
 * schema version 2; analyze named the truth's cross-quadratic term; the file's cross_quadratic
 * has exactly that one non-zero coefficient (at the named axis and monomial), equal (f32) to
 * the report's value and within 10 % of the truth's. Returns `{ name, value }` or `{ error }`.
 */
function checkAnalyzedCal({ cal, report, truth }) {
  if (cal.schema !== 'wiical-calibration/2') return { error: `schema ${cal.schema}, not wiical-calibration/2` };
  const want = truth.open_basis?.[0]?.terms?.[0];
  const row = report.effects.find((e) => e.name === want);
  if (!row) return { error: `analyze did not name the truth's ${want}: effects ${JSON.stringify(report.effects.map((e) => e.name))}` };
  const [, axisName, monomial] = want.match(/^cross-quadratic \(([xyz]): (.+)\)$/) ?? [];
  const axis = 'xyz'.indexOf(axisName);
  const k = axis < 0 ? -1 : crossQuadMonomials(axis).indexOf(monomial);
  if (k < 0) return { error: `cannot place ${want} in cross_quadratic` };
  const cq = cal.effects?.cross_quadratic;
  const nonZero = (cq ?? []).flatMap((r, i) => r.map((v, j) => ({ i, j, v }))).filter((c) => c.v !== 0);
  if (nonZero.length !== 1 || nonZero[0].i !== axis || nonZero[0].j !== k) {
    return { error: `cross_quadratic ${JSON.stringify(cq)} does not hold ${want} alone (row ${axis}, column ${k})` };
  }
  const value = nonZero[0].v;
  if (!f32eq(value, row.values[axis])) return { error: `the file's ${value} is not the report's ${row.values[axis]}` };
  const truthValue = truth.open_basis[0].coefficients[axis];
  if (Math.abs(value - truthValue) > 0.1 * Math.abs(truthValue)) return { error: `${want} = ${value}, truth ${truthValue}` };
  return { name: want, value, truthValue, stdError: row.std_errors[axis] };
}

/** A scenario's failure (a success is the plain detail string). */
const fail = (message) => ({ fail: message });
const measurements = {};
const shared = {}; // images handed from one scenario to the next

/**
 * The UF2 file against the ELF it was made from: every byte the ELF's segments put in flash is
 * the same in flash loaded from the UF2, and every other byte the UF2 writes is 0 (padding of
 * a page or of an erase sector). Then the same file, damaged, must be refused.
 */
function checkUf2Image() {
  const fromUf2 = new Board({ uf2Bytes }).flashImage();
  const elfWrites = new Uint8Array(FLASH_SIZE);
  const fromElf = new Uint8Array(FLASH_SIZE).fill(0xff);
  for (const { paddr, bytes } of parseElf(elfBytes).segments) {
    if (paddr < 0x10000000 || paddr + bytes.length > 0x10000000 + FLASH_SIZE) continue;
    fromElf.set(bytes, paddr - 0x10000000);
    elfWrites.fill(1, paddr - 0x10000000, paddr - 0x10000000 + bytes.length);
  }
  let elfCount = 0;
  let padding = 0;
  for (let i = 0; i < FLASH_SIZE; i++) {
    if (elfWrites[i]) {
      elfCount += 1;
      if (fromUf2[i] !== fromElf[i]) return { error: `flash offset 0x${i.toString(16)}: the UF2 holds ${fromUf2[i]}, the ELF ${fromElf[i]}` };
    } else if (fromUf2[i] === 0) padding += 1;
    else if (fromUf2[i] !== 0xff) return { error: `flash offset 0x${i.toString(16)}: the UF2 writes ${fromUf2[i]} where the ELF writes nothing` };
  }
  const pages = parseUf2(uf2Bytes).length;
  const damaged = {
    'bad magic': (b) => { b[512 * 7 + 1] ^= 0xff; },
    'missing block': null,
    'wrong family': (b) => { b[512 * 3 + 28] ^= 0x0f; },
  };
  const refusals = [];
  for (const [what, damage] of Object.entries(damaged)) {
    const bytes = damage ? Uint8Array.from(uf2Bytes) : Buffer.concat([uf2Bytes.subarray(0, 512 * 5), uf2Bytes.subarray(512 * 6)]);
    damage?.(bytes);
    try {
      new Board({ uf2Bytes: bytes });
      return { error: `a UF2 with a ${what} was loaded` };
    } catch (e) {
      if (!(e instanceof Uf2Error)) throw e;
      refusals.push(`${what}: "${e.message}"`);
    }
  }
  return { detail: `${pages} pages (${uf2Bytes.length} B) hold the ELF's ${elfCount} flash bytes at their load addresses, plus ${padding} bytes of zero padding; refused ${refusals.join('; ')}` };
}


/** MotionPlus turns: 1.5-s segments of constant true rate °/s [yaw, roll, pitch], both ranges
 * (the device switches to its fast range above 350 °/s). */
const TURNS = [
  [0, 0, 0], [120, -80, 40], [-300, 250, -150], [700, -600, 0], [-900, 0, 800], [0, 0, 0],
];
const TURN_S = 1.5;
/** The simulated MotionPlus: its own zero (a bias of several °/s) and sensitivity (+10 % / +3 %
 * / −6 % against the nominal 8192/440 counts per °/s its block states), 2 counts of noise. The
 * bias is a rate bias, the same °/s in both ranges (the fast range's zero off the block's by the
 * slow offset × 440/2000): the one bias of a gyro calibration (slow counts) describes both
 * ranges only so (crates/adapter/src/motionplus.rs). A fast zero off by the slow range's
 * counts instead (`zeroFast = zero`) leaves 12-26 °/s in the fast range (measured). */
const MP_ZERO = [8192 + 150, 8192 - 90, 8192 + 60];
const MP_DEVICE = {
  zero: MP_ZERO,
  zeroFast: MP_ZERO.map((z) => 8192 + (z - 8192) * (440 / 2000)),
  perDps: [20.5, 19.2, 17.5],
  noiseCounts: 2,
  slowLimitDps: 350,
  fastRatio: 440 / 2000,
};
/** The gyro calibration file of that device, as `gyrofit --out` writes one (version 1): bias in
 * slow counts, K in rad/s per count, along the count axes (so the host's frame conversion is
 * the identity). */
function writeGyroCal() {
  const k = (s) => Math.PI / 180 / s;
  const p = MP_DEVICE.perDps;
  const path = join(work, 'gyro.json');
  writeFileSync(path, JSON.stringify({
    format: 'wiical-gyro-calibration/1', model: 'full+bias', bias: MP_DEVICE.zero,
    matrix: [[k(p[0]), 0, 0], [0, k(p[1]), 0], [0, 0, k(p[2])]], units: 'rad/s', cv_rms_deg: 0.5,
  }));
  return path;
}
/** A report's rates °/s along the count axes as a reader of `block` computes them (each range's
 * span taken by its magnitude: positive where the count rises). */
function blockRates(block, report) {
  const u16 = (i) => (block[i] << 8) | block[i + 1];
  return [0, 1, 2].map((i) => {
    const o = report.slow[i] ? 0x10 : 0x00;
    const zero = u16(o + 2 * i);
    const span = Math.abs(u16(o + 6 + 2 * i) - zero);
    return ((report.rate[i] * 4 - zero) / span) * block[o + 12] * 6;
  });
}
/** Runs the turns once from now; per segment and axis the 1-s mean (0.25..1.25 s into the
 * segment) of the rates the Wii Remote read, decoded with `block`, minus the truth. */
async function turnErrors(rig, block) {
  const t0 = rig.board.nanos;
  rig.turnsFrom = t0;
  await rig.board.run(TURNS.length * TURN_S * 1000);
  return TURNS.map((truth, k) => {
    const from = t0 + (k * TURN_S + 0.25) * 1e9;
    const rs = rig.remote.reports.filter((r) => r.tNs >= from && r.tNs < from + 1e9);
    const rates = rs.map((r) => blockRates(block, decodeMotionPlusReport(r.bytes)));
    const mean = [0, 1, 2].map((i) => rates.reduce((a, r) => a + r[i], 0) / Math.max(1, rates.length));
    return { truth, n: rates.length, error: mean.map((m, i) => m - truth[i]) };
  });
}
const IDEAL_MP_BLOCK_RANGES = { slow: [24576, 55], fast: [12288, 125] };

/** Power cut during a gyro commit (motionplus-powercut): the MotionPlus turns at this constant
 * rate (°/s, slow range, above the tracker's 10 °/s rest limit so the bias stays put), and a
 * second gyro calibration unlike the first (bias +25 counts, K 6 % larger) to commit over it. */
const CUT_RATE = [40, -30, 25];
function writeGyroCalB() {
  const a = JSON.parse(readFileSync(writeGyroCal(), 'utf8'));
  const path = join(work, 'gyro-b.json');
  writeFileSync(path, JSON.stringify({ ...a, bias: a.bias.map((b) => b + 25), matrix: a.matrix.map((r) => r.map((v) => v * 1.06)) }));
  return path;
}
/** The rates (°/s) a gyro calibration file makes of the device's slow counts at CUT_RATE. */
function cutExpected(cal) {
  return [0, 1, 2].map((i) => {
    const m = MP_DEVICE.zero[i] + MP_DEVICE.perDps[i] * CUT_RATE[i];
    return (cal.matrix[i][i] * (m - cal.bias[i]) * 180) / Math.PI;
  });
}
/** Boots on `image`, asks `device get` and reads 0.5 s of rates: 'old' / 'new' / 'none' when
 * both say the same calibration (or none), else what is wrong. */
async function gyroAfterReboot(image, calOld, calNew) {
  const rig = newRig(image, { motionplus: { rates: () => CUT_RATE, ...MP_DEVICE } });
  await rig.board.runUntilTrue(() => rig.remote.reports.length > 20, 3000);
  const state = await getState(rig);
  const t0 = rig.board.nanos;
  rig.remote.rereadBlock = true;
  await rig.board.run(600);
  const block = rig.remote.blocks.at(-1)?.block;
  const rs = rig.remote.reports.filter((r) => r.tNs > t0 + 50e6);
  rig.close();
  if (rig.board.fault) return `firmware fault ${rig.board.fault}`;
  if (state.error) return state.error;
  if (!block || rs.length < 50) return `after the reboot the Wii Remote read ${rs.length} reports and ${block ? 'a' : 'no'} block`;
  const rates = rs.map((r) => blockRates(block, decodeMotionPlusReport(r.bytes)));
  const mean = [0, 1, 2].map((i) => rates.reduce((a, r) => a + r[i], 0) / rates.length);
  const live = state.gyro?.live ?? null;
  const same = (cal) => live && cal.bias.every((v, i) => f32eq(v, live.bias[i])) &&
    cal.matrix.every((row, i) => row.every((v, j) => f32eq(v, live.matrix[i][j])));
  const near = (want) => mean.every((m, i) => Math.abs(m - want[i]) < 0.25);
  // Uncalibrated, the device's own (nominal) block is read: 8192/440 counts per °/s about 8192.
  const rawRates = [0, 1, 2].map((i) => ((MP_DEVICE.zero[i] + MP_DEVICE.perDps[i] * CUT_RATE[i] - 8192) * 440) / 8192);
  const says = live === null ? 'none' : same(calOld) ? 'old' : same(calNew) ? 'new' : 'other';
  const reads = near(cutExpected(calOld)) ? 'old' : near(cutExpected(calNew)) ? 'new' : near(rawRates) ? 'none' : 'other';
  if (says !== reads) return `device get says ${says}, the rates read ${reads} ([${mean.map((m) => m.toFixed(2))}] °/s)`;
  return says === 'other' ? `neither calibration: ${JSON.stringify(live)}` : says;
}

/** The Nunchuk in the MotionPlus's port (motionplus-passthrough): zero and counts per g per
 * axis (not the ideal 512 + 200·g), 2 counts of Gaussian noise, one pose (g) per turn segment. */
const PT_NUNCHUK = { zero: [508, 516, 520], perG: [204, 200, 204], noiseCounts: 2 };
const PT_POSES = [[0, 0, 1], [1, 0, 0], [0, -1, 0], [0.6, 0, 0.8], [0, 0.6, -0.8], [-1, 0, 0]];
/** Its accelerometer calibration file (as `wiical fit --out` writes one). */
function writeNunchukCal() {
  const path = join(work, 'pt-nunchuk.json');
  const p = PT_NUNCHUK.perG;
  writeFileSync(path, JSON.stringify({ bias: PT_NUNCHUK.zero, matrix: [[1 / p[0], 0, 0], [0, 1 / p[1], 0], [0, 0, 1 / p[2]]] }));
  return path;
}
/** Runs the turns and poses once from now; per segment the 1-s means (0.25..1.25 s into the
 * segment) of what the Wii Remote read minus the truth: gyro frames decoded with `block`
 * (°/s), Nunchuk frames on the ideal scale 512 + 200·g (g). */
async function passthroughErrors(rig, block) {
  const t0 = rig.board.nanos;
  rig.turnsFrom = t0;
  await rig.board.run(TURNS.length * TURN_S * 1000);
  const mean = (xs) => [0, 1, 2].map((i) => xs.reduce((a, x) => a + x[i], 0) / Math.max(1, xs.length));
  return TURNS.map((truth, k) => {
    const from = t0 + (k * TURN_S + 0.25) * 1e9;
    const rs = rig.remote.reports.filter((r) => r.tNs >= from && r.tNs < from + 1e9);
    const gyro = rs.filter((r) => r.bytes[5] & 2).map((r) => blockRates(block, decodeMotionPlusReport(r.bytes)));
    const acc = rs.filter((r) => !(r.bytes[5] & 2)).map((r) => decodePassthroughNunchuk(r.bytes).accel.map((c) => (c - 512) / 200));
    const pose = PT_POSES[k];
    return {
      truth, pose, n: gyro.length, nAcc: acc.length,
      error: mean(gyro).map((m, i) => m - truth[i]),
      accError: mean(acc).map((m, i) => m - pose[i]),
    };
  });
}

const scenarios = [
  ['uf2-image', async () => {
    if (!uf2Bytes) return fail('no --uf2 file (cargo xtask emulate passes target/uf2/wiical-adapter-rp2040.uf2)');
    const r = checkUf2Image();
    return r.error ? fail(r.error) : r.detail;
  }],
  ['boot-passthrough', async () => {
    const rig = newRig();
    await rig.board.runUntilTrue(() => rig.remote.reports.length > 0, 2000);
    if (rig.board.fault) return fail(`firmware fault: ${rig.board.fault}`);
    if (rig.nunchuk.inits < 1) return fail('the firmware never initialised the Nunchuk');
    const hs = rig.remote.handshakes[0];
    if (!hs) return fail(`no Wii Remote handshake (bus errors: ${JSON.stringify(rig.remote.errors.slice(0, 3))})`);
    if (!sameBytes(hs.id, ID)) return fail(`identifier ${hs.id} is not a Nunchuk's`);
    if (!sameBytes(hs.block, rig.nunchuk.block)) return fail(`pass-through block ${hs.block} differs from the Nunchuk's ${rig.nunchuk.block}`);
    measurements.bootToFirstReportNs = rig.remote.reports[0].tNs;
    await rig.board.run(600);
    const err = checkReports(rig, 1, (a) => a);
    collectTiming(rig);
    rig.close();
    const from = uf2Bytes ? `booted from ${rig.board.uf2Pages} UF2 pages` : 'booted from the ELF';
    return err ? fail(err) : `${from}; ${rig.remote.reports.length} reports equal the raw Nunchuk reports (pass-through)`;
  }],
  ['hang-up-ends-session', async () => {
    // A host killed mid-session sends no EndSession: its driver clears DTR as the port
    // closes, and the next opener raises it again. That opener's bare commit is refused.
    const rig = newRig();
    await rig.board.runUntilTrue(() => rig.usb.configured, 500);
    const host = new RawHost(rig);
    if (!(await host.hello())) return fail('no Hello answer');
    const put = await host.request(putFrame(CAL_B));
    if (put?.tag !== RESPONSE.ack) return fail('the upload was not staged');
    for (const dtr of [false, true]) {
      const n = rig.usb.lineStates ?? 0;
      rig.usb.setLineState(dtr);
      if (!(await rig.board.runUntilTrue(() => (rig.usb.lineStates ?? 0) > n, 500))) return fail(`SET_CONTROL_LINE_STATE (DTR ${dtr}) not completed`);
      await rig.board.run(20);
    }
    const commit = await host.request(frame([3]), 2000);
    if (commit?.tag !== RESPONSE.error) return fail(`the next opener's bare commit was answered with tag ${commit?.tag}, not an error`);
    const state = await getState(rig);
    rig.close();
    if (state.error) return fail(state.error);
    if (state.stored || state.staged) return fail('the killed host\'s upload is staged or stored after its hang-up');
    return 'DTR cleared: the session and its staged upload ended; the next opener\'s bare commit refused, nothing stored';
  }],
  ['commit-live', async () => {
    const rig = newRig();
    await rig.board.runUntilTrue(() => rig.remote.handshakes.length > 0, 2000);
    const info = await rig.wiical(['info']);
    if (info.code !== 0) return fail(`wiical device info: exit ${info.code}: ${info.stderr.trim()}`);
    const e = await putCommit(rig, calA);
    if (e) return fail(e);
    const before = rig.remote.handshakes.length;
    const ok = await rig.board.runUntilTrue(() => rig.remote.handshakes.length > before, 1000);
    if (!ok) return fail('the Wii Remote did not re-read the extension after the commit (detect did not toggle)');
    const hs = rig.remote.handshakes[rig.remote.handshakes.length - 1];
    if (!sameBytes(hs.block, IDEAL_BLOCK)) return fail(`calibrated block ${hs.block} is not the ideal one ${IDEAL_BLOCK}`);
    await rig.board.run(600);
    const fn = correctionBatch(calA);
    prefill(fn, calA, rig);
    const err = checkReports(rig, rig.remote.handshakes.length, fn);
    const state = await getState(rig);
    if (state.error) return fail(state.error);
    if (!state.stored || !sameCal(state.live, CAL_A)) return fail('wiical device get does not show the committed calibration as stored and live');
    shared.committedA = rig.board.flashImage();
    rig.close();
    return err ? fail(err) : 'put + commit: detect toggled, block re-read, reports equal the core\'s correction';
  }],
  ['power-cycle', async () => {
    if (!shared.committedA) return fail('needs commit-live');
    const rig = newRig(shared.committedA);
    await rig.board.runUntilTrue(() => rig.remote.reports.length > 0, 2000);
    if (!rig.remote.handshakes.length) return fail('no handshake after the power cycle');
    if (!sameBytes(rig.remote.handshakes[0].block, IDEAL_BLOCK)) return fail('after the power cycle the block is not the calibrated one');
    await rig.board.run(500);
    const fn = correctionBatch(calA);
    prefill(fn, calA, rig);
    const err = checkReports(rig, 1, fn);
    const state = await getState(rig);
    rig.close();
    if (state.error) return fail(state.error);
    if (!state.stored || !sameCal(state.live, CAL_A)) return fail('the committed calibration is not live after the power cycle');
    return err ? fail(err) : 'new emulator on the same flash: calibration still live, reports corrected';
  }],
  ['commit-cross-terms', async () => {
    // A calibration with orientation-dependent cross terms, committed through the
    // CLI, corrects the Wii Remote's reports on the device (expected counts: the core's
    // correction with the acceleration-only terms, xtask emulate-correct), survives a power
    // cycle (flash record version 2), and `device put` says which terms the adapter applies.
    const rig = newRig();
    await rig.board.runUntilTrue(() => rig.remote.handshakes.length > 0, 2000);
    const put = await rig.wiical(['put', calX]);
    if (put.code !== 0) return fail(`wiical device put: exit ${put.code}: ${put.stderr.trim()}`);
    const applied = 'applied by the adapter: bias and K, quadratic, cross_quadratic (orientation), cross_cubic (orientation)';
    const hostOnly = 'not applied by the adapter: bias_drift (time)';
    if (!put.stdout.includes(applied) || !put.stdout.includes(hostOnly)) return fail(`device put does not name the applied terms: ${put.stdout.trim()}`);
    const commit = await rig.wiical(['commit', calX]);
    if (commit.code !== 0) return fail(`wiical device commit: exit ${commit.code}: ${commit.stderr.trim()}`);
    const before = rig.remote.handshakes.length;
    if (!(await rig.board.runUntilTrue(() => rig.remote.handshakes.length > before, 1000))) return fail('the Wii Remote did not re-read the extension after the commit');
    await rig.board.run(600);
    const fn = correctionBatch(calX);
    prefill(fn, calX, rig);
    const linear = correctionBatch(calA);
    prefill(linear, calA, rig);
    let err = checkReports(rig, rig.remote.handshakes.length, fn);
    // The cross terms must matter for the reports checked: some differ from the linear ones.
    const moved = rig.nunchuk.served.filter((s) => fn(s.raw.accel).some((v, i) => v !== linear(s.raw.accel)[i])).length;
    const state = await getState(rig);
    const image = rig.board.flashImage();
    rig.close();
    if (err) return fail(err);
    if (!moved) return fail('the cross terms change none of the served readings: the test would not see them');
    if (state.error) return fail(state.error);
    const sameCross = (live) => live && ['cross_quadratic', 'cross_cubic'].every((k) =>
      CAL_X.effects[k].every((row, i) => row.every((v, j) => f32eq(v, live.effects[k][i][j]))));
    if (!state.stored || !sameCal(state.live, CAL_X) || !sameCross(state.live)) return fail('wiical device get does not show the committed cross terms as stored and live');
    const again = newRig(image);
    await again.board.runUntilTrue(() => again.remote.reports.length > 0, 2000);
    await again.board.run(500);
    prefill(fn, calX, again);
    err = checkReports(again, 1, fn);
    const after = await getState(again);
    again.close();
    if (err) return fail(`after the power cycle: ${err}`);
    if (after.error) return fail(after.error);
    if (!after.stored || !sameCross(after.live)) return fail('the cross terms are not live after the power cycle');
    return `put names the applied terms; ${moved} of ${rig.nunchuk.served.length} served readings move with the cross terms; reports equal the core's correction before and after a power cycle; ${overtaken(rig)}`;
  }],
  ['commit-analyzed-cal', async () => {
    // A calibration the pipeline produced (simulate → analyze --out, with a cross
    // term analyze found) put and committed through the CLI; the Wii Remote's reports must
    // equal the core's correction with that file (xtask emulate-correct).
    const a = analyzedCalibration();
    if (a.error) return fail(a.error);
    const found = checkAnalyzedCal(a);
    if (found.error) return fail(found.error);
    const rig = newRig();
    await rig.board.runUntilTrue(() => rig.remote.handshakes.length > 0, 2000);
    const put = await rig.wiical(['put', a.calPath]);
    if (put.code !== 0) return fail(`wiical device put: exit ${put.code}: ${put.stderr.trim()}`);
    if (!put.stdout.includes('applied by the adapter: bias and K, cross_quadratic (orientation)\n')) return fail(`device put does not name the applied terms: ${put.stdout.trim()}`);
    const commit = await rig.wiical(['commit', a.calPath]);
    if (commit.code !== 0) return fail(`wiical device commit: exit ${commit.code}: ${commit.stderr.trim()}`);
    const from = rig.remote.handshakes.length + 1;
    if (!(await rig.board.runUntilTrue(() => rig.remote.handshakes.length >= from, 1000))) return fail('the Wii Remote did not re-read the extension after the commit');
    await rig.board.run(600);
    const fn = correctionBatch(a.calPath);
    prefill(fn, a.calPath, rig);
    const linearPath = writeCal('analyzed-linear', { bias: a.cal.bias, matrix: a.cal.matrix });
    const linear = correctionBatch(linearPath);
    prefill(linear, linearPath, rig);
    // Every report after the re-handshake is compared, the first one too: it follows the
    // 16-byte block read (6 + 6 + 4 of 6 bytes served), and when the firmware sees that
    // read's end only after the report's pointer write and read have come (a Nunchuk poll
    // just before), it must still apply the write first and serve the report from 0x00, not
    // from 0x32 where the block read left the pointer (firmware/src/wiimote.rs, overtaken).
    const err = checkReports(rig, from, fn, 40);
    // The control: the same reports against bias and K alone must not all match.
    const withoutTerm = checkReports(rig, from, linear, 40);
    const compared = rig.remote.reports.filter((r) => r.handshake >= from).length;
    const moved = rig.nunchuk.served.filter((s) => fn(s.raw.accel).some((v, i) => v !== linear(s.raw.accel)[i])).length;
    const state = await getState(rig);
    rig.close();
    if (err) return fail(err);
    if (!moved || !withoutTerm) return fail(`the reports match bias and K alone: ${found.name} is not seen`);
    if (state.error) return fail(state.error);
    const sameCross = (live) => live?.effects && a.cal.effects.cross_quadratic.every((row, i) =>
      row.every((v, j) => f32eq(v, live.effects.cross_quadratic[i][j])));
    if (!state.stored || !sameCal(state.live, a.cal) || !sameCross(state.live)) return fail('wiical device get does not show the analysed calibration as stored and live');
    const se = found.stdError.toExponential(1);
    return `simulate ${ANALYZED.device} ${ANALYZED.effect} ${ANALYZED.magnitudeMg} mg seed ${ANALYZED.seed} → analyze named ${found.name} = ${found.value.toFixed(5)} ± ${se} /g (truth ${found.truthValue}); put names it applied; ${compared} reports equal the core's correction with the file (against bias and K alone: ${withoutTerm}); ${moved} of ${rig.nunchuk.served.length} served readings move with the term; ${overtaken(rig)}`;
  }],
  ...selfCalScenarios({
    newRig, getState, fail, shared, work, sameBytes, sameCal, checkReports, correctionBatch, prefill,
    expectedCounts, IDEAL_BLOCK, CAL_A, calA, measurements,
  }),
  ...backgroundScenarios({
    newRig, getState, fail, shared, work, sameCal, checkReports, correctionBatch, prefill, expectedCounts, measurements,
  }),
  ['power-cut-commit', async () => {
    if (!shared.committedA) return fail('needs commit-live');
    // Two commits to cut: B over A (page programs only), and the commit that finds the
    // store's sectors full and erases one (reached by committing A and B alternately).
    const erasing = await fillUntilErase(shared.committedA, CAL_A);
    if (!erasing) return fail('no commit erased a sector');
    const commits = [
      { name: 'B over A', image: shared.committedA, old: CAL_A, next: CAL_B },
      { name: `commit ${erasing.commits + 2} (erases)`, ...erasing },
    ];
    // At every step: a cut before it and halfway through it (an erase that flipped about half
    // the programmed bits back to 1; a page program with half its bytes written and the next
    // one partly); an erase also at 10 % and 90 %.
    const tally = {};
    const corrupt = [];
    let cuts = 0;
    for (const c of commits) {
      const probe = newRig(c.image);
      await probe.board.runUntilTrue(() => probe.usb.configured, 500);
      const host = new RawHost(probe);
      const ok = (await host.hello()) && (await host.putCommit(c.next));
      const kinds = probe.board.flashSteps.map((s) => s.kind);
      probe.close();
      if (!ok || !kinds.length) return fail(`${c.name}: the uninterrupted commit failed or wrote nothing`);
      for (let k = 0; k < kinds.length; k++) {
        const fractions = kinds[k] === 'erase' ? [0, 0.1, 0.5, 0.9] : [0, 0.5];
        for (const done of fractions) {
          cuts += 1;
          const outcome = await cutCommitAt(c.image, c.old, c.next, k, done, cuts * 7919);
          const key = `${done ? 'during' : 'before'} ${kinds[k]}`;
          tally[key] ??= { old: 0, new: 0, corrupt: 0 };
          if (outcome === 'old' || outcome === 'new') tally[key][outcome] += 1;
          else {
            tally[key].corrupt += 1;
            corrupt.push(`${c.name}, ${Math.round(done * 100)} % into ${kinds[k]} step ${k}: ${outcome}`);
          }
        }
      }
    }
    const summary = Object.entries(tally).map(([k, t]) => `${k}: ${t.old} old/${t.new} new/${t.corrupt} corrupt`).join('; ');
    if (corrupt.length) return fail(`${summary}; first: ${corrupt[0]}`);
    return `${cuts} cuts in 2 commits (${summary})`;
  }],
  ['nunchuk-replug', async () => {
    const rig = newRig();
    await rig.board.runUntilTrue(() => rig.remote.reports.length > 20, 2000);
    const inits = rig.nunchuk.inits;
    rig.nunchuk.setPlugged(false);
    const dropped = await rig.board.runUntilTrue(() => !rig.remote.detect, 500);
    if (!dropped) return fail('extension detect stayed high after the Nunchuk was unplugged');
    await rig.board.run(300);
    const hs = rig.remote.handshakes.length;
    rig.nunchuk.setPlugged(true);
    const back = await rig.board.runUntilTrue(() => rig.remote.handshakes.length > hs, 3000);
    if (!back) return fail('the Wii Remote did not see the Nunchuk again after the replug');
    if (rig.nunchuk.inits <= inits) return fail('the firmware did not re-initialise the Nunchuk');
    await rig.board.run(400);
    const err = checkReports(rig, hs + 1, (a) => a);
    rig.close();
    return err ? fail(err) : 'unplug: detect dropped; replug: re-initialised, handshake, reports pass through again';
  }],
  ['motionplus-activation', async () => {
    // A MotionPlus instead of the Nunchuk, uncalibrated (no gyro calibration stored): the
    // adapter must find it at 0x53, activate it, and answer the Wii Remote's whole dance as
    // the MotionPlus does, its rates and block passed through unchanged.
    const truth = [30, -60, 120];
    const rig = newRig(null, { motionplus: { rates: () => truth } });
    await rig.board.runUntilTrue(() => rig.remote.reports.length > 40, 3000);
    if (rig.board.fault) return fail(`firmware fault: ${rig.board.fault}`);
    const mp = rig.motionplus;
    if (mp.activations < 1) return fail('the firmware never activated the MotionPlus');
    const hs = rig.remote.handshakes[0];
    if (!hs) return fail(`no Wii Remote handshake (bus errors: ${JSON.stringify(rig.remote.errors.slice(-3))})`);
    if (!sameBytes(hs.id, [0x00, 0x00, 0xa6, 0x20, 0x00, 0x05])) return fail(`inactive ID ${hs.id} is not a MotionPlus's`);
    if (!sameBytes(hs.activeId, [0x00, 0x00, 0xa4, 0x20, 0x04, 0x05])) return fail(`active ID ${hs.activeId} is not an active MotionPlus's (mode 4)`);
    if (!sameBytes(hs.block, mp.block)) return fail(`pass-through block ${hs.block} differs from the MotionPlus's ${mp.block}`);
    const crc = crc32([...hs.block.slice(0, 14), ...hs.block.slice(16, 30)]);
    const stored = ((hs.block[14] << 24) | (hs.block[15] << 16) | (hs.block[30] << 8) | hs.block[31]) >>> 0;
    if (crc !== stored) return fail(`the block read has a bad CRC (${stored.toString(16)} vs ${crc.toString(16)})`);
    // Without noise every latched report is the same; each report the Wii Remote reads must be it.
    const want = mp.measure(truth);
    const reports = rig.remote.reports.map((r) => decodeMotionPlusReport(r.bytes));
    const bad = reports.find((r) => !r.motionPlusData || !sameBytes(r.rate, want.rate) || !sameBytes(r.slow, want.slow));
    if (bad) return fail(`a report ${JSON.stringify(bad)} is not the MotionPlus's ${JSON.stringify(want)}`);
    const errorsAfter = rig.remote.errors.filter((e) => e.tNs > hs.tNs);
    rig.close();
    if (errorsAfter.length) return fail(`bus errors after the activation: ${JSON.stringify(errorsAfter.slice(0, 3))}`);
    return `found at 0x53 (${rig.remote.errors.length} NAKs before the adapter moved there), activated: active ID, the 32-byte block (CRC ok) and ${reports.length} reports passed through at 0x52`;
  }],
  ['motionplus-turns', async () => {
    // Turns at known rates in both ranges, read by the Wii Remote through the adapter, first
    // uncorrected, then with the device's gyro calibration uploaded and committed with the real
    // CLI: the corrected 1-s means must be within 2× the simulated noise of the truth.
    let rig = null;
    const rates = (t) => {
      if (rig?.turnsFrom === undefined) return [0, 0, 0];
      const k = Math.floor((t - rig.turnsFrom) / (TURN_S * 1e9));
      return TURNS[Math.max(0, Math.min(TURNS.length - 1, k))];
    };
    rig = newRig(null, { motionplus: { rates, ...MP_DEVICE } });
    await rig.board.runUntilTrue(() => rig.remote.reports.length > 20, 3000);
    if (rig.board.fault) return fail(`firmware fault: ${rig.board.fault}`);
    const hs = rig.remote.handshakes[0];
    if (!hs) return fail(`no Wii Remote handshake (bus errors: ${JSON.stringify(rig.remote.errors.slice(-3))})`);
    const before = await turnErrors(rig, hs.block);
    const err = await putCommit(rig, writeGyroCal());
    if (err) return fail(err);
    rig.remote.rereadBlock = true;
    await rig.board.runUntilTrue(() => rig.remote.blocks.length > 0, 500);
    const block = rig.remote.blocks[0]?.block;
    if (!block) return fail('the Wii Remote could not read the block again after the commit');
    const crc = crc32([...block.slice(0, 14), ...block.slice(16, 30)]);
    if (crc !== (((block[14] << 24) | (block[15] << 16) | (block[30] << 8) | block[31]) >>> 0)) return fail('the block after the commit has a bad CRC');
    for (const [o, [span, d6]] of [[0x10, IDEAL_MP_BLOCK_RANGES.slow], [0x00, IDEAL_MP_BLOCK_RANGES.fast]]) {
      const zero = (block[o] << 8) | block[o + 1];
      const sc = (block[o + 6] << 8) | block[o + 7];
      if (zero !== 32768 || Math.abs(sc - zero) !== span || block[o + 12] !== d6) return fail(`the block after the commit is not the ideal scale's: ${block}`);
    }
    const phase2 = rig.board.nanos;
    const after = await turnErrors(rig, block);
    // Busy cycles per 5-ms poll period (between the first reports latched from the MotionPlus in
    // two polls) while the corrected turns ran: the correction, the tracker and serving the Wii
    // Remote. Each poll's read latches twice, 25 us apart (two address phases of one read in
    // rp2040js, no instruction between them), so latches under 1 ms after the previous one are
    // the same poll's: counted as periods they made half of them 0 cycles and the median
    // meaningless.
    const latched = rig.motionplus.served
      .filter((r) => r.tNs >= phase2)
      .filter((r, i, all) => i === 0 || r.tNs - all[i - 1].tNs >= 1e6);
    const busy = latched.slice(1).map((r, i) => r.busy - latched[i].busy).sort((a, b) => a - b);
    const errorsAfter = rig.remote.errors.filter((e) => e.tNs > hs.tNs);
    rig.close();
    const sigma = MP_DEVICE.perDps.map((p) => MP_DEVICE.noiseCounts / p); // °/s per sample
    const worst = (segs) => Math.max(...segs.flatMap((s) => s.error.map(Math.abs)));
    measurements.motionplusTurns = { before, after, sigma, busy };
    if (errorsAfter.length) return fail(`bus errors after the activation: ${JSON.stringify(errorsAfter.slice(0, 3))}`);
    const few = after.find((s) => s.n < 150);
    if (few) return fail(`only ${few.n} reports in a 1-s window`);
    for (const s of after) {
      const bad = s.error.findIndex((e, i) => Math.abs(e) > 2 * sigma[i]);
      if (bad >= 0) return fail(`truth ${s.truth}: corrected 1-s mean off by ${s.error[bad].toFixed(3)} °/s on axis ${bad} (2σ = ${(2 * sigma[bad]).toFixed(3)})`);
    }
    return `6 segments, slow and fast range: worst 1-s mean error ${worst(before).toFixed(2)} °/s uncorrected -> ${worst(after).toFixed(3)} °/s corrected (2σ of the noise ${(2 * Math.min(...sigma)).toFixed(3)}-${(2 * Math.max(...sigma)).toFixed(3)} °/s)`;
  }],
  ...motionplusDriftScenarios({
    newRig, fail, putCommit, getState, measurements, work, blockRates, device: MP_DEVICE, f32eq,
  }),
  ['motionplus-passthrough', async () => {
    // A Nunchuk in the MotionPlus's port and a Wii Remote that activates the adapter in
    // Nunchuk pass-through (0x05): the adapter must activate the real MotionPlus in that mode
    // too, and answer with both kinds of frame, each corrected (the gyro with the gyro
    // calibration, the Nunchuk with the accelerometer calibration), both uploaded and committed
    // with the real CLI: the 1-s means within 2× the simulated noise of the truth.
    let rig = null;
    const segment = (t) => (rig?.turnsFrom === undefined ? -1 : Math.max(0, Math.min(TURNS.length - 1, Math.floor((t - rig.turnsFrom) / (TURN_S * 1e9)))));
    const rates = (t) => (segment(t) < 0 ? [0, 0, 0] : TURNS[segment(t)]);
    const random = mulberry32(77);
    const gauss = () => Math.sqrt(-2 * Math.log(Math.max(random(), 1e-12))) * Math.cos(2 * Math.PI * random());
    const motion = (t) => {
      const g = segment(t) < 0 ? [0, 0, 1] : PT_POSES[segment(t)];
      const accel = [0, 1, 2].map((i) => Math.round(PT_NUNCHUK.zero[i] + PT_NUNCHUK.perG[i] * g[i] + PT_NUNCHUK.noiseCounts * gauss()));
      return { accel, stick: [0x80, 0x7f], c: false, z: false };
    };
    const nunchuk = { motion, zero: PT_NUNCHUK.zero, oneG: PT_NUNCHUK.zero.map((z, i) => z + PT_NUNCHUK.perG[i]) };
    rig = newRig(null, { motionplus: { rates, ...MP_DEVICE, nunchuk }, remote: { motionplusMode: 0x05 } });
    await rig.board.runUntilTrue(() => rig.remote.reports.length > 40, 3000);
    if (rig.board.fault) return fail(`firmware fault: ${rig.board.fault}`);
    const hs = rig.remote.handshakes[0];
    if (!hs) return fail(`no Wii Remote handshake (bus errors: ${JSON.stringify(rig.remote.errors.slice(-3))})`);
    if (!sameBytes(hs.activeId, [0x00, 0x00, 0xa4, 0x20, 0x05, 0x05])) return fail(`active ID ${hs.activeId} is not a MotionPlus's in Nunchuk pass-through`);
    const before = await passthroughErrors(rig, hs.block);
    const modes = rig.motionplus.modes.slice();
    if (!before.some((s) => s.nAcc > 0)) return fail(`no Nunchuk frame reached the Wii Remote (the real MotionPlus was activated in modes ${modes})`);
    for (const cal of [writeNunchukCal(), writeGyroCal()]) {
      const err = await putCommit(rig, cal);
      if (err) return fail(err);
    }
    rig.remote.rereadBlock = true;
    await rig.board.runUntilTrue(() => rig.remote.blocks.length > 0, 500);
    const block = rig.remote.blocks[0]?.block;
    if (!block) return fail('the Wii Remote could not read the block again after the commits');
    const after = await passthroughErrors(rig, block);
    const errorsAfter = rig.remote.errors.filter((e) => e.tNs > hs.tNs);
    rig.close();
    const sigma = MP_DEVICE.perDps.map((p) => MP_DEVICE.noiseCounts / p); // °/s per sample
    const accSigma = PT_NUNCHUK.perG.map((p) => PT_NUNCHUK.noiseCounts / p); // g per sample
    measurements.motionplusPassthrough = { before, after, sigma, accSigma, modes };
    if (errorsAfter.length) return fail(`bus errors after the activation: ${JSON.stringify(errorsAfter.slice(0, 3))}`);
    const few = after.find((s) => s.n < 60 || s.nAcc < 60);
    if (few) return fail(`only ${few.n} gyro and ${few.nAcc} Nunchuk frames in a 1-s window`);
    for (const s of after) {
      const bad = s.error.findIndex((e, i) => Math.abs(e) > 2 * sigma[i]);
      if (bad >= 0) return fail(`truth ${s.truth}: corrected gyro 1-s mean off by ${s.error[bad].toFixed(3)} °/s on axis ${bad} (2σ = ${(2 * sigma[bad]).toFixed(3)})`);
      const badAcc = s.accError.findIndex((e, i) => Math.abs(e) > 2 * accSigma[i]);
      if (badAcc >= 0) return fail(`pose ${s.pose}: corrected Nunchuk 1-s mean off by ${(s.accError[badAcc] * 1000).toFixed(1)} mg on axis ${badAcc} (2σ = ${(2000 * accSigma[badAcc]).toFixed(1)} mg)`);
    }
    const worst = (segs, key) => Math.max(...segs.flatMap((s) => s[key].map(Math.abs)));
    return `real MotionPlus activated in modes ${modes.join(',')}; 6 segments: gyro worst 1-s mean error ${worst(before, 'error').toFixed(2)} °/s uncorrected -> ${worst(after, 'error').toFixed(3)} °/s corrected (2σ ${(2 * Math.min(...sigma)).toFixed(3)}-${(2 * Math.max(...sigma)).toFixed(3)}); Nunchuk ${(1000 * worst(before, 'accError')).toFixed(1)} mg -> ${(1000 * worst(after, 'accError')).toFixed(1)} mg (2σ ${(2000 * Math.min(...accSigma)).toFixed(1)}-${(2000 * Math.max(...accSigma)).toFixed(1)} mg); ${after.reduce((a, s) => a + s.nAcc, 0)} Nunchuk and ${after.reduce((a, s) => a + s.n, 0)} gyro frames in the windows`;
  }],
  ['motionplus-powercut', async () => {
    // Gyro commits with the real CLI (`device put/commit GYRO.json`) cut at each of their flash
    // steps (before it and halfway through it), then a reboot: the adapter must hold the old or
    // the new gyro calibration, as `device get` says and as the rates the Wii Remote reads show;
    // never a mix, never none when one was there.
    const gyroA = writeGyroCal();
    const gyroB = writeGyroCalB();
    const calA = JSON.parse(readFileSync(gyroA, 'utf8'));
    const calB = JSON.parse(readFileSync(gyroB, 'utf8'));
    const commitOver = async (image, path, cut) => {
      const rig = newRig(image, { motionplus: { rates: () => CUT_RATE, ...MP_DEVICE } });
      await rig.board.runUntilTrue(() => rig.usb.configured && rig.remote.reports.length > 5, 3000);
      const put = await rig.wiical(['put', path]);
      if (put.code !== 0) return { error: `device put: exit ${put.code}: ${put.stderr.trim()}` };
      const n = rig.board.flashSteps.length;
      if (cut) rig.board.onFlashStep = (_step, index) => index === n + cut.k && (cut.done > 0 ? { done: cut.done, random: mulberry32(cut.seed) } : true);
      const commit = await rig.wiical(['commit', path]);
      rig.close();
      const kinds = rig.board.flashSteps.slice(n).map((x) => x.kind);
      if (!cut && commit.code !== 0) return { error: `device commit: exit ${commit.code}: ${commit.stderr.trim()}` };
      if (cut && !rig.board.powerCut) return { error: `the commit finished without reaching flash step ${cut.k}` };
      return { image: rig.board.flashImage(), kinds };
    };
    const first = await commitOver(null, gyroA, null);
    if (first.error) return fail(`committing the first gyro calibration: ${first.error}`);
    if ((await gyroAfterReboot(first.image, calA, calB)) !== 'old') return fail('the first gyro calibration is not held after a reboot');
    const commits = [
      { name: 'B over A', image: first.image, path: gyroB, old: calA, next: calB, allowed: ['old', 'new'] },
      { name: 'A over none', image: null, path: gyroA, old: calB, next: calA, allowed: ['none', 'new'] },
    ];
    const tally = {};
    const bad = [];
    let cuts = 0;
    for (const c of commits) {
      const probe = await commitOver(c.image, c.path, null);
      if (probe.error || !probe.kinds.length) return fail(`${c.name}: the uninterrupted commit failed or wrote nothing (${probe.error ?? ''})`);
      for (let k = 0; k < probe.kinds.length; k++) {
        for (const done of [0, 0.5]) {
          cuts += 1;
          const cut = await commitOver(c.image, c.path, { k, done, seed: cuts * 7919 });
          const outcome = cut.error ?? (await gyroAfterReboot(cut.image, c.old, c.next));
          const key = `${c.name}, ${done ? 'during' : 'before'} ${probe.kinds[k]}`;
          tally[key] ??= {};
          tally[key][outcome] = (tally[key][outcome] ?? 0) + 1;
          if (!c.allowed.includes(outcome)) bad.push(`${c.name}, ${done * 100} % into ${probe.kinds[k]} step ${k}: ${outcome}`);
        }
      }
    }
    const summary = Object.entries(tally).map(([k, t]) => `${k}: ${Object.entries(t).map(([o, n]) => `${n} ${o}`).join('/')}`).join('; ');
    measurements.motionplusPowercut = summary;
    if (bad.length) return fail(`${summary}; first: ${bad[0]}`);
    return `${cuts} cuts in 2 gyro commits (${summary}); device get and the rates read agree every time`;
  }],
  ['motionplus-stream', async () => {
    // Protocol 8: a host streaming from the adapter while it serves a MotionPlus gets a
    // GyroSample per gyro frame polled (the firmware's take_gyro_sample after each poll): one
    // seq without gaps, the real report's counts and range bits (noise-free device: every one
    // the model's measure of the truth), no correction while no gyro calibration is stored.
    const truth = [30, -60, 600];
    const rig = newRig(null, { motionplus: { rates: () => truth } });
    await rig.board.runUntilTrue(() => rig.remote.reports.length > 20, 3000);
    if (rig.board.fault) return fail(`firmware fault: ${rig.board.fault}`);
    const host = new RawHost(rig);
    if (!(await host.hello(8))) return fail('no Hello answer');
    const started = await host.request(startStreamFrame(1));
    if (started?.tag !== RESPONSE.streamStarted) return fail(`StartStream answered ${JSON.stringify(started)}`);
    // The host's bytes start at the request's reply (a frame boundary); the stream is what
    // follows StreamStarted.
    await rig.board.run(250);
    const all = decodeFrames(host.bytes);
    const frames = all.slice(all.findIndex((f) => f.tag === RESPONSE.streamStarted) + 1);
    rig.close();
    if (rig.board.fault) return fail(`firmware fault: ${rig.board.fault}`);
    const bad = frames.filter((f) => f.bad);
    if (bad.length) return fail(`${bad.length} corrupt frames in the stream`);
    const other = frames.filter((f) => f.tag !== RESPONSE.gyroSample);
    if (other.length) return fail(`frames other than GyroSample in the stream: tags ${other.map((f) => f.tag)}`);
    const gs = frames.map((f) => decodeGyroSample(f.body));
    // 250 ms of 5-ms polls: 50 gyro frames (a frame cut at either end aside).
    if (gs.length < 45) return fail(`only ${gs.length} GyroSamples in 250 ms`);
    const gap = gs.findIndex((g, k) => k > 0 && g.seq !== gs[k - 1].seq + 1);
    if (gap > 0) return fail(`seq jumps from ${gs[gap - 1].seq} to ${gs[gap].seq}`);
    const want = rig.motionplus.measure(truth);
    const wrong = gs.find((g) => !sameBytes(g.raw, want.rate) || g.slow.some((s, k) => s !== want.slow[k]) || g.corrected !== null);
    if (wrong) return fail(`GyroSample ${JSON.stringify(wrong)}, want ${JSON.stringify(want)} and no correction`);
    return `${gs.length} GyroSamples in 250 ms, seq ${gs[0].seq}..${gs[gs.length - 1].seq} without gaps, counts ${want.rate} and range bits ${want.slow.map(Number)} as the MotionPlus reported them, uncorrected (no gyro calibration)`;
  }],
  ['usb-garbage-disconnect', async () => {
    const rig = newRig();
    await rig.board.runUntilTrue(() => rig.remote.reports.length > 5, 2000);
    let lines = 0;
    let injected = false;
    let reset = false;
    // From the garbage on, the adapter's bytes are captured (until the bus reset) to check
    // its answers: nothing or BadFrame errors for the garbage, then one clean reply to the
    // valid request sent right after it, samples throughout.
    const junk = Array.from({ length: 300 }, (_, i) => (i * 73 + 11) & 0xff);
    const junkFrames = junk.filter((b) => b === 0).length + 1;
    const captured = [];
    let capturing = false;
    let atFrameStart = true;
    const forward = rig.usb.onData;
    rig.usb.onData = (bytes) => {
      // Start at the first frame boundary after the garbage went out.
      if (injected && !reset && (capturing || atFrameStart)) {
        capturing = true;
        captured.push(...bytes);
      }
      if (bytes.length) atFrameStart = bytes[bytes.length - 1] === 0;
      forward(bytes);
    };
    const stream = await rig.wiical(['stream', '--count', '2000', '--timeout-ms', '500'], {
      onStdout: (text) => {
        lines += (text.match(/\n/g) || []).length;
        if (lines > 40 && !injected) {
          injected = true;
          // Garbage ending mid-"frame", then the lone 0x00 a host sends to resynchronise, then
          // a valid GetCalibration request.
          rig.usb.write([...junk, 0, ...unitRequestFrame(REQUEST.getCalibration)]);
          rig.linesAtGarbage = lines;
        }
        if (lines > rig.linesAtGarbage + 60 && !reset && injected) {
          reset = true;
          rig.usb.busReset();
        }
      },
    });
    if (!injected) return fail(`stream gave only ${lines} lines (exit ${stream.code}: ${stream.stderr.trim()})`);
    if (!reset) return fail(`stream stopped after the garbage: ${lines} lines (exit ${stream.code}: ${stream.stderr.trim()})`);
    const answer = checkGarbageAnswers(decodeFrames(captured), junkFrames);
    if (answer.error) return fail(answer.error);
    const gapNs = maxGap(rig.remote.reports.map((r) => r.tNs));
    if (rig.remote.reports.length < 100) return fail(`the Wii Remote read only ${rig.remote.reports.length} reports meanwhile`);
    await rig.board.runUntilTrue(() => rig.usb.configured, 1000);
    const info = await rig.wiical(['info']);
    rig.close();
    if (rig.board.fault) return fail(`firmware fault: ${rig.board.fault}`);
    if (info.code !== 0) return fail(`after the disconnect wiical device info fails: ${info.stderr.trim()}`);
    if (gapNs > 50e6) return fail(`the Wii Remote went ${(gapNs / 1e6).toFixed(1)} ms without a report`);
    return `stream survived 300 garbage bytes (answered: ${answer.detail}), then a bus reset; re-enumerated, info works, Wii Remote never starved (max gap ${(gapNs / 1e6).toFixed(1)} ms)`;
  }],
];

/**
 * The adapter's frames after garbage + resync + GetCalibration: every frame intact; before
 * the reply only samples and at most `maxErrors` BadFrame errors; exactly one Calibration
 * reply; after it only samples.
 */
function checkGarbageAnswers(frames, maxErrors) {
  const bad = frames.filter((f) => f.bad);
  if (bad.length) return { error: `${bad.length} of the adapter's frames are corrupt (${bad[0].bad})` };
  const replies = frames.filter((f) => f.tag !== RESPONSE.sample);
  const reply = replies.findIndex((f) => f.tag === RESPONSE.calibration);
  if (reply < 0) return { error: `no reply to the GetCalibration sent after the garbage (got tags ${replies.map((f) => f.tag)})` };
  const errors = replies.slice(0, reply);
  const notBadFrame = errors.find((f) => !(f.tag === RESPONSE.error && f.body[1] === ERROR_BAD_FRAME));
  if (notBadFrame) return { error: `before the reply the adapter sent tag ${notBadFrame.tag} ${notBadFrame.body}, not a BadFrame error` };
  if (errors.length > maxErrors) return { error: `${errors.length} BadFrame errors for ${maxErrors} garbage frames` };
  if (replies.length > reply + 1) return { error: `${replies.length - reply - 1} unexpected replies after the GetCalibration reply` };
  const samples = frames.length - replies.length;
  return { detail: `${errors.length} BadFrame error(s) for ${maxErrors} garbage frame(s), then the calibration reply; ${samples} intact samples` };
}

function maxGap(times) {
  let gap = 0;
  for (let i = 1; i < times.length; i++) gap = Math.max(gap, times[i] - times[i - 1]);
  return gap;
}

function collectTiming(rig) {
  measurements.stretchNs = rig.remote.readStretchNs.slice();
  const t = rig.nunchuk.pollTimes;
  const d = [];
  for (let i = 1; i < t.length; i++) d.push(t[i] - t[i - 1]);
  measurements.pollPeriodsNs = d;
}

function stats(xs) {
  const s = xs.slice().sort((a, b) => a - b);
  const mean = s.reduce((a, b) => a + b, 0) / s.length;
  const sd = Math.sqrt(s.reduce((a, b) => a + (b - mean) ** 2, 0) / s.length);
  return { n: s.length, min: s[0], median: s[s.length >> 1], max: s[s.length - 1], mean, sd };
}

let passed = 0;
let failed = 0;
const NS_PER_CYCLE = 8; // 125 MHz
for (const [name, fn, opts] of scenarios) {
  if (only.length && !only.includes(name)) continue;
  // Long scenarios run only when named (their command is in docs/background-calibration.md).
  if (opts?.optIn && !only.includes(name)) continue;
  const t0 = Date.now();
  let detail;
  let ok = false;
  try {
    const r = await fn();
    ok = typeof r === 'string';
    detail = ok ? r : r.fail;
  } catch (e) {
    detail = `exception: ${e.stack || e}`;
  }
  if (ok) passed += 1;
  else failed += 1;
  console.log(`${ok ? 'ok  ' : 'FAIL'} ${name}: ${detail} (${((Date.now() - t0) / 1000).toFixed(1)} s)`);
}
if (measurements.stretchNs?.length) {
  const s = stats(measurements.stretchNs.map((ns) => ns / NS_PER_CYCLE));
  console.log(`measure clock stretch, report read address match -> first byte in TX FIFO: median ${s.median.toFixed(0)} cycles (${(s.median * NS_PER_CYCLE / 1000).toFixed(1)} us), min ${s.min.toFixed(0)}, max ${s.max.toFixed(0)}, n=${s.n}`);
}
if (measurements.pollPeriodsNs?.length) {
  const s = stats(measurements.pollPeriodsNs.map((ns) => ns / 1000));
  console.log(`measure Nunchuk poll period: mean ${s.mean.toFixed(1)} us, sd ${s.sd.toFixed(2)} us, min ${s.min.toFixed(1)}, max ${s.max.toFixed(1)} us (jitter ${(s.max - s.min).toFixed(1)} us), n=${s.n}`);
}
if (measurements.selfCal) {
  const m = measurements.selfCal;
  const ms = (ns) => (ns / 1e6).toFixed(1);
  console.log(`measure self-calibration on the RP2040: longest Nunchuk poll interval while the last pose ends and the 12-pose fit + checks run ${ms(m.pollGapNs)} ms (nominal 5 ms); last pose left -> first flash step of the commit ${ms(m.fitToCommitNs)} ms; Wii Remote's longest wait for a report ${ms(m.remoteGapNs)} ms during the session, ${ms(m.commitGapNs)} ms including the commit and the 100 ms extension-detect drop that makes it re-read the block`);
}
if (measurements.background) {
  const m = measurements.background;
  console.log(`measure background recalibration on the RP2040: adopted after ${m.adoptS.toFixed(1)} s of play (${m.rests} rests); error of the correction against the truth ${m.before.toFixed(2)} mg after the drift -> ${m.after.toFixed(2)} mg after the adoption (floor: the self-calibration before the drift, ${m.floor.toFixed(2)} mg)`);
}
for (const key of ['background-drift', 'background-drift-2h']) {
  const m = measurements[key];
  if (!m) continue;
  const c = m.cycles;
  console.log(`measure ${key} on the RP2040 (Cortex-M0+ at 125 MHz, rp2040js's cycle counts): ${m.emulatedS.toFixed(0)} s emulated in ${m.playWallS.toFixed(0)} s wall; busy cycles per 5-ms poll period (625000 cycles) over ${c.periods} periods: median ${c.median}, 99.9 % ${c.p999}, worst ${c.worst} at ${(c.worstAtNs / 1e9).toFixed(2)} s; the ${c.commitPeriods} periods holding an adoption's flash writes: worst ${c.commitWorst}`);
}
if (measurements.motionplusTurns) {
  const m = measurements.motionplusTurns;
  const f = (e) => e.map((x) => x.toFixed(3)).join(' ');
  m.before.forEach((b, k) => {
    console.log(`measure motionplus-turns truth [${b.truth}] °/s: 1-s mean error [yaw roll pitch] uncorrected ${f(b.error)}, corrected ${f(m.after[k].error)} °/s (n=${m.after[k].n})`);
  });
  const b = m.busy;
  if (b.length) console.log(`measure motionplus-turns on the RP2040 (rp2040js cycle counts, 125 MHz): busy cycles per 5-ms poll period (625000 cycles) with the gyro correction and the tracker, over ${b.length} periods: median ${b[b.length >> 1]}, worst ${b[b.length - 1]}`);
}
if (measurements.motionplusDrift) {
  const m = measurements.motionplusDrift;
  const f = (e) => `[${e.map((x) => x.toFixed(3)).join(' ')}]`;
  for (const w of m.win) {
    console.log(`measure motionplus-drift ${w.name} ${w.from.toFixed(2)}-${w.to.toFixed(2)} s truth [${w.truth}] °/s${w.checked ? '' : ' (not checked)'}: 1-s mean error [yaw roll pitch] uncorrected ${f(w.uncorrected)}, calibration only ${f(w.calOnly)}, corrected ${f(w.corrected)} °/s (n=${w.n})`);
  }
}
if (measurements.motionplusPassthrough) {
  const m = measurements.motionplusPassthrough;
  const f = (e) => e.map((x) => x.toFixed(3)).join(' ');
  const mg = (e) => e.map((x) => (1000 * x).toFixed(1)).join(' ');
  m.before.forEach((b, k) => {
    const a = m.after[k];
    console.log(`measure motionplus-passthrough truth [${b.truth}] °/s, pose [${b.pose}] g: 1-s mean error gyro [yaw roll pitch] uncorrected ${f(b.error)}, corrected ${f(a.error)} °/s (n=${a.n}); Nunchuk [x y z] uncorrected ${mg(b.accError)}, corrected ${mg(a.accError)} mg (n=${a.nAcc})`);
  });
}
if (measurements.bootToFirstReportNs) {
  const ns = measurements.bootToFirstReportNs;
  console.log(`measure boot to first report served to the Wii Remote: ${(ns / 1e6).toFixed(2)} ms = ${(ns / NS_PER_CYCLE).toFixed(0)} cycles (includes the Wii Remote's 20 ms detect debounce)`);
}
rmSync(work, { recursive: true, force: true });
console.log(`${passed} passed, ${failed} failed`);
process.exit(failed ? 1 : 0);
