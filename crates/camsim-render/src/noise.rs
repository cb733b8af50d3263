//! Solid noise for pbrt-v4's procedural textures (`fbm`, `wrinkled`, `windy`, `marble`, `dots`).
//!
//! Perlin's gradient noise as revised in "Improving Noise" (K. Perlin, SIGGRAPH 2002): a
//! pseudo-random gradient at each integer lattice point, picked by hashing the point through a
//! fixed permutation of 0..255 (the table of Perlin's reference implementation, which pbrt-v4 uses
//! as `NoisePerm`, so patterns match pbrt-v4's), the quintic fade 6t^5 - 15t^4 + 10t^3 and
//! trilinear interpolation of the eight corner ramps. The noise is 0 at every lattice point and
//! lies in [-1, 1].
//!
//! Sums of octaves (pbrt-v4 4th ed. sec. 10.6.3): fractional Brownian motion
//! `FBm(p) = sum_i omega^i N(1.99^i p)` and turbulence `sum_i omega^i |N(1.99^i p)|`. pbrt-v4 limits
//! the octaves to the pixel footprint from ray differentials; camsim traces none, so every
//! octave is summed (point sampling: the pixel's samples do the averaging), which is pbrt-v4's
//! formula with a zero footprint (turbulence then adds its `0.2 omega^octaves` remainder term).

/// Perlin's permutation of 0..=255 (Perlin 2002 reference implementation).
const PERM_256: [u8; 256] = [
    151, 160, 137, 91, 90, 15, 131, 13, 201, 95, 96, 53, 194, 233, 7, 225, 140, 36, 103, 30, 69,
    142, 8, 99, 37, 240, 21, 10, 23, 190, 6, 148, 247, 120, 234, 75, 0, 26, 197, 62, 94, 252, 219,
    203, 117, 35, 11, 32, 57, 177, 33, 88, 237, 149, 56, 87, 174, 20, 125, 136, 171, 168, 68, 175,
    74, 165, 71, 134, 139, 48, 27, 166, 77, 146, 158, 231, 83, 111, 229, 122, 60, 211, 133, 230,
    220, 105, 92, 41, 55, 46, 245, 40, 244, 102, 143, 54, 65, 25, 63, 161, 1, 216, 80, 73, 209, 76,
    132, 187, 208, 89, 18, 169, 200, 196, 135, 130, 116, 188, 159, 86, 164, 100, 109, 198, 173,
    186, 3, 64, 52, 217, 226, 250, 124, 123, 5, 202, 38, 147, 118, 126, 255, 82, 85, 212, 207, 206,
    59, 227, 47, 16, 58, 17, 182, 189, 28, 42, 223, 183, 170, 213, 119, 248, 152, 2, 44, 154, 163,
    70, 221, 153, 101, 155, 167, 43, 172, 9, 129, 22, 39, 253, 19, 98, 108, 110, 79, 113, 224, 232,
    178, 185, 112, 104, 218, 246, 97, 228, 251, 34, 242, 193, 238, 210, 144, 12, 191, 179, 162,
    241, 81, 51, 145, 235, 249, 14, 239, 107, 49, 192, 214, 31, 181, 199, 106, 157, 184, 84, 204,
    176, 115, 121, 50, 45, 127, 4, 150, 254, 138, 236, 205, 93, 222, 114, 67, 29, 24, 72, 243, 141,
    128, 195, 78, 66, 215, 61, 156, 180,
];

/// The permutation twice over, so that `perm(perm(x) + y) + z` needs no wrap (x, y, z <= 256).
#[inline(always)]
fn perm(i: usize) -> usize {
    PERM_256[i & 255] as usize
}

/// Perlin 2002's gradient ramp: one of 12 edge directions of a cube (16 cases, 4 repeated) dotted
/// with the offset (dx, dy, dz) from lattice point (x, y, z).
#[inline(always)]
fn grad(x: usize, y: usize, z: usize, dx: f64, dy: f64, dz: f64) -> f64 {
    let h = perm(perm(perm(x) + y) + z) & 15;
    let u = if h < 8 || h == 12 || h == 13 { dx } else { dy };
    let v = if h < 4 || h == 12 || h == 13 { dy } else { dz };
    (if h & 1 != 0 { -u } else { u }) + (if h & 2 != 0 { -v } else { v })
}

