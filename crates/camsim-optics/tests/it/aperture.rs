//! Aperture shapes of the wavefront pupil (issue 41 item 1): the default circle is unchanged bit
//! for bit; blade polygons against the closed-form Fourier transform of a polygon; diffraction
//! spikes; encircled energy and peak against the area; central obstruction and spider vanes.

use camsim_optics::{Optics, OpticsConfig, Wavefront};

/// FNV-1a over the bits of every value.
fn fnv(data: &[f64]) -> u64 {
    let mut h: u64 = 0xcbf29ce484222325;
    for v in data {
        for b in v.to_bits().to_le_bytes() {
            h ^= b as u64;
            h = h.wrapping_mul(0x100000001b3);
        }
    }
    h
}

/// The rustfft SIMD path the golden hashes were recorded with (x86_64 AVX + FMA): other paths
/// round differently in the last bit, so there only the shapes are compared.
fn golden_path() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        is_x86_feature_detected!("avx") && is_x86_feature_detected!("fma")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// Without `aperture` the PSF is the one camsim computed before apertures existed, bit for bit
/// (hashes recorded from the code before the change, commit 5488989), for a diffraction-limited
/// lens and the pixel4a preset (defocus), kernel and full grid.
#[test]
fn default_aperture_psf_is_unchanged_bit_for_bit() {
    let dl = Wavefront::diffraction_limited(4.38e-3, 2.8).unwrap();
    let p4 = Optics::preset("pixel4a").unwrap();
    let p4 = p4.wavefront();
    let a = dl.psf(550.0, 1.0e-6, 15).unwrap();
    let b = p4.psf(550.0, 1.4e-6, 21).unwrap();
    let c = dl.psf_full(450.0, 450e-9 * 2.8 / 4.0).unwrap();
    let got = [fnv(&a.data), fnv(&b.data), fnv(&c.data)];
    eprintln!("default PSF hashes: {got:#x?}");
    for p in [&a, &b, &c] {
        assert!((p.data.iter().sum::<f64>() - 1.0).abs() < 1e-12);
    }
    if golden_path() {
        assert_eq!(got, GOLDEN);
    }
    let _ = OpticsConfig::preset("pixel4a").unwrap();
}

const GOLDEN: [u64; 3] = [0xba8d5f81e1941488, 0xbc713f02bda45469, 0x482737cf232a9bfa];

use camsim_optics::aperture::TransmissionMask;
use camsim_optics::Aperture;
use std::f64::consts::PI;

/// Test lens: f = 4 mm at f/2 (D = 2 mm), 550 nm, PSF sampled at lambda N / 4 with 128 pupil
/// samples across D (a 512 x 512 FFT): one PSF sample is 1/8 of a cycle per pupil radius.
const F_M: f64 = 4e-3;
const FNUM: f64 = 2.0;
const WL_NM: f64 = 550.0;

fn psf_of(ap: Aperture) -> (usize, Vec<f64>) {
    let wf = Wavefront::diffraction_limited(F_M, FNUM)
        .unwrap()
        .with_min_pupil_samples(128)
        .with_aperture(ap);
    let p = wf.psf_full(WL_NM, WL_NM * 1e-9 * FNUM / 4.0).unwrap();
    (p.size, p.data)
}

/// PSF value at offset (dc, dr) samples from the centre (N/2, N/2).
fn at(psf: &(usize, Vec<f64>), dc: i64, dr: i64) -> f64 {
    let n = psf.0 as i64;
    psf.1[((n / 2 + dr) * n + n / 2 + dc) as usize]
}

/// Vertices (counter-clockwise, normalized by the pupil radius) of the regular `n`-gon inscribed
/// in the unit circle, a vertex at `rot_deg`.
fn polygon(n: usize, rot_deg: f64) -> Vec<(f64, f64)> {
    (0..n)
        .map(|k| {
            let t = rot_deg.to_radians() + 2.0 * PI * k as f64 / n as f64;
            (t.cos(), t.sin())
        })
        .collect()
}

