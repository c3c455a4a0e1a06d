// A simulated Nunchuk on the adapter's I²C0 (rp2040js emulates the RP2040's controller side;
// this answers as the target at 0x52). Behaviour from WiiBrew ("Wiimote/Extension
// Controllers", ".../Nunchuck"):
// * register map: report 0x00-0x05, calibration block 0x20-0x2F and its copy 0x30-0x3F, key
//   0x40-0x4F, init registers 0xF0/0xFB, identifier 0xFA-0xFF; a write sets the register pointer
//   with its first byte and stores the following bytes; a read returns bytes from the pointer on;
// * init: 0x55 → 0xF0 then 0x00 → 0xFB (plain); 0x00 → 0x40 starts the legacy "encrypted" mode
//   in which every byte read is sent as x = (plain − 0x17) ^ 0x17 (the reader computes
//   (x ^ 0x17) + 0x17); an `legacyOnly` Nunchuk NAKs the
//   plain init (as the original ones the adapter's poller falls back for);
// * until initialised, reads return 0xFF; unplugged, nothing answers (address NAK).
// Byte timing: 9 SCL periods at the bus speed the controller was set to (400 kHz).

const ADDRESS = 0x52;
const ID = [0x00, 0x00, 0xa4, 0x20, 0x00, 0x00];
const BYTE_NS = 9 * 2500; // 9 bits at 400 kHz

/** 16-byte calibration block from zero/one-g counts and stick calibration (WiiBrew layout). */
export function calibrationBlock(zero, oneG, stickX = [0xe0, 0x20, 0x80], stickY = [0xe0, 0x20, 0x80]) {
  const pack = (v) => [v[0] >> 2, v[1] >> 2, v[2] >> 2, ((v[0] & 3) << 4) | ((v[1] & 3) << 2) | (v[2] & 3)];
  const data = [...pack(zero), ...pack(oneG), ...stickX, ...stickY];
  const c1 = data.reduce((a, b) => (a + b) & 0xff, 0x55);
  return [...data, c1, (c1 + 0x55) & 0xff];
}

/** The 6 report bytes for 10-bit accel counts, stick and buttons (pressed = bit 0). */
export function reportBytes({ accel, stick, c, z }) {
  const a = accel.map((v) => Math.max(0, Math.min(1023, v)));
  const lsb = ((a[2] & 3) << 6) | ((a[1] & 3) << 4) | ((a[0] & 3) << 2) | ((c ? 0 : 1) << 1) | (z ? 0 : 1);
  return [stick[0], stick[1], a[0] >> 2, a[1] >> 2, a[2] >> 2, lsb];
}

/** Inverse of {@link reportBytes}. */
export function decodeReport(b) {
  return {
    stick: [b[0], b[1]],
    accel: [(b[2] << 2) | ((b[5] >> 2) & 3), (b[3] << 2) | ((b[5] >> 4) & 3), (b[4] << 2) | ((b[5] >> 6) & 3)],
    c: (b[5] & 2) === 0,
    z: (b[5] & 1) === 0,
  };
}

export class Nunchuk {
  /**
   * `motion(tNs)` gives the report content at emulated time t: { accel:[3], stick:[2], c, z }.
   * `zero`/`oneG` are the factory calibration written into its block.
   */
  constructor(board, { motion, zero = [508, 516, 520], oneG = [712, 716, 724], legacyOnly = false, attach = true } = {}) {
    this.board = board;
    this.motion = motion;
    this.legacyOnly = legacyOnly;
    this.block = calibrationBlock(zero, oneG);
    this.plugged = true;
    this.reset();
    /** Every report served: { tNs, raw: { accel, stick, c, z } }, and init events. */
    this.served = [];
    this.inits = 0;
    this.pollTimes = [];
    const i2c = board.rp2040.i2c[0];
    this.i2c = i2c;
    // Not attached (`attach: false`): it sits in a MotionPlus's port, which hands it the
    // transactions it passes through (connect/write/read/stop, each completing the bus step).
    if (!attach) return;
    this.alarm = board.clock.createAlarm(() => this.pending?.());
    i2c.onStart = () => this.later(BYTE_NS / 9, () => i2c.completeStart());
    i2c.onConnect = (address, mode) => this.later(BYTE_NS, () => this.connect(address, mode));
    i2c.onWriteByte = (value) => this.later(BYTE_NS, () => i2c.completeWrite(this.write(value)));
    i2c.onReadByte = () => this.later(BYTE_NS, () => i2c.completeRead(this.read()));
    i2c.onStop = () => this.later(BYTE_NS / 9, () => this.stop());
  }

  reset() {
    this.regs = new Uint8Array(256).fill(0xff);
    this.regs.set(ID, 0xfa);
    this.regs.set(this.block, 0x20);
    this.regs.set(this.block, 0x30);
    this.pointer = 0;
    this.encrypted = false;
    this.initialised = false;
    this.firstWrite = false;
  }

  later(ns, fn) {
    this.pending = fn;
    this.alarm.schedule(ns);
  }

  /** Unplug (true → false) loses the Nunchuk's state, as a power loss does. */
  setPlugged(plugged) {
    if (!plugged) this.reset();
    this.plugged = plugged;
  }

  connect(address, mode) {
    const ack = this.plugged && address === ADDRESS;
    if (ack && mode === 0) this.firstWrite = true;
    const now = this.board.nanos;
    const restarted = now - (this.lastReadAddressNs ?? -1e9) < 100e3; // repeated START of the same read
    if (ack && mode === 1) this.lastReadAddressNs = now;
    if (ack && mode === 1 && this.pointer === 0 && this.initialised && !restarted) {
      // A report read begins: latch the current motion into registers 0..5.
      const raw = this.motion(this.board.nanos);
      this.regs.set(reportBytes(raw), 0);
      this.served.push({ tNs: this.board.nanos, raw });
      this.pollTimes.push(this.board.nanos);
    }
    this.i2c.completeConnect(ack);
  }

  write(value) {
    if (!this.plugged) return false;
    if (this.firstWrite) {
      this.firstWrite = false;
      this.pointer = value;
      return true;
    }
    const register = this.pointer;
    if (register === 0xf0 && value === 0x55 && this.legacyOnly) return false; // NAK: unknown
    this.regs[register] = value;
    this.pointer = (this.pointer + 1) & 0xff;
    if (register === 0xf0 && value === 0x55) this.encrypted = false;
    if (register === 0xfb && value === 0x00) this.initialise();
    if (register === 0x40 && value === 0x00) {
      this.encrypted = true;
      this.initialise();
    }
    return true;
  }

  initialise() {
    this.initialised = true;
    this.inits += 1;
    this.regs.set(ID, 0xfa);
  }

  read() {
    if (!this.plugged) return 0xff;
    let byte = this.initialised || this.pointer >= 0x20 ? this.regs[this.pointer] : 0xff;
    this.pointer = (this.pointer + 1) & 0xff;
    if (this.encrypted) byte = ((byte - 0x17) & 0xff) ^ 0x17; // reader decodes (x ^ 0x17) + 0x17
    return byte;
  }

  stop() {
    this.firstWrite = false;
    this.i2c.completeStop();
  }
}
