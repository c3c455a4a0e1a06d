//! UF2 images of the firmware, for flashing by drag and drop: hold BOOTSEL, plug the board in
//! and copy the file onto the drive that appears (`RPI-RP2` on an RP2040, `RP2350` on an
//! RP2350). The boot ROM writes each block's payload to flash and boots the image.
//!
//! The block format (512-byte blocks, magic numbers, flags, family ID, extension tags) is the
//! `uftwo` crate's. What no crate does for us is the layout the RP2040 and RP2350 boot ROMs
//! expect, together with the RP2350-E10 block, so that is written here, following picotool's
//! `uf2 convert` (elf2uf2.cpp) and the RP2350 datasheet:
//!
//! * one 256-byte payload per block (a flash page), at a page-aligned flash address;
//!   bytes of a page that no segment fills are 0;
//! * the pages come from the ELF's `PT_LOAD` segments that have file contents, at their
//!   *physical* (load) addresses: `.data`'s initial values are stored in flash at its LMA,
//!   not at its RAM address;
//! * every 4 KiB erase sector that holds a page is completed with zero pages up to the last
//!   page, as picotool does: the boot ROM's sector-erase bookkeeping counts on it;
//! * the family ID (RP2350 datasheet, table "standard UF2 family IDs understood by the RP2350
//!   bootrom"; the RP2040's from the UF2 family list): RP2040 `0xe48bff56`, RP2350 Arm
//!   Secure image `0xe48bff59`;
//! * RP2350 only, first: the erratum RP2350-E10 block (family "absolute" `0xe48bff57`, block 0
//!   of 2, 256 bytes of `0xEF`, tagged with Raspberry Pi's `RP2_IGNORE_BLOCK` extension). An A2
//!   boot ROM needs it to download a UF2 onto a flash that holds a partition table; it writes
//!   that page (erasing its sector), A3 and later boot ROMs skip it. picotool targets the end
//!   of a 16 MiB flash, which on a 2 MiB RP2350 board is our calibration store: we target
//!   the last page of the program region instead ([`E10_BLOCK_ADDR`]), which the image never
//!   reaches.
//!
//! [`decode`] reads such a file back (the round trip in `cargo xtask firmware` and the tests).

use std::collections::BTreeMap;

use object::read::elf::{ElfFile32, ProgramHeader};
use object::Endianness;
use uftwo::{Block, ExtensionTag, Flags, Uf2File};

/// Bytes of payload per block: one flash page.
pub const PAGE: u32 = 256;
/// Flash erase sector.
pub const SECTOR: u32 = 4096;
/// Where flash is mapped (XIP), on both chips.
pub const FLASH_BASE: u32 = 0x1000_0000;
/// End of the program region on both chips: 2 MiB minus the 16 KiB calibration store
/// (memory-rp2040.x, memory-rp2350.x, firmware/src/storage.rs). A UF2 never writes past it.
pub const PROGRAM_END: u32 = FLASH_BASE + 2 * 1024 * 1024 - 16 * 1024;
/// The RP2350-E10 block's target: the last page of the program region.
pub const E10_BLOCK_ADDR: u32 = PROGRAM_END - PAGE;

/// UF2 family IDs (RP2350 datasheet, section 5.5.3 "UF2 targeting rules").
pub const RP2040_FAMILY_ID: u32 = 0xe48b_ff56;
pub const ABSOLUTE_FAMILY_ID: u32 = 0xe48b_ff57;
pub const RP2350_ARM_S_FAMILY_ID: u32 = 0xe48b_ff59;

/// `UF2_EXTENSION_RP2_IGNORE_BLOCK` (0x9957e304 as a little-endian word): an extension of
/// length 4 (no data) with tag 0x9957e3.
const RP2_IGNORE_BLOCK_TAG: u32 = 0x99_57e3;
const RP2_IGNORE_BLOCK_BYTES: [u8; 4] = [0x04, 0xe3, 0x57, 0x99];

/// RP2350 boot ROM block markers (`PICOBIN_BLOCK_MARKER_START`/`_END`) and the IMAGE_TYPE
/// item of an Arm Secure executable for the RP2350 (datasheet 5.9.3 and 5.9.5.1): item 0x42,
/// one word, flags EXE | SECURITY_S | CPU_ARM | CHIP_RP2350 = 0x1021.
const BLOCK_MARKER_START: u32 = 0xffff_ded3;
const BLOCK_MARKER_END: u32 = 0xab12_3579;
const IMAGE_TYPE_ARM_S_EXE: u32 = 0x1021_0142;
/// The boot ROM looks for the IMAGE_DEF in the first 4 KiB of the image.
const IMAGE_DEF_WINDOW: u32 = 4096;

