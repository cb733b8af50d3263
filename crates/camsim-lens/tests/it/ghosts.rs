//! Two-bounce ghosts ([`camsim_lens::ghost`]) against closed forms: the coating reflectances
//! (Fresnel; the quarter-wave layer's ((n0 n2 - n1^2) / (n0 n2 + n1^2))^2), the path count
//! N (N - 1) / 2, a thick singlet's one ghost (position and size from its paraxial ABCD matrix
//! with the two internal reflections), its energy (R1 R2 T1 T2 times the passed fraction) and the
//! ghost chain of a double Gauss on the line through the axis and the source's image.

use camsim_lens::ghost::fresnel_normal;
use camsim_lens::{Coating, GhostPath, Lens, Medium, Surface};
use std::path::Path;

const N_GLASS: f64 = 1.5;
const R1_MM: f64 = 40.0;
const R2_MM: f64 = -40.0;
const T_GLASS_MM: f64 = 4.0;
const STOP_GAP_MM: f64 = 2.0;
const STOP_MM: f64 = 1.0;

fn surface(radius_mm: f64, thickness_mm: f64, n: f64, semi_mm: f64) -> Surface {
    Surface {
        radius_mm,
        thickness_mm,
        medium: Medium::constant(n),
        semi_aperture_mm: semi_mm,
        conic: 0.0,
        aspheric: Vec::new(),
        is_stop: radius_mm == 0.0,
    }
}

/// A stop 2 mm in front of a biconvex singlet (R = +-40 mm, 4 mm, n = 1.5): f = 40.7 mm, f/20.
fn singlet() -> Lens {
    let lens = Lens {
        name: "singlet".into(),
        surfaces: vec![
            surface(0.0, STOP_GAP_MM, 1.0, STOP_MM),
            surface(R1_MM, T_GLASS_MM, N_GLASS, 6.0),
            surface(R2_MM, 40.0, 1.0, 6.0),
        ],
    };
    lens.check("singlet").unwrap();
    lens
}

type M2 = [[f64; 2]; 2];
fn mul(a: M2, b: M2) -> M2 {
    [
        [
            a[0][0] * b[0][0] + a[0][1] * b[1][0],
            a[0][0] * b[0][1] + a[0][1] * b[1][1],
        ],
        [
            a[1][0] * b[0][0] + a[1][1] * b[1][0],
            a[1][0] * b[0][1] + a[1][1] * b[1][1],
        ],
    ]
}
fn gap(t_over_n: f64) -> M2 {
    [[1.0, t_over_n], [0.0, 1.0]]
}
fn power(p: f64) -> M2 {
    [[1.0, 0.0], [-p, 1.0]]
}

/// Paraxial matrices on (y, n u) from the stop plane (Hecht, Optics, 5th ed., sec. 6.2), with a
/// reflection taken as a refraction into index -n (the unfolded mirror, Gerrard & Burch,
/// Introduction to Matrix Methods in Optics, sec. III.5): refraction n' u' = n u - y (n' - n) c,
/// so a reflection inside glass n off a surface of curvature c met travelling +z has power
/// -2 n c and one met travelling -z power +2 n c; a gap of length t in |n| is [[1, t/|n|], [0, 1]]
/// either way. Returns (main to the last vertex, ghost to the last vertex).
fn singlet_matrices() -> (M2, M2) {
    let (c1, c2, n) = (1.0 / R1_MM, 1.0 / R2_MM, N_GLASS);
    let mut main = gap(STOP_GAP_MM);
    main = mul(power((n - 1.0) * c1), main);
    main = mul(gap(T_GLASS_MM / n), main);
    main = mul(power((1.0 - n) * c2), main);
    let mut g = gap(STOP_GAP_MM);
    g = mul(power((n - 1.0) * c1), g);
    g = mul(gap(T_GLASS_MM / n), g);
    g = mul(power(-2.0 * n * c2), g); // reflect back at surface 2 (n -> -n)
    g = mul(gap(T_GLASS_MM / n), g);
    g = mul(power(2.0 * n * c1), g); // reflect forward at surface 1 (-n -> n)
    g = mul(gap(T_GLASS_MM / n), g);
    g = mul(power((1.0 - n) * c2), g);
    (main, g)
}

fn stats(points: &[[f64; 2]]) -> ([f64; 2], f64) {
    let p: Vec<&[f64; 2]> = points.iter().filter(|p| p[0].is_finite()).collect();
    let k = p.len() as f64;
    let cx = p.iter().map(|q| q[0]).sum::<f64>() / k;
    let cy = p.iter().map(|q| q[1]).sum::<f64>() / k;
    let rms = (p
        .iter()
        .map(|q| (q[0] - cx).powi(2) + (q[1] - cy).powi(2))
        .sum::<f64>()
        / k)
        .sqrt();
    ([cx, cy], rms)
}

