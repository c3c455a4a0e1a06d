// A simulated Wii MotionPlus on the adapter's I²C0 (rp2040js emulates the RP2040's controller
// side; this answers as the target). Behaviour from the sources docs/gyro.md names (WiiBrew's
// "Wiimote/Extension Controllers/Wii Motion Plus" page, Dolphin's emulated MotionPlus):
// * inactive it answers at 0x53 only: ID `00 00 A6 20 00 05` at 0xFA, the 32-byte calibration
//   block at 0x20 (CRC-32 of bytes 0x00-0x0D and 0x10-0x1D, stored big-endian as bytes
//   0x0E-0x0F (high half) and 0x1E-0x1F (low half));
// * 0x55 → 0xF0 at 0x53 is stored; the mode 0x04/0x05/0x07 → 0xFE activates it: it then
//   answers at 0x52 only (after `switchNs`, 20 ms: it does not answer meanwhile), ID
//   `00 00 A4 20 <mode> 05`; any write to 0xF0 at 0x52 deactivates it (back to 0x53);
// * active, a read starting at 0x00 latches one report: per axis [yaw, roll, pitch] a 14-bit
//   count and its slow bit (byte 3 bit 1 yaw, byte 4 bit 1 roll, byte 3 bit 0 pitch), byte 5
//   bit 1 set (MotionPlus data), byte 4 bit 0 clear (nothing in its port);
// * unplugged, nothing answers (address NAK);
// * with a Nunchuk in its port (`nunchuk`, nunchuk.js's model, not attached to the bus itself):
//   inactive, every transaction at 0x52 is the Nunchuk's (so its init 0x55 → 0xF0, 0x00 → 0xFB
//   reaches it there); active in Nunchuk pass-through (mode 0x05) and once the Nunchuk was
//   initialised, the reads of 0x00 alternate its own report (first) with the Nunchuk's in the
//   pass-through layout (crates/extbus motionplus.rs's table: accelerometer bit 0 dropped,
//   byte 5 bit 1 clear); byte 4 bit 0 of every frame says a Nunchuk is plugged in (in mode
//   0x04 too). The real MotionPlus reads its extension itself; here the Nunchuk's `motion` is
//   sampled when the frame is latched.
// The gyro itself: `rates(tNs)` gives the true rate °/s per axis; the counts are
// `zero + perDps·rate + noise` in the slow range while |rate| ≤ `slowLimitDps`, else
// `zeroFast + perDps·fastRatio·rate + noise`, rounded and clamped to 0..16383, noise Gaussian
// with `noiseCounts` sd (slow counts; scaled by the range's sensitivity in the fast range),
// from a seeded generator.
// Optionally (motionplus-drift) a misaligned gyro and a drifting bias: with `sensitivity`, a
// full 3×3 matrix S of slow counts per °/s (row: count axis, column: true rate axis; off the
// diagonal each count axis also sees the other axes' rates), the slow counts are
// `zero + S·rate + drift(t) + noise`; with `drift(tNs)` (slow counts per axis, e.g. a warming
// MotionPlus's zero moving), the zero moves by it in both ranges as a rate bias does
// (`fastRatio·drift` fast counts). The range is chosen per axis by its own true rate as above.

import { mulberry32 } from './pose-nunchuk.js';

const INACTIVE = 0x53;
const ACTIVE = 0x52;
const BYTE_NS = 9 * 2500; // 9 bits at 400 kHz

/** CRC-32 (ISO-HDLC: reflected 0xEDB88320, init and xorout ~0) of a byte list. */
export function crc32(bytes) {
  let crc = 0xffffffff;
  for (const b of bytes) {
    crc ^= b;
    for (let i = 0; i < 8; i++) crc = crc & 1 ? (crc >>> 1) ^ 0xedb88320 : crc >>> 1;
  }
  return (crc ^ 0xffffffff) >>> 0;
}

/**
 * The 32-byte calibration block: per range (fast at 0x00, slow at 0x10) zero and scale per
 * axis as 16-bit big-endian (14-bit × 4), the reference rate / 6, a UID byte; then the CRC.
 */
