//! PNG chunks for tests that build hostile or unusual PNGs by hand (a header claiming a huge
//! image, ancillary chunks before the pixels): length, type, data and the chunk's CRC-32,
//! computed here bit by bit (ISO 3309, the polynomial 0xEDB88320 reflected), apart from the
//! `crc32fast` the code under test may use.

/// One PNG chunk: 4-byte big-endian length, `kind`, `data`, CRC-32 of `kind` and `data`.
pub fn chunk(kind: &[u8; 4], data: &[u8]) -> Vec<u8> {
    let mut out = (data.len() as u32).to_be_bytes().to_vec();
    out.extend(kind);
    out.extend(data);
    let mut crc = 0xFFFF_FFFFu32;
    for &byte in kind.iter().chain(data) {
        crc ^= u32::from(byte);
        for _ in 0..8 {
            crc = if crc & 1 == 1 { (crc >> 1) ^ 0xEDB8_8320 } else { crc >> 1 };
        }
    }
    out.extend((!crc).to_be_bytes());
    out
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_iend_chunk_has_its_well_known_crc() {
        // Every PNG ends with these 12 bytes.
        assert_eq!(super::chunk(b"IEND", &[]), [0, 0, 0, 0, b'I', b'E', b'N', b'D', 0xAE, 0x42, 0x60, 0x82]);
    }
}
