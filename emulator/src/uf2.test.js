// Tests of the UF2 loader (src/uf2.js): run with `node --test src/uf2.test.js` (cargo xtask
// emulate runs it before the scenarios). The files are built here block by block from the UF2
// specification's layout, independently of the loader and of `cargo xtask firmware`'s writer.

import test from 'node:test';
import assert from 'node:assert/strict';
import { parseUf2, loadUf2, Uf2Error } from './uf2.js';

const RP2040 = 0xe48bff56;
const RP2350_ARM_S = 0xe48bff59;
const ABSOLUTE = 0xe48bff57;

/** One 512-byte block; `payload` bytes go at offset 32. */
function block({ no, total, addr, family = RP2040, flags = 0x2000, size = 256, payload = [], magics = [0x0a324655, 0x9e5d5157, 0x0ab16f30] }) {
  const b = new Uint8Array(512);
  const v = new DataView(b.buffer);
  [magics[0], magics[1], flags, addr, size, no, total, family].forEach((w, i) => v.setUint32(4 * i, w, true));
  v.setUint32(508, magics[2], true);
  b.set(payload, 32);
  return b;
}
const concat = (blocks) => {
  const out = new Uint8Array(blocks.length * 512);
  blocks.forEach((b, i) => out.set(b, i * 512));
  return out;
};
/** A good three-page file: pages 0x10000000, 0x10000100, 0x10001000 filled with 1, 2, 3. */
function goodBlocks() {
  return [0x10000000, 0x10000100, 0x10001000].map((addr, i) =>
    block({ no: i, total: 3, addr, payload: new Array(256).fill(i + 1) }));
}
/** Asserts that `data` is refused with one sentence matching `pattern`. */
function refused(data, pattern) {
  assert.throws(() => parseUf2(data), (e) => {
    assert.ok(e instanceof Uf2Error, `not a Uf2Error: ${e}`);
    assert.match(e.message, pattern);
    assert.match(e.message, /^[^\n]+\.$/, 'one sentence ending with a full stop');
    return true;
  });
}

test('a good file is written page by page at its addresses', () => {
  const flash = new Uint8Array(2 * 1024 * 1024).fill(0xff);
  assert.equal(loadUf2(concat(goodBlocks()), flash), 3);
  assert.deepEqual([...new Set(flash.subarray(0, 0x100))], [1]);
  assert.deepEqual([...new Set(flash.subarray(0x100, 0x200))], [2]);
  assert.deepEqual([...new Set(flash.subarray(0x200, 0x1000))], [0xff]); // not in the file: erased
  assert.deepEqual([...new Set(flash.subarray(0x1000, 0x1100))], [3]);
  assert.equal(flash[0x1100], 0xff);
});

test('a bad magic number is refused, at the start and at the end of a block', () => {
  for (const k of [0, 1, 2]) {
    const blocks = goodBlocks();
    const magics = [0x0a324655, 0x9e5d5157, 0x0ab16f30];
    magics[k] ^= 0x100;
    blocks[1] = block({ no: 1, total: 3, addr: 0x10000100, magics });
    refused(concat(blocks), /^block 1 \(byte 512\) has a bad magic number/);
  }
});

test('a missing, repeated or misplaced block is refused', () => {
  const b = goodBlocks();
  refused(concat([b[0], b[2]]), /^block 0 \(byte 0\) says the file has 3 blocks, but it holds 2: a block is missing or one too many\.$/);
  refused(concat([...b, b[2]]), /^block 0 .* says the file has 3 blocks, but it holds 4/);
  const three = (order) => concat(order.map((no) => block({ no, total: 3, addr: 0x10000000 + 256 * no })));
  refused(three([0, 1, 1]), /^block 2 \(byte 1024\) is numbered 1, so the blocks are repeated or out of order\.$/);
  refused(three([1, 0, 2]), /^block 0 .* is numbered 1, so the blocks are repeated or out of order\.$/);
  // Same address twice under correct numbers.
  const twice = [0, 1].map((no) => block({ no, total: 2, addr: 0x10000000 }));
  refused(concat(twice), /^block 1 .* writes 0x10000000 a second time\.$/);
});

test('another chip\'s file is refused by its family ID', () => {
  const rp2350 = [0, 1].map((no) => block({ no, total: 2, addr: 0x10000000 + no * 256, family: RP2350_ARM_S }));
  refused(concat(rp2350), /^block 0 .* has family 0xe48bff59, not the RP2040's 0xe48bff56\.$/);
  // An RP2350 file starting with the RP2350-E10 block (family "absolute").
  const e10 = block({ no: 0, total: 2, addr: 0x101fbf00, family: ABSOLUTE, flags: 0xa000 });
  refused(concat([e10, ...rp2350]), /^block 0 .* says the file has 2 blocks, but it holds 3/);
  refused(concat([block({ no: 0, total: 1, addr: 0x10000000, flags: 0, family: 512 })]), /has no family ID, not the RP2040's/);
});

test('a block outside the flash or not a whole page is refused', () => {
  for (const addr of [0x10200000, 0x101fff80, 0x20000000, 0x0ffffff0, 0x10000080]) {
    refused(concat([block({ no: 0, total: 1, addr })]), /targets 0x[0-9a-f]{8}, which is not a page of the 2 MiB flash at 0x10000000\.$/);
  }
  refused(concat([block({ no: 0, total: 1, addr: 0x10000000, size: 476 })]), /carries 476 bytes, but the RP2040 boot ROM writes 256-byte pages only\.$/);
});

test('a file that is not whole blocks is refused', () => {
  refused(new Uint8Array(0), /^the file is 0 bytes, not a whole number of 512-byte UF2 blocks\.$/);
  refused(concat(goodBlocks()).subarray(0, 1000), /^the file is 1000 bytes/);
});

test('blocks flagged "not main flash" are skipped, not written', () => {
  const b = goodBlocks();
  b[1] = block({ no: 1, total: 3, addr: 0x10000100, flags: 0x2001, payload: new Array(256).fill(9) });
  const pages = parseUf2(concat(b));
  assert.deepEqual(pages.map((p) => p.addr), [0x10000000, 0x10001000]);
});
