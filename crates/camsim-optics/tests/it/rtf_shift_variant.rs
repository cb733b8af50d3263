//! Shift-variant optics from the Pixel 4a ray-transfer function (`blur.rtf_file`): PSF energy,
//! PSF centroid on the chief ray, relative illumination against `Rtf::relative_illumination`, a
//! flat field, the on-axis diffraction limit and clear errors.

use camsim_core::image::ImageGeometry;
use camsim_core::{Quantity, SpectralImage, WavelengthGrid};
use camsim_lens::Rtf;
use camsim_optics::config::{BlurConfig, BlurKind, BlurMethod, ShadingConfig, ShadingName};
use camsim_optics::rtf_psf::{Field, RtfLens, Spot, RI_GRID};
use camsim_optics::{Optics, OpticsConfig};
use std::path::PathBuf;

fn data(name: &str) -> PathBuf {
    PathBuf::from(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../../shared/data/isetcornellbox/lens"
    ))
    .join(name)
}

fn rtf_path() -> PathBuf {
    data("pixel4a-rearcamera-ellipse-raytransfer.json")
}

/// The RTF's on-axis f-number from its own pass region: N = sqrt(pi / (4 Omega)).
fn rtf_f_number() -> f64 {
    let rtf = Rtf::from_file(&rtf_path()).unwrap();
    (std::f64::consts::PI / (4.0 * rtf.irradiance(0.0, 256).unwrap())).sqrt()
}

fn config() -> OpticsConfig {
    let mut c = OpticsConfig::preset("diffraction-limited").unwrap();
    c.f_number = (rtf_f_number() * 100.0).round() / 100.0;
    c.focal_length_mm = 4.38;
    c.shading = ShadingConfig::Named(ShadingName::None);
    c.psf.method = BlurMethod::Kernel;
    c.psf.far_tail = false;
    c.blur = Some(BlurConfig {
        method: BlurKind::ShiftVariant,
        field_heights: 8,
        block_px: None,
        rotation_oversampling: 3,
        lens_file: None,
        rtf_file: Some(rtf_path()),
        field_zernike: None,
        measured_psf: None,
        ghosts: None,
    });
    c
}

fn lens() -> RtfLens {
    RtfLens::from_file(&rtf_path(), rtf_f_number(), 4.38).unwrap()
}

/// A radiance image at infinity with `fov_deg` across its columns.
fn image(
    rows: usize,
    cols: usize,
    grid: WavelengthGrid,
    fov_deg: f64,
    f: impl Fn(usize, usize) -> f32,
) -> SpectralImage {
    let mut data = vec![0.0f32; rows * cols * grid.len()];
    for plane in data.chunks_mut(rows * cols) {
        for r in 0..rows {
            for c in 0..cols {
                plane[r * cols + c] = f(r, c);
            }
        }
    }
    let mut img =
        SpectralImage::from_data(rows, cols, grid, 1e-6, Quantity::Radiance, data).unwrap();
    img.geometry = ImageGeometry {
        fov_deg,
        distance_m: 0.0,
        focal_length_m: 0.0,
        f_number: 0.0,
    };
    img
}

fn field(h_mm: f64) -> Field {
    Field {
        ideal_height_mm: h_mm,
        image_distance_mm: 4.38,
        object_distance_mm: f64::INFINITY,
    }
}