/// The quintic fade (Perlin 2002): zero first and second derivatives at 0 and 1.
#[inline(always)]
fn fade(t: f64) -> f64 {
    t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
}

#[inline(always)]
fn lerp(t: f64, a: f64, b: f64) -> f64 {
    (1.0 - t) * a + t * b
}

/// Gradient noise at `p` (Perlin 2002), in [-1, 1], 0 at integer points.
pub fn noise(p: [f64; 3]) -> f64 {
    let f = p.map(f64::floor);
    let [dx, dy, dz] = [p[0] - f[0], p[1] - f[1], p[2] - f[2]];
    // Lattice coordinates modulo 256 (two's complement wrap for negative cells, as pbrt's `& 255`).
    let [ix, iy, iz] = f.map(|v| (v as i64 & 255) as usize);
    let w000 = grad(ix, iy, iz, dx, dy, dz);
    let w100 = grad(ix + 1, iy, iz, dx - 1.0, dy, dz);
    let w010 = grad(ix, iy + 1, iz, dx, dy - 1.0, dz);
    let w110 = grad(ix + 1, iy + 1, iz, dx - 1.0, dy - 1.0, dz);
    let w001 = grad(ix, iy, iz + 1, dx, dy, dz - 1.0);
    let w101 = grad(ix + 1, iy, iz + 1, dx - 1.0, dy, dz - 1.0);
    let w011 = grad(ix, iy + 1, iz + 1, dx, dy - 1.0, dz - 1.0);
    let w111 = grad(ix + 1, iy + 1, iz + 1, dx - 1.0, dy - 1.0, dz - 1.0);
    let (wx, wy, wz) = (fade(dx), fade(dy), fade(dz));
    let y0 = lerp(wy, lerp(wx, w000, w100), lerp(wx, w010, w110));
    let y1 = lerp(wy, lerp(wx, w001, w101), lerp(wx, w011, w111));
    lerp(wz, y0, y1)
}

/// Frequency step between octaves (pbrt-v4: 1.99, not 2, so lattice points of successive
/// octaves do not line up).
const LACUNARITY: f64 = 1.99;

/// Fractional Brownian motion, `octaves` octaves with amplitude ratio `omega`.
pub fn fbm(p: [f64; 3], omega: f64, octaves: u32) -> f64 {
    let (mut sum, mut lambda, mut o) = (0.0, 1.0, 1.0);
    for _ in 0..octaves {
        sum += o * noise(p.map(|v| v * lambda));
        lambda *= LACUNARITY;
        o *= omega;
    }
    sum
}

/// Turbulence: octaves of |noise|, plus pbrt-v4's allowance of 0.2 (the mean of |noise|, about)
/// for the octave after the last.
pub fn turbulence(p: [f64; 3], omega: f64, octaves: u32) -> f64 {
    let (mut sum, mut lambda, mut o) = (0.0, 1.0, 1.0);
    for _ in 0..octaves {
        sum += o * noise(p.map(|v| v * lambda)).abs();
        lambda *= LACUNARITY;
        o *= omega;
    }
    sum + 0.2 * o
}

/// pbrt-v4 `WindyTexture`: |FBm(0.1 p, 0.5, 3)| (wind strength) times FBm(p, 0.5, 6) (waves).
pub fn windy(p: [f64; 3]) -> f64 {
    fbm(p.map(|v| 0.1 * v), 0.5, 3).abs() * fbm(p, 0.5, 6)
}

