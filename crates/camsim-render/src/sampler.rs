//! Where the path tracer's uniform numbers come from: a low-discrepancy, Owen-scrambled Sobol
//! sampler (the default) or independent pseudo-random numbers.
//!
//! Both are keyed, never stateful across pixels, so a render is bit-identical for any thread
//! count:
//! - [`SamplerKind::Independent`] (pbrt-v4 `IndependentSampler`): uniform numbers drawn in call
//!   order from the keyed PCG stream of the tile and pass (`camsim_core::rng::keyed(seed,
//!   stage::RENDER, pass, tile)`); the dimension index is ignored.
//! - [`SamplerKind::Sobol`] (pbrt-v4 `PaddedSobolSampler`, 4th ed. §8.7.3): each 1D or 2D request
//!   takes the first one or two dimensions of an Owen-scrambled Sobol sequence (Burley 2020,
//!   "Practical Hash-based Owen Scrambling", JCGT 9(4), via the `sobol_burley` crate) whose
//!   scramble and index shuffle are seeded by a hash of (seed, pixel, dimension). The first two
//!   Sobol dimensions form a (0,2)-sequence, which Owen scrambling and Burley's index shuffle
//!   keep, so every 2D request (film, light position, BSDF direction) is stratified in every
//!   power-of-two prefix of a pixel's samples; the different hashes decorrelate the dimensions
//!   ("padding", Kollig & Keller 2002). There is no fixed number of dimensions: padding by hash
//!   serves any path depth. `sobol_burley` shuffles at most 2^16 samples per sequence, so sample
//!   index `i` uses sequence `i >> 16` (mixed into the hash) at index `i & 0xffff`: unbiased for
//!   any sample count, stratified within each block of 2^16.
//!
//! Dimensions are allocated per bounce the same way on every path ([`dim`]), whether or not a
//! request is made (delta BSDFs skip light sampling; Russian roulette may not run): the same
//! dimension always serves the same decision. For speed a bounce's seven numbers come from two
//! 4-wide Sobol evaluations (`source`), and the Sobol product itself is two table lookups
//! (`SOBOL_BYTES`, bit-identical to `sobol_burley::sample_4d`): per 4-wide evaluation the
//! crate's loop over the shuffled index's set bits was the largest part of the sampler's cost
//! (measured on the Cornell box, one thread: 2.09 s with the loop, 1.76 s with the tables,
//! 1.36 s with the independent sampler; the rest is the hashing and bit reversal of the Owen
//! scramble, emulated with SSE2 where SSE4.1 / SSSE3 are not enabled at compile time).

use camsim_core::rng::mix64;
use rand::Rng as _;

pub use camsim_scene3d::scene::SamplerKind;

/// The dimension layout of one path sample. A 2D request at dimension `d` uses `d` and `d + 1`.
pub mod dim {
    /// Position in the pixel (2D).
    pub const FILM: u32 = 0;
    /// Point on the lens (2D; reserved: camsim's camera is a pinhole).
    pub const LENS: u32 = 2;
    /// Hero wavelength (1D).
    pub const WAVELENGTH: u32 = 4;
    /// First dimension of the first bounce.
    pub const FIRST_BOUNCE: u32 = 5;
    /// Dimensions per bounce.
    pub const PER_BOUNCE: u32 = 7;
    /// Offsets within a bounce: which light (1D).
    pub const LIGHT_CHOICE: u32 = 0;
    /// Point on the light (2D).
    pub const LIGHT_POSITION: u32 = 1;
    /// Which BSDF lobe (1D).
    pub const BSDF_LOBE: u32 = 3;
    /// BSDF direction (2D).
    pub const BSDF_DIRECTION: u32 = 4;
    /// Russian roulette (1D).
    pub const RUSSIAN_ROULETTE: u32 = 6;
    /// The path's time in the shutter window (1D; drawn only when the scene moves, so static
    /// renders are unchanged). Its own sequence, far from the bounce dimensions.
    pub const TIME: u32 = 0x7FFF_FFF0;

    /// First dimension of bounce `depth` (1 for the first scattering vertex).
    #[inline(always)]
    pub fn bounce(depth: u32) -> u32 {
        // Wrapping: only a hash input, and depths past 6e8 bounces never occur.
        FIRST_BOUNCE.wrapping_add(PER_BOUNCE.wrapping_mul(depth.saturating_sub(1)))
    }
}