/// Fourier transform of a polygon's indicator, F(k) = integral over P of exp(-i k.x) dA, in closed
/// form. Derivation (divergence theorem): exp(-i k.x) = div(i k / |k|^2 exp(-i k.x)), so
/// F = (i / |k|^2) sum over edges (k . n_e) L_e exp(-i k.m_e) sinc(k.(b - a) / 2), edge a -> b,
/// midpoint m_e, outward normal n_e, length L_e; (k . n_e) L_e = kx dy - ky dx for a CCW
/// polygon. (The same sum over edges as Lee & Mittra 1983.) F(0) = the area. Returns |F|^2.
fn polygon_ft_sq(v: &[(f64, f64)], kx: f64, ky: f64) -> f64 {
    let k2 = kx * kx + ky * ky;
    if k2 == 0.0 {
        let a: f64 = (0..v.len())
            .map(|i| {
                let (p, q) = (v[i], v[(i + 1) % v.len()]);
                p.0 * q.1 - q.0 * p.1
            })
            .sum::<f64>()
            / 2.0;
        return a * a;
    }
    let (mut re, mut im) = (0.0, 0.0);
    for i in 0..v.len() {
        let (a, b) = (v[i], v[(i + 1) % v.len()]);
        let (dx, dy) = (b.0 - a.0, b.1 - a.1);
        let (mx, my) = ((a.0 + b.0) / 2.0, (a.1 + b.1) / 2.0);
        let half = (kx * dx + ky * dy) / 2.0;
        let sinc = if half.abs() < 1e-12 {
            1.0
        } else {
            half.sin() / half
        };
        let w = (kx * dy - ky * dx) * sinc;
        let ph = -(kx * mx + ky * my);
        re += w * ph.cos();
        im += w * ph.sin();
    }
    // Times i / |k|^2: |F|^2 = (re^2 + im^2) / |k|^4.
    (re * re + im * im) / (k2 * k2)
}

/// Test 1: The Fraunhofer pattern of a 6- and a 5-blade iris (straight blades, rotated) against the
/// closed-form transform of the polygon. The unit-sum PSF sample at sensor offset u is
/// |F(k)|^2 s^2 / A (Parseval), s = a dx / (lambda z) = 1/8, k = 2 pi u a / (lambda z)
/// = (pi / 4) (col, row) per sample. Tolerance, set by the pupil sampling (128 samples across,
/// rim cells 8 x 8 subsampled, so the discrete polygon's area and edges are off by ~1e-4 of the
/// area): |error| < 2e-3 of the peak at every sample, and < 1 % of the value where it exceeds
/// 2 % of the peak.
#[test]
fn polygon_psf_matches_the_polygon_fourier_transform() {
    let offsets: [(i64, i64); 12] = [
        (0, 0),
        (1, 0),
        (0, 2),
        (2, 2),
        (3, 0),
        (0, 3),
        (5, 1),
        (-4, 3),
        (6, -2),
        (8, 0),
        (0, 8),
        (10, 4),
    ];
    for (n, rot) in [(6usize, 0.0), (5, 10.0), (3, 35.0)] {
        let psf = psf_of(Aperture::circle().with_blades(n, rot, 0.0).unwrap());
        let v = polygon(n, rot);
        let area = polygon_ft_sq(&v, 0.0, 0.0).sqrt();
        let s = 1.0 / 8.0;
        let peak = area * s * s;
        let (mut worst_abs, mut worst_rel): (f64, f64) = (0.0, 0.0);
        for (c, r) in offsets {
            let (kx, ky) = (PI / 4.0 * c as f64, PI / 4.0 * r as f64);
            let want = polygon_ft_sq(&v, kx, ky) * s * s / area;
            let got = at(&psf, c, r);
            let e_abs = (got - want).abs() / peak;
            worst_abs = worst_abs.max(e_abs);
            assert!(
                e_abs < 2e-3,
                "{n} blades, sample ({c}, {r}): PSF {got:.4e} vs polygon FT {want:.4e} (peak {peak:.4e})"
            );
            if want > 0.02 * peak {
                let e_rel = (got / want - 1.0).abs();
                worst_rel = worst_rel.max(e_rel);
                assert!(
                    e_rel < 0.01,
                    "{n} blades, sample ({c}, {r}): PSF {got:.4e} vs polygon FT {want:.4e}"
                );
            }
        }
        eprintln!(
            "{n} blades: polygon FT agreement: max |error| {worst_abs:.2e} of the peak, max relative {worst_rel:.2e}"
        );
    }
}

