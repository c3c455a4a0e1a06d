// Minimal ELF32 little-endian reader: the loadable segments of the firmware (at their load
// addresses, LMA = p_paddr) and the symbol table (for a few addresses the harness reports).

/** Thrown for a file that is not a 32-bit little-endian ARM ELF. */
export class ElfError extends Error {}

/**
 * Parses `data` (Uint8Array). Returns { entry, segments: [{ paddr, bytes }], symbols: Map }.
 */
export function parseElf(data) {
  const view = new DataView(data.buffer, data.byteOffset, data.byteLength);
  if (data.length < 52 || view.getUint32(0, false) !== 0x7f454c46) {
    throw new ElfError('not an ELF file');
  }
  if (data[4] !== 1 || data[5] !== 1) {
    throw new ElfError('not a 32-bit little-endian ELF');
  }
  if (view.getUint16(18, true) !== 40) {
    throw new ElfError('not an ARM ELF');
  }
  const entry = view.getUint32(24, true);
  const phoff = view.getUint32(28, true);
  const shoff = view.getUint32(32, true);
  const phentsize = view.getUint16(42, true);
  const phnum = view.getUint16(44, true);
  const shentsize = view.getUint16(46, true);
  const shnum = view.getUint16(48, true);

  const segments = [];
  for (let i = 0; i < phnum; i++) {
    const o = phoff + i * phentsize;
    const type = view.getUint32(o, true);
    const offset = view.getUint32(o + 4, true);
    const paddr = view.getUint32(o + 12, true);
    const filesz = view.getUint32(o + 16, true);
    if (type === 1 && filesz > 0) {
      if (offset + filesz > data.length) {
        throw new ElfError(`segment ${i} runs past the end of the file`);
      }
      segments.push({ paddr, bytes: data.subarray(offset, offset + filesz) });
    }
  }

  const symbols = new Map();
  for (let i = 0; i < shnum; i++) {
    const o = shoff + i * shentsize;
    if (o + 40 > data.length || view.getUint32(o + 4, true) !== 2) {
      continue; // not SHT_SYMTAB
    }
    const symOff = view.getUint32(o + 16, true);
    const symSize = view.getUint32(o + 20, true);
    const strIndex = view.getUint32(o + 24, true);
    const strOff = view.getUint32(shoff + strIndex * shentsize + 16, true);
    for (let s = symOff; s + 16 <= symOff + symSize; s += 16) {
      const nameOff = view.getUint32(s, true);
      const value = view.getUint32(s + 4, true);
      let end = strOff + nameOff;
      while (end < data.length && data[end] !== 0) end++;
      const name = new TextDecoder().decode(data.subarray(strOff + nameOff, end));
      if (name) symbols.set(name, value);
    }
  }
  return { entry, segments, symbols };
}
