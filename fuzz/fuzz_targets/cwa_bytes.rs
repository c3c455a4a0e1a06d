//! A `.cwa` file for the fuzz targets that read one (`cwa_reader`, `raw_block_reader`): a valid
//! header whose flags and rate code come from the fuzzer's first byte `pick`, then `body` as
//! data blocks; with `pick` odd every block's checksum is made to pass, so that the fields
//! (and the clock that places the blocks) are reached.

use wiical_analysis::input::raw::cwa;

/// The header, then `body`; checksums fixed when `pick` is odd.
pub fn cwa_file(pick: u8, body: impl IntoIterator<Item = u8>) -> Vec<u8> {
    let mut file = vec![0u8; cwa::HEADER_BYTES];
    file[..2].copy_from_slice(b"MD");
    file[2..4].copy_from_slice(&1020u16.to_le_bytes());
    file[4] = if pick & 2 != 0 { 0x64 } else { 0 };
    file[36] = pick >> 2;
    file.extend(body);
    if pick & 1 == 1 {
        for b in file[cwa::HEADER_BYTES..].chunks_exact_mut(cwa::BLOCK_BYTES) {
            b[510] = 0;
            b[511] = 0;
            let s = b.chunks_exact(2).fold(0u16, |s, w| {
                s.wrapping_add(u16::from_le_bytes([w[0], w[1]]))
            });
            b[510..512].copy_from_slice(&0u16.wrapping_sub(s).to_le_bytes());
        }
    }
    file
}