/// What the boot ROM of one chip needs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Target {
    pub family_id: u32,
    /// Prepend the RP2350-E10 block at [`E10_BLOCK_ADDR`].
    pub e10_block: bool,
    /// Require an Arm Secure IMAGE_DEF block in the first 4 KiB (the RP2350 boots nothing else).
    pub image_def: bool,
}

impl Target {
    pub const RP2040: Target = Target {
        family_id: RP2040_FAMILY_ID,
        e10_block: false,
        image_def: false,
    };
    pub const RP2350: Target = Target {
        family_id: RP2350_ARM_S_FAMILY_ID,
        e10_block: true,
        image_def: true,
    };
}

/// Flash pages by address (page-aligned), 256 bytes each.
pub type Pages = BTreeMap<u32, [u8; PAGE as usize]>;

/// Why an ELF cannot become a UF2, or a UF2 is not one we wrote.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum Uf2Error {
    #[error("not a 32-bit ELF file ({0})")]
    NotElf(String),
    #[error("program header {0}: its contents lie outside the file")]
    BadSegment(usize),
    #[error("a segment at {start:#010x}..{end:#010x} lies outside the program flash {FLASH_BASE:#010x}..{PROGRAM_END:#010x}")]
    OutsideFlash { start: u64, end: u64 },
    #[error("two segments both fill flash address {0:#010x}")]
    Overlap(u32),
    #[error("the ELF has no loadable contents")]
    Empty,
    #[error("the image reaches the sector the RP2350-E10 block erases ({0:#010x})")]
    E10Overlap(u32),
    #[error("no Arm Secure IMAGE_DEF block in the first 4 KiB of flash: the RP2350 boot ROM would not boot this image")]
    NoImageDef,
    #[error("not a UF2 file ({0})")]
    NotUf2(String),
    #[error("block {index}: {what}")]
    BadBlock { index: usize, what: String },
}

/// The flash pages of an ELF's loadable contents, checked for `target`.
pub fn pages_from_elf(elf: &[u8], target: Target) -> Result<Pages, Uf2Error> {
    let file = ElfFile32::<Endianness>::parse(elf).map_err(|e| Uf2Error::NotElf(e.to_string()))?;
    let endian = file.endian();
    let mut pages = Pages::new();
    let mut filled: BTreeMap<u32, [bool; PAGE as usize]> = BTreeMap::new();
    for (i, ph) in file.elf_program_headers().iter().enumerate() {
        if ph.p_type(endian) != object::elf::PT_LOAD || ph.p_filesz(endian) == 0 {
            continue; // .bss, .uninit, the stack: nothing to store
        }
        let bytes = ph.data(endian, elf).map_err(|()| Uf2Error::BadSegment(i))?;
        let start = u64::from(ph.p_paddr(endian));
        let end = start + bytes.len() as u64;
        if start < u64::from(FLASH_BASE) || end > u64::from(PROGRAM_END) {
            return Err(Uf2Error::OutsideFlash { start, end });
        }
        for (k, &b) in bytes.iter().enumerate() {
            let addr = start as u32 + k as u32;
            let (page, off) = (addr & !(PAGE - 1), (addr % PAGE) as usize);
            let used = filled.entry(page).or_insert([false; PAGE as usize]);
            if used[off] {
                return Err(Uf2Error::Overlap(addr));
            }
            used[off] = true;
            pages.entry(page).or_insert([0; PAGE as usize])[off] = b;
        }
    }
    let Some(&last) = pages.keys().next_back() else {
        return Err(Uf2Error::Empty);
    };
    let sectors: Vec<u32> = pages.keys().map(|p| p & !(SECTOR - 1)).collect();
    for sector in sectors {
        for page in (sector..sector + SECTOR).step_by(PAGE as usize) {
            if page < last {
                pages.entry(page).or_insert([0; PAGE as usize]);
            }
        }
    }
    if target.e10_block && last >= E10_BLOCK_ADDR & !(SECTOR - 1) {
        return Err(Uf2Error::E10Overlap(last));
    }
    if target.image_def && !has_image_def(&pages) {
        return Err(Uf2Error::NoImageDef);
    }
    Ok(pages)
}

