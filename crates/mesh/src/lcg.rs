//! The deterministic generator shared by the tests of every spherify crate
//! (and their benches and examples): Knuth's MMIX linear congruential
//! generator. It is public, not `cfg(test)`, so that the tests of the other
//! crates can use it.
//!
//! Tests want the same "random" meshes and matrices on every platform and
//! every run, with no dependency; statistical quality hardly matters. Do not
//! use it for anything a user sees: it is predictable by design.

/// Knuth's MMIX LCG, `x <- x * 6364136223846793005 + 1442695040888963407`
/// (mod 2^64). The low bits of an LCG have short periods (the lowest one
/// alternates), so [`Lcg::next_f64`] and [`Lcg::below`] draw from the top 53.
#[derive(Debug, Clone)]
pub struct Lcg(u64);

impl Lcg {
    /// A generator whose first step starts from `seed` (any value, 0 too).
    pub const fn new(seed: u64) -> Lcg {
        Lcg(seed)
    }

    /// Advances the state and returns it whole; see the type's note on low bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        self.0
    }

    /// Uniform in [0, 1): the top 53 bits of the next state over 2^53.
    pub fn next_f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Uniform in [lo, hi): `lo + (hi - lo) * next_f64()`.
    pub fn between(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.next_f64()
    }

    /// An index in `0..n`: the top 53 bits of the next state modulo `n`
    /// (biased by at most n / 2^53, nothing a test notices); 0 when `n` is 0.
    pub fn below(&mut self, n: usize) -> usize {
        ((self.next_u64() >> 11) % (n as u64).max(1)) as usize
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Tests in several crates depend on these exact sequences.
    #[test]
    fn the_sequence_never_changes() {
        let mut rng = Lcg::new(12345);
        let states: Vec<u64> = (0..3).map(|_| rng.next_u64()).collect();
        assert_eq!(states, [0x1c0d_57f1_0c89_4254, 0x43f0_4a6e_ce53_d613, 0xe2b8_4105_1066_8fa6]);
        let mut rng = Lcg::new(0);
        assert_eq!(rng.clone().next_u64(), 0x1405_7b7e_f767_814f);
        assert_eq!(
            rng.clone().next_f64(),
            (0x1405_7b7e_f767_814f_u64 >> 11) as f64 / 2f64.powi(53)
        );
        assert_eq!(rng.clone().below(1000), (0x1405_7b7e_f767_814f_u64 >> 11) as usize % 1000);
        assert_eq!(rng.between(-1.0, 1.0), 2.0 * 0.078_208_654_878_293_87 - 1.0);
    }

    #[test]
    fn draws_stay_in_range() {
        let mut rng = Lcg::new(7);
        for _ in 0..10_000 {
            let x = rng.next_f64();
            assert!((0.0..1.0).contains(&x));
            assert!((-3.0..2.0).contains(&rng.between(-3.0, 2.0)));
            assert!(rng.below(17) < 17);
        }
        assert_eq!(rng.below(0), 0);
    }
}
