// A simulated Wii Remote: the bus controller on the adapter's I²C1 (400 kHz), reading the
// adapter as the extension at 0x52. It does what a real one does with a Nunchuk: wait for the
// extension-detect line (GP6) to go high, initialise (0x55 → 0xF0, 0x00 → 0xFB), read the
// identifier (0xFA, 6 bytes) and the calibration block (0x20, 16 bytes), then poll 6-byte
// reports from 0x00 at `pollHz`. When detect drops it stops, and re-initialises (and re-reads
// the calibration block) when it comes back.
// With `motionplus` it does what a real one does to use a MotionPlus instead: look for it at
// 0x53 every 50 ms (ID at 0xFA, the 32-byte calibration block at 0x20), activate it alone
// (0x55 → 0xF0, 0x04 → 0xFE at 0x53; `motionplusMode` 0x05: in Nunchuk pass-through), wait 20 ms, read the active ID at 0x52 and poll 6-byte
// reports from 0x00 there; three failed reads in a row start the search over.
//
// Every transfer is: START + address (10 bit times), bytes (9 bit times each), STOP; a held
// clock (the target stretching SCL) is waited for in 1 µs steps and measured. A transfer whose
// clock stays held longer than `stretchTimeoutNs` is abandoned (a real Wii Remote gives up on
// the extension too) and counted as a bus error.

const BIT_NS = 2500; // 400 kHz
const POLL_STEP_NS = 1000;

export class WiiRemote {
  constructor(board, { pollHz = 200, stretchTimeoutNs = 200e6, motionplus = false, motionplusMode = 0x04 } = {}) {
    this.board = board;
    this.motionplus = motionplus;
    this.motionplusMode = motionplusMode;
    /** MotionPlus: set to read the calibration block again at 0x52; the blocks read so. */
    this.rereadBlock = false;
    this.blocks = [];
    /** The address transfers go to. */
    this.addr = 0x52;
    this.target = board.i2c1;
    this.pollHz = pollHz;
    this.stretchTimeoutNs = stretchTimeoutNs;
    this.alarm = board.clock.createAlarm(() => this.step());
    this.gen = null;
    /** Reports read: { tNs, bytes }; handshakes: { tNs, id, block }. */
    this.reports = [];
    this.handshakes = [];
    this.errors = [];
    /** Clock stretch from a read's address match to the first byte in the TX FIFO, ns. */
    this.readStretchNs = [];
    this.lastStretchNs = 0;
    this.detectHighSince = null;
    this.running = false;
    this.target.onEvent = (event) => this.onTargetEvent(event);
  }

  get detect() {
    const pin = this.board.rp2040.gpio[6];
    return pin.outputEnable && pin.outputValue;
  }

  start() {
    this.running = true;
    this.gen = this.motionplus ? this.mainMotionPlus() : this.main();
    this.schedule(0);
  }

  stop() {
    this.running = false;
    this.alarm.cancel();
  }

  schedule(ns) {
    this.alarm.schedule(ns);
  }

  step() {
    if (!this.running) return;
    const { value, done } = this.gen.next();
    if (done) return;
    this.schedule(value);
  }

  onTargetEvent(event) {
    if (event === 'read-address') {
      this.readAddressNs = this.board.nanos;
      this.firstTxNs = null;
    } else if (event === 'tx-byte' && this.readAddressNs !== null && this.firstTxNs === null) {
      this.firstTxNs = this.board.nanos;
    }
  }

  *main() {
    for (;;) {
      // Wait for the extension to be plugged (detect high for 20 ms: debounce).
      while (!this.detect) yield 1e6;
      yield 20e6;
      if (!this.detect) continue;
      const session = yield* this.handshake();
      if (!session) {
        yield 50e6;
        continue;
      }
      const period = 1e9 / this.pollHz;
      while (this.detect) {
        const t = this.board.nanos;
        const bytes = yield* this.readRegisters(0x00, 6, true);
        if (bytes) this.reports.push({ tNs: t, bytes, handshake: this.handshakes.length });
        const spent = this.board.nanos - t;
        yield Math.max(BIT_NS, period - spent);
      }
    }
  }

