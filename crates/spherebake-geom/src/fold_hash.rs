//! A fast keyed hasher for maps that are only looked up, never iterated (so the random key
//! changes no output): the OBJ parser's corner map (`spherebake-io`'s `obj_parse`) and the
//! position weld ([`crate::mesh`]). Each integer written is mixed in by a 64 × 64 → 128-bit
//! multiply folded to 64 bits, from a per-map random key ([`FoldKey`]), so an input cannot be
//! crafted to make its keys collide; std's SipHash costs several times more per key (the
//! bunny's weld spent most of its 13 M instructions a call hashing).

use std::hash::Hasher;

/// The hasher [`FoldKey`] makes: each integer written is mixed in by a folded multiply (a
/// `u32` as its `u64`, the value `write` gives its four little-endian bytes).
#[derive(Clone, Copy, Debug)]
pub struct FoldHasher(u64);

/// The [`std::hash::BuildHasher`] of [`FoldHasher`]: its start value drawn from std's
/// `RandomState` (randomly keyed per process) when the map is made.
#[derive(Clone, Copy, Debug)]
pub struct FoldKey(u64);

impl Default for FoldKey {
    fn default() -> Self {
        use std::hash::BuildHasher;
        FoldKey(std::collections::hash_map::RandomState::new().hash_one(0x243F_6A88_85A3_08D3u64))
    }
}

impl std::hash::BuildHasher for FoldKey {
    type Hasher = FoldHasher;
    fn build_hasher(&self) -> FoldHasher {
        FoldHasher(self.0)
    }
}

impl FoldHasher {
    fn mix(&mut self, x: u64) {
        let m = u128::from(self.0 ^ x) * 0x9E37_79B9_7F4A_7C15u128;
        self.0 = (m as u64) ^ ((m >> 64) as u64);
    }
}

impl Hasher for FoldHasher {
    fn write(&mut self, bytes: &[u8]) {
        for chunk in bytes.chunks(8) {
            let mut b = [0u8; 8];
            b[..chunk.len()].copy_from_slice(chunk);
            self.mix(u64::from_le_bytes(b));
        }
    }

    fn write_u32(&mut self, x: u32) {
        self.mix(u64::from(x));
    }

    fn write_usize(&mut self, x: usize) {
        self.mix(x as u64);
    }

    fn write_u64(&mut self, x: u64) {
        self.mix(x);
    }

    fn finish(&self) -> u64 {
        self.0
    }
}
