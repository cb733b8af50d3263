//! Keyed random streams: the stream for (seed, stage, frame, index) comes from hashing those
//! numbers, so results do not depend on the number of threads or on scheduling.

use rand::SeedableRng;
pub use rand_pcg::Pcg64Mcg as Rng;

/// Stage keys, so two stages never share a stream.
pub mod stage {
    pub const SENSOR_TEMPORAL: u64 = 1;
    pub const SENSOR_FIXED_PATTERN: u64 = 2;
    pub const RENDER: u64 = 3;
    pub const SCENE: u64 = 4;
    pub const ANALYSIS: u64 = 5;
    /// The states of random-telegraph-noise pixels, per frame.
    pub const SENSOR_RTN: u64 = 6;
}

/// SplitMix64 finaliser (Steele, Lea & Flood 2014): a bijective 64-bit mixer.
#[inline]
pub fn mix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// 128-bit key for (seed, stage, frame, index).
#[inline]
pub fn key(seed: u64, stage: u64, frame: u64, index: u64) -> u128 {
    let a = mix64(seed ^ mix64(stage.wrapping_add(0x1234_5678)));
    let b = mix64(a ^ mix64(frame.wrapping_add(0x0F0F_0F0F)));
    let c = mix64(b ^ mix64(index));
    ((mix64(c ^ a) as u128) << 64) | (c as u128 | 1)
}

/// A generator for (seed, stage, frame, index): one per tile, row or pixel, never per thread.
#[inline]
pub fn keyed(seed: u64, stage: u64, frame: u64, index: u64) -> Rng {
    Rng::new(key(seed, stage, frame, index))
}

/// A generator from a plain 64-bit seed (for one-off, single-threaded work).
pub fn seeded(seed: u64) -> Rng {
    Rng::seed_from_u64(seed)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::Rng as _;

    #[test]
    fn streams_differ_by_every_key_part_and_repeat_for_the_same_key() {
        let draw = |s, st, f, i| keyed(s, st, f, i).gen::<u64>();
        let base = draw(1, 2, 3, 4);
        assert_eq!(base, draw(1, 2, 3, 4));
        assert_ne!(base, draw(2, 2, 3, 4));
        assert_ne!(base, draw(1, 3, 3, 4));
        assert_ne!(base, draw(1, 2, 4, 4));
        assert_ne!(base, draw(1, 2, 3, 5));
    }
}