/// pbrt-v4 `MarbleTexture`'s colour at texture-space `p` (already multiplied by `scale`): the
/// stripe parameter t = 1/2 + sin(y + variation FBm(p)) / 2 runs through a cubic Bezier spline of
/// nine greys and a blue-grey (the colour table of pbrt's marble texture, RGB), times 1.5.
pub fn marble_rgb(p: [f64; 3], variation: f64, omega: f64, octaves: u32) -> [f64; 3] {
    const C: [[f64; 3]; 9] = [
        [0.58, 0.58, 0.6],
        [0.58, 0.58, 0.6],
        [0.58, 0.58, 0.6],
        [0.5, 0.5, 0.5],
        [0.6, 0.59, 0.58],
        [0.58, 0.58, 0.6],
        [0.58, 0.58, 0.6],
        [0.2, 0.2, 0.33],
        [0.58, 0.58, 0.6],
    ];
    let m = p[1] + variation * fbm(p, omega, octaves);
    let t = 0.5 + 0.5 * m.sin();
    let n_seg = C.len() - 3;
    let first = ((t * n_seg as f64).floor().max(0.0) as usize).min(n_seg - 1);
    let t = t * n_seg as f64 - first as f64;
    // Cubic Bezier through C[first..first + 4] by de Casteljau's algorithm.
    let mut c = [C[first], C[first + 1], C[first + 2], C[first + 3]];
    for k in (1..4).rev() {
        for i in 0..k {
            c[i] = std::array::from_fn(|j| lerp(t, c[i][j], c[i + 1][j]));
        }
    }
    c[0].map(|v| 1.5 * v)
}

