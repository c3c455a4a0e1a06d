// DW_apb_i2c in target ("slave") mode, as the RP2040 datasheet (section 4.3) describes it and
// as embassy-rp's `i2c_slave` driver uses it. rp2040js models only the controller side, so
// this peripheral replaces rp2040js's I2C1. The bus side is driven by a simulated controller
// (wiimote.js) through `busStart`, `busWrite`, `busRead` and `busStop`.
//
// Modelled:
// * address match against IC_SAR (7-bit), START_DET, RESTART_DET (a repeated start that
//   addresses us), STOP_DET (only when addressed if IC_CON.STOP_DET_IFADDRESSED);
// * controller writes: bytes into the RX FIFO (16 deep) with FIRST_DATA_BYTE (bit 11) on the
//   first byte after the address; RX_FULL above IC_RX_TL; while the RX FIFO is full and
//   IC_CON.RX_FIFO_FULL_HLD_CTRL is set, the bus is held (the controller waits);
// * controller reads: RD_REQ whenever a byte is requested and the TX FIFO is empty, the clock
//   held low until software writes IC_DATA_CMD; TX_EMPTY (TX_EMPTY_CTRL) at or below
//   IC_TX_TL; RX_DONE when the controller NACKs a byte (end of the read); on a new read with
//   stale bytes in the TX FIFO: TX_ABRT with ABRT_SLVFLUSH_TXFIFO and TX_FLUSH_CNT, the FIFO
//   flushed and kept flushed until TX_ABRT is cleared;
// * the interrupt line: IC_INTR_STAT = IC_RAW_INTR_STAT & IC_INTR_MASK.
// Not modelled: 10-bit addressing, general call, spike filtering, timing registers.

import { BasePeripheral } from 'rp2040js';

const IC_CON = 0x00;
const IC_TAR = 0x04;
const IC_SAR = 0x08;
const IC_DATA_CMD = 0x10;
const IC_INTR_STAT = 0x2c;
const IC_INTR_MASK = 0x30;
const IC_RAW_INTR_STAT = 0x34;
const IC_RX_TL = 0x38;
const IC_TX_TL = 0x3c;
const IC_CLR_INTR = 0x40;
const IC_CLR_RX_UNDER = 0x44;
const IC_CLR_RX_OVER = 0x48;
const IC_CLR_TX_OVER = 0x4c;
const IC_CLR_RD_REQ = 0x50;
const IC_CLR_TX_ABRT = 0x54;
const IC_CLR_RX_DONE = 0x58;
const IC_CLR_ACTIVITY = 0x5c;
const IC_CLR_STOP_DET = 0x60;
const IC_CLR_START_DET = 0x64;
const IC_CLR_GEN_CALL = 0x68;
const IC_ENABLE = 0x6c;
const IC_STATUS = 0x70;
const IC_TXFLR = 0x74;
const IC_RXFLR = 0x78;
const IC_TX_ABRT_SOURCE = 0x80;
const IC_ENABLE_STATUS = 0x9c;
const IC_CLR_RESTART_DET = 0xa8;
const IC_COMP_PARAM_1 = 0xf4;
const IC_COMP_VERSION = 0xf8;
const IC_COMP_TYPE = 0xfc;

// IC_CON
const MASTER_MODE = 1 << 0;
const IC_SLAVE_DISABLE = 1 << 6;
const STOP_DET_IFADDRESSED = 1 << 7;
// Raw interrupt bits
export const R_RX_UNDER = 1 << 0;
export const R_RX_OVER = 1 << 1;
export const R_RX_FULL = 1 << 2;
export const R_TX_OVER = 1 << 3;
export const R_TX_EMPTY = 1 << 4;
export const R_RD_REQ = 1 << 5;
export const R_TX_ABRT = 1 << 6;
export const R_RX_DONE = 1 << 7;
export const R_ACTIVITY = 1 << 8;
export const R_STOP_DET = 1 << 9;
export const R_START_DET = 1 << 10;
export const R_GEN_CALL = 1 << 11;
export const R_RESTART_DET = 1 << 12;
const CLEARED_BY_CLR_INTR =
  R_RX_UNDER | R_RX_OVER | R_TX_OVER | R_RD_REQ | R_TX_ABRT | R_RX_DONE | R_ACTIVITY |
  R_STOP_DET | R_START_DET | R_GEN_CALL | R_RESTART_DET;