/// Energy and centre: each field's geometric spot lies inside its grid (the splat conserves the
/// weights: sum 1 to round-off), the diffraction-convolved kernels keep what the Airy pattern
/// keeps in a 41-sample window of 0.47 um (within 1 %; the rest is its far rings), and the spot's
/// centroid sits on the chief ray's meridian, radially off it by the coma only (distortion and PSF
/// consistent; the pipeline-level check is `point_source_lands_on_the_rtf_chief_ray`).
#[test]
fn field_psfs_hold_their_energy_and_centre_on_the_chief_ray() {
    let l = lens();
    let dz = l.focus_offset_mm(f64::INFINITY).unwrap();
    println!(
        "infinity focus: film {:.2} um behind the RTF's input plane",
        dz * 1e3
    );
    let (spacing, n) = (1.4e-6 / 3.0, 41usize);
    let r_window = (n / 2) as f64 * spacing;
    for h in [0.0, 1.0, 2.0, 2.8, 3.3] {
        let sp = l.field_spot(&field(h), dz).unwrap();
        let fp = sp.psf(spacing, n);
        let sum: f64 = fp.spot.iter().sum();
        let wl = [450.0, 550.0, 650.0];
        let k = l.with_diffraction(&fp, &wl);
        let ksum: Vec<f32> = k.iter().map(|k| k.iter().sum()).collect();
        // The Airy pattern's energy outside radius R: ~ 2 lambda N / (pi^2 R) (Born & Wolf 8.5.2).
        let n_eff = 1.0 / (2.0 * sp.na[0].min(sp.na[1]));
        let floor: Vec<f64> = wl
            .iter()
            .map(|w| {
                1.0 - 2.0 * w * 1e-9 * n_eff / (std::f64::consts::PI.powi(2) * r_window) - 0.01
            })
            .collect();
        println!(
            "ideal {h:.2} mm: chief lands at {:.4} mm ({} rays), centroid ({:.3}, {:.3}) um, RMS radius {:.3} um, r99.5 {:.3} um, NA ({:.4}, {:.4}); spot sum {sum:.6}, kernel sums {ksum:?}",
            sp.chief_height_m * 1e3,
            sp.hits.len(),
            sp.centroid_m[0] * 1e6,
            sp.centroid_m[1] * 1e6,
            sp.rms_radius_m * 1e6,
            sp.r995_m * 1e6,
            sp.na[0],
            sp.na[1]
        );
        assert!((sum - 1.0).abs() < 1e-9, "spot sum {sum}");
        assert!(
            ksum.iter()
                .zip(&floor)
                .all(|(s, f)| *s as f64 > *f && *s <= 1.0 + 1e-5),
            "{ksum:?} vs {floor:?}"
        );
        // On the axis the RTF's polynomials keep a constant exit tilt (1.2e-4 rad at r = 0, a
        // fitting residue): the axial film point's rays form a ring of f x 1.2e-4 = 0.5 um about
        // it, and the chief ray is undefined at that scale. Off the axis the centroid sits on the
        // meridian (mirror symmetry: tangential offset ~0) and off the chief ray radially by the
        // coma only: under half the spot's RMS radius (measured <= 0.32 um, 0.23 px).
        if h == 0.0 {
            assert!(
                sp.centroid_m[0].hypot(sp.centroid_m[1]) < 0.6e-6,
                "centroid {:?}",
                sp.centroid_m
            );
        } else {
            assert!(
                sp.centroid_m[1].abs() < 0.02e-6,
                "tangential centroid {:?}",
                sp.centroid_m
            );
            assert!(
                sp.centroid_m[0].abs() < 0.5 * sp.rms_radius_m,
                "radial centroid {:?} vs RMS {}",
                sp.centroid_m,
                sp.rms_radius_m
            );
        }
    }
}

/// Diffraction alone: a single ray (a point spot) convolved with the pass ellipse's OTF gives the
/// Airy pattern, whose encircled energy within the first dark ring 1.22 lambda N is
/// 1 - J0(3.8317)^2 - J1(3.8317)^2 = 0.838 (Born & Wolf, Principles of Optics, sec. 8.5.2);
/// on the axis the ellipse's NA is 1 / (2 N) of the RTF's f-number. The RTF's own on-axis spot
/// is far smaller than the Airy disk (its RMS radius is printed), so the full kernel holds nearly
/// as much in that radius.
#[test]
fn on_axis_psf_is_the_airy_pattern_of_the_pass_ellipse() {
    let l = lens();
    let n_rtf = rtf_f_number();
    let sp = l
        .field_spot(&field(0.0), l.focus_offset_mm(f64::INFINITY).unwrap())
        .unwrap();
    let na_want = 1.0 / (2.0 * n_rtf);
    println!(
        "on-axis NA {:?} vs 1/(2N) = {na_want:.4} (N = {n_rtf:.3})",
        sp.na
    );
    assert!(
        sp.na.iter().all(|v| (v / na_want - 1.0).abs() < 0.02),
        "{:?}",
        sp.na
    );
    let point = Spot {
        hits: vec![([0.0, 0.0], 1.0)],
        rms_radius_m: 0.0,
        r995_m: 0.0,
        ..sp.clone()
    };
    let spacing = 0.1e-6;
    let n = 201;
    let ee = |k: &[f32], r_m: f64| -> f64 {
        let h = (n / 2) as f64;
        let mut s = 0.0;
        for r in 0..n {
            for c in 0..n {
                if ((r as f64 - h).hypot(c as f64 - h)) * spacing <= r_m {
                    s += k[r * n + c] as f64;
                }
            }
        }
        // The kernel is not renormalized: its sum is the energy in the window.
        s
    };
    for wl in [450.0, 550.0, 650.0] {
        let first_zero = 1.22 * wl * 1e-9 * n_rtf;
        let airy = &l.with_diffraction(&point.psf(spacing, n), &[wl])[0];
        let full = &l.with_diffraction(&sp.psf(spacing, n), &[wl])[0];
        let (e_airy, e_full) = (ee(airy, first_zero), ee(full, first_zero));
        println!(
            "{wl} nm: first zero {:.3} um; EE there: point {e_airy:.4}, RTF spot {e_full:.4} (spot RMS radius {:.3} um)",
            first_zero * 1e6,
            sp.rms_radius_m * 1e6
        );
        assert!((e_airy - 0.838).abs() < 0.01, "{e_airy}");
        assert!(e_full > 0.75 && e_full <= e_airy + 0.005, "{e_full}");
    }
    assert!(
        sp.rms_radius_m < 0.5 * 1.22 * 550e-9 * n_rtf,
        "on-axis spot RMS radius {} m",
        sp.rms_radius_m
    );
}

