//! The BVH must return exactly what a brute-force loop over all primitives returns.

use camsim_render::bvh::Bvh;
use camsim_render::geometry::{Prim, Ray, RayInv};
use camsim_render::math::V3;
use rand::Rng;

fn random_soup(n_tris: usize, n_spheres: usize, seed: u64) -> Vec<Prim> {
    let mut rng = camsim_core::rng::seeded(seed);
    let v = |rng: &mut camsim_core::rng::Rng, s: f32| {
        V3::new(
            rng.gen_range(-s..s),
            rng.gen_range(-s..s),
            rng.gen_range(-s..s),
        )
    };
    let mut prims = Vec::new();
    for i in 0..n_tris {
        // Mostly small triangles, some long slivers and some large ones (stress the SAH).
        let size = match i % 10 {
            0 => 3.0,
            1 => 0.01,
            _ => 0.3,
        };
        let p0 = v(&mut rng, 5.0);
        prims.push(Prim::Tri {
            p0,
            e1: v(&mut rng, size),
            e2: v(&mut rng, size),
        });
    }
    for _ in 0..n_spheres {
        prims.push(Prim::Sphere {
            center: v(&mut rng, 5.0),
            radius: rng.gen_range(0.05..0.6),
        });
    }
    prims
}

fn brute(prims: &[Prim], r: &RayInv) -> Option<(f32, usize)> {
    let mut best: Option<(f32, usize)> = None;
    for (i, p) in prims.iter().enumerate() {
        let t_max = best.map(|b| b.0).unwrap_or(f32::INFINITY);
        if let Some((t, _, _)) = p.intersect(r, t_max) {
            best = Some((t, i));
        }
    }
    best
}

#[test]
fn bvh_hits_equal_brute_force_on_a_random_soup() {
    for (seed, n_tris, n_spheres) in [
        (1u64, 3000usize, 40usize),
        (2, 1, 0),
        (3, 0, 5),
        (4, 200, 0),
    ] {
        let prims = random_soup(n_tris, n_spheres, seed);
        let bvh = Bvh::build(prims.clone());
        assert!(bvh.depth() < 100);
        let mut rng = camsim_core::rng::seeded(seed + 100);
        let mut hits = 0;
        for k in 0..20_000 {
            // Rays from outside and from inside the soup, in random directions.
            let s = if k % 2 == 0 { 8.0 } else { 4.0 };
            let o = V3::new(
                rng.gen_range(-s..s),
                rng.gen_range(-s..s),
                rng.gen_range(-s..s),
            );
            let d = V3::new(
                rng.gen_range(-1.0..1.0),
                rng.gen_range(-1.0..1.0),
                rng.gen_range(-1.0..1.0),
            )
            .normalize();
            let r = RayInv::new(&Ray { o, d });
            let want = brute(&prims, &r);
            let got = bvh.intersect(&r, f32::INFINITY);
            match (want, got) {
                (None, None) => {}
                (Some((t, i)), Some(h)) => {
                    hits += 1;
                    assert_eq!(h.t, t, "seed {seed} ray {k}: distance differs");
                    let id = bvh.ids[h.slot as usize] as usize;
                    // Equal distance on two primitives (shared point) may pick either.
                    assert!(
                        id == i || prims[id].intersect(&r, f32::INFINITY).map(|x| x.0) == Some(t),
                        "seed {seed} ray {k}: primitive {id} vs {i}"
                    );
                }
                (w, g) => panic!(
                    "seed {seed} ray {k}: brute force {w:?}, BVH {:?}",
                    g.map(|h| h.t)
                ),
            }
            assert_eq!(
                bvh.occluded(&r, f32::INFINITY),
                want.is_some(),
                "seed {seed} ray {k}: any-hit differs"
            );
            if let Some((t, _)) = want {
                // A shadow ray that stops just short of the first hit is not occluded.
                assert!(
                    !bvh.occluded(&r, t * 0.999),
                    "seed {seed} ray {k}: occluded before the first hit"
                );
            }
        }
        if n_tris > 100 {
            assert!(hits > 2000, "too few hits ({hits}) for a meaningful test");
        }
    }
}

#[test]
fn empty_bvh_hits_nothing() {
    let bvh = Bvh::build(vec![]);
    let r = RayInv::new(&Ray {
        o: V3::splat(0.0),
        d: V3::new(0.0, 0.0, 1.0),
    });
    assert!(bvh.intersect(&r, f32::INFINITY).is_none());
    assert!(!bvh.occluded(&r, f32::INFINITY));
}

#[test]
fn degenerate_inputs_build_bounded_trees() {
    // Many primitives with identical centroids (a fan around one point) and a flat grid.
    let mut prims = vec![];
    for i in 0..5000 {
        let a = i as f32 * 0.001;
        prims.push(Prim::Tri {
            p0: V3::new(-a.cos(), -a.sin(), 0.0),
            e1: V3::new(2.0 * a.cos(), 2.0 * a.sin(), 0.0),
            e2: V3::new(0.0, 0.0, 0.0),
        });
    }
    let bvh = Bvh::build(prims);
    assert!(bvh.depth() < 100, "depth {}", bvh.depth());
    assert!(bvh.node_count() < 5000);
}
