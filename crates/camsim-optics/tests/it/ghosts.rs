//! Lens ghost images ([`camsim_optics::traced::ghost_irradiance`], `TracedLens::add_ghosts`)
//! against closed forms: a stop 2 mm in front of a thick biconvex singlet has one ghost
//! (reflected back at the rear surface, forward at the front one), whose centre B tan(theta),
//! radius |A| a (A, B of the paraxial ghost matrix from the stop to the film, the reflections as
//! refractions into index -n) and power E cos(theta) pi a^2 R1 R2 T1 T2 follow from first-order
//! optics; a detected bright spot's ghost carries R1 R2 of the spot's power. And the
//! `blur.ghosts` keys.

use camsim_core::{Quantity, SpectralImage, WavelengthGrid};
use camsim_lens::{Coating, Lens, Medium, Surface};
use camsim_optics::config::{GhostConfig, OpticsConfig};
use camsim_optics::traced::{
    ghost_irradiance, GhostSource, Ghosts, SensorGeometry, SourceStrength, TracedLens,
};

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

fn singlet() -> Lens {
    Lens {
        name: "singlet".into(),
        surfaces: vec![
            surface(0.0, STOP_GAP_MM, 1.0, STOP_MM),
            surface(R1_MM, T_GLASS_MM, N_GLASS, 6.0),
            surface(R2_MM, 40.0, 1.0, 6.0),
        ],
    }
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

/// Paraxial (y, n u) matrices from the stop plane to the film at the main image's focus (Hecht,
/// Optics, 5th ed., sec. 6.2; a reflection in glass n is a refraction into -n, power -+2 n c):
/// (main, ghost, film distance behind the last vertex in mm).
fn singlet_matrices() -> (M2, M2, f64) {
    let (c1, c2, n) = (1.0 / R1_MM, 1.0 / R2_MM, N_GLASS);
    let front = mul(power((n - 1.0) * c1), gap(STOP_GAP_MM));
    let main = mul(power((1.0 - n) * c2), mul(gap(T_GLASS_MM / n), front));
    let mut g = mul(gap(T_GLASS_MM / n), front);
    g = mul(power(-2.0 * n * c2), g);
    g = mul(gap(T_GLASS_MM / n), g);
    g = mul(power(2.0 * n * c1), g);
    g = mul(gap(T_GLASS_MM / n), g);
    g = mul(power((1.0 - n) * c2), g);
    let d = -main[0][0] / main[1][0];
    (mul(gap(d), main), mul(gap(d), g), d)
}

/// Power (sum of irradiance x pixel area, W/nm with the area in m^2), centroid and RMS radius (mm)
/// of an image plane.
fn moments(img: &[f32], rows: usize, cols: usize, pitch_mm: f64) -> (f64, [f64; 2], f64) {
    let (mut s, mut sx, mut sy, mut sxx) = (0.0, 0.0, 0.0, 0.0);
    for r in 0..rows {
        for c in 0..cols {
            let v = img[r * cols + c] as f64;
            let x = (c as f64 + 0.5 - cols as f64 / 2.0) * pitch_mm;
            let y = (r as f64 + 0.5 - rows as f64 / 2.0) * pitch_mm;
            s += v;
            sx += v * x;
            sy += v * y;
            sxx += v * (x * x + y * y);
        }
    }
    let (cx, cy) = (sx / s, sy / s);
    let rms = (sxx / s - cx * cx - cy * cy).sqrt();
    (s * (pitch_mm * 1e-3).powi(2), [cx, cy], rms)
}

#[test]
fn singlet_ghost_image_position_size_and_power_follow_first_order_optics() {
    let lens = singlet();
    let (_, g, d_film) = singlet_matrices();
    let tan_t = 3f64.to_radians().tan();
    let e_w_m2_nm = 2.0;
    let (rows, cols, pitch) = (256, 256, 0.06);
    let sensor = SensorGeometry {
        rows,
        cols,
        pixel_pitch_mm: pitch,
        film_z_mm: lens.track_length_mm() + d_film,
    };
    let src = GhostSource {
        direction: [tan_t, 0.0, 1.0],
        strength: SourceStrength::Irradiance(vec![e_w_m2_nm]),
    };
    let coatings = [Coating::Uncoated];
    let img = ghost_irradiance(&lens, &coatings, &sensor, &[src], &[550.0], 96);
    let (p, c, rms) = moments(&img, rows, cols, pitch);
    let r = Coating::Uncoated.reflectance(1.0, N_GLASS, 550.0);
    let cos = 1.0 / tan_t.hypot(1.0);
    let p_closed =
        e_w_m2_nm * cos * std::f64::consts::PI * (STOP_MM * 1e-3).powi(2) * (r * (1.0 - r)).powi(2);
    let (c_closed, rms_closed) = (g[0][1] * tan_t, g[0][0].abs() * STOP_MM / 2f64.sqrt());
    println!(
        "ghost power {p:.4e} W/nm (closed form {p_closed:.4e}, {:+.2} %); centre {:.4} mm ({c_closed:.4}, {:+.2} %); rms radius {rms:.4} mm ({rms_closed:.4}, {:+.2} %)",
        100.0 * (p / p_closed - 1.0),
        c[0],
        100.0 * (c[0] / c_closed - 1.0),
        100.0 * (rms / rms_closed - 1.0)
    );
    assert!((p / p_closed - 1.0).abs() < 0.01);
    assert!((c[0] / c_closed - 1.0).abs() < 0.03);
    assert!(c[1].abs() < 1e-3 * rms_closed);
    assert!((rms / rms_closed - 1.0).abs() < 0.03);
    // A uniform disk: the irradiance inside 0.7 of the radius is flat within 5 % (footprints tile).
    let (cx, r_px) = (
        c_closed / pitch + cols as f64 / 2.0,
        g[0][0].abs() * STOP_MM / pitch,
    );
    let (mut lo, mut hi) = (f64::INFINITY, 0.0f64);
    for rr in 0..rows {
        for cc in 0..cols {
            let (dx, dy) = (cc as f64 + 0.5 - cx, rr as f64 + 0.5 - rows as f64 / 2.0);
            if dx.hypot(dy) < 0.7 * r_px {
                let v = img[rr * cols + cc] as f64;
                lo = lo.min(v);
                hi = hi.max(v);
            }
        }
    }
    println!("irradiance inside 0.7 radius: {lo:.4e} .. {hi:.4e} W/(m^2 nm)");
    assert!(hi / lo < 1.05, "{lo} {hi}");
}

/// A bright 2 x 2 spot in a one-band irradiance image is detected as a source; the ghost added
/// carries R1 R2 of the spot's power (the ghost and the main image pass the same rays of the
/// stop, and T1 T2 is common to both) and is centred at B tan(theta) of the direction whose chief
/// ray lands on the spot; splatted on a raster 4 times coarser than the image.
#[test]
fn a_detected_source_gets_r1_r2_of_its_power_as_ghost() {
    let lens = singlet();
    let efl = lens.paraxial(550.0).efl_mm;
    // The stop is the entrance pupil: f / (2 a) keeps its 1 mm radius.
    let tl = TracedLens::new(lens, "singlet", efl / (2.0 * STOP_MM), efl).unwrap();
    let (rows, cols, pitch_mm) = (200, 200, 0.08);
    let cam = tl
        .camera(f64::INFINITY, pitch_mm * (rows as f64).hypot(cols as f64))
        .unwrap();
    let grid = WavelengthGrid::new(550.0, 550.0, 10.0).unwrap();
    let mut img =
        SpectralImage::zeros(rows, cols, grid, pitch_mm * 1e-3, Quantity::Irradiance).unwrap();
    // A dim floor below the threshold and the spot at columns 108-109, rows 99-100.
    img.data.iter_mut().for_each(|v| *v = 0.01);
    for (r, c) in [(99, 108), (99, 109), (100, 108), (100, 109)] {
        img.data[r * cols + c] = 100.0;
    }
    let before = img.data.clone();
    let cfg = GhostConfig {
        coating: camsim_optics::config::CoatingConfig::Named(
            camsim_optics::config::CoatingName::Uncoated,
        ),
        raster_px: 50,
        rays: 96,
        ..GhostConfig::default()
    };
    let g = Ghosts::from_config(&cfg, &tl.lens).unwrap();
    let used = tl.add_ghosts(&cam, &g, &mut img).unwrap();
    assert_eq!(used.len(), 1);
    let d = used[0].direction;
    // The spot's centroid: pixel centres 8.5 and 9.5 pixels right of the axis.
    let x_spot = 9.0 * pitch_mm;
    let ghost: Vec<f32> = img.data.iter().zip(&before).map(|(a, b)| a - b).collect();
    let (p, c, _) = moments(&ghost, rows, cols, pitch_mm);
    let p_spot = 4.0 * 100.0 * (pitch_mm * 1e-3).powi(2);
    let r = Coating::Uncoated.reflectance(1.0, N_GLASS, 550.0);
    let (m, g_m, _) = singlet_matrices();
    let c_closed = g_m[0][1] * d[0];
    println!(
        "source tan {:.5} (paraxial x / B {:.5}); ghost power / spot power {:.5} (R1 R2 = {:.5}, {:+.2} %); ghost centre {:.4} mm ({c_closed:.4})",
        d[0],
        x_spot / m[0][1],
        p / p_spot,
        r * r,
        100.0 * (p / p_spot / (r * r) - 1.0),
        c[0]
    );
    assert!((d[0] / (x_spot / m[0][1]) - 1.0).abs() < 0.01);
    assert!(d[1].abs() < 1e-12);
    assert!((p / p_spot / (r * r) - 1.0).abs() < 0.02);
    assert!((c[0] / c_closed - 1.0).abs() < 0.03);
}

#[test]
fn ghost_keys_parse_and_bad_values_name_their_key() {
    let text = r#"
f_number = 2.8
focal_length_mm = 4.38
shading = "none"
[blur]
method = "shift-variant"
lens_file = "lens.json"
ghosts = { coating = { quarter_wave_nm = 520 }, threshold = 0.3, sources = [{ field_deg = [10, -2], irradiance_w_m2_nm = 5.0 }] }
"#;
    let c = OpticsConfig::from_toml_str(text, "test").unwrap();
    let gc = c.blur.as_ref().unwrap().ghosts.clone().unwrap();
    let lens = singlet();
    let g = Ghosts::from_config(&gc, &lens).unwrap();
    assert_eq!(
        g.coatings[1],
        Coating::QuarterWave {
            design_wavelength_nm: 520.0,
            layer_index: 1.38
        }
    );
    assert_eq!(g.sources.len(), 1);
    assert!((g.sources[0].direction[0] - 10f64.to_radians().tan()).abs() < 1e-15);
    for (toml_ghosts, key) in [
        ("{ threshold = 0.0 }", "blur.ghosts.threshold"),
        ("{ coating = { reflectance = 1.5 } }", "blur.ghosts.coating"),
        (
            "{ surface_reflectance = [0.01, 0.02] }",
            "blur.ghosts.surface_reflectance",
        ),
        ("{ rays = 2 }", "blur.ghosts.rays"),
        (
            "{ sources = [{ field_deg = [95, 0], irradiance_w_m2_nm = 1 }] }",
            "blur.ghosts.sources[0]",
        ),
    ] {
        let t = text.replace(
            &text[text.find("ghosts = ").unwrap()..],
            &format!("ghosts = {toml_ghosts}\n"),
        );
        let c = OpticsConfig::from_toml_str(&t, "test").unwrap();
        let e = Ghosts::from_config(c.blur.unwrap().ghosts.as_ref().unwrap(), &lens)
            .unwrap_err()
            .to_string();
        assert!(e.contains(key), "{toml_ghosts}: {e}");
    }
    // Unknown keys are refused; without `ghosts` nothing is written.
    assert!(OpticsConfig::from_toml_str(&text.replace("threshold", "treshold"), "t").is_err());
    let plain = OpticsConfig::preset("pixel4a").unwrap();
    assert!(!plain.to_toml().contains("ghosts"));
}