/// Mean PSF per angular bin (`bins` equal bins from +x towards +y) over the annulus
/// r0 <= r < r1 samples.
fn angular_profile(psf: &(usize, Vec<f64>), r0: f64, r1: f64, bins: usize) -> Vec<f64> {
    let n = psf.0 as i64;
    let (mut sum, mut cnt) = (vec![0.0; bins], vec![0usize; bins]);
    for r in 0..n {
        for c in 0..n {
            let (x, y) = ((c - n / 2) as f64, (r - n / 2) as f64);
            let rad = x.hypot(y);
            if rad >= r0 && rad < r1 {
                let t = y.atan2(x).rem_euclid(2.0 * PI);
                let b = ((t / (2.0 * PI) * bins as f64) as usize).min(bins - 1);
                sum[b] += psf.1[(r * n + c) as usize];
                cnt[b] += 1;
            }
        }
    }
    sum.iter().zip(&cnt).map(|(s, c)| s / *c as f64).collect()
}

/// Circular local maxima of prominence `factor`: the maximum exceeds `factor` times the higher
/// of the two minima reached walking down from it on either side. Their bin indices.
fn spikes(p: &[f64], factor: f64) -> Vec<usize> {
    let n = p.len();
    let walk = |i: usize, step: usize| {
        let (mut j, mut low) = (i, p[i]);
        loop {
            let k = (j + step) % n;
            if p[k] > low || k == i {
                return low;
            }
            low = p[k];
            j = k;
        }
    };
    (0..n)
        .filter(|&i| p[i] > p[(i + n - 1) % n] && p[i] >= p[(i + 1) % n])
        .filter(|&i| p[i] > factor * walk(i, 1).max(walk(i, n - 1)))
        .collect()
}

/// Test 2: Diffraction spikes: each straight blade edge sends a streak perpendicular to it both ways,
/// and parallel edges share one; so N spikes for even N and 2N for odd N. Counted as the
/// angular maxima (144 bins of 2.5 deg) of the PSF on an annulus 10..20 cycles per pupil
/// diameter out (40..80 samples) standing 2x above the minima beside them. The circle has none; the hexagon's
/// spikes lie along its edge normals (30 + 60 k deg for a vertex at 0 deg).
#[test]
fn blade_edges_make_n_or_2n_diffraction_spikes() {
    let bins = 144;
    for (n, want) in [(6usize, 6usize), (5, 10), (8, 8), (7, 14)] {
        let psf = psf_of(Aperture::circle().with_blades(n, 0.0, 0.0).unwrap());
        let prof = angular_profile(&psf, 40.0, 80.0, bins);
        let sp = spikes(&prof, 2.0);
        eprintln!(
            "{n} blades: {} spikes at {:?} deg",
            sp.len(),
            sp.iter().map(|b| *b as f64 * 2.5).collect::<Vec<_>>()
        );
        assert_eq!(sp.len(), want, "{n} blades: spikes at bins {sp:?}");
        if n == 6 {
            for b in &sp {
                // Bin b covers 2.5 b .. 2.5 b + 2.5 deg; an edge normal at 30 + 60 k deg is a
                // bin edge, so the maximum is in a bin on either side of it.
                let centre = *b as f64 * 2.5 + 1.25;
                let off = (centre - 30.0).rem_euclid(60.0);
                assert!(
                    !(2.5..=57.5).contains(&off),
                    "hexagon spike at {centre} deg is not along an edge normal"
                );
            }
        }
    }
    let circ = psf_of(Aperture::circle());
    let sp = spikes(&angular_profile(&circ, 40.0, 80.0, bins), 2.0);
    assert!(sp.is_empty(), "circle: spikes at {sp:?}");
}