/// Whether the first 4 KiB of flash hold an IMAGE_DEF block whose first item declares an Arm
/// Secure RP2350 executable (what embassy-rp's `ImageDef::secure_exe()` places in
/// `.start_block`): start marker, IMAGE_TYPE item, and an end marker within the window.
fn has_image_def(pages: &Pages) -> bool {
    let word = |addr: u32| -> Option<u32> {
        let page = pages.get(&(addr & !(PAGE - 1)))?;
        let off = (addr % PAGE) as usize;
        Some(u32::from_le_bytes(page[off..off + 4].try_into().ok()?))
    };
    let window = FLASH_BASE..FLASH_BASE + IMAGE_DEF_WINDOW;
    window.clone().step_by(4).any(|addr| {
        word(addr) == Some(BLOCK_MARKER_START)
            && word(addr + 4) == Some(IMAGE_TYPE_ARM_S_EXE)
            && (addr + 8..window.end)
                .step_by(4)
                .any(|a| word(a) == Some(BLOCK_MARKER_END))
    })
}

/// The RP2350-E10 block, as picotool (2.1 and later) writes it.
fn e10_block() -> Block {
    let mut block = Block::new(0, 2, &[0xef; PAGE as usize], E10_BLOCK_ADDR as usize);
    block.flags |= Flags::FamilyId;
    block.board_family_id_or_file_size = ABSOLUTE_FAMILY_ID;
    block
        .add_extension(ExtensionTag::Other(RP2_IGNORE_BLOCK_TAG), &[])
        .expect("a 4-byte extension fits after a 256-byte payload");
    block
}

/// The UF2 file for `pages`: blocks numbered 0..N in address order, each with the family ID.
pub fn encode(pages: &Pages, target: Target) -> Vec<u8> {
    let mut file = Uf2File::new();
    if target.e10_block {
        file.push_block(e10_block());
    }
    for (n, (&addr, data)) in pages.iter().enumerate() {
        let mut block = Block::new(n, pages.len(), data, addr as usize);
        block.flags |= Flags::FamilyId;
        block.board_family_id_or_file_size = target.family_id;
        file.push_block(block);
    }
    file.to_bytes()
}

/// A UF2 file read back.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Decoded {
    pub pages: Pages,
    /// Where the RP2350-E10 block points, if the file has one.
    pub e10_block: Option<u32>,
}

/// Reads a UF2 file of `family_id`: every block a full page at a page-aligned flash address
/// inside the program region, numbered 0..N with total N, each address once; an RP2350-E10
/// block (only as the first block) is set aside.
pub fn decode(bytes: &[u8], family_id: u32) -> Result<Decoded, Uf2Error> {
    let file = uftwo::reader::from_bytes(bytes).map_err(|e| Uf2Error::NotUf2(e.to_string()))?;
    let mut blocks = file.blocks();
    let mut e10_block = None;
    if let Some(first) = blocks.first().filter(|b| is_e10_block(b)) {
        e10_block = Some(first.target_addr);
        blocks = &blocks[1..];
    }
    let mut pages = Pages::new();
    for (n, b) in blocks.iter().enumerate() {
        let bad = |what: String| Uf2Error::BadBlock {
            index: n + usize::from(e10_block.is_some()),
            what,
        };
        if b.board_family_id() != Some(family_id) {
            return Err(bad(format!(
                "family {:?}, not {family_id:#010x}",
                b.board_family_id()
            )));
        }
        if b.block as usize != n || b.total_blocks as usize != blocks.len() {
            return Err(bad(format!(
                "numbered {} of {}, expected {n} of {}",
                b.block,
                b.total_blocks,
                blocks.len()
            )));
        }
        let addr = b.target_addr;
        if b.data_len != PAGE || addr % PAGE != 0 || !(FLASH_BASE..PROGRAM_END).contains(&addr) {
            return Err(bad(format!(
                "{} bytes at {addr:#010x}, not a program flash page",
                b.data_len
            )));
        }
        let page: [u8; PAGE as usize] = b
            .data()
            .try_into()
            .map_err(|_| bad("short payload".into()))?;
        if pages.insert(addr, page).is_some() {
            return Err(bad(format!("{addr:#010x} written twice")));
        }
    }
    Ok(Decoded { pages, e10_block })
}

