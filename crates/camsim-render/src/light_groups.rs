//! Light groups (as ISETHDR renders day, dusk and night from one scene): the radiance split by
//! which group of lights each path's light came from, in the same pass as the total. A path's
//! estimate is a sum of terms, each the contribution of one light (emission hit by the path, a
//! light sample of next-event estimation, an infinite light seen by an escaping ray); each term
//! goes to its light's group, so the groups sum to the total (the same samples, only summed in
//! another order) and a weighted sum of the groups is an unbiased render of the scene with each
//! group's lights scaled by its weight.
//!
//! A light's group is its shape's `tags.light_group` (area lights) or
//! `SceneDescription::light_groups` (other lights); without one it is [`DEFAULT_GROUP`].

use crate::scene::SceneDescription;
use std::collections::BTreeSet;

/// The group of lights that name none.
pub const DEFAULT_GROUP: &str = "default";

/// Where a path's light contributions go.
pub(crate) trait PathRadiance<const N: usize> {
    /// Add the contribution `v` of compiled light `light`.
    fn add(&mut self, light: u32, v: [f32; N]);
}

/// One sum over all lights (the plain render: the same arithmetic as before groups existed).
impl<const N: usize> PathRadiance<N> for [f32; N] {
    #[inline(always)]
    fn add(&mut self, _light: u32, v: [f32; N]) {
        for i in 0..N {
            self[i] += v[i];
        }
    }
}

/// The total and one sum per group.
pub(crate) struct GroupRadiance<'a, const N: usize> {
    /// All lights (bit-identical to the plain sum: same terms, same order).
    pub total: [f32; N],
    /// Per group.
    pub groups: &'a mut [[f32; N]],
    /// Group of each compiled light.
    pub group_of: &'a [u16],
}

impl<const N: usize> PathRadiance<N> for GroupRadiance<'_, N> {
    #[inline(always)]
    fn add(&mut self, light: u32, v: [f32; N]) {
        for i in 0..N {
            self.total[i] += v[i];
        }
        // A medium's own emission belongs to no light (`NO_LIGHT`): the total only (the
        // renderer refuses light groups with emissive media, so it does not arise there).
        if let Some(&k) = self.group_of.get(light as usize) {
            let g = &mut self.groups[k as usize];
            for i in 0..N {
                g[i] += v[i];
            }
        }
    }
}

/// The light groups of a scene: their names (sorted) and each compiled light's group.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct GroupTable {
    pub names: Vec<String>,
    pub group_of: Vec<u16>,
}

/// The group names of `scene`'s lights, sorted (the default group included when some light has
/// none).
pub fn light_group_names(scene: &SceneDescription) -> Vec<String> {
    let mut names = BTreeSet::new();
    for s in scene.shapes.iter().filter(|s| s.area_light.is_some()) {
        names.insert(group_name(s.tags.light_group.as_deref()));
    }
    for i in 0..scene.lights.len() {
        names.insert(group_name(
            scene.light_groups.get(i).and_then(|g| g.as_deref()),
        ));
    }
    names.into_iter().map(str::to_string).collect()
}

fn group_name(g: Option<&str>) -> &str {
    g.unwrap_or(DEFAULT_GROUP)
}

impl GroupTable {
    /// The groups of a tracer's compiled lights (from `scene`); `light_source`: per compiled
    /// light, its shape's index or `shapes.len()` plus its scene light's (`Tracer::light_source`).
    pub(crate) fn new(scene: &SceneDescription, light_source: &[u32]) -> GroupTable {
        let names = light_group_names(scene);
        let index =
            |g: Option<&str>| names.iter().position(|n| n == group_name(g)).unwrap_or(0) as u16;
        let n_shapes = scene.shapes.len();
        let group_of = light_source
            .iter()
            .map(|&src| {
                let src = src as usize;
                if src < n_shapes {
                    index(scene.shapes[src].tags.light_group.as_deref())
                } else {
                    index(
                        scene
                            .light_groups
                            .get(src - n_shapes)
                            .and_then(|g| g.as_deref()),
                    )
                }
            })
            .collect();
        GroupTable { names, group_of }
    }
}