/// Energy within `r` samples of the centre.
fn encircled(psf: &(usize, Vec<f64>), r: f64) -> f64 {
    let n = psf.0 as i64;
    let mut e = 0.0;
    for row in 0..n {
        for c in 0..n {
            let (x, y) = ((c - n / 2) as f64, (row - n / 2) as f64);
            if x.hypot(y) <= r {
                e += psf.1[(row * n + c) as usize];
            }
        }
    }
    e
}

/// Test 3: Encircled energy of the iris PSF against the circle's at the same circumscribed diameter.
/// camsim normalizes every PSF to unit volume (checked), so the smaller open area shows as a
/// wider core: less energy within 0.25, 0.5 and 1 lambda N. The peak of the unit-volume PSF is
/// A s^2 (Parseval: peak |F(0)|^2 = A^2, volume proportional to A), so the peak ratio iris/circle
/// equals the area ratio N sin(2 pi / N) / (2 pi) (0.8270 for 6 blades), within 0.2 %.
#[test]
fn iris_psf_has_a_wider_core_and_the_area_ratio_peak() {
    let circ = psf_of(Aperture::circle());
    for n in [5usize, 6, 9] {
        let ap = Aperture::circle().with_blades(n, 0.0, 0.0).unwrap();
        let want_area = n as f64 * (2.0 * PI / n as f64).sin() / (2.0 * PI);
        assert!((ap.blade_area_fraction() - want_area).abs() < 1e-12);
        assert!(
            (ap.area_fraction() / want_area - 1.0).abs() < 1e-3,
            "{n} blades: area fraction {} vs {want_area}",
            ap.area_fraction()
        );
        let poly = psf_of(ap);
        assert!((poly.1.iter().sum::<f64>() - 1.0).abs() < 1e-12);
        let peak_ratio = at(&poly, 0, 0) / at(&circ, 0, 0);
        eprintln!("{n} blades: peak ratio {peak_ratio:.5}, area ratio {want_area:.5}");
        assert!(
            (peak_ratio / want_area - 1.0).abs() < 2e-3,
            "{n} blades: peak ratio {peak_ratio} vs area ratio {want_area}"
        );
        // Radii in samples: lambda N = 4 samples.
        for r_lam_n in [0.25, 0.5, 1.0] {
            let (ep, ec) = (
                encircled(&poly, 4.0 * r_lam_n),
                encircled(&circ, 4.0 * r_lam_n),
            );
            eprintln!(
                "{n} blades: EE({r_lam_n} lambda N) {ep:.4} vs circle {ec:.4} (ratio {:.4})",
                ep / ec
            );
            assert!(
                ep < ec,
                "{n} blades: EE at {r_lam_n} lambda N {ep} >= circle's {ec}"
            );
        }
    }
}

/// Area of the part of the strip |s| <= w inside the annulus eps <= r <= 1 on one side, per
/// vane: integral of sqrt(R^2 - s^2) ds over [-w, w] = w sqrt(R^2 - w^2) + R^2 asin(w / R),
/// for R = 1 minus R = eps (w < eps, so the vanes meet inside the obstruction).
fn vane_area(w: f64, eps: f64) -> f64 {
    let seg = |r: f64| w * (r * r - w * w).sqrt() + r * r * (w / r).asin();
    seg(1.0) - seg(eps)
}