  *mainMotionPlus() {
    const period = 1e9 / this.pollHz;
    for (;;) {
      this.addr = 0x53;
      const id = yield* this.readRegisters(0xfa, 6);
      const block = id && (yield* this.readRegisters(0x20, 32));
      if (!block) {
        yield 50e6;
        continue;
      }
      if (!(yield* this.writeBytes([0xf0, 0x55]))) continue;
      yield 1e6;
      if (!(yield* this.writeBytes([0xfe, this.motionplusMode]))) continue;
      yield 20e6;
      this.addr = 0x52;
      const activeId = yield* this.readRegisters(0xfa, 6);
      if (!activeId) continue;
      this.handshakes.push({ tNs: this.board.nanos, id, block, activeId });
      let failures = 0;
      while (failures < 3) {
        if (this.rereadBlock) {
          // Asked by a scenario (e.g. after a commit changed the block): read it again at 0x52.
          this.rereadBlock = false;
          const again = yield* this.readRegisters(0x20, 32);
          if (again) this.blocks.push({ tNs: this.board.nanos, block: again });
        }
        const t = this.board.nanos;
        const bytes = yield* this.readRegisters(0x00, 6, true);
        if (bytes) this.reports.push({ tNs: t, bytes, handshake: this.handshakes.length });
        failures = bytes ? 0 : failures + 1;
        yield Math.max(BIT_NS, period - (this.board.nanos - t));
      }
    }
  }

  *handshake() {
    if (!(yield* this.writeBytes([0xf0, 0x55]))) return false;
    yield 1e6;
    if (!(yield* this.writeBytes([0xfb, 0x00]))) return false;
    yield 1e6;
    const id = yield* this.readRegisters(0xfa, 6);
    if (!id) return false;
    const block = yield* this.readRegisters(0x20, 16);
    if (!block) return false;
    this.handshakes.push({ tNs: this.board.nanos, id, block });
    return true;
  }

  /** Sets the register pointer (write + STOP), waits, reads `n` bytes (+ STOP). */
  *readRegisters(register, n, measure = false) {
    if (!(yield* this.writeBytes([register]))) return null;
    yield 100e3; // the pause a real Wii Remote leaves between pointer and read
    this.readAddressNs = null;
    const bytes = yield* this.readBytes(n);
    if (bytes && measure && this.firstTxNs !== null && this.readAddressNs !== null) {
      this.readStretchNs.push(this.firstTxNs - this.readAddressNs);
    }
    return bytes;
  }

  *address(read) {
    yield 10 * BIT_NS;
    return this.target.busStart(this.addr, read);
  }

  *writeBytes(bytes) {
    if (!(yield* this.address(false))) {
      yield BIT_NS;
      this.target.busStop();
      this.errors.push({ tNs: this.board.nanos, what: 'address NAK (write)' });
      return false;
    }
    for (const b of bytes) {
      let held = 0;
      while (this.target.busWrite(b) === 'hold') {
        yield POLL_STEP_NS;
        held += POLL_STEP_NS;
        if (held > this.stretchTimeoutNs) return this.abandon('clock held on write');
      }
      yield 9 * BIT_NS;
    }
    yield BIT_NS;
    this.target.busStop();
    return true;
  }

  *readBytes(n) {
    if (!(yield* this.address(true))) {
      yield BIT_NS;
      this.target.busStop();
      this.errors.push({ tNs: this.board.nanos, what: 'address NAK (read)' });
      return null;
    }
    const out = [];
    for (let i = 0; i < n; i++) {
      let held = 0;
      let byte;
      while ((byte = this.target.busRead(i < n - 1)) === null) {
        yield POLL_STEP_NS;
        held += POLL_STEP_NS;
        if (held > this.stretchTimeoutNs) return this.abandon(`clock held on read byte ${i}`);
      }
      this.lastStretchNs = held;
      out.push(byte);
      yield 9 * BIT_NS;
    }
    yield BIT_NS;
    this.target.busStop();
    return out;
  }

  abandon(what) {
    this.errors.push({ tNs: this.board.nanos, what });
    this.target.busStop();
    return null;
  }
}