// IC_DATA_CMD read bits
const FIRST_DATA_BYTE = 1 << 11;
// IC_TX_ABRT_SOURCE
const ABRT_SLVFLUSH_TXFIFO = 1 << 13;
const TX_FLUSH_CNT_SHIFT = 23;
const FIFO_DEPTH = 16;

export class I2CTarget extends BasePeripheral {
  constructor(rp2040, name, irq) {
    super(rp2040, name);
    this.irq = irq;
    this.con = 0x65; // reset value: controller mode, target disabled (datasheet IC_CON)
    this.sar = 0x55;
    this.tar = 0x55;
    this.enable = 0;
    this.intMask = 0x8ff;
    this.raw = 0;
    this.rxTl = 0;
    this.txTl = 0;
    this.rx = [];
    this.tx = [];
    this.abortSource = 0;
    this.txFlushed = false;
    // Bus state
    this.addressed = false; // inside a transaction addressed to us
    this.reading = false;
    this.firstByte = false;
    /** Reads addressed while a write before them was still unread in the RX FIFO and bytes
     * of the read before that still in the TX FIFO: the target's software was late (see
     * firmware/src/wiimote.rs `ReadEnd::Overtaken`). A measurement, for the scenarios to report. */
    this.lateReads = 0;
    /** Hook: (event, detail) for measurements (e.g. first TX byte after a read address). */
    this.onEvent = null;
  }

  get targetEnabled() {
    return (this.enable & 1) && !(this.con & MASTER_MODE) && !(this.con & IC_SLAVE_DISABLE);
  }

  update() {
    // Level-type bits follow the FIFOs.
    if (this.rx.length > this.rxTl) this.raw |= R_RX_FULL;
    else this.raw &= ~R_RX_FULL;
    if (this.tx.length <= this.txTl) this.raw |= R_TX_EMPTY;
    else this.raw &= ~R_TX_EMPTY;
    this.rp2040.setInterrupt(this.irq, !!(this.raw & this.intMask));
  }

  clear(mask) {
    const was = this.raw & mask;
    this.raw &= ~mask;
    if (mask & R_TX_ABRT) {
      this.abortSource = 0;
      this.txFlushed = false;
    }
    this.update();
    return was ? 1 : 0;
  }

  // ---- bus side (called by the simulated controller) ----

  /** START (or repeated START) with address + direction; returns true on ACK. */
  busStart(address, read) {
    const repeated = this.addressed;
    if (!this.targetEnabled || address !== (this.sar & 0x7f)) {
      if (repeated) this.endTransaction();
      return false;
    }
    this.raw |= R_START_DET | R_ACTIVITY;
    if (repeated) this.raw |= R_RESTART_DET;
    this.addressed = true;
    this.reading = read;
    this.firstByte = true;
    if (read) {
      if (this.tx.length) {
        if (this.rx.length) this.lateReads += 1;
        this.abortSource = ABRT_SLVFLUSH_TXFIFO | (this.tx.length << TX_FLUSH_CNT_SHIFT);
        this.tx = [];
        this.txFlushed = true;
        this.raw |= R_TX_ABRT;
      }
      this.raw |= R_RD_REQ;
      this.onEvent?.('read-address', {});
    }
    this.update();
    return true;
  }

  /** One byte from the controller; returns 'ack', or 'hold' while the RX FIFO is full. */
  busWrite(byte) {
    if (this.rx.length >= FIFO_DEPTH) {
      if (this.con & (1 << 9)) return 'hold'; // RX_FIFO_FULL_HLD_CTRL
      this.raw |= R_RX_OVER;
      this.update();
      return 'ack';
    }
    this.rx.push((byte & 0xff) | (this.firstByte ? FIRST_DATA_BYTE : 0));
    this.firstByte = false;
    this.update();
    return 'ack';
  }

  /**
   * The controller clocks one byte out of us. Returns the byte, or null while the clock is
   * held (TX FIFO empty: RD_REQ is raised and software must write IC_DATA_CMD).
   * `ack` is what the controller answers after the byte (false on the last byte).
   */
  busRead(ack) {
    if (!this.tx.length) {
      if (!(this.raw & R_RD_REQ)) {
        this.raw |= R_RD_REQ;
        this.update();
      }
      return null;
    }
    const byte = this.tx.shift();
    if (!ack) this.raw |= R_RX_DONE;
    this.update();
    return byte;
  }