/// Test 4: Central obstruction eps (fraction of the diameter): the annulus has area (1 - eps^2) of
/// the circle's. The unnormalized peak |F(0)|^2 = A^2 falls as (1 - eps^2)^2 and the energy as
/// (1 - eps^2) (Parseval), so camsim's unit-volume PSF peaks at (1 - eps^2) of the clear pupil's
/// (Born & Wolf sec. 8.6.1 for the annular pupil's intensity). Checked for eps = 0.3, 0.5 within
/// 0.2 %, and with 4 spider vanes (width 0.02 D) against the closed-form vane area.
#[test]
fn obstruction_and_vanes_scale_the_peak_by_the_open_area() {
    let circ = psf_of(Aperture::circle());
    for eps in [0.3, 0.5] {
        let ap = Aperture::circle().with_obstruction(eps).unwrap();
        let want = 1.0 - eps * eps;
        assert!((ap.area_fraction() / want - 1.0).abs() < 1e-3);
        let p = psf_of(ap);
        let ratio = at(&p, 0, 0) / at(&circ, 0, 0);
        eprintln!(
            "obstruction {eps}: normalized peak ratio {ratio:.5} (1 - eps^2 = {want:.5}); unnormalized {:.5} ((1 - eps^2)^2 = {:.5})",
            ratio * want,
            want * want
        );
        assert!(
            (ratio / want - 1.0).abs() < 2e-3,
            "obstruction {eps}: peak ratio {ratio} vs {want}"
        );
        // A wider pedestal: more energy in the rings, less in the core.
        assert!(encircled(&p, 4.0) < encircled(&circ, 4.0));
    }
    let (eps, w) = (0.3, 0.02);
    let ap = Aperture::circle()
        .with_obstruction(eps)
        .unwrap()
        .with_vanes(4, w, 45.0)
        .unwrap();
    let want = 1.0 - eps * eps - 4.0 * vane_area(w, eps) / PI;
    let got_area = ap.area_fraction();
    let p = psf_of(ap);
    let ratio = at(&p, 0, 0) / at(&circ, 0, 0);
    eprintln!("4 vanes: area fraction {got_area:.5}, peak ratio {ratio:.5}, closed form {want:.5}");
    assert!((got_area / want - 1.0).abs() < 1e-3);
    assert!(
        (ratio / want - 1.0).abs() < 2e-3,
        "vanes: {ratio} vs {want}"
    );
    // Vanes at 45 + 90 k deg streak the PSF perpendicular to themselves: 4 spikes.
    let sp = spikes(&angular_profile(&p, 40.0, 80.0, 144), 2.0);
    assert_eq!(sp.len(), 4, "vane spikes at bins {sp:?}");
}

/// Curvature 1 is the circle; curvature in between has the closed-form area (polygon plus the
/// circular segments of the blade arcs).
#[test]
fn curved_blades_reach_the_circle() {
    let circ = psf_of(Aperture::circle());
    let round = psf_of(Aperture::circle().with_blades(6, 12.0, 1.0).unwrap());
    let worst = circ
        .1
        .iter()
        .zip(&round.1)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(worst < 1e-12, "curvature 1 vs circle: {worst}");
    for c in [0.25, 0.5, 0.75] {
        let ap = Aperture::circle().with_blades(5, 0.0, c).unwrap();
        let (closed, sampled) = (ap.blade_area_fraction(), ap.area_fraction());
        assert!(
            (sampled / closed - 1.0).abs() < 1e-3,
            "curvature {c}: sampled area {sampled} vs closed form {closed}"
        );
        assert!(closed > 0.7568 && closed < 1.0);
    }
}

