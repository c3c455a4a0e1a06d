// The emulated Raspberry Pi Pico: rp2040js's RP2040 plus what the firmware needs and
// rp2040js does not model — the stub boot ROM's functions (flash erase/program, XIP), the XIP
// stream engine the flash driver's async reads use, the flash chip's unique-ID and JEDEC
// commands on the SSI, and the I²C1 target mode (i2c-target.js).

import { RP2040, ConsoleLogger, LogLevel, BasePeripheral } from 'rp2040js';
import { buildBootrom, ROM_FUNCTIONS, TRAP_RESET, TRAP_NMI, TRAP_HARDFAULT } from './bootrom.js';
import { parseElf } from './elf.js';
import { loadUf2 } from './uf2.js';
import { I2CTarget } from './i2c-target.js';

/** Size of the Pico's flash (W25Q16JV). */
export const FLASH_SIZE = 2 * 1024 * 1024;
/** clk_sys as embassy-rp sets it up on the RP2040 (and as rp2040js's Simulator assumes). */
export const CLK_SYS_HZ = 125_000_000;
const NS_PER_CYCLE = 1e9 / CLK_SYS_HZ;
/** Where the boot ROM copies boot2 (datasheet 2.8.1.3); the ROM's own initial SP (vector 0). */
const BOOT2_RAM = 0x20041f00;
const BOOT_STACK = 0x20042000;
/** W25Q16JV timings (datasheet, typical): sector erase 45 ms, page program 0.4 ms. */
export const SECTOR_ERASE_NS = 45e6;
export const PAGE_PROGRAM_NS = 0.4e6;
/** DREQ number of the XIP stream (datasheet 2.5.3.1). */
const DREQ_XIP_STREAM = 37;

/** A byte whose bits are each set with probability `p` (`random()` uniform in [0, 1)). */
function randomBits(random, p) {
  let b = 0;
  for (let i = 0; i < 8; i++) if (random() < p) b |= 1 << i;
  return b;
}

/** Thrown out of the run loop when a scripted power cut happens at a flash step. */
export class PowerCut extends Error {}

/** CRC-32 as the boot ROM checks boot2 (polynomial 0x04C11DB7, MSB first, init ~0, no xorout). */
export function boot2Crc(bytes) {
  let crc = 0xffffffff;
  for (const b of bytes) {
    crc ^= b << 24;
    for (let i = 0; i < 8; i++) {
      crc = crc & 0x80000000 ? (crc << 1) ^ 0x04c11db7 : crc << 1;
    }
  }
  return crc >>> 0;
}

/** XIP_CTRL (0x14000000): only the stream registers (datasheet 2.6.3.5 and 2.6.4). */
class XipCtrl extends BasePeripheral {
  constructor(board) {
    super(board.rp2040, 'XIP_CTRL');
    this.board = board;
    this.ctrl = 3;
    this.streamAddr = 0;
    this.streamCtr = 0;
  }
  readUint32(offset) {
    switch (offset) {
      case 0x00: return this.ctrl;
      case 0x04: return 0; // FLUSH
      case 0x08: return 0b011; // STAT: FLUSH_READY, FIFO_EMPTY (words go straight to the AUX port)
      case 0x0c: case 0x10: return 0; // CTR_HIT, CTR_ACC
      case 0x14: return this.streamAddr;
      case 0x18: return this.streamCtr;
      case 0x1c: return this.pop();
    }
    return super.readUint32(offset);
  }
  writeUint32(offset, value) {
    switch (offset) {
      case 0x00: this.ctrl = value; return;
      case 0x04: return;
      case 0x0c: case 0x10: return;
      case 0x14: this.streamAddr = value & 0xfffffffc; return;
      case 0x18:
        this.streamCtr = value & 0x3fffff;
        if (this.streamCtr) this.rp2040.dma.setDREQ(DREQ_XIP_STREAM);
        else this.rp2040.dma.clearDREQ(DREQ_XIP_STREAM);
        return;
    }
    super.writeUint32(offset, value);
  }
  /** One word of the stream (read through the FIFO register or the AUX port). */
  pop() {
    if (!this.streamCtr) return 0;
    const word = this.rp2040.flashView.getUint32(this.streamAddr & 0xffffff, true);
    this.streamAddr += 4;
    this.streamCtr -= 1;
    if (!this.streamCtr) this.rp2040.dma.clearDREQ(DREQ_XIP_STREAM);
    return word;
  }
}

/** The XIP AUX port (0x50400000): the stream FIFO as a DMA source. */
class XipAux extends BasePeripheral {
  constructor(board, xip) {
    super(board.rp2040, 'XIP_AUX');
    this.xip = xip;
  }
  readUint32() {
    return this.xip.pop();
  }
  writeUint32() {}
}

