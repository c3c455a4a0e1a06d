// A stub RP2040 boot ROM, written here from the RP2040 datasheet (section 2.8, "Bootrom"), so
// that no vendor ROM image is needed. It keeps the ROM's documented layout:
//
//   0x00  initial stack pointer          0x10  magic 'M' 'u' 0x01, then the version byte
//   0x04  reset handler                  0x14  u16 pointer to the public function table
//   0x08  NMI handler                    0x16  u16 pointer to the public data table
//   0x0C  HardFault handler              0x18  u16 pointer to rom_table_lookup(table, code)
//
// rom_table_lookup is real Thumb code (below), walking tables of (u16 code, u16 pointer) pairs
// ended by a zero code, as the datasheet describes. Every public function is a two-instruction
// trampoline `BKPT #n; BX LR`: the BKPT traps into the harness (board.js), which does the work on
// the emulated flash and registers (r0..r3 arguments, r0 result) and lets the core return.
//
// Thumb encodings used (ARMv6-M Architecture Reference Manual, section A6.7):
//   BKPT #imm8   1011 1110 iiii iiii      = 0xBE00 | imm8
//   BX LR        0100 0111 0111 0000      = 0x4770
//   LDRH r2,[r0] 1000 1 00000 000 010     = 0x8802   (LDRH Rt,[Rn,#imm5*2], imm5 = 0)
//   LDRH r0,[r0,#2]                       = 0x8840   (imm5 = 1, Rn = r0, Rt = r0)
//   CMP r2,#0    0010 1 010 00000000      = 0x2A00
//   CMP r2,r1    0100 0010 10 001 010     = 0x428A
//   BEQ label    1101 0000 iiii iiii      = 0xD000 | (offset-4)/2 (signed 8 bit)
//   ADDS r0,#4   0011 0 000 00000100      = 0x3004
//   B label      1110 0 iiiiiiiiiii       = 0xE000 | (offset-4)/2 (signed 11 bit)
//   MOVS r0,#0   0010 0 000 00000000      = 0x2000
//   NOP          1011 1111 0000 0000      = 0xBF00

/** The codes of the ROM functions (two ASCII characters, little-endian), datasheet 2.8.3. */
export const ROM_FUNCTIONS = {
  // harness trap number: [code, name]
  1: ['IF', 'connect_internal_flash'],
  2: ['EX', 'flash_exit_xip'],
  3: ['RE', 'flash_range_erase'],
  4: ['RP', 'flash_range_program'],
  5: ['FC', 'flash_flush_cache'],
  6: ['CX', 'flash_enter_cmd_xip'],
  7: ['C4', 'memcpy44'],
  8: ['MS', 'memset'],
  9: ['M4', 'memset4'],
  10: ['MC', 'memcpy'],
  11: ['UB', 'reset_to_usb_boot'],
  12: ['P3', 'popcount32'],
  13: ['R3', 'reverse32'],
  14: ['L3', 'clz32'],
  15: ['T3', 'ctz32'],
};

/** Trap numbers of the vectors (not functions). */
export const TRAP_RESET = 0x80;
export const TRAP_NMI = 0x81;
export const TRAP_HARDFAULT = 0x82;

/** Offsets inside the ROM image. */
const LOOKUP = 0x40; // rom_table_lookup
const VECTORS = 0x60; // reset, NMI, HardFault trampolines (BKPT only)
const FUNC_TABLE = 0x100;
const DATA_TABLE = 0x180;
const TRAMPOLINES = 0x200;
/** Version byte at 0x13: 3 is the B2 ROM's. */
export const ROM_VERSION = 3;

function code16(chars) {
  return chars.charCodeAt(0) | (chars.charCodeAt(1) << 8);
}

/**
 * Builds the ROM image (Uint32Array of words, as rp2040js's `loadBootrom` takes it).
 * `stackTop` is the initial SP; SRAM's end is the datasheet's value.
 */
export function buildBootrom(stackTop = 0x20042000) {
  const bytes = new Uint8Array(4096);
  const view = new DataView(bytes.buffer);
  const h = (offset, value) => view.setUint16(offset, value, true);
  const w = (offset, value) => view.setUint32(offset, value >>> 0, true);

  // Vector table: SP and handlers (Thumb bit set).
  w(0x00, stackTop);
  w(0x04, VECTORS + 0 + 1);
  w(0x08, VECTORS + 2 + 1);
  w(0x0c, VECTORS + 4 + 1);
  h(VECTORS + 0, 0xbe00 | TRAP_RESET);
  h(VECTORS + 2, 0xbe00 | TRAP_NMI);
  h(VECTORS + 4, 0xbe00 | TRAP_HARDFAULT);

  // Magic, version, table pointers.
  bytes[0x10] = 'M'.charCodeAt(0);
  bytes[0x11] = 'u'.charCodeAt(0);
  bytes[0x12] = 0x01;
  bytes[0x13] = ROM_VERSION;
  h(0x14, FUNC_TABLE);
  h(0x16, DATA_TABLE);
  h(0x18, LOOKUP + 1);

  // rom_table_lookup(r0 = table, r1 = code) -> r0 = pointer or 0. Branch offsets are
  // (target - (branch address + 4)) / 2.
  const lookup = [
    0x8802, // 0x40 loop:     LDRH r2, [r0]
    0x2a00, // 0x42           CMP  r2, #0
    0xd000 | ((0x54 - (0x44 + 4)) >> 1), // 0x44 BEQ notfound (0x54)
    0x428a, // 0x46           CMP  r2, r1
    0xd000 | ((0x50 - (0x48 + 4)) >> 1), // 0x48 BEQ found (0x50)
    0x3004, // 0x4a           ADDS r0, #4
    0xe000 | (((0x40 - (0x4c + 4)) >> 1) & 0x7ff), // 0x4c B loop (0x40)
    0xbf00, // 0x4e           NOP
    0x8840, // 0x50 found:    LDRH r0, [r0, #2]
    0x4770, // 0x52           BX   LR
    0x2000, // 0x54 notfound: MOVS r0, #0
    0x4770, // 0x56           BX   LR
  ];
  lookup.forEach((op, i) => h(LOOKUP + 2 * i, op));

  // Function table and trampolines.
  let entry = FUNC_TABLE;
  let tramp = TRAMPOLINES;
  for (const [trap, [chars]] of Object.entries(ROM_FUNCTIONS)) {
    h(entry, code16(chars));
    h(entry + 2, tramp + 1);
    entry += 4;
    h(tramp, 0xbe00 | Number(trap));
    h(tramp + 2, 0x4770);
    tramp += 4;
  }
  h(entry, 0); // end of table
  // Data table: empty (no entries), just the terminator.
  h(DATA_TABLE, 0);

  return new Uint32Array(bytes.buffer);
}
