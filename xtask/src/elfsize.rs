//! Flash and static RAM use of an embedded ELF, the way `size` (Berkeley format) counts:
//!
//! * `text`: allocated, read-only sections (vector table, code, read-only data) — flash;
//! * `data`: allocated, writable sections with contents (`.data`) — flash (the initial
//!   values) *and* RAM;
//! * `bss`: allocated sections without contents (`.bss`, `.uninit`) — RAM.
//!
//! Flash = text + data, static RAM = data + bss. The stack is not a section (cortex-m-rt
//! places it at the top of RAM, below whatever is free), so it is not included.

use object::{Object, ObjectSection, SectionFlags};
use std::fmt;

/// ELF `SHF_WRITE`.
const SHF_WRITE: u64 = 0x1;
/// ELF `SHF_ALLOC`.
const SHF_ALLOC: u64 = 0x2;

/// Section totals in bytes.
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
pub struct Sizes {
    pub text: u64,
    pub data: u64,
    pub bss: u64,
}

impl Sizes {
    /// Bytes of flash: code, read-only data and the initial values of `.data`.
    pub fn flash(&self) -> u64 {
        self.text + self.data
    }

    /// Bytes of statically allocated RAM: `.data` and `.bss` (without the stack).
    pub fn ram(&self) -> u64 {
        self.data + self.bss
    }

    /// Adds one section given its ELF flags, whether it has no file contents (`SHT_NOBITS`)
    /// and its size.
    pub fn add(&mut self, sh_flags: u64, nobits: bool, size: u64) {
        if sh_flags & SHF_ALLOC == 0 {
            return; // debug info, defmt's string table, symbols: not on the device
        }
        if nobits {
            self.bss += size;
        } else if sh_flags & SHF_WRITE != 0 {
            self.data += size;
        } else {
            self.text += size;
        }
    }
}

impl fmt::Display for Sizes {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "   text    data     bss\n{:>7} {:>7} {:>7}",
            self.text, self.data, self.bss
        )
    }
}

/// Measures an ELF file's allocated sections.
pub fn measure(elf: &[u8]) -> Result<Sizes, String> {
    let file = object::File::parse(elf).map_err(|e| format!("not an ELF file: {e}"))?;
    let mut sizes = Sizes::default();
    for section in file.sections() {
        let SectionFlags::Elf { sh_flags, sh_type } = section.flags() else {
            continue;
        };
        sizes.add(
            sh_flags.0,
            sh_type == object::elf::SHT_NOBITS,
            section.size(),
        );
    }
    Ok(sizes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sections_are_classified_like_berkeley_size() {
        let mut s = Sizes::default();
        s.add(SHF_ALLOC, false, 1000); // .text
        s.add(SHF_ALLOC, false, 200); // .rodata
        s.add(SHF_ALLOC | SHF_WRITE, false, 30); // .data
        s.add(SHF_ALLOC | SHF_WRITE, true, 400); // .bss
        s.add(0, false, 99_999); // .debug_info: not on the device
        assert_eq!(
            s,
            Sizes {
                text: 1200,
                data: 30,
                bss: 400
            }
        );
        assert_eq!(s.flash(), 1230);
        assert_eq!(s.ram(), 430);
    }

    #[test]
    fn garbage_is_refused() {
        assert!(measure(b"not an elf").is_err());
    }
}