export function motionPlusBlock({ fast, slow, uid = [0x0d, 0x1d] }) {
  const b = new Array(32).fill(0);
  for (const [o, r, u] of [[0x00, fast, uid[0]], [0x10, slow, uid[1]]]) {
    [...r.zero, ...r.scale].forEach((v, i) => {
      b[o + 2 * i] = (v >> 8) & 0xff;
      b[o + 2 * i + 1] = v & 0xff;
    });
    b[o + 12] = r.degreesDiv6;
    b[o + 13] = u;
  }
  const crc = crc32([...b.slice(0x00, 0x0e), ...b.slice(0x10, 0x1e)]);
  b[0x0e] = crc >>> 24;
  b[0x0f] = (crc >>> 16) & 0xff;
  b[0x1e] = (crc >>> 8) & 0xff;
  b[0x1f] = crc & 0xff;
  return b;
}

/** The 6 report bytes of 14-bit counts and slow bits [yaw, roll, pitch]. */
export function motionPlusReportBytes(rate, slow, extension = false) {
  return [
    rate[0] & 0xff, rate[1] & 0xff, rate[2] & 0xff,
    ((rate[0] >> 8) << 2) | (slow[0] ? 2 : 0) | (slow[2] ? 1 : 0),
    ((rate[1] >> 8) << 2) | (slow[1] ? 2 : 0) | (extension ? 1 : 0),
    ((rate[2] >> 8) << 2) | 2,
  ];
}

/** A Nunchuk report ({ accel (10-bit), stick, c, z }) as a MotionPlus passes it through. */
export function passthroughNunchukBytes({ accel, stick, c, z }, extension = true) {
  const [x, y, zz] = accel.map((v) => Math.max(0, Math.min(1023, v)));
  const bit = (v, n) => (v >> n) & 1;
  return [
    stick[0], stick[1], x >> 2, y >> 2, ((zz >> 3) << 1) | (extension ? 1 : 0),
    (bit(zz, 2) << 7) | (bit(zz, 1) << 6) | (bit(y, 1) << 5) | (bit(x, 1) << 4) | ((c ? 0 : 1) << 3) | ((z ? 0 : 1) << 2),
  ];
}

/** Inverse of {@link passthroughNunchukBytes} (accelerometer bit 0 is 0): { accel, stick, c, z }. */
export function decodePassthroughNunchuk(b) {
  const bit = (n) => (b[5] >> n) & 1;
  return {
    stick: [b[0], b[1]],
    accel: [(b[2] << 2) | (bit(4) << 1), (b[3] << 2) | (bit(5) << 1), ((b[4] >> 1) << 3) | (bit(7) << 2) | (bit(6) << 1)],
    c: (b[5] & 8) === 0,
    z: (b[5] & 4) === 0,
  };
}

/** Inverse of {@link motionPlusReportBytes}: { rate, slow, motionPlusData }. */
export function decodeMotionPlusReport(b) {
  return {
    rate: [b[0] | ((b[3] >> 2) << 8), b[1] | ((b[4] >> 2) << 8), b[2] | ((b[5] >> 2) << 8)],
    slow: [(b[3] & 2) !== 0, (b[4] & 2) !== 0, (b[3] & 1) !== 0],
    motionPlusData: (b[5] & 2) !== 0,
  };
}