#[test]
fn coating_reflectances_match_their_closed_forms() {
    // Uncoated crown: ((1.5 - 1) / 2.5)^2 = 0.04.
    assert!((fresnel_normal(1.0, 1.5) - 0.04).abs() < 1e-15);
    assert!((Coating::Uncoated.reflectance(1.5, 1.0, 700.0) - 0.04).abs() < 1e-15);
    // Quarter-wave MgF2 (1.38) on n = 1.52 at its design wavelength: 0.0126 (Hecht sec. 9.7.2).
    let q = Coating::QuarterWave {
        design_wavelength_nm: 550.0,
        layer_index: 1.38,
    };
    for (n0, n2) in [(1.0, 1.52), (1.0, 1.9), (1.7, 1.0)] {
        let closed = ((n0 * n2 - 1.38f64.powi(2)) / (n0 * n2 + 1.38f64.powi(2))).powi(2);
        let r = q.reflectance(n0, n2, 550.0);
        assert!((r - closed).abs() < 1e-12, "{n0} {n2}: {r} vs {closed}");
        // Off the design wavelength the layer reflects more, never more than the bare surface.
        let r_blue = q.reflectance(n0, n2, 400.0);
        assert!(r_blue > r && r_blue < fresnel_normal(n0, n2));
    }
    // Index-matched layer (n1 = sqrt(n0 n2)) cancels the reflection at the design wavelength.
    let matched = Coating::QuarterWave {
        design_wavelength_nm: 500.0,
        layer_index: 1.5f64.sqrt(),
    };
    assert!(matched.reflectance(1.0, 1.5, 500.0) < 1e-15);
    // A half-wave wavelength (lambda = lambda_0 / 2) leaves the bare Fresnel reflectance.
    assert!((q.reflectance(1.0, 1.52, 275.0) - fresnel_normal(1.0, 1.52)).abs() < 1e-12);
    assert!(Coating::Reflectance(1.0).check().is_err());
    assert!(q.check().is_ok());
}

#[test]
fn a_lens_has_n_choose_2_ghost_paths_and_the_stop_reflects_nothing() {
    let dir = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../../shared/data/isetcornellbox/lens"
    );
    let lens = Lens::from_file(&Path::new(dir).join("dgauss.82deg.4.38mm.json")).unwrap();
    let n = lens.surfaces.iter().filter(|s| !s.is_stop).count();
    let paths = lens.ghost_paths();
    assert_eq!(paths.len(), n * (n - 1) / 2);
    let stop = lens.stop_index();
    assert!(paths
        .iter()
        .all(|p| p.back > p.front && p.back != stop && p.front != stop));
    assert_eq!(
        singlet().ghost_paths(),
        vec![GhostPath { back: 2, front: 1 }]
    );
}

/// The singlet's ghost at field angle 1 degree on a film at the paraxial focus: centre B tan(theta)
/// and radius |A| a of the ghost matrix to the film (a uniformly filled disk: RMS radius
/// |A| a / sqrt 2), against the traced bundle.
#[test]
fn thick_singlet_ghost_position_and_size_follow_the_paraxial_matrix() {
    let lens = singlet();
    let (main, g) = singlet_matrices();
    // Film at the main image's paraxial focus: A + d C = 0.
    let d_film = -main[0][0] / main[1][0];
    let to_film = |m: M2| mul(gap(d_film), m);
    let (m_f, g_f) = (to_film(main), to_film(g));
    assert!(m_f[0][0].abs() < 1e-12);
    let film_z = lens.track_length_mm() + d_film;
    let tan_t = 1f64.to_radians().tan();
    let ghost = GhostPath { back: 2, front: 1 };
    let b = lens.trace_bundle(Some(ghost), [tan_t, 0.0, 1.0], film_z, 550.0, 96);
    let (c, rms) = stats(&b.landing_mm);
    let (c_par, rms_par) = (g_f[0][1] * tan_t, g_f[0][0].abs() * STOP_MM / 2f64.sqrt());
    let main_b = lens.trace_bundle(None, [tan_t, 0.0, 1.0], film_z, 550.0, 96);
    let (cm, rms_m) = stats(&main_b.landing_mm);
    println!(
        "film {d_film:.4} mm behind the lens; main image x {:.5} mm (paraxial {:.5}), rms {:.2e} mm",
        cm[0],
        m_f[0][1] * tan_t,
        rms_m
    );
    println!(
        "ghost centre x {:.5} mm (paraxial {c_par:.5}, {:+.2} %), rms radius {rms:.5} mm (paraxial {rms_par:.5}, {:+.2} %), {} of {} rays",
        c[0],
        100.0 * (c[0] / c_par - 1.0),
        100.0 * (rms / rms_par - 1.0),
        b.passed,
        b.launched
    );
    assert!(
        (c[0] / c_par - 1.0).abs() < 0.02,
        "centre {} vs {c_par}",
        c[0]
    );
    assert!(c[1].abs() < 1e-9);
    assert!((rms / rms_par - 1.0).abs() < 0.03, "rms {rms} vs {rms_par}");
    // The ghost is well out of focus: many times the main image's spot.
    assert!(rms > 20.0 * rms_m);
}