/// A source of uniform numbers in [0, 1) for one path sample, addressed by dimension.
pub(crate) trait PathSampler {
    /// Start sample `index` of the current pixel.
    fn start_sample(&mut self, index: u64);
    /// One number for dimension `d`.
    fn get_1d(&mut self, d: u32) -> f32;
    /// Two numbers for dimensions `d`, `d + 1`.
    fn get_2d(&mut self, d: u32) -> [f32; 2];
}

/// Independent numbers from a keyed PCG stream, in call order.
pub(crate) struct IndependentSampler<'a> {
    pub rng: &'a mut camsim_core::rng::Rng,
}

impl PathSampler for IndependentSampler<'_> {
    #[inline(always)]
    fn start_sample(&mut self, _index: u64) {}
    #[inline(always)]
    fn get_1d(&mut self, _d: u32) -> f32 {
        self.rng.gen()
    }
    #[inline(always)]
    fn get_2d(&mut self, _d: u32) -> [f32; 2] {
        [self.rng.gen(), self.rng.gen()]
    }
}

/// Samples per `sobol_burley` sequence (its index shuffle covers 16 bits).
const SOBOL_BLOCK: u64 = 1 << 16;

/// The unscrambled Sobol points of dimensions 0-3 (bit-reversed, as `sobol_burley` keeps them)
/// for each value of the high and the low byte of a bit-reversed 16-bit index. A Sobol point is
/// the XOR of its generator matrix's columns selected by the index bits (a product over GF(2),
/// Joe & Kuo 2008), so the point of any index is `HI[byte 3] ^ LO[byte 2]`: two loads instead of
/// `sobol_burley::parts::sobol_int4_rev`'s loop over the set bits (about 8 dependent steps for
/// the shuffled, random-looking index), which profiling showed as the Sobol sampler's main cost.
static SOBOL_BYTES: std::sync::LazyLock<[[[u32; 4]; 256]; 2]> = std::sync::LazyLock::new(|| {
    let mut t = [[[0u32; 4]; 256]; 2];
    for b in 0..256u32 {
        t[0][b as usize] = sobol_burley::parts::sobol_int4_rev(b << 24, 0).into();
        t[1][b as usize] = sobol_burley::parts::sobol_int4_rev(b << 16, 0).into();
    }
    t
});

/// `sobol_burley::sample_4d(index, 0, seed)`, bit for bit, from the crate's own parts (index
/// shuffle, Owen scramble and hashes; Burley 2020) with the Sobol product taken from
/// [`SOBOL_BYTES`].
#[inline(always)]
fn sobol_4d(index: u32, seed: u32) -> [f32; 4] {
    use sobol_burley::parts::{hash, hash_int4, owen_scramble_int4_rev, owen_scramble_rev, Int4};
    let rev = owen_scramble_rev(index.reverse_bits(), hash(seed ^ 0x79c6_8e4a));
    let t = &*SOBOL_BYTES;
    let (hi, lo) = (
        t[0][(rev >> 24) as usize],
        t[1][((rev >> 16) & 0xff) as usize],
    );
    let sobol: Int4 = [hi[0] ^ lo[0], hi[1] ^ lo[1], hi[2] ^ lo[2], hi[3] ^ lo[3]].into();
    // The crate's per-lane scramble of dimension set 0.
    let scramble: Int4 = {
        let s = seed.wrapping_mul(0x9c8f_2d3b);
        [
            s ^ 0x912f_69ba,
            s ^ 0x174f_18ab,
            s ^ 0x691e_72ca,
            s ^ 0xb40c_c1b8,
        ]
        .into()
    };
    owen_scramble_int4_rev(sobol, hash_int4(scramble))
        .reverse_bits()
        .to_f32_norm()
}

/// The padded, Owen-scrambled Sobol sampler of one pixel ([module docs](self)).
#[derive(Debug, Clone, Copy)]
pub struct SobolSampler {
    pixel_key: u64,
    /// Hash key of the current block of 2^16 samples.
    block_key: u64,
    /// Index within the block.
    index: u32,
    /// Per group (light sampling, BSDF sampling): the seed dimension whose four numbers
    /// `cache` holds for the current sample, or `u32::MAX`.
    cached: [u32; 2],
    cache: [[f32; 4]; 2],
}