/// A transmission mask: a uniform 0.5 grey PNG halves the transmitted area and leaves the
/// unit-volume PSF as the circle's; Optics scales the irradiance by the area fraction; a missing
/// or coloured file names the file; bad keys are named.
#[test]
fn mask_file_and_config_keys() {
    let dir = tempfile::tempdir().unwrap();
    let png = dir.path().join("half.png");
    camsim_io::raster::write_png16_gray(&png, 8, 8, &[32768u16; 64]).unwrap();
    let mask = TransmissionMask::from_file(&png).unwrap();
    let ap = Aperture::circle().with_mask(mask);
    let t = 32768.0 / 65535.0;
    assert!((ap.area_fraction() / t - 1.0).abs() < 1e-3);
    let (circ, masked) = (psf_of(Aperture::circle()), psf_of(ap));
    let worst = circ
        .1
        .iter()
        .zip(&masked.1)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(worst < 1e-12, "uniform mask vs circle: {worst}");

    let exr = dir.path().join("ramp.exr");
    let ramp: Vec<f32> = (0..16).map(|i| (i % 4) as f32 / 3.0).collect();
    camsim_io::exr::write_gray_exr(&exr, 4, 4, "T", &ramp).unwrap();
    let m = TransmissionMask::from_file(&exr).unwrap();
    // Pixel centres at x = -0.75 .. 0.75: transmission 0 .. 1 across, bilinear between.
    assert!((m.eval(-0.75, 0.0) - 0.0).abs() < 1e-7 && (m.eval(0.75, 0.3) - 1.0).abs() < 1e-7);
    assert!((m.eval(0.0, 0.0) - 0.5).abs() < 1e-6);

    let mut cfg = OpticsConfig::preset("diffraction-limited").unwrap();
    let text = format!(
        "[aperture]\nblades = 6\nrotation_deg = 15\nmask = {:?}\n",
        png.display().to_string()
    );
    let extra: OpticsConfig = OpticsConfig::from_toml_str(
        &format!("f_number = 2.0\nfocal_length_mm = 4.0\n{text}"),
        "test",
    )
    .unwrap();
    cfg.aperture = extra.aperture.clone();
    let o = Optics::from_config(&cfg).unwrap();
    let want = 6.0 * (PI / 3.0).sin() / (2.0 * PI) * t;
    assert!((o.aperture_area_fraction() / want - 1.0).abs() < 2e-3);
    assert_eq!(o.wavefront().aperture().blades(), Some((6, 15.0, 0.0)));

    let err = |a: camsim_optics::config::ApertureConfig| {
        let mut c = cfg.clone();
        c.aperture = Some(a);
        Optics::from_config(&c).unwrap_err().to_string()
    };
    let base = camsim_optics::config::ApertureConfig::default();
    let e = err(camsim_optics::config::ApertureConfig {
        blades: Some(2),
        ..base.clone()
    });
    assert!(e.contains("aperture.blades"), "{e}");
    let e = err(camsim_optics::config::ApertureConfig {
        blades: Some(6),
        curvature: 1.5,
        ..base.clone()
    });
    assert!(e.contains("aperture.curvature"), "{e}");
    let e = err(camsim_optics::config::ApertureConfig {
        obstruction: 1.0,
        ..base.clone()
    });
    assert!(e.contains("aperture.obstruction"), "{e}");
    let e = err(camsim_optics::config::ApertureConfig {
        vanes: 3,
        ..base.clone()
    });
    assert!(e.contains("aperture.vane_width"), "{e}");
    let missing = dir.path().join("nope.png");
    let e = err(camsim_optics::config::ApertureConfig {
        mask: Some(missing.clone()),
        ..base.clone()
    });
    assert!(e.contains("nope.png"), "{e}");
    let rgb = dir.path().join("rgb.png");
    camsim_io::raster::write_png8_rgb(&rgb, 1, 2, &[255, 0, 0, 9, 9, 9]).unwrap();
    let e = err(camsim_optics::config::ApertureConfig {
        mask: Some(rgb),
        ..base.clone()
    });
    assert!(e.contains("rgb.png") && e.contains("grey"), "{e}");
    // An empty [aperture] table is the circle: the same PSF bit for bit.
    let mut plain = cfg.clone();
    plain.aperture = None;
    let mut empty = cfg.clone();
    empty.aperture = Some(base);
    let (a, b) = (
        Optics::from_config(&plain).unwrap(),
        Optics::from_config(&empty).unwrap(),
    );
    assert_eq!(a.aperture_area_fraction(), 1.0);
    assert_eq!(
        a.wavefront().psf(550.0, 1e-6, 15).unwrap().data,
        b.wavefront().psf(550.0, 1e-6, 15).unwrap().data
    );
}