export class MotionPlus {
  /**
   * `rates(tNs)`: true rate °/s [yaw, roll, pitch]. The device: slow-range `zero` counts and
   * `perDps` counts per °/s per axis (its real sensitivity), fast range `fastRatio` of it
   * (440/2000 nominally) about `zeroFast`; `block` the calibration block it stores (by
   * default the nominal one, 8192 zero, 8192/440 and 8192/2000 counts per °/s, Dolphin's
   * signs), so that a reader of the block alone gets the wrong scale and no bias.
   */
  constructor(board, {
    rates = () => [0, 0, 0], zero = [8192, 8192, 8192], zeroFast = null, perDps = [8192 / 440, 8192 / 440, 8192 / 440],
    fastRatio = 440 / 2000, slowLimitDps = 400, noiseCounts = 0, seed = 50, block = null, nunchuk = null,
    sensitivity = null, drift = null,
  } = {}) {
    this.board = board;
    /** The Nunchuk in its port (nunchuk.js's model, `attach: false`), or null. */
    this.nunchuk = nunchuk;
    Object.assign(this, { rates, zero, perDps, fastRatio, slowLimitDps, noiseCounts, sensitivity, drift });
    this.zeroFast = zeroFast ?? zero;
    this.random = mulberry32(seed);
    this.block = block ?? motionPlusBlock({
      fast: { zero: [32768, 32768, 32768], scale: [32768 - 12288, 32768 + 12288, 32768 - 12288], degreesDiv6: 125 },
      slow: { zero: [32768, 32768, 32768], scale: [32768 - 24576, 32768 + 24576, 32768 - 24576], degreesDiv6: 55 },
    });
    this.switchNs = 20e6;
    this.plugged = true;
    this.reset();
    /** Every report latched: { tNs, busy (the board's busy cycles then), truth, rate, slow }. */
    this.served = [];
    /** Every Nunchuk frame latched: { tNs, raw } (raw: the Nunchuk's full-precision report). */
    this.servedNunchuk = [];
    this.activations = 0;
    /** The mode of every activation, in order. */
    this.modes = [];
    const i2c = board.rp2040.i2c[0];
    this.i2c = i2c;
    this.alarm = board.clock.createAlarm(() => this.pending?.());
    i2c.onStart = () => this.later(BYTE_NS / 9, () => i2c.completeStart());
    i2c.onConnect = (address, mode) => this.later(BYTE_NS, () => this.connect(address, mode));
    // A transaction passed through to the Nunchuk is the Nunchuk's until its STOP.
    i2c.onWriteByte = (value) => this.later(BYTE_NS, () => i2c.completeWrite(this.forward ? this.nunchuk.write(value) : this.write(value)));
    i2c.onReadByte = () => this.later(BYTE_NS, () => i2c.completeRead(this.forward ? this.nunchuk.read() : this.read()));
    i2c.onStop = () => this.later(BYTE_NS / 9, () => this.stop());
  }

  reset() {
    this.regs = new Uint8Array(256);
    this.regs.set([0x00, 0x00, 0xa6, 0x20, 0x00, 0x05], 0xfa);
    this.regs.set(this.block, 0x20);
    this.pointer = 0;
    this.active = false;
    this.switchedAtNs = -1e12;
    this.firstWrite = false;
    this.address = null;
    this.forward = false;
    this.lastWasGyro = false;
    this.mode = 0;
  }

  later(ns, fn) {
    this.pending = fn;
    this.alarm.schedule(ns);
  }

  setPlugged(plugged) {
    if (!plugged) this.reset();
    this.nunchuk?.setPlugged(plugged);
    this.plugged = plugged;
  }

  gauss() {
    const u = Math.max(this.random(), 1e-12);
    return Math.sqrt(-2 * Math.log(u)) * Math.cos(2 * Math.PI * this.random());
  }

  /** Counts and slow bits of the true rates at time `tNs` (see the header). */
  measure(truth, tNs = 0) {
    if (this.sensitivity || this.drift) return this.measureMisaligned(truth, tNs);
    const rate = [];
    const slow = [];
    for (let i = 0; i < 3; i++) {
      const s = Math.abs(truth[i]) <= this.slowLimitDps;
      const per = s ? this.perDps[i] : this.perDps[i] * this.fastRatio;
      const z = s ? this.zero[i] : this.zeroFast[i];
      const noise = this.noiseCounts * this.gauss() * (s ? 1 : this.fastRatio);
      rate.push(Math.max(0, Math.min(16383, Math.round(z + per * truth[i] + noise))));
      slow.push(s);
    }
    return { rate, slow };
  }