/// Where dimension `d` comes from: (the dimension whose hash seeds the Sobol sequence, the
/// Sobol dimension, i.e. the lane of `sobol_burley::sample_4d`; a 2D request takes that lane
/// and the next). Within a bounce, one 4-wide evaluation serves light sampling (lanes 0-1 the
/// light position, 2 the light choice, 3 the BSDF lobe) and one BSDF sampling (lanes 0-1 the
/// direction, 2 Russian roulette): Sobol dimensions 0-1 are a (0,2)-sequence and each
/// dimension alone a (0,1)-sequence, so every request stays stratified. Camera dimensions use
/// lane 0 (and 1) of their own sequence.
#[inline(always)]
fn source(d: u32) -> (u32, usize) {
    if d >= dim::FIRST_BOUNCE && d != dim::TIME {
        let off = (d - dim::FIRST_BOUNCE) % dim::PER_BOUNCE;
        let d0 = d - off;
        return match off {
            dim::LIGHT_CHOICE => (d0 + dim::LIGHT_POSITION, 2),
            dim::BSDF_LOBE => (d0 + dim::LIGHT_POSITION, 3),
            dim::RUSSIAN_ROULETTE => (d0 + dim::BSDF_DIRECTION, 2),
            _ => (d, 0),
        };
    }
    (d, 0)
}

/// Which cache slot a bounce dimension's sequence uses (0 light sampling, 1 BSDF sampling).
#[inline(always)]
fn slot(seed_dim: u32) -> usize {
    let off = seed_dim.wrapping_sub(dim::FIRST_BOUNCE) % dim::PER_BOUNCE;
    usize::from(off >= dim::BSDF_LOBE)
}

impl SobolSampler {
    /// The sampler of pixel (`x`, `y`) (raster coordinates) for render seed `seed`, at sample 0.
    pub fn new(seed: u64, x: u32, y: u32) -> SobolSampler {
        // SplitMix64 chain over (seed, a tag for this sampler, pixel): distinct pixels and seeds
        // get unrelated scrambles.
        const TAG: u64 = 0x536F_626F_6C53_6D70; // "SobolSmp"
        let pixel_key = mix64(mix64(seed ^ TAG) ^ (((x as u64) << 32) | y as u64));
        let mut s = SobolSampler {
            pixel_key,
            block_key: 0,
            index: 0,
            cached: [u32::MAX; 2],
            cache: [[0.0; 4]; 2],
        };
        s.set_sample(0);
        s
    }

    /// Move to sample `index` of this pixel.
    #[inline]
    pub fn set_sample(&mut self, index: u64) {
        self.block_key = mix64(self.pixel_key ^ mix64(index / SOBOL_BLOCK));
        self.index = (index % SOBOL_BLOCK) as u32;
        self.cached = [u32::MAX; 2];
    }

    /// The 32-bit sequence seed of dimension `d` in the current block.
    #[inline(always)]
    fn dim_seed(&self, d: u32) -> u32 {
        (mix64(self.block_key ^ (d as u64).wrapping_mul(0xD1B5_4A32_D192_ED03)) >> 32) as u32
    }

    /// One number for dimension `d` of the current sample.
    #[inline]
    pub fn sample_1d(&self, d: u32) -> f32 {
        let (seed_dim, lane) = source(d);
        // Lane 0 of `sample_4d` equals `sample(.., 0, ..)` (the crate tests this).
        sobol_4d(self.index, self.dim_seed(seed_dim))[lane]
    }

    /// Two numbers for dimensions `d`, `d + 1` of the current sample: two consecutive Sobol
    /// dimensions (0 and 1) of one scrambled sequence, so they are jointly stratified.
    #[inline]
    pub fn sample_2d(&self, d: u32) -> [f32; 2] {
        let (seed_dim, lane) = source(d);
        let v = sobol_4d(self.index, self.dim_seed(seed_dim));
        [v[lane], v[lane + 1]]
    }

    /// The four numbers of bounce sequence `seed_dim`, computed once per sample.
    #[inline(always)]
    fn cached4(&mut self, seed_dim: u32) -> &[f32; 4] {
        let k = slot(seed_dim);
        if self.cached[k] != seed_dim {
            self.cache[k] = sobol_4d(self.index, self.dim_seed(seed_dim));
            self.cached[k] = seed_dim;
        }
        &self.cache[k]
    }
}