/**
 * The SSI (datasheet 4.10) with a W25Q16JV behind it. boot2 and the ROM-less flash driver
 * only need: the configuration registers to hold their values, SR with TFNF/TFE and RFNE,
 * and the direct commands the driver issues in EEPROM-read mode (CTRLR0.TMOD = 3): 0x4B read
 * unique ID (4 dummy bytes, then 8 ID bytes) and 0x9F JEDEC ID. In the other modes every byte
 * written to DR0 clocks one byte back; the chip answers status reads (0x05, 0x35) with
 * "not busy, QE set", so boot2 finds the chip ready and leaves its status register alone.
 */
class FlashChipSsi extends BasePeripheral {
  constructor(rp2040, uniqueId) {
    super(rp2040, 'SSI');
    this.uniqueId = uniqueId;
    this.regs = new Map();
    this.rx = [];
    this.command = null;
    this.index = 0;
  }
  get ctrlr0() {
    return this.regs.get(0x00) ?? 0;
  }
  readUint32(offset) {
    switch (offset) {
      case 0x24: return this.rx.length; // RXFLR
      case 0x20: return 0; // TXFLR: the emulated transfer is instant
      case 0x28: return 0b0110 | (this.rx.length ? 0b1000 : 0); // SR: TFNF, TFE, RFNE
      case 0x58: return 0x51535049; // IDR
      case 0x5c: return 0x3430312a; // SSI_VERSION_ID
      case 0x60: return this.rx.length ? this.rx.shift() : 0;
    }
    return this.regs.get(offset) ?? 0;
  }
  writeUint32(offset, value) {
    if (offset === 0x08) {
      // SSIENR: (re)enabling starts a new command.
      this.rx = [];
      this.command = null;
      this.index = 0;
    }
    if (offset !== 0x60) {
      this.regs.set(offset, value >>> 0);
      return;
    }
    const byte = value & 0xff;
    const tmod = (this.ctrlr0 >> 8) & 3;
    if (tmod === 3) {
      if (this.command === null) {
        this.command = byte;
        const frames = ((this.regs.get(0x04) ?? 0) & 0xffff) + 1;
        let reply = [];
        if (byte === 0x4b) reply = [0, 0, 0, 0, ...this.uniqueId];
        else if (byte === 0x9f) reply = [0xef, 0x70, 0x15];
        this.rx = Array.from({ length: frames }, (_, i) => reply[i] ?? 0xff);
      }
      return;
    }
    // Full duplex: one byte back per byte out.
    if (this.command === null) this.command = byte;
    const statusRead = this.command === 0x05 || this.command === 0x35;
    const reply = this.index === 0 ? 0 : statusRead ? (this.command === 0x35 ? 0x02 : 0x00) : 0;
    this.index++;
    this.rx.push(reply);
  }
}

/**
 * rp2040js 1.4.1's I²C controller ignores writes to IC_INTR_MASK (0x30), so its interrupt line
 * never rises and an interrupt-driven driver (embassy-rp's async I²C) waits forever. Route the
 * write to the mask it already keeps.
 */
function patchI2cController(i2c) {
  const write = i2c.writeUint32.bind(i2c);
  i2c.writeUint32 = (offset, value) => {
    if (offset === 0x30) {
      i2c.intEnable = value & 0x1fff;
      i2c.checkInterrupts();
      return;
    }
    write(offset, value);
  };
}

/**
 * One emulated board. `flashImage` (2 MiB) restores a previous board's flash (power cycle);
 * otherwise `uf2Bytes` (the drag-and-drop file, as the boot ROM would write it) or else the
 * ELF's loadable segments are written into an erased flash. Throws Uf2Error for a UF2 file
 * the loader refuses.
 */