/// pbrt-v4 `InsidePolkaDot`: whether `(s, t)` lies in the dot of its unit cell (cells centred on
/// integers); a cell has a dot where noise at its centre is positive, of radius 0.35, shifted by
/// up to 0.15 in s and t by noise.
pub fn inside_polka_dot(s: f64, t: f64) -> bool {
    let (sc, tc) = ((s + 0.5).floor(), (t + 0.5).floor());
    if noise([sc + 0.5, tc + 0.5, 0.5]) > 0.0 {
        let radius = 0.35;
        let max_shift = 0.5 - radius;
        let s_center = sc + max_shift * noise([sc + 1.5, tc + 2.8, 0.5]);
        let t_center = tc + max_shift * noise([sc + 4.5, tc + 9.8, 0.5]);
        let (ds, dt) = (s - s_center, t - t_center);
        return ds * ds + dt * dt < radius * radius;
    }
    false
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The table is a permutation of 0..=255 (each value once): a mistyped entry fails.
    #[test]
    fn the_table_is_a_permutation() {
        let mut seen = [false; 256];
        for v in PERM_256 {
            assert!(!seen[v as usize], "{v} twice");
            seen[v as usize] = true;
        }
    }

    /// Gradient noise vanishes at lattice points, stays within [-1, 1], is continuous, and its
    /// slope at a lattice point is the picked gradient (one of the 12 cube-edge directions:
    /// two components +-1, one 0), as Perlin's construction says.
    #[test]
    fn noise_is_zero_on_the_lattice_with_an_edge_gradient() {
        let mut lo: f64 = 0.0;
        let mut hi: f64 = 0.0;
        for i in -3..4 {
            for j in -3..4 {
                for k in -3..4 {
                    let p = [i as f64, j as f64, k as f64];
                    assert_eq!(noise(p), 0.0, "{p:?}");
                    let e = 1e-6;
                    let g: Vec<f64> = (0..3)
                        .map(|a| {
                            let mut q = p;
                            q[a] += e;
                            noise(q) / e
                        })
                        .collect();
                    let mut sorted: Vec<f64> = g.iter().map(|v| v.abs()).collect();
                    sorted.sort_by(f64::total_cmp);
                    assert!(
                        sorted[0] < 1e-5
                            && (sorted[1] - 1.0).abs() < 1e-5
                            && (sorted[2] - 1.0).abs() < 1e-5,
                        "{p:?}: {g:?}"
                    );
                }
            }
        }
        // Along a line: steps of 1.1e-3 change the noise by at most its slope (< 3) times that.
        let line = |x: f64| noise([x, 0.7 + 0.37 * x, 0.1 - 0.21 * x]);
        let mut prev = line(0.3);
        for n in 1..20000 {
            let x = 0.3 + n as f64 * 1e-3;
            let v = line(x);
            assert!((v - prev).abs() < 0.01, "jump at {x}");
            prev = v;
            lo = lo.min(v);
            hi = hi.max(v);
        }
        assert!(
            lo >= -1.0 && hi <= 1.0 && lo < -0.3 && hi > 0.3,
            "range [{lo}, {hi}]"
        );
    }

    /// Octave sums: one octave of FBm is the noise; FBm is linear in the octaves' amplitudes
    /// (omega 0 keeps the first only); turbulence with omega 0 is |noise| + 0 and its remainder
    /// term is 0.2 omega^octaves; |FBm| <= sum omega^i.
    #[test]
    fn octave_sums_follow_their_definitions() {
        for p in [[0.31, 1.7, -2.2], [5.5, -0.25, 0.75], [-7.1, 3.3, 9.9]] {
            assert_eq!(fbm(p, 0.5, 1), noise(p));
            assert_eq!(fbm(p, 0.0, 8), noise(p));
            assert!((turbulence(p, 0.0, 1) - noise(p).abs()).abs() < 1e-15);
            let two = noise(p) + 0.5 * noise(p.map(|v| v * 1.99));
            assert!((fbm(p, 0.5, 2) - two).abs() < 1e-15);
            let turb_two = noise(p).abs() + 0.5 * noise(p.map(|v| v * 1.99)).abs() + 0.2 * 0.25;
            assert!((turbulence(p, 0.5, 2) - turb_two).abs() < 1e-15);
            assert!(fbm(p, 0.5, 8).abs() <= 2.0);
        }
    }

    /// Polka dots: about half the cells hold a dot (noise at the cell centre > 0) of radius 0.35,
    /// so the covered fraction is near 0.5 pi 0.35^2 = 0.192 over many cells; a dot never leaves
    /// its cell (0.35 + 0.15 = 0.5).
    #[test]
    fn polka_dots_cover_the_expected_fraction() {
        let n = 400;
        let mut inside = 0usize;
        let cells = 40.0;
        for i in 0..n {
            for j in 0..n {
                let (s, t) = (
                    (i as f64 + 0.5) / n as f64 * cells,
                    (j as f64 + 0.5) / n as f64 * cells,
                );
                inside += inside_polka_dot(s, t) as usize;
            }
        }
        let frac = inside as f64 / (n * n) as f64;
        let mut dotted = 0;
        for i in 0..40 {
            for j in 0..40 {
                dotted += (noise([i as f64 + 0.5, j as f64 + 0.5, 0.5]) > 0.0) as usize;
            }
        }
        let want = dotted as f64 / 1600.0 * std::f64::consts::PI * 0.35 * 0.35;
        assert!(
            (frac / want - 1.0).abs() < 0.03,
            "covered {frac} vs {want} ({dotted} of 1600 cells dotted)"
        );
        assert!(
            (dotted as f64 / 1600.0 - 0.5).abs() < 0.15,
            "{dotted} dotted cells"
        );
    }

    /// Marble: the spline reproduces its control colours where the four are equal (t in the first
    /// segment's flat stretch gives exactly 1.5 x (0.58, 0.58, 0.6)), and stays within the hull.
    #[test]
    fn marble_colours_stay_in_the_spline_hull() {
        for k in 0..200 {
            let p = [k as f64 * 0.173, k as f64 * 0.071, -(k as f64) * 0.05];
            let c = marble_rgb(p, 0.2, 0.5, 8);
            for (j, v) in c.iter().enumerate() {
                let (lo, hi) = if j < 2 { (0.2, 0.6) } else { (0.33, 0.6) };
                assert!(*v >= 1.5 * lo - 1e-12 && *v <= 1.5 * hi + 1e-12, "{c:?}");
            }
        }
        // y with sin(y) = -1 (t = 0, variation 0): the first segment's start, C[0].
        let c = marble_rgb([0.0, -std::f64::consts::FRAC_PI_2, 0.0], 0.0, 0.5, 8);
        assert!(
            c.iter()
                .zip([0.87, 0.87, 0.9])
                .all(|(a, b)| (a - b).abs() < 1e-12),
            "{c:?}"
        );
    }
}
