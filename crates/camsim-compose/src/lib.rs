//! camsim stage 1 (3D): scene composition. Edits a [`camsim_scene3d::SceneDescription`] from
//! outside, after a reader (`camsim-pbrt`, `camsim-assets`) or a built-in made it and before the
//! renderer sees it: the datasets' "put 3 to 12 objects from my asset folder on a table, let them
//! settle, light them with a random sky, look at them from a random viewpoint".
//!
//! - [`manifest`]: asset libraries (a folder, a glob, a CSV/JSON manifest), checked up front.
//! - [`spawn`]: draw assets, scale and orient them, place them on a support, in a box or on a grid
//!   without interpenetration.
//! - [`physics`]: settle the placed objects with rapier3d (convex hulls or a convex
//!   decomposition, static supports), recording the resting poses.
//! - [`environment`]: equirectangular HDR maps and a spectral sky model as the scene's light.
//! - [`camera`]: camera samplers (a spherical shell around a target) and view validation.
//! - [`materials`]: material randomization (reflectance spectra drawn from a set).
//!
//! Every draw comes from the sample's seed through keyed streams ([`stream`]), so a sample's
//! scene is the same for any worker or thread count. The renderer is never imported here.

pub mod camera;
pub mod environment;
pub mod manifest;
pub mod materials;
pub mod physics;
pub mod spawn;

/// A composition step that cannot be done: the key or asset at fault and why.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{key}: {message}")]
pub struct ComposeError {
    /// The spec key (`compose.spawn.0.count`) or asset path the message is about.
    pub key: String,
    pub message: String,
}

impl ComposeError {
    pub fn new(key: impl Into<String>, message: impl Into<String>) -> Self {
        ComposeError {
            key: key.into(),
            message: message.into(),
        }
    }
}

pub type Result<T> = std::result::Result<T, ComposeError>;

/// The keyed random stream of one composition stage of one sample: the same (seed, stage, index)
/// gives the same stream whatever else ran before it (DESIGN.md: randomness is keyed).
pub fn stream(seed: u64, stage: u64, index: u64) -> rand_pcg::Pcg64 {
    use rand::SeedableRng;
    // SplitMix64 finaliser over the three keys (Steele et al. 2014), one 128-bit state.
    let mix = |mut z: u64| {
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    };
    let a = mix(seed ^ mix(stage.wrapping_add(0x9e37_79b9_7f4a_7c15)));
    let b = mix(a ^ mix(index.wrapping_add(0x6a09_e667_f3bc_c909)));
    let mut key = [0u8; 32];
    key[..8].copy_from_slice(&a.to_le_bytes());
    key[8..16].copy_from_slice(&b.to_le_bytes());
    key[16..24].copy_from_slice(&mix(a ^ b).to_le_bytes());
    key[24..].copy_from_slice(&mix(b.wrapping_add(a)).to_le_bytes());
    rand_pcg::Pcg64::from_seed(key)
}

/// The stages' stream numbers (the `stage` of [`stream`]).
pub mod stage {
    pub const SPAWN: u64 = 1;
    pub const PHYSICS: u64 = 2;
    pub const ENVIRONMENT: u64 = 3;
    pub const CAMERA: u64 = 4;
    pub const MATERIALS: u64 = 5;
}