/// Relative illumination and flat field: a uniform scene through the RTF blur (blur,
/// distortion, gain) falls off as `Rtf::relative_illumination` at each sample's film height,
/// out to the Zemax table's heights: median deviation under 2e-4 (measured 6e-5), every sample
/// within 0.2 %. Inside a block the unit-sum kernels keep the flat field exactly; at block seams
/// two different kernels meet and a flat field moves by up to ~0.1 % (measured 1.1e-3 at 650 nm on
/// this 14 um grid), the piecewise shift-invariant scheme's own error.
#[test]
fn uniform_scene_follows_the_rtf_relative_illumination() {
    let grid = WavelengthGrid::new(450.0, 650.0, 100.0).unwrap();
    // 14 um samples (10 pixels): the image reaches 3.53 mm at its corner as the IMX363 does.
    let (rows, cols, spacing) = (302usize, 404usize, 14e-6);
    let fov = 2.0 * (cols as f64 * spacing / 2.0 / 4.38e-3).atan().to_degrees();
    let o = Optics::from_config(&config()).unwrap();
    let img = image(rows, cols, grid, fov, |_, _| 1.0);
    let out = o.compute(&img).unwrap();
    let rtf = Rtf::from_file(&rtf_path()).unwrap();
    let zemax = camsim_lens::rtf::read_zemax_relative_illumination(&data(
        "zemax-relative-illumination.txt",
    ))
    .unwrap();
    let (r0, c0) = (out.rows / 2, out.cols / 2);
    let height = |r: usize, c: usize| {
        let (x, y) = (
            (c as f64 + 0.5 - out.cols as f64 / 2.0) * spacing,
            (r as f64 + 0.5 - out.rows as f64 / 2.0) * spacing,
        );
        x.hypot(y) * 1e3
    };
    // Per band: the axial irradiance (the camera equation) over the RI at the centre sample.
    let ri0 = rtf.relative_illumination(&[height(r0, c0)], RI_GRID)[0].unwrap();
    let e0: Vec<f64> = (0..out.bands())
        .map(|b| out.data[(b * out.rows + r0) * out.cols + c0] as f64 / ri0)
        .collect();
    let diag = (out.rows as f64).hypot(out.cols as f64) / 2.0;
    let mut worst = 0.0f64;
    let mut devs = Vec::new();
    for row in zemax.iter().filter(|z| z.height_mm <= 3.3) {
        // The sample on the diagonal nearest the listed height (at least 12 samples inside).
        let t = (row.height_mm / (spacing * 1e3) / diag).min(1.0 - 16.0 / diag);
        let (r, c) = (
            (r0 as f64 + t * out.rows as f64 / 2.0) as usize,
            (c0 as f64 + t * out.cols as f64 / 2.0) as usize,
        );
        let h = height(r, c);
        let want = rtf.relative_illumination(&[h], RI_GRID)[0].unwrap();
        for (b, e0b) in e0.iter().enumerate() {
            let got = out.data[(b * out.rows + r) * out.cols + c] as f64 / e0b;
            worst = worst.max((got / want - 1.0).abs());
            devs.push((got / want - 1.0).abs());
            assert!(
                (got / want - 1.0).abs() < 2e-3,
                "band {b}, {h:.3} mm: {got} vs {want}"
            );
        }
        println!(
            "film height {h:.3} mm (Zemax row {:.3} mm): RTF RI {want:.4}, Zemax {:.4}",
            row.height_mm, row.ri
        );
    }
    devs.sort_by(f64::total_cmp);
    let median = devs[devs.len() / 2];
    println!("relative deviation: median {median:.2e}, worst {worst:.2e}");
    assert!(median < 2e-4, "{median}");
}