  /** {@link measure} with the full sensitivity S and the drifting zero (see the header). */
  measureMisaligned(truth, tNs) {
    const S = this.sensitivity ?? this.perDps.map((p, i) => [0, 1, 2].map((j) => (i === j ? p : 0)));
    const d = this.drift?.(tNs) ?? [0, 0, 0];
    const rate = [];
    const slow = [];
    for (let i = 0; i < 3; i++) {
      const s = Math.abs(truth[i]) <= this.slowLimitDps;
      const slowCounts = S[i].reduce((a, v, j) => a + v * truth[j], 0) + d[i];
      const ratio = s ? 1 : this.fastRatio;
      const z = s ? this.zero[i] : this.zeroFast[i];
      const noise = this.noiseCounts * this.gauss() * ratio;
      rate.push(Math.max(0, Math.min(16383, Math.round(z + ratio * slowCounts + noise))));
      slow.push(s);
    }
    return { rate, slow };
  }

  connect(address, mode) {
    const settled = this.board.nanos - this.switchedAtNs >= this.switchNs;
    if (this.plugged && settled && !this.active && address === ACTIVE && this.nunchuk) {
      this.forward = true;
      this.nunchuk.connect(address, mode);
      return;
    }
    const ack = this.plugged && settled && address === (this.active ? ACTIVE : INACTIVE);
    if (ack && mode === 0) this.firstWrite = true;
    // rp2040js sends a read's address phase twice, 25 µs apart: one read latches one frame
    // (else every read would skip the frame it latched first, and in pass-through the gyro
    // frames would never be read).
    const now = this.board.nanos;
    const restarted = now - (this.lastReadAddressNs ?? -1e9) < 100e3;
    if (ack && mode === 1) this.lastReadAddressNs = now;
    if (ack && mode === 1 && this.active && this.pointer === 0 && !restarted) this.latch();
    this.i2c.completeConnect(ack);
  }

  /** A read of 0x00 while active: the next frame into registers 0..5 (see the header). */
  latch() {
    const tNs = this.board.nanos;
    const plugged = !!this.nunchuk?.plugged;
    if (this.mode === 5 && plugged && this.nunchuk.initialised && this.lastWasGyro) {
      const raw = this.nunchuk.motion(tNs);
      this.regs.set(passthroughNunchukBytes(raw, true), 0);
      this.servedNunchuk.push({ tNs, raw });
      this.lastWasGyro = false;
      return;
    }
    const truth = this.rates(tNs);
    const m = this.measure(truth, tNs);
    this.regs.set(motionPlusReportBytes(m.rate, m.slow, plugged), 0);
    this.served.push({ tNs, busy: this.board.busyCycles, truth, ...m });
    this.lastWasGyro = true;
  }

  write(value) {
    if (!this.plugged) return false;
    if (this.firstWrite) {
      this.firstWrite = false;
      this.pointer = value;
      return true;
    }
    const register = this.pointer;
    this.pointer = (this.pointer + 1) & 0xff;
    if (register === 0xfe && [4, 5, 7].includes(value)) {
      this.regs[0xfe] = value;
      this.mode = value;
      this.modes.push(value);
      if (!this.active) {
        this.switchedAtNs = this.board.nanos;
        this.lastWasGyro = false;
      }
      this.active = true;
      this.activations += 1;
      this.regs[0xfc] = 0xa4;
    } else if (register === 0xf0 && this.active) {
      this.active = false;
      this.switchedAtNs = this.board.nanos;
      this.regs[0xfc] = 0xa6;
    } else if (register >= 0x40 && register < 0xf0) {
      this.regs[register] = value;
    }
    return true;
  }

  read() {
    if (!this.plugged) return 0xff;
    const byte = this.regs[this.pointer];
    this.pointer = (this.pointer + 1) & 0xff;
    return byte;
  }

  stop() {
    this.firstWrite = false;
    if (this.forward) {
      this.forward = false;
      this.nunchuk.stop();
      return;
    }
    this.i2c.completeStop();
  }
}
