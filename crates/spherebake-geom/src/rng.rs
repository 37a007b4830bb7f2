//! SplitMix64 (Steele, Lea, Flood 2014), the one seeded generator of the baker: the fit's
//! seeded starts and splits, the minimal enclosing ball's shuffle, and (as the stateless
//! [`mix`]) the reference's per-receiver Monte Carlo jitter. Results depend only on the seed.

/// The golden-ratio increment of the SplitMix64 state.
const GAMMA: u64 = 0x9E37_79B9_7F4A_7C15;

/// The SplitMix64 output for the state `z`: the state advanced by one step, then the finaliser
/// (a bijection of u64 that mixes every input bit into every output bit). `mix(z)` equals the
/// first output of `SplitMix64::new(z)`, so `mix(seed ^ …)` is a stateless hash for
/// per-item streams.
#[inline]
#[must_use]
pub fn mix(z: u64) -> u64 {
    let mut z = z.wrapping_add(GAMMA);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Uniform in [0, 1) from the top 53 bits of `z` (every value a multiple of 2⁻⁵³).
#[inline]
#[must_use]
pub fn unit(z: u64) -> f64 {
    (z >> 11) as f64 / (1u64 << 53) as f64
}

/// The SplitMix64 generator: a 64-bit state advanced by a fixed odd increment, each output the
/// [`mix`] finaliser of the state. Period 2⁶⁴; not cryptographic.
#[derive(Clone, Debug)]
pub struct SplitMix64 {
    state: u64,
}

impl SplitMix64 {
    /// A generator whose first output is `mix(seed)`.
    #[must_use]
    pub fn new(seed: u64) -> Self {
        Self { state: seed }
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        let out = mix(self.state);
        self.state = self.state.wrapping_add(GAMMA);
        out
    }

    /// Uniform in [0, 1) ([`unit`] of the next output).
    pub fn next_f64(&mut self) -> f64 {
        unit(self.next_u64())
    }

    /// Uniform integer in [0, n) for n > 0 (0 for n ≤ 1), by rejection, so it is unbiased.
    pub fn below(&mut self, n: u64) -> u64 {
        if n <= 1 {
            return 0;
        }
        let zone = u64::MAX - u64::MAX % n;
        loop {
            let x = self.next_u64();
            if x < zone {
                return x % n;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The published first outputs for seed 0 (the reference implementation, `splitmix64.c`).
    #[test]
    fn first_outputs_of_seed_zero_match_the_reference() {
        let mut r = SplitMix64::new(0);
        assert_eq!(r.next_u64(), 0xe220_a839_7b1d_cdaf);
        assert_eq!(r.next_u64(), 0x6e78_9e6a_a1b9_65f4);
        assert_eq!(r.next_u64(), 0x06c4_5d18_8009_454f);
        assert_eq!(mix(0), 0xe220_a839_7b1d_cdaf);
        assert_eq!(mix(GAMMA), 0x6e78_9e6a_a1b9_65f4);
    }

    #[test]
    fn unit_and_below_stay_in_range() {
        assert_eq!(unit(0), 0.0);
        assert_eq!(unit(u64::MAX), 1.0 - 2f64.powi(-53));
        let mut r = SplitMix64::new(7);
        let mut seen = [0u32; 5];
        for _ in 0..5000 {
            let x = r.next_f64();
            assert!((0.0..1.0).contains(&x));
            seen[r.below(5) as usize] += 1;
        }
        // Each of 5 values ~1000 times (binomial sd ~28).
        assert!(seen.iter().all(|&c| (850..1150).contains(&c)), "{seen:?}");
        assert_eq!(r.below(0), 0);
        assert_eq!(r.below(1), 0);
    }
}
