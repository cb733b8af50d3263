//! pbrt-v4 `Camera "realistic"` (4th ed. sec. 5.3): camera rays traced through a lens
//! prescription (camsim-lens), weighted by cos^4(theta) A / D^2, so a uniform scene images as the
//! camera equation's irradiance with the lens's relative illumination.

use camsim_core::WavelengthGrid;
use camsim_pbrt::parse_str;
use camsim_render::*;
use camsim_scene3d::*;
use std::path::PathBuf;

use crate::common;
fn dgauss() -> String {
    concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../../shared/data/isetcornellbox/lens/dgauss.82deg.4.38mm.json"
    )
    .to_string()
}

fn scene_text(camera: &str, film: &str, world: &str) -> String {
    format!("LookAt 0 0 0  0 0 1  0 1 0\n{camera}\n{film}\nWorldBegin\n{world}\n")
}

fn realistic(lens: &str, aperture_mm: f64, focus_m: f64) -> String {
    format!("Camera \"realistic\" \"string lensfile\" \"{lens}\" \"float aperturediameter\" {aperture_mm} \"float focusdistance\" {focus_m}")
}

fn render_scene(mut s: SceneDescription, spp: u32) -> RenderOutput {
    s.settings.grid = WavelengthGrid::new(400.0, 700.0, 10.0).unwrap();
    s.settings.samples_per_pixel = spp;
    s.settings.wavelengths_per_path = 4;
    s.settings.seed = 11;
    s.settings.max_depth = 1;
    render(&s, &|_, _| {}).unwrap()
}

/// Per-pixel radiance summed over bands, row-major.
fn band_sum(out: &RenderOutput) -> Vec<f64> {
    let img = &out.radiance;
    let mut v = vec![0f64; img.rows * img.cols];
    for b in 0..img.bands() {
        for (a, x) in v.iter_mut().zip(img.band(b)) {
            *a += *x as f64;
        }
    }
    v
}

/// Largest angle from the axis (rad) of a ray leaving the film centre that passes the lens, by
/// bisection: for a rotationally symmetric lens the passing rays from the axial film point fill a
/// cone, so E / L = pi sin^2(theta_max) (the camera equation; Kingslake, Optical System Design,
/// sec. 6.5).
fn axial_cone_half_angle_rad(cam: &camsim_lens::LensCamera, wavelength_nm: f64) -> f64 {
    let passes = |t: f64| {
        cam.trace_ray([0.0, 0.0], [t.sin(), 0.0, -t.cos()], wavelength_nm)
            .is_some()
    };
    assert!(passes(1e-4));
    let (mut lo, mut hi) = (1e-4, 1.5);
    assert!(!passes(hi));
    for _ in 0..60 {
        let m = 0.5 * (lo + hi);
        if passes(m) {
            lo = m
        } else {
            hi = m
        }
    }
    lo
}