export class Board {
  constructor({ elfBytes = null, uf2Bytes = null, flashImage = null, uniqueId = [0xe6, 0x60, 0x38, 0xb7, 0x13, 0x2a, 0x4c, 0x2d] }) {
    const rp2040 = new RP2040();
    this.rp2040 = rp2040;
    rp2040.logger = new ConsoleLogger(LogLevel.Error, true);
    rp2040.loadBootrom(buildBootrom(BOOT_STACK));
    const elf = elfBytes ? parseElf(elfBytes) : null;
    this.symbols = elf ? elf.symbols : new Map();
    if (flashImage) {
      rp2040.flash.set(flashImage.subarray(0, FLASH_SIZE));
    } else if (uf2Bytes) {
      this.uf2Pages = loadUf2(uf2Bytes, rp2040.flash, { flashSize: FLASH_SIZE });
    } else if (elf) {
      for (const { paddr, bytes } of elf.segments) {
        if (paddr >= 0x10000000 && paddr + bytes.length <= 0x10000000 + FLASH_SIZE) {
          rp2040.flash.set(bytes, paddr - 0x10000000);
        }
      }
    } else {
      throw new Error('Board needs a flash image, a UF2 file or an ELF');
    }
    patchI2cController(rp2040.i2c[0]);
    const xip = new XipCtrl(this);
    rp2040.peripherals[0x14000] = xip;
    rp2040.peripherals[0x50400] = new XipAux(this, xip);
    rp2040.peripherals[0x18000] = new FlashChipSsi(rp2040, uniqueId);
    this.i2c1 = new I2CTarget(rp2040, 'I2C1', 24);
    rp2040.i2c[1] = this.i2c1;
    rp2040.peripherals[0x40048] = this.i2c1;

    this.fault = null;
    this.flashSteps = []; // { kind, offset, length, atNs }
    /**
     * Called before each flash erase sector / program page; return true to cut the power
     * before it, or { done, random } to cut it a fraction `done` of the way through.
     */
    this.onFlashStep = null;
    this.bootedAtNs = null;
    this.stopped = false;
    /** Cycles the core executed (not waiting in WFI/WFE) since power-on: the CPU's load. */
    this.busyCycles = 0;
    rp2040.onBreak = (code) => this.trap(code);
    rp2040.core.reset();
  }

  get clock() {
    return this.rp2040.clock;
  }
  get nanos() {
    return this.rp2040.clock.nanos;
  }
  /** Emulated clk_sys cycles since power-on. */
  get cycles() {
    return Math.round(this.rp2040.clock.nanos / NS_PER_CYCLE);
  }

  /** A copy of the whole flash (what survives a power cycle). */
  flashImage() {
    return this.rp2040.flash.slice(0, FLASH_SIZE);
  }

  reg(n) {
    return this.rp2040.core.registers[n] >>> 0;
  }

  trap(code) {
    const { rp2040 } = this;
    const core = rp2040.core;
    if (code === TRAP_RESET) {
      // The ROM's flash boot: copy boot2 to the top of SRAM, check its CRC, run it with LR = 0
      // so that it jumps through the flash image's vector table when done.
      const boot2 = rp2040.flash.subarray(0, 256);
      const crc = new DataView(boot2.buffer, boot2.byteOffset).getUint32(252, true);
      if (boot2Crc(boot2.subarray(0, 252)) !== crc) {
        this.fail('boot ROM: boot2 CRC mismatch (no valid image in flash)');
        return;
      }
      rp2040.sram.set(boot2, BOOT2_RAM - 0x20000000);
      core.SP = BOOT2_RAM; // the stack grows down from just below boot2, not over it
      core.LR = 0;
      core.PC = BOOT2_RAM;
      return;
    }
    if (code === TRAP_NMI || code === TRAP_HARDFAULT) {
      this.fail(`${code === TRAP_NMI ? 'NMI' : 'HardFault'} (stacked PC ${this.stackedPc().toString(16)})`);
      return;
    }
    const fn = ROM_FUNCTIONS[code];
    if (!fn || core.PC >= 0x1000) {
      this.fail(`BKPT/UDF #${code} at ${(core.PC - 2).toString(16)} (firmware panic or breakpoint)`);
      return;
    }
    this.romFunction(fn[1]);
  }

  stackedPc() {
    return this.rp2040.readUint32(this.rp2040.core.SP + 24) >>> 0;
  }

  fail(message) {
    if (!this.fault) this.fault = message;
    this.stopped = true;
  }