/// The RP2350-E10 block: family absolute, block 0 of 2, a page of 0xEF, RP2_IGNORE_BLOCK.
fn is_e10_block(b: &Block) -> bool {
    b.board_family_id() == Some(ABSOLUTE_FAMILY_ID)
        && b.block == 0
        && b.total_blocks == 2
        && b.data_len == PAGE
        && b.data[..PAGE as usize].iter().all(|&x| x == 0xef)
        && b.flags.contains(Flags::ExtensionTags)
        && b.data[PAGE as usize..PAGE as usize + 4] == RP2_IGNORE_BLOCK_BYTES
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One `PT_LOAD` (or other) program header of a test ELF and its file contents.
    struct Seg {
        p_type: u32,
        vaddr: u32,
        paddr: u32,
        bytes: Vec<u8>,
        memsz: u32,
    }

    fn load(paddr: u32, bytes: Vec<u8>) -> Seg {
        let memsz = bytes.len() as u32;
        Seg {
            p_type: 1,
            vaddr: paddr,
            paddr,
            bytes,
            memsz,
        }
    }

    /// A minimal ELF32 little-endian ARM executable (ELF specification: 52-byte file header,
    /// 32-byte program headers, no sections), written field by field.
    fn elf(segments: &[Seg]) -> Vec<u8> {
        let mut out = vec![0x7f, b'E', b'L', b'F', 1, 1, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0];
        let h16 = |o: &mut Vec<u8>, v: u16| o.extend_from_slice(&v.to_le_bytes());
        let h32 = |o: &mut Vec<u8>, v: u32| o.extend_from_slice(&v.to_le_bytes());
        h16(&mut out, 2); // ET_EXEC
        h16(&mut out, 40); // EM_ARM
        h32(&mut out, 1);
        h32(&mut out, FLASH_BASE | 1); // entry
        h32(&mut out, 52); // e_phoff
        h32(&mut out, 0); // e_shoff
        h32(&mut out, 0x0500_0200); // EABI5
        for v in [52, 32, segments.len() as u16, 40, 0, 0] {
            h16(&mut out, v);
        }
        let mut offset = 52 + 32 * segments.len() as u32;
        for s in segments {
            for v in [
                s.p_type,
                offset,
                s.vaddr,
                s.paddr,
                s.bytes.len() as u32,
                s.memsz,
                5,
                4,
            ] {
                h32(&mut out, v);
            }
            offset += s.bytes.len() as u32;
        }
        for s in segments {
            out.extend_from_slice(&s.bytes);
        }
        out
    }

    fn word(bytes: &[u8], at: usize) -> u32 {
        u32::from_le_bytes(bytes[at..at + 4].try_into().unwrap())
    }

    /// An RP2350 IMAGE_DEF as embassy-rp's `ImageDef::secure_exe()` lays it out: start
    /// marker, IMAGE_TYPE item, LAST item, link, end marker.
    fn image_def() -> Vec<u8> {
        [0xffff_ded3u32, 0x1021_0142, 0x0000_01ff, 0, 0xab12_3579]
            .iter()
            .flat_map(|w| w.to_le_bytes())
            .collect()
    }

    #[test]
    fn pages_take_load_addresses_and_skip_empty_segments() {
        let text: Vec<u8> = (0..300u32).map(|i| (i * 7 + 1) as u8).collect();
        let data = vec![0xd1, 0xd2, 0xd3, 0xd4];
        let elf = elf(&[
            load(FLASH_BASE, text.clone()),
            // .data: runs at 0x2000_0000, stored in flash at 0x1000_0140 (its LMA)
            Seg {
                p_type: 1,
                vaddr: 0x2000_0000,
                paddr: FLASH_BASE + 0x140,
                bytes: data.clone(),
                memsz: 4,
            },
            // .bss: no file contents
            Seg {
                p_type: 1,
                vaddr: 0x2000_0004,
                paddr: 0x2000_0004,
                bytes: vec![],
                memsz: 400,
            },
            // not PT_LOAD (PT_NOTE): ignored even though it has contents
            Seg {
                p_type: 4,
                vaddr: 0x3000_0000,
                paddr: 0x3000_0000,
                bytes: vec![9; 8],
                memsz: 8,
            },
        ]);
        let pages = pages_from_elf(&elf, Target::RP2040).unwrap();
        assert_eq!(
            pages.keys().copied().collect::<Vec<_>>(),
            [FLASH_BASE, FLASH_BASE + 0x100]
        );
        let flat: Vec<u8> = pages.values().flatten().copied().collect();
        assert_eq!(&flat[..300], &text[..]);
        assert_eq!(&flat[0x12c..0x140], &[0; 20]); // gap: zero
        assert_eq!(&flat[0x140..0x144], &data[..]);
        assert!(flat[0x144..].iter().all(|&b| b == 0));
    }

    #[test]
    fn touched_sectors_are_filled_up_to_the_last_page() {
        // Sector 0: pages 0 and 8; sector 2: page 0x2100 (the last page).
        let elf = elf(&[
            load(FLASH_BASE, vec![1; 16]),
            load(FLASH_BASE + 0x800, vec![2; 16]),
            load(FLASH_BASE + 0x2100, vec![3; 16]),
        ]);
        let pages = pages_from_elf(&elf, Target::RP2040).unwrap();
        let want: Vec<u32> = (0..16)
            .map(|k| FLASH_BASE + k * 0x100) // all of sector 0
            .chain([FLASH_BASE + 0x2000, FLASH_BASE + 0x2100]) // sector 2 up to the last page
            .collect();
        assert_eq!(pages.keys().copied().collect::<Vec<_>>(), want);
        assert_eq!(pages[&(FLASH_BASE + 0x100)], [0; 256]);
        assert_eq!(pages[&(FLASH_BASE + 0x2000)], [0; 256]);
        assert_eq!(pages[&(FLASH_BASE + 0x800)][..16], [2; 16]);
    }

    #[test]
    fn rp2040_blocks_follow_the_uf2_specification() {
        let text: Vec<u8> = (0..1000u32).map(|i| (i % 251) as u8).collect();
        let pages =
            pages_from_elf(&elf(&[load(FLASH_BASE, text.clone())]), Target::RP2040).unwrap();
        let uf2 = encode(&pages, Target::RP2040);
        assert_eq!(uf2.len(), 4 * 512); // 1000 bytes: 4 pages, no E10 block
        for n in 0..4 {
            let b = &uf2[n * 512..(n + 1) * 512];
            // UF2 specification: magics, flags (familyID present), address, payload size,
            // block number, total, family; final magic at 508.
            assert_eq!(word(b, 0), 0x0A32_4655);
            assert_eq!(word(b, 4), 0x9E5D_5157);
            assert_eq!(word(b, 8), 0x0000_2000);
            assert_eq!(word(b, 12), FLASH_BASE + 256 * n as u32);
            assert_eq!(word(b, 16), 256);
            assert_eq!(word(b, 20), n as u32);
            assert_eq!(word(b, 24), 4);
            assert_eq!(word(b, 28), 0xe48b_ff56);
            assert_eq!(word(b, 508), 0x0AB1_6F30);
            let want = &text[n * 256..text.len().min((n + 1) * 256)];
            assert_eq!(&b[32..32 + want.len()], want);
        }
        let back = decode(&uf2, RP2040_FAMILY_ID).unwrap();
        assert_eq!(
            back,
            Decoded {
                pages,
                e10_block: None
            }
        );
    }

    #[test]
    fn rp2350_file_starts_with_the_e10_block_and_round_trips() {
        let mut text = vec![0u8; 0x20];
        text.extend(image_def());
        text.extend((0..5000u32).map(|i| (i * 31 % 256) as u8));
        let pages = pages_from_elf(&elf(&[load(FLASH_BASE, text)]), Target::RP2350).unwrap();
        let uf2 = encode(&pages, Target::RP2350);
        assert_eq!(uf2.len(), 512 * (1 + pages.len()));
        let e10 = &uf2[..512];
        // RP2350 datasheet, erratum RP2350-E10, and picotool's gen_abs_block.
        assert_eq!(word(e10, 8), 0x0000_a000); // familyID present | extension tags present
        assert_eq!(word(e10, 12), E10_BLOCK_ADDR);
        assert_eq!([word(e10, 16), word(e10, 20), word(e10, 24)], [256, 0, 2]);
        assert_eq!(word(e10, 28), 0xe48b_ff57);
        assert!(e10[32..288].iter().all(|&b| b == 0xef));
        assert_eq!(word(e10, 288), 0x9957_e304);
        assert_eq!(E10_BLOCK_ADDR, 0x101f_bf00);
        for n in 0..pages.len() {
            let b = &uf2[(n + 1) * 512..];
            assert_eq!([word(b, 20), word(b, 24)], [n as u32, pages.len() as u32]);
            assert_eq!(word(b, 28), 0xe48b_ff59);
        }
        let back = decode(&uf2, RP2350_ARM_S_FAMILY_ID).unwrap();
        assert_eq!(
            back,
            Decoded {
                pages,
                e10_block: Some(E10_BLOCK_ADDR)
            }
        );
    }

    #[test]
    fn elf_files_the_boot_rom_cannot_use_are_refused() {
        let refuse = |segs: &[Seg], t: Target| pages_from_elf(&elf(segs), t).unwrap_err();
        assert!(matches!(
            pages_from_elf(b"not an elf", Target::RP2040),
            Err(Uf2Error::NotElf(_))
        ));
        assert_eq!(refuse(&[], Target::RP2040), Uf2Error::Empty);
        assert!(matches!(
            refuse(&[load(0x2000_0000, vec![1])], Target::RP2040),
            Uf2Error::OutsideFlash { .. }
        ));
        // Into the calibration store (the last 16 KiB of the 2 MiB).
        assert!(matches!(
            refuse(&[load(PROGRAM_END - 2, vec![1; 4])], Target::RP2040),
            Uf2Error::OutsideFlash { .. }
        ));
        assert_eq!(
            refuse(
                &[
                    load(FLASH_BASE, vec![1; 8]),
                    load(FLASH_BASE + 4, vec![2; 8])
                ],
                Target::RP2040
            ),
            Uf2Error::Overlap(FLASH_BASE + 4)
        );
        // The RP2350 boots only an image with an IMAGE_DEF in its first 4 KiB.
        assert_eq!(
            refuse(&[load(FLASH_BASE, vec![0; 64])], Target::RP2350),
            Uf2Error::NoImageDef
        );
        let mut late = vec![0; 4096];
        late.extend(image_def());
        assert_eq!(
            refuse(&[load(FLASH_BASE, late)], Target::RP2350),
            Uf2Error::NoImageDef
        );
        let mut image = image_def();
        image.resize(64, 0);
        let e10_sector = E10_BLOCK_ADDR & !(SECTOR - 1);
        assert!(matches!(
            refuse(
                &[load(FLASH_BASE, image.clone()), load(e10_sector, vec![1])],
                Target::RP2350
            ),
            Uf2Error::E10Overlap(_)
        ));
        assert!(pages_from_elf(&elf(&[load(FLASH_BASE, image)]), Target::RP2350).is_ok());
    }

    #[test]
    fn corrupt_uf2_files_are_refused() {
        let pages =
            pages_from_elf(&elf(&[load(FLASH_BASE, vec![5; 1000])]), Target::RP2040).unwrap();
        let good = encode(&pages, Target::RP2040);
        assert!(decode(&good, RP2040_FAMILY_ID).is_ok());
        assert!(matches!(
            decode(&good, RP2350_ARM_S_FAMILY_ID),
            Err(Uf2Error::BadBlock { index: 0, .. })
        ));
        assert!(matches!(
            decode(&good[..1000], RP2040_FAMILY_ID),
            Err(Uf2Error::NotUf2(_))
        ));
        let mut magic = good.clone();
        magic[512 + 4] ^= 1;
        assert!(matches!(
            decode(&magic, RP2040_FAMILY_ID),
            Err(Uf2Error::NotUf2(_))
        ));
        // Block 1 missing: 3 blocks that say 4.
        let missing = [&good[..512], &good[1024..]].concat();
        assert_eq!(
            decode(&missing, RP2040_FAMILY_ID).unwrap_err().to_string(),
            "block 0: numbered 0 of 4, expected 0 of 3"
        );
        // Blocks 1 and 2 swapped: as many blocks as announced, but out of order.
        let swapped = [
            &good[..512],
            &good[1024..1536],
            &good[512..1024],
            &good[1536..],
        ]
        .concat();
        assert_eq!(
            decode(&swapped, RP2040_FAMILY_ID).unwrap_err().to_string(),
            "block 1: numbered 2 of 4, expected 1 of 4"
        );
        let mut outside = good.clone();
        outside[512 + 12..512 + 16].copy_from_slice(&PROGRAM_END.to_le_bytes());
        assert!(matches!(
            decode(&outside, RP2040_FAMILY_ID),
            Err(Uf2Error::BadBlock { index: 1, .. })
        ));
    }
}
