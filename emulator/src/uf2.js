// UF2 loader: the file a user drops on the Pico's RPI-RP2 drive, read into the emulated flash
// the way the RP2040 boot ROM would write it. Written from the UF2 specification
// (github.com/microsoft/uf2, README "File format"): 512-byte blocks, little-endian words
//
//   0 magicStart0 0x0A324655   4 magicStart1 0x9E5D5157   8 flags   12 targetAddr
//  16 payloadSize              20 blockNo                 24 numBlocks
//  28 fileSize or familyID (flag 0x2000)   32..508 data   508 magicEnd 0x0AB16F30
//
// and what the RP2040's boot ROM takes (RP2040 datasheet, "UF2 Format Details" under the boot
// ROM's USB mass storage interface): 256-byte payloads at page-aligned flash addresses, family
// ID 0xe48bff56 (also listed for the RP2040 in the RP2350 datasheet's table of UF2 family IDs). Stricter than the ROM in one way: the blocks must
// come in order, numbered 0..N-1 with total N, as `cargo xtask firmware` writes them, so that
// a missing, repeated or shuffled block is refused rather than flashed as a partial image.

/** A file the loader refuses; the message is one sentence naming the block. */
export class Uf2Error extends Error {}

export const BLOCK_SIZE = 512;
export const PAGE_SIZE = 256;
export const MAGIC_START0 = 0x0a324655;
export const MAGIC_START1 = 0x9e5d5157;
export const MAGIC_END = 0x0ab16f30;
export const FLAG_NOT_MAIN_FLASH = 0x00000001;
export const FLAG_FAMILY_ID = 0x00002000;
export const RP2040_FAMILY_ID = 0xe48bff56;
export const FLASH_BASE = 0x10000000;

const hex = (v) => `0x${(v >>> 0).toString(16).padStart(8, '0')}`;

/** The header fields of block `i` of `data` (Uint8Array). */
function header(view, i) {
  const o = i * BLOCK_SIZE;
  const w = (k) => view.getUint32(o + k, true);
  return {
    offset: o,
    magic: [w(0), w(4), w(508)],
    flags: w(8),
    addr: w(12),
    size: w(16),
    blockNo: w(20),
    numBlocks: w(24),
    family: w(28),
  };
}

/**
 * Parses a UF2 file for the RP2040 with `flashSize` bytes of flash. Returns the pages in file
 * order, [{ addr, bytes }] (`bytes` a 256-byte view into `data`); throws Uf2Error otherwise.
 */
export function parseUf2(data, { familyId = RP2040_FAMILY_ID, flashSize = 2 * 1024 * 1024 } = {}) {
  if (!(data instanceof Uint8Array)) throw new Uf2Error('the UF2 loader needs the file\'s bytes (a Uint8Array).');
  if (data.length === 0 || data.length % BLOCK_SIZE !== 0) {
    throw new Uf2Error(`the file is ${data.length} bytes, not a whole number of 512-byte UF2 blocks.`);
  }
  const view = new DataView(data.buffer, data.byteOffset, data.byteLength);
  const count = data.length / BLOCK_SIZE;
  const pages = [];
  const seen = new Set();
  for (let i = 0; i < count; i++) {
    const h = header(view, i);
    const at = `block ${i} (byte ${h.offset})`;
    if (h.magic[0] !== MAGIC_START0 || h.magic[1] !== MAGIC_START1 || h.magic[2] !== MAGIC_END) {
      throw new Uf2Error(`${at} has a bad magic number, so the file is not a UF2 image or is damaged.`);
    }
    if (h.numBlocks !== count) {
      throw new Uf2Error(`${at} says the file has ${h.numBlocks} blocks, but it holds ${count}: a block is missing or one too many.`);
    }
    if (h.blockNo !== i) {
      throw new Uf2Error(`${at} is numbered ${h.blockNo}, so the blocks are repeated or out of order.`);
    }
    if (!(h.flags & FLAG_FAMILY_ID) || h.family !== familyId) {
      const family = h.flags & FLAG_FAMILY_ID ? `family ${hex(h.family)}` : 'no family ID';
      throw new Uf2Error(`${at} has ${family}, not the RP2040's ${hex(familyId)}.`);
    }
    if (h.flags & FLAG_NOT_MAIN_FLASH) continue; // not for flash (UF2 specification): skipped
    if (h.size !== PAGE_SIZE) {
      throw new Uf2Error(`${at} carries ${h.size} bytes, but the RP2040 boot ROM writes 256-byte pages only.`);
    }
    if (h.addr % PAGE_SIZE !== 0 || h.addr < FLASH_BASE || h.addr + PAGE_SIZE > FLASH_BASE + flashSize) {
      throw new Uf2Error(`${at} targets ${hex(h.addr)}, which is not a page of the ${flashSize >> 20} MiB flash at ${hex(FLASH_BASE)}.`);
    }
    if (seen.has(h.addr)) throw new Uf2Error(`${at} writes ${hex(h.addr)} a second time.`);
    seen.add(h.addr);
    pages.push({ addr: h.addr, bytes: data.subarray(h.offset + 32, h.offset + 32 + PAGE_SIZE) });
  }
  return pages;
}

/**
 * Writes the pages of a UF2 file into `flash` (the flash's bytes, offset 0 = FLASH_BASE);
 * `options` as for parseUf2. Returns the number of pages written.
 */
export function loadUf2(data, flash, options = {}) {
  const pages = parseUf2(data, options);
  for (const { addr, bytes } of pages) flash.set(bytes, addr - FLASH_BASE);
  return pages.length;
}