/// The shading map itself: the relative illumination table the stage applies equals
/// `Rtf::relative_illumination` at the Zemax table's heights within 0.1 % (linear interpolation
/// between its samples), and distortion grows monotonically (the chief rays' film heights).
#[test]
fn shading_map_is_the_rtf_relative_illumination() {
    let l = lens();
    let dz = l.focus_offset_mm(f64::INFINITY).unwrap();
    let maps = l.maps(4.38, f64::INFINITY, dz, 3.6e-3).unwrap();
    let rtf = Rtf::from_file(&rtf_path()).unwrap();
    let zemax = camsim_lens::rtf::read_zemax_relative_illumination(&data(
        "zemax-relative-illumination.txt",
    ))
    .unwrap();
    let interp = |x: f64| {
        let xs = &maps.ri_height_m;
        let i = xs.partition_point(|v| *v < x).clamp(1, xs.len() - 1);
        let t = (x - xs[i - 1]) / (xs[i] - xs[i - 1]);
        maps.ri[i - 1] * (1.0 - t) + maps.ri[i] * t
    };
    let mut worst = 0.0f64;
    for z in &zemax {
        let want = rtf.relative_illumination(&[z.height_mm], RI_GRID)[0].unwrap();
        let got = interp(z.height_mm * 1e-3);
        worst = worst.max((got / want - 1.0).abs());
        assert!(
            (got / want - 1.0).abs() < 1e-3,
            "{} mm: {got} vs {want}",
            z.height_mm
        );
    }
    println!(
        "shading map vs Rtf::relative_illumination at {} Zemax heights: worst {worst:.2e}",
        zemax.len()
    );
    assert!(maps.real_m.windows(2).all(|w| w[1] > w[0]));
}

/// A point source off the axis: its image's centroid is where the RTF's chief ray lands (the
/// distortion), within 0.15 samples.
#[test]
fn point_source_lands_on_the_rtf_chief_ray() {
    let grid = WavelengthGrid::new(550.0, 550.0, 10.0).unwrap();
    let (rows, cols, spacing) = (302usize, 404usize, 14e-6);
    let fov = 2.0 * (cols as f64 * spacing / 2.0 / 4.38e-3).atan().to_degrees();
    let o = Optics::from_config(&config()).unwrap();
    let l = lens();
    for (pr, pc) in [(40usize, 50usize), (151, 390), (280, 210)] {
        let img = image(rows, cols, grid, fov, |r, c| {
            if r == pr && c == pc {
                1.0
            } else {
                0.0
            }
        });
        let out = o.compute(&img).unwrap();
        let v = out.sample_spacing_m;
        let (x, y) = (
            (pc as f64 + 0.5 - cols as f64 / 2.0) * v,
            (pr as f64 + 0.5 - rows as f64 / 2.0) * v,
        );
        let h = x.hypot(y);
        let dz = l.focus_offset_mm(f64::INFINITY).unwrap();
        let real = l
            .chief_height_mm(
                &Field {
                    ideal_height_mm: h * 1e3,
                    image_distance_mm: 4.38,
                    object_distance_mm: f64::INFINITY,
                },
                dz,
            )
            .unwrap()
            * 1e-3;
        let s = real / h;
        let (want_r, want_c) = (
            y * s / v + out.rows as f64 / 2.0 - 0.5,
            x * s / v + out.cols as f64 / 2.0 - 0.5,
        );
        let (mut sw, mut sr, mut sc) = (0.0, 0.0, 0.0);
        for r in (want_r as usize).saturating_sub(4)..=(want_r as usize + 4).min(out.rows - 1) {
            for c in (want_c as usize).saturating_sub(4)..=(want_c as usize + 4).min(out.cols - 1) {
                let w = out.data[r * out.cols + c] as f64;
                (sw, sr, sc) = (sw + w, sr + w * r as f64, sc + w * c as f64);
            }
        }
        let (mr, mc) = (sr / sw, sc / sw);
        println!(
            "point ({pr}, {pc}) at {:.3} mm: distortion {:+.3} %, {:.2} samples; centroid off the chief ray by ({:.3}, {:.3}) samples",
            h * 1e3,
            (s - 1.0) * 100.0,
            h * (s - 1.0) / v,
            mr - want_r,
            mc - want_c
        );
        assert!((mr - want_r).abs() < 0.15 && (mc - want_c).abs() < 0.15);
    }
}