#[test]
fn uniform_sky_gives_camera_equation_and_relative_illumination() {
    let n = 41usize;
    let diag_mm = 4.0;
    let text = scene_text(
        &realistic(&dgauss(), 1.2, 0.5),
        &format!("Film \"spectral\" \"integer xresolution\" {n} \"integer yresolution\" {n} \"float diagonal\" {diag_mm}"),
        "LightSource \"infinite\" \"rgb L\" [1 1 1]",
    );
    let scene = parse_str(&text, "/tmp/realistic.pbrt").unwrap();
    let lens = scene
        .camera
        .lens
        .as_ref()
        .and_then(|l| l.realistic())
        .cloned()
        .unwrap();
    let mut pinhole = scene.clone();
    pinhole.camera.lens = None;
    // The sky's radiance through a pinhole: L per pixel.
    let l_ref = band_sum(&render_scene(pinhole, 4));
    let l_mean = l_ref.iter().sum::<f64>() / l_ref.len() as f64;
    let out = render_scene(scene, 256);
    let e = band_sum(&out);

    // Centre: the 3 x 3 central pixels against pi sin^2(theta_max) L (dgauss has no dispersion).
    let theta = axial_cone_half_angle_rad(&lens.camera, 550.0);
    let expect = std::f64::consts::PI * theta.sin().powi(2);
    let c = n / 2;
    let centre: f64 = (c - 1..=c + 1)
        .flat_map(|r| (c - 1..=c + 1).map(move |q| (r, q)))
        .map(|(r, q)| e[r * n + q])
        .sum::<f64>()
        / 9.0;
    let ratio = centre / l_mean;
    eprintln!(
        "theta_max {:.4} deg, E/L expected {expect:.5} sr, rendered {ratio:.5} sr",
        theta.to_degrees()
    );
    assert!(
        (ratio / expect - 1.0).abs() < 0.03,
        "centre E/L {ratio} vs camera equation {expect}"
    );

    // Fall-off: pixels binned by film radius against LensCamera::relative_illumination.
    let half = camera::film_half_extent_mm(diag_mm, n, n);
    let r_max = half[0].hypot(half[1]);
    let heights: Vec<f64> = (0..=16).map(|i| r_max * i as f64 / 16.0).collect();
    let ri = lens.camera.relative_illumination(&heights, 96, 550.0);
    let ri_at = |h: f64| {
        let t = (h / r_max * 16.0).min(15.999);
        let i = t.floor() as usize;
        ri[i] + (ri[i + 1] - ri[i]) * (t - i as f64)
    };
    let bins = 5;
    let (mut got, mut want, mut cnt) = (vec![0f64; bins], vec![0f64; bins], vec![0usize; bins]);
    for r in 0..n {
        for q in 0..n {
            let fx = (2.0 * (q as f64 + 0.5) / n as f64 - 1.0) * half[0];
            let fy = (2.0 * (r as f64 + 0.5) / n as f64 - 1.0) * half[1];
            let h = fx.hypot(fy);
            let b = ((h / r_max) * bins as f64).floor() as usize;
            got[b] += e[r * n + q] / l_mean / expect;
            want[b] += ri_at(h);
            cnt[b] += 1;
        }
    }
    for b in 0..bins {
        let (g, w) = (got[b] / cnt[b] as f64, want[b] / cnt[b] as f64);
        eprintln!(
            "radius bin {b}: rendered {g:.4}, relative illumination {w:.4} ({} px)",
            cnt[b]
        );
        assert!(
            (g - w).abs() < 0.03 * w.max(0.05),
            "bin {b}: rendered {g} vs relative illumination {w}"
        );
    }
    // The fall-off is real (not a flat image that matches trivially).
    assert!(want[bins - 1] / (cnt[bins - 1] as f64) < 0.9 * want[0] / cnt[0] as f64);
}

/// RMS width (pixels) across columns of the image of a vertical line, from the central rows.
fn line_rms_width_px(out: &RenderOutput) -> f64 {
    let (rows, cols) = (out.radiance.rows, out.radiance.cols);
    let e = band_sum(out);
    let mut p = vec![0f64; cols];
    for r in rows / 4..3 * rows / 4 {
        for q in 0..cols {
            p[q] += e[r * cols + q];
        }
    }
    let s: f64 = p.iter().sum();
    assert!(s > 0.0);
    let m: f64 = p.iter().enumerate().map(|(q, v)| q as f64 * v).sum::<f64>() / s;
    (p.iter()
        .enumerate()
        .map(|(q, v)| (q as f64 - m).powi(2) * v)
        .sum::<f64>()
        / s)
        .sqrt()
}