  /** STOP condition. */
  busStop() {
    if (this.addressed || !(this.con & STOP_DET_IFADDRESSED)) this.raw |= R_STOP_DET;
    this.endTransaction();
    this.update();
  }

  endTransaction() {
    this.addressed = false;
    this.reading = false;
    this.raw &= ~R_ACTIVITY;
  }

  // ---- register side (the firmware) ----

  readUint32(offset) {
    switch (offset) {
      case IC_CON: return this.con;
      case IC_TAR: return this.tar;
      case IC_SAR: return this.sar;
      case IC_DATA_CMD: {
        if (!this.rx.length) {
          this.raw |= R_RX_UNDER;
          this.update();
          return 0;
        }
        const v = this.rx.shift();
        this.update();
        return v;
      }
      case IC_INTR_STAT: return this.raw & this.intMask;
      case IC_INTR_MASK: return this.intMask;
      case IC_RAW_INTR_STAT: return this.raw;
      case IC_RX_TL: return this.rxTl;
      case IC_TX_TL: return this.txTl;
      case IC_CLR_INTR: return this.clear(CLEARED_BY_CLR_INTR);
      case IC_CLR_RX_UNDER: return this.clear(R_RX_UNDER);
      case IC_CLR_RX_OVER: return this.clear(R_RX_OVER);
      case IC_CLR_TX_OVER: return this.clear(R_TX_OVER);
      case IC_CLR_RD_REQ: return this.clear(R_RD_REQ);
      case IC_CLR_TX_ABRT: return this.clear(R_TX_ABRT);
      case IC_CLR_RX_DONE: return this.clear(R_RX_DONE);
      case IC_CLR_ACTIVITY: return this.clear(R_ACTIVITY);
      case IC_CLR_STOP_DET: return this.clear(R_STOP_DET);
      case IC_CLR_START_DET: return this.clear(R_START_DET);
      case IC_CLR_GEN_CALL: return this.clear(R_GEN_CALL);
      case IC_CLR_RESTART_DET: return this.clear(R_RESTART_DET);
      case IC_ENABLE: return this.enable;
      case IC_STATUS:
        return (
          (this.addressed ? (1 << 6) | 1 : 0) | // SLV_ACTIVITY, ACTIVITY
          (this.rx.length >= FIFO_DEPTH ? 1 << 4 : 0) | // RFF
          (this.rx.length ? 1 << 3 : 0) | // RFNE
          (this.tx.length ? 0 : 1 << 2) | // TFE
          (this.tx.length < FIFO_DEPTH ? 1 << 1 : 0) // TFNF
        );
      case IC_TXFLR: return this.tx.length;
      case IC_RXFLR: return this.rx.length;
      case IC_TX_ABRT_SOURCE: return this.abortSource;
      case IC_ENABLE_STATUS: return this.enable & 1;
      case IC_COMP_PARAM_1: return 0;
      case IC_COMP_VERSION: return 0x3230312a;
      case IC_COMP_TYPE: return 0x44570140;
      default:
        return 0;
    }
  }

  writeUint32(offset, value) {
    switch (offset) {
      case IC_CON: this.con = value & 0x7ff; return;
      case IC_TAR: this.tar = value & 0xfff; return;
      case IC_SAR: this.sar = value & 0x3ff; return;
      case IC_DATA_CMD:
        if (this.txFlushed) return; // held flushed until TX_ABRT is cleared
        if (this.tx.length >= FIFO_DEPTH) {
          this.raw |= R_TX_OVER;
        } else {
          this.tx.push(value & 0xff);
          this.onEvent?.('tx-byte', { level: this.tx.length });
        }
        this.update();
        return;
      case IC_INTR_MASK: this.intMask = value & 0x1fff; this.update(); return;
      case IC_RX_TL: this.rxTl = Math.min(value & 0xff, FIFO_DEPTH - 1); this.update(); return;
      case IC_TX_TL: this.txTl = Math.min(value & 0xff, FIFO_DEPTH - 1); this.update(); return;
      case IC_ENABLE:
        this.enable = value & 0x7;
        if (!(value & 1)) {
          this.rx = [];
          this.tx = [];
          this.addressed = false;
        }
        this.update();
        return;
      default:
        // Timing, spike-length, SDA hold/setup, DMA and general-call registers: accepted.
        return;
    }
  }
}