/// Energy: every ray of the singlet's ghost keeps R1 R2 (1 - R1)(1 - R2) of its power, and the
/// stop passes the fraction (stop area) / (launch disk area) of the bundle (the ghost rays meet
/// the stop before any reflection).
#[test]
fn ghost_energy_is_the_product_of_reflectances_transmittances_and_the_passed_fraction() {
    let lens = singlet();
    let ghost = Some(GhostPath { back: 2, front: 1 });
    for coating in [
        Coating::Uncoated,
        Coating::Reflectance(0.01),
        Coating::QuarterWave {
            design_wavelength_nm: 550.0,
            layer_index: 1.38,
        },
    ] {
        for wl in [450.0, 550.0, 650.0] {
            let r = coating.reflectance(1.0, N_GLASS, wl);
            let t = lens.path_transmission(ghost, wl, &[coating]);
            let closed = r * r * (1.0 - r) * (1.0 - r);
            assert!(
                (t - closed).abs() < 1e-15,
                "{coating:?} {wl}: {t} vs {closed}"
            );
            let main = lens.path_transmission(None, wl, &[coating]);
            assert!((main - (1.0 - r) * (1.0 - r)).abs() < 1e-15);
        }
    }
    // A path with backward crossings: the double Gauss's ghost off surfaces 5 and 1, with
    // (1 - R) for surfaces 1-4 forward, 4-2 backward and 2-11 forward (the stop: none).
    let dir = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../../shared/data/isetcornellbox/lens"
    );
    let dg = Lens::from_file(&Path::new(dir).join("dgauss.82deg.4.38mm.json")).unwrap();
    let c = [Coating::Uncoated];
    let r = |i: usize| dg.surface_reflectance(i, 550.0, &c[0]);
    let t = |i: usize| 1.0 - r(i);
    let fwd1: f64 = (0..4).map(t).product();
    let back: f64 = (1..4).map(t).product();
    let fwd2: f64 = (1..dg.surfaces.len()).map(t).product();
    let closed = fwd1 * r(4) * back * r(0) * fwd2;
    let got = dg.path_transmission(Some(GhostPath { back: 4, front: 0 }), 550.0, &c);
    assert!((got / closed - 1.0).abs() < 1e-12, "{got} vs {closed}");
    assert_eq!(r(dg.stop_index()), 0.0);
    let b = lens.trace_bundle(ghost, [0.0, 0.0, 1.0], 80.0, 550.0, 128);
    let disk = std::f64::consts::PI * STOP_MM * STOP_MM / b.launch_area_mm2();
    println!(
        "passed fraction {:.5}, stop / launch area {disk:.5}",
        b.passed_fraction()
    );
    assert!((b.passed_fraction() / disk - 1.0).abs() < 0.01);
}

/// A double Gauss's ghosts of a source at field (3, 4) degrees on a tilted azimuth: each ghost's
/// centroid lies on the line through the axis and the main image (rotational symmetry), the
/// chain spreading on both sides of the axis. The square ray grid is not symmetric about a
/// 53-degree meridian, so a vignetted ghost's centroid carries a sampling error of order
/// (ghost radius) / sqrt(rays): the bound is half that; on the 45-degree meridian, about which
/// the grid is symmetric, the centroids lie on the line to rounding.
#[test]
fn the_ghost_chain_lies_on_the_line_through_the_axis_and_the_source_image() {
    let dir = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../../shared/data/isetcornellbox/lens"
    );
    let lens = Lens::from_file(&Path::new(dir).join("dgauss.82deg.4.38mm.json")).unwrap();
    let film_z = lens.track_length_mm() + lens.paraxial(550.0).bfd_mm;
    for (ax, ay, exact) in [(3.0f64, 4.0f64, false), (4.0, 4.0, true)] {
        let d = [ax.to_radians().tan(), ay.to_radians().tan(), 1.0];
        let main = lens.trace_bundle(None, d, film_z, 550.0, 48);
        let (m, _) = stats(&main.landing_mm);
        let u = [m[0] / m[0].hypot(m[1]), m[1] / m[0].hypot(m[1])];
        let (mut n_ghosts, mut worst, mut sides) = (0, 0.0f64, [0, 0]);
        for p in lens.ghost_paths() {
            let b = lens.trace_bundle(Some(p), d, film_z, 550.0, 48);
            if b.passed < 10 {
                continue;
            }
            let (c, rms) = stats(&b.landing_mm);
            // Distance from the line, relative to its bound.
            let off = (c[0] * u[1] - c[1] * u[0]).abs();
            let bound = if exact {
                1e-9 * rms
            } else {
                0.5 * rms / (b.passed as f64).sqrt()
            };
            worst = worst.max(off / bound);
            n_ghosts += 1;
            sides[usize::from(c[0] * u[0] + c[1] * u[1] < 0.0)] += 1;
        }
        println!(
            "field ({ax}, {ay}) deg: {n_ghosts} ghosts reach the film; largest distance from the line {worst:.2} of its bound; {} on the source's side, {} opposite",
            sides[0], sides[1]
        );
        assert!(n_ghosts > 10);
        assert!(worst < 1.0, "{worst}");
        assert!(sides[0] > 0 && sides[1] > 0);
    }
}