#[test]
fn line_at_focus_is_sharp_and_defocused_line_is_blurred() {
    // A 0.5 mm wide emitting strip 0.5 m away: its geometric image (~4 um) is under a pixel.
    let world = "AttributeBegin\nAreaLightSource \"diffuse\" \"rgb L\" [1 1 1] \"bool twosided\" true\n\
                 Shape \"trianglemesh\" \"integer indices\" [0 1 2 0 2 3] \"point3 P\" [-0.00025 -0.05 0.5  0.00025 -0.05 0.5  0.00025 0.05 0.5  -0.00025 0.05 0.5]\nAttributeEnd";
    let film = "Film \"spectral\" \"integer xresolution\" 64 \"integer yresolution\" 32 \"float diagonal\" 1.0";
    let scene = |focus_m: f64| {
        parse_str(
            &scene_text(&realistic(&dgauss(), 1.2, focus_m), film, world),
            "/tmp/realistic.pbrt",
        )
        .unwrap()
    };
    let sharp = line_rms_width_px(&render_scene(scene(0.5), 64));
    let defocused = scene(0.05);
    let cam = defocused
        .camera
        .lens
        .as_ref()
        .and_then(|l| l.realistic())
        .unwrap()
        .camera
        .clone();
    let blurred = line_rms_width_px(&render_scene(defocused, 64));
    // Geometric prediction: the blur disk of the axial point of the line, from rays traced
    // forward (object to film) through the lens; a uniform disk of radius R projects onto x with
    // RMS width R / 2.
    let pitch_mm = 2.0 * camera::film_half_extent_mm(1.0, 64, 32)[0] / 64.0;
    let film_z = cam.film_z_mm();
    let obj = [0.0, 0.0, film_z - 500.0];
    let a = cam.lens.surfaces[0].semi_aperture_mm;
    let mut r_blur_mm = 0f64;
    for i in 0..=400 {
        let x = -a + 2.0 * a * i as f64 / 400.0;
        let ray = camsim_lens::Ray::new(obj, [x, 0.0, -obj[2]]);
        if let Ok(out) = cam.lens.trace_forward(&ray, 550.0) {
            let t = (film_z - out.origin_mm[2]) / out.direction[2];
            r_blur_mm = r_blur_mm.max((out.origin_mm[0] + t * out.direction[0]).abs());
        }
    }
    let predicted = (r_blur_mm / 2.0 / pitch_mm).hypot(sharp);
    eprintln!(
        "line RMS width: focused at the line {sharp:.3} px, focused at 0.05 m {blurred:.3} px (geometric blur disk radius {:.2} px: predicted {predicted:.3} px)",
        r_blur_mm / pitch_mm
    );
    assert!(sharp < 1.0, "in-focus line RMS width {sharp} px");
    assert!(
        blurred > 3.0 * sharp,
        "defocused {blurred} px vs focused {sharp} px"
    );
    assert!(
        (blurred / predicted - 1.0).abs() < 0.2,
        "defocused {blurred} px vs geometric {predicted} px"
    );
}

#[test]
fn parser_reads_realistic_camera_and_reports_bad_lens() {
    let dir = tempfile::tempdir().unwrap();
    let lens_path = dir.path().join("dgauss.json");
    std::fs::copy(dgauss(), &lens_path).unwrap();
    let film = "Film \"spectral\" \"integer xresolution\" 16 \"integer yresolution\" 8";
    let world = "LightSource \"infinite\" \"rgb L\" [1 1 1]";
    let scene_path: PathBuf = dir.path().join("s.pbrt");
    // Relative to the scene file.
    let s = parse_str(
        &scene_text(&realistic("dgauss.json", 1.0, 0.5), film, world),
        &scene_path,
    )
    .unwrap();
    let l = s
        .camera
        .lens
        .as_ref()
        .and_then(|l| l.realistic())
        .expect("a realistic camera");
    assert_eq!(l.film_diagonal_mm, 35.0);
    assert_eq!(s.focus_distance_m, Some(0.5));
    // Stop opened to 1.0 mm: semi-aperture 0.5 mm.
    let stop = l.camera.lens.stop_index();
    assert!((l.camera.lens.surfaces[stop].semi_aperture_mm - 0.5).abs() < 1e-12);
    assert!(l.camera.film_distance_mm > 0.0);

    // The same prescription as a pbrt-v4 lens text file (radius, thickness, ior, aperture
    // diameter per line, mm) focuses to the same film distance.
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dgauss()).unwrap()).unwrap();
    let mut dat = String::from("# dgauss from the ISET3d JSON\n");
    for sf in json["surfaces"].as_array().unwrap() {
        let f = |k: &str| sf[k].as_f64().unwrap();
        dat += &format!(
            "{} {} {} {}\n",
            f("radius"),
            f("thickness"),
            f("ior"),
            2.0 * f("semi_aperture")
        );
    }
    std::fs::write(dir.path().join("dgauss.dat"), dat).unwrap();
    let s2 = parse_str(
        &scene_text(&realistic("dgauss.dat", 1.0, 0.5), film, world),
        &scene_path,
    )
    .unwrap();
    let d2 = s2
        .camera
        .lens
        .as_ref()
        .and_then(|l| l.realistic())
        .unwrap()
        .camera
        .film_distance_mm;
    assert!(
        (d2 - l.camera.film_distance_mm).abs() < 1e-9,
        "{d2} vs {}",
        l.camera.film_distance_mm
    );

    let e = parse_str(
        &scene_text(&realistic("missing.json", 1.0, 0.5), film, world),
        &scene_path,
    )
    .unwrap_err();
    let msg = e.to_string();
    assert!(
        msg.contains("s.pbrt:2:1") && msg.contains("missing.json"),
        "{msg}"
    );
    // 1 mm in front of the first vertex: inside the focal length, no real image to focus on.
    let e = parse_str(
        &scene_text(&realistic("dgauss.json", 1.0, 0.001), film, world),
        &scene_path,
    )
    .unwrap_err();
    let msg = e.to_string();
    assert!(
        msg.contains("s.pbrt:2:1") && msg.contains("realistic"),
        "{msg}"
    );
    eprintln!("{msg}");
}