impl PathSampler for SobolSampler {
    #[inline(always)]
    fn start_sample(&mut self, index: u64) {
        self.set_sample(index);
    }
    #[inline(always)]
    fn get_1d(&mut self, d: u32) -> f32 {
        if d < dim::FIRST_BOUNCE || d == dim::TIME {
            return self.sample_1d(d);
        }
        let (seed_dim, lane) = source(d);
        self.cached4(seed_dim)[lane]
    }
    #[inline(always)]
    fn get_2d(&mut self, d: u32) -> [f32; 2] {
        if d < dim::FIRST_BOUNCE {
            return self.sample_2d(d);
        }
        let (seed_dim, lane) = source(d);
        let v = self.cached4(seed_dim);
        [v[lane], v[lane + 1]]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn byte_table_sobol_equals_sobol_burley_bit_for_bit() {
        let mut seed = 0x1234_5678u32;
        for index in (0..1u32 << 16).step_by(7).chain([0, 1, 0xffff]) {
            seed = (mix64(seed as u64 ^ index as u64) >> 32) as u32;
            let fast = sobol_4d(index, seed);
            let want = sobol_burley::sample_4d(index, 0, seed);
            assert_eq!(
                fast.map(f32::to_bits),
                want.map(f32::to_bits),
                "index {index} seed {seed}"
            );
            assert_eq!(
                fast[0].to_bits(),
                sobol_burley::sample(index, 0, seed).to_bits()
            );
        }
    }

    #[test]
    fn names_round_trip() {
        for k in [SamplerKind::Independent, SamplerKind::Sobol] {
            assert_eq!(SamplerKind::from_name(k.name()), Some(k));
        }
        assert_eq!(SamplerKind::from_name("zsobol"), Some(SamplerKind::Sobol));
        assert_eq!(SamplerKind::from_name("halton"), None);
    }

    #[test]
    fn cached_bounce_numbers_equal_the_direct_ones() {
        let mut s = SobolSampler::new(4, 10, 20);
        for i in [0u64, 1, 7, 300, (1 << 16) + 5] {
            s.start_sample(i);
            // Request order as on a path, RR only on some bounces.
            for depth in 1..6u32 {
                let d0 = dim::bounce(depth);
                for d in [
                    d0 + dim::LIGHT_CHOICE,
                    d0 + dim::BSDF_LOBE,
                    d0 + dim::RUSSIAN_ROULETTE,
                ] {
                    let direct = s.sample_1d(d);
                    assert_eq!(
                        s.get_1d(d).to_bits(),
                        direct.to_bits(),
                        "sample {i} dimension {d}"
                    );
                }
                for d in [d0 + dim::LIGHT_POSITION, d0 + dim::BSDF_DIRECTION] {
                    assert_eq!(s.get_2d(d), s.sample_2d(d), "sample {i} dimension {d}");
                }
            }
            assert_eq!(s.get_1d(dim::WAVELENGTH), s.sample_1d(dim::WAVELENGTH));
        }
        // The three numbers of a bounce differ (different Sobol dimensions).
        s.set_sample(3);
        let d0 = dim::bounce(2);
        let v = [
            s.sample_1d(d0),
            s.sample_1d(d0 + dim::BSDF_LOBE),
            s.sample_1d(d0 + dim::RUSSIAN_ROULETTE),
        ];
        assert!(v[0] != v[1] && v[1] != v[2] && v[0] != v[2], "{v:?}");
    }

    #[test]
    fn bounce_dimensions_do_not_overlap_the_camera_or_each_other() {
        assert_eq!(dim::bounce(1), dim::FIRST_BOUNCE);
        assert_eq!(dim::bounce(2) - dim::bounce(1), dim::PER_BOUNCE);
    }

    // The layout's own constraints, checked at compile time.
    const _: () = assert!(dim::WAVELENGTH < dim::FIRST_BOUNCE && dim::LENS + 2 <= dim::WAVELENGTH);
    const _: () = assert!(
        dim::RUSSIAN_ROULETTE < dim::PER_BOUNCE && dim::BSDF_DIRECTION + 2 <= dim::RUSSIAN_ROULETTE
    );
}