  /** Performs a ROM function on the emulated flash; arguments in r0..r3, result in r0. */
  romFunction(name) {
    const { rp2040 } = this;
    const r = (n) => this.reg(n);
    const set = (n, v) => { rp2040.core.registers[n] = v >>> 0; };
    switch (name) {
      case 'connect_internal_flash':
      case 'flash_exit_xip':
      case 'flash_flush_cache':
      case 'flash_enter_cmd_xip':
        return;
      case 'flash_range_erase': {
        const [offset, count] = [r(0), r(1)];
        for (let o = offset & ~0xfff; o < offset + count; o += 4096) {
          this.flashStep('erase', o, 4096, SECTOR_ERASE_NS, (done = 1, random = Math.random) => {
            // An erase raises every cell of the sector towards 1 at once; cut short, each
            // programmed (0) bit has flipped to 1 with probability `done`.
            for (let i = o; i < o + 4096; i++) {
              rp2040.flash[i] |= done >= 1 ? 0xff : randomBits(random, done);
            }
          });
        }
        return;
      }
      case 'flash_range_program': {
        const [offset, data, count] = [r(0), r(1), r(2)];
        for (let o = 0; o < count; o += 256) {
          const n = Math.min(256, count - o);
          this.flashStep('program', offset + o, n, PAGE_PROGRAM_NS, (done = 1, random = Math.random) => {
            // NOR flash: programming can only clear bits. Cut short, the first `done` of the
            // bytes are programmed, the next one only partly (some of its 0 bits), the rest not.
            const whole = Math.floor(n * done);
            for (let i = 0; i < Math.min(n, whole + 1); i++) {
              const want = rp2040.readUint8(data + o + i);
              rp2040.flash[offset + o + i] &= i < whole ? want : want | randomBits(random, 0.5);
            }
          });
        }
        return;
      }
      case 'memcpy44':
      case 'memcpy': {
        const [dst, src, n] = [r(0), r(1), r(2)];
        for (let i = 0; i < n; i++) rp2040.writeUint8(dst + i, rp2040.readUint8(src + i));
        return;
      }
      case 'memset':
      case 'memset4': {
        const [dst, c, n] = [r(0), r(1), r(2)];
        for (let i = 0; i < n; i++) rp2040.writeUint8(dst + i, c & 0xff);
        return;
      }
      case 'popcount32': {
        let v = r(0), c = 0;
        while (v) { c += v & 1; v >>>= 1; }
        set(0, c);
        return;
      }
      case 'reverse32': {
        let v = r(0), o = 0;
        for (let i = 0; i < 32; i++) { o = (o << 1) | (v & 1); v >>>= 1; }
        set(0, o);
        return;
      }
      case 'clz32': set(0, Math.clz32(r(0))); return;
      case 'ctz32': { const v = r(0); set(0, v ? 31 - Math.clz32(v & -v) : 32); return; }
      default:
        this.fail(`ROM function ${name} is not provided by the stub ROM`);
    }
  }

  /**
   * One flash operation (a sector erase or a page program): offers the power cut, then lets
   * the emulated time pass that the flash chip needs (the CPU sits in the ROM meanwhile, but
   * the peripherals — the Wii Remote's bus, USB — go on), then applies it.
   */
  flashStep(kind, offset, length, ns, apply) {
    const step = { kind, offset, length, atNs: this.nanos };
    const cut = this.onFlashStep?.(step, this.flashSteps.length);
    if (cut) {
      // `true` or { done: 0 }: before the step; { done: f, random } with 0 < f < 1: after a
      // fraction f of it (the chip's cells left as NOR flash leaves them).
      const done = cut === true ? 0 : cut.done;
      if (done > 0) {
        this.clock.tick(ns * done);
        apply(done, cut.random);
      }
      this.stopped = true;
      throw new PowerCut(`power cut ${done > 0 ? `${Math.round(done * 100)} % into` : 'before'} ${kind} at 0x${offset.toString(16)}`);
    }
    this.flashSteps.push(step);
    this.clock.tick(ns);
    apply();
  }

  /**
   * Runs the core until the emulated clock reaches `targetNs` (or a fault / power cut).
   * While the core sleeps (WFI/WFE) the clock jumps to the next alarm.
   */
  runUntil(targetNs) {
    const { rp2040 } = this;
    const { core, clock } = rp2040;
    while (!this.stopped && clock.nanos < targetNs) {
      if (core.waiting) {
        const next = clock.nanosToNextAlarm;
        const room = targetNs - clock.nanos;
        clock.tick(next > 0 && next < room ? next : room);
      } else {
        const cycles = core.executeInstruction();
        this.busyCycles += cycles;
        clock.tick(cycles * NS_PER_CYCLE);
      }
    }
  }

  /**
   * Runs for `ms` of emulated time, giving Node's event loop a turn every `sliceMs` (so that
   * the pseudo-terminal and child processes are served while the firmware runs).
   */
  async run(ms, sliceMs = 2) {
    const end = this.nanos + ms * 1e6;
    while (!this.stopped && this.nanos < end) {
      try {
        this.runUntil(Math.min(end, this.nanos + sliceMs * 1e6));
      } catch (e) {
        if (e instanceof PowerCut) {
          this.powerCut = e.message;
          return;
        }
        throw e;
      }
      await new Promise((resolve) => setImmediate(resolve));
    }
  }

  /** Runs until `predicate()` holds, at most `ms` of emulated time; returns whether it held. */
  async runUntilTrue(predicate, ms, sliceMs = 2) {
    const end = this.nanos + ms * 1e6;
    while (!this.stopped && this.nanos < end) {
      if (predicate()) return true;
      await this.run(Math.min(sliceMs, (end - this.nanos) / 1e6), sliceMs);
    }
    return predicate();
  }
}