/// Centroid (column, row) of the image, pixels, relative to the image centre.
fn centroid_px(out: &RenderOutput) -> (f64, f64) {
    let (rows, cols) = (out.radiance.rows, out.radiance.cols);
    let e = band_sum(out);
    let (mut s, mut sx, mut sy) = (0.0, 0.0, 0.0);
    for r in 0..rows {
        for q in 0..cols {
            let v = e[r * cols + q];
            s += v;
            sx += v * (q as f64 + 0.5 - cols as f64 / 2.0);
            sy += v * (r as f64 + 0.5 - rows as f64 / 2.0);
        }
    }
    assert!(s > 0.0);
    (sx / s, sy / s)
}

#[test]
fn image_is_upright_like_the_pinhole_camera() {
    // A 2 mm emitting square right of and above the axis, 0.5 m away: the lens inverts the image
    // on the film and the camera reads the film so that it lands where a pinhole camera of the
    // same field shows it (not mirrored, not upside down).
    let world = "AttributeBegin\nAreaLightSource \"diffuse\" \"rgb L\" [1 1 1] \"bool twosided\" true\n\
                 Shape \"trianglemesh\" \"integer indices\" [0 1 2 0 2 3] \"point3 P\" [0.009 0.004 0.5  0.011 0.004 0.5  0.011 0.006 0.5  0.009 0.006 0.5]\nAttributeEnd";
    let film = "Film \"spectral\" \"integer xresolution\" 64 \"integer yresolution\" 48 \"float diagonal\" 1.0";
    let s = parse_str(
        &scene_text(&realistic(&dgauss(), 1.2, 0.5), film, world),
        "/tmp/realistic.pbrt",
    )
    .unwrap();
    let mut pinhole = s.clone();
    pinhole.camera.lens = None;
    let (px, py) = centroid_px(&render_scene(pinhole, 16));
    let (lx, ly) = centroid_px(&render_scene(s, 64));
    eprintln!("centroid from the image centre: pinhole ({px:.2}, {py:.2}) px, realistic ({lx:.2}, {ly:.2}) px");
    assert!(
        px.abs() > 3.0 && py.abs() > 1.5,
        "the square is off-axis in the pinhole image"
    );
    // Same side in both axes, and the same place (the pinhole-equivalent field uses the chief
    // ray's image distance; distortion is small this close to the axis).
    assert!(
        lx * px > 0.0 && ly * py > 0.0,
        "mirrored: pinhole ({px}, {py}), realistic ({lx}, {ly})"
    );
    for (a, b) in [(lx, px), (ly, py)] {
        assert!(
            (a / b - 1.0).abs() < 0.05,
            "image position {a} px vs pinhole {b} px"
        );
    }
}