/// Bad input: errors that name the key or file.
#[test]
fn bad_rtf_configs_give_clear_errors() {
    let n = (rtf_f_number() * 100.0).round() / 100.0;
    let rtf = rtf_path();
    let err = |text: &str| -> String {
        match OpticsConfig::from_toml_str(text, "test.toml").and_then(|c| Optics::from_config(&c)) {
            Ok(_) => panic!("accepted: {text}"),
            Err(e) => e.to_string(),
        }
    };
    let base = format!("f_number = {n}\nfocal_length_mm = 4.38\nshading = \"none\"\n");
    let e = err(&format!(
        "{base}blur = {{ method = \"shift-variant\", rtf_file = \"/nonexistent/rtf.json\" }}"
    ));
    assert!(
        e.contains("blur.rtf_file") && e.contains("/nonexistent/rtf.json"),
        "{e}"
    );
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad-rtf.json");
    std::fs::write(&bad, "{ \"thickness\": 1.0 }").unwrap();
    let e = err(&format!(
        "{base}blur = {{ method = \"shift-variant\", rtf_file = \"{}\" }}",
        bad.display()
    ));
    assert!(
        e.contains("blur.rtf_file") && e.contains("bad-rtf.json"),
        "{e}"
    );
    // The pixel4a preset's f/1.73 is the design's; the RTF's pass region is about f/3.4.
    let e = err(&format!(
        "f_number = 1.73\nfocal_length_mm = 4.38\nshading = \"none\"\nblur = {{ method = \"shift-variant\", rtf_file = \"{}\" }}",
        rtf.display()
    ));
    assert!(
        e.contains("f_number") && e.contains(&format!("{n:.2}")),
        "{e}"
    );
    let e = err(&format!(
        "f_number = {n}\nfocal_length_mm = 5.0\nshading = \"none\"\nblur = {{ method = \"shift-variant\", rtf_file = \"{}\" }}",
        rtf.display()
    ));
    assert!(
        e.contains("blur.rtf_file") && e.contains("focal_length_mm"),
        "{e}"
    );
    let e =
        err(&format!("f_number = {n}\nfocal_length_mm = 4.38\nblur = {{ method = \"shift-variant\", rtf_file = \"{}\" }}", rtf.display()));
    assert!(e.contains("shading"), "{e}");
    let e = err(&format!(
        "{base}blur = {{ method = \"shift-variant\", rtf_file = \"{}\", lens_file = \"x.json\" }}",
        rtf.display()
    ));
    assert!(e.contains("one of lens_file, rtf_file"), "{e}");
    let e = err(&format!(
        "{base}blur = {{ method = \"shift-invariant\", rtf_file = \"{}\" }}",
        rtf.display()
    ));
    assert!(e.contains("blur.method"), "{e}");
}

/// The two autofocus criteria agree: this module's image-space one (the on-axis spot's RMS radius
/// on the film) and the renderer camera's object-space one (`Rtf::focus_offset_mm`: the angular
/// spread of the axial film point's rays), at infinity and at 1 m (object distances from the
/// output plane and from the film differ by the lens's 6.8 mm: 0.13 um of focus at 1 m).
#[test]
fn image_and_object_space_autofocus_agree() {
    let l = lens();
    let rtf = Rtf::from_file(&rtf_path()).unwrap();
    for d_mm in [f64::INFINITY, 1000.0] {
        let image = l.focus_offset_mm(d_mm).unwrap();
        let object = rtf.focus_offset_mm(d_mm).unwrap();
        println!(
            "focus at {d_mm} mm: image-space {:.3} um, object-space {:.3} um",
            image * 1e3,
            object * 1e3
        );
        assert!((image - object).abs() < 1e-3, "{image} vs {object} mm");
    }
}