#[test]
fn realistic_render_is_the_same_for_any_thread_count() {
    let text = scene_text(
        &realistic(&dgauss(), 1.2, 0.5),
        "Film \"spectral\" \"integer xresolution\" 40 \"integer yresolution\" 24 \"float diagonal\" 3.0",
        "LightSource \"infinite\" \"rgb L\" [1 1 1]",
    );
    let scene = parse_str(&text, "/tmp/realistic.pbrt").unwrap();
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap()
        .install(|| render_scene(scene.clone(), 8));
    let many = rayon::ThreadPoolBuilder::new()
        .num_threads(3)
        .build()
        .unwrap()
        .install(|| render_scene(scene, 8));
    assert!(one.radiance.data.iter().any(|v| *v > 0.0));
    assert_eq!(one.radiance.data, many.radiance.data);
}

/// The depth map lines up with the image through the lens at a near focus: its pinhole sits at
/// the lens's entrance pupil with the image distance of a chief ray near the axis. An emitting
/// half-plane at 0.3 m (the focus) whose edge sits 90 % of the way to the right border of a 320
/// x 4 film of 5 um pixels (dgauss 4.38 mm, 1.2 mm aperture): the lens image's 50 % crossing and
/// the depth map's first finite pixel agree within 0.6 pixel (distortion included); a pinhole on
/// the film instead of the pupil (2.2 mm in front) would see it 1.1 pixels off.
#[test]
fn the_depth_map_lines_up_with_the_near_focused_lens_image() {
    let (w, h) = (320usize, 4usize);
    let pitch_mm = 5e-3;
    let diag_mm = (w as f64).hypot(h as f64) * pitch_mm;
    let z = 0.3;
    let film = format!("Film \"spectral\" \"integer xresolution\" {w} \"integer yresolution\" {h} \"float diagonal\" {diag_mm}");
    let world = |x0: f64| {
        format!(
            "AttributeBegin\nAreaLightSource \"diffuse\" \"rgb L\" [1 1 1] \"bool twosided\" true\n\
             Shape \"bilinearmesh\" \"point3 P\" [{x0} -1 {z}  1 -1 {z}  {x0} 1 {z}  1 1 {z}]\nAttributeEnd"
        )
    };
    let probe = parse_str(
        &scene_text(&realistic(&dgauss(), 1.2, z), &film, &world(0.5)),
        "/tmp/real-depth.pbrt",
    )
    .unwrap();
    let Some(CameraLens::Realistic(lens)) = probe.camera.lens.clone() else {
        panic!("a realistic camera")
    };
    let x0 =
        0.9 * (w as f64 / 2.0) * pitch_mm / lens.image_distance_mm * (z - lens.pupil_z_mm * 1e-3);
    let s = parse_str(
        &scene_text(&realistic(&dgauss(), 1.2, z), &film, &world(x0)),
        "/tmp/real-depth.pbrt",
    )
    .unwrap();
    let out = render_scene(s, 64);
    let prof: Vec<f64> = {
        let e = band_sum(&out);
        (0..w).map(|c| (0..h).map(|r| e[r * w + c]).sum()).collect()
    };
    let lens_x = common::half_crossing_px(&prof);
    let depth_x = common::first_finite_px(&out.depth_m, w, 1);
    // Where a pinhole on the film (same image distance) would see the edge, from the 90 % mark.
    let off = 0.9 * w as f64 / 2.0;
    let on_film_px = off * (z - lens.pupil_z_mm * 1e-3) / z - off;
    eprintln!(
        "edge: lens image {lens_x:.2} px, depth map {depth_x:.0} px (pupil {:.3} mm before the film, v = {:.4} mm, paraxial {:.4} mm; a pinhole on the film: {on_film_px:+.2} px)",
        lens.pupil_z_mm,
        lens.image_distance_mm,
        camsim_scene3d::camera::pinhole_image_distance_mm(&lens.camera)
    );
    assert!(
        on_film_px.abs() > 0.9,
        "the test must tell the pupil from the film: {on_film_px}"
    );
    assert!(
        (lens_x - depth_x).abs() < 0.6,
        "lens edge {lens_x} px vs depth edge {depth_x} px"
    );
}
