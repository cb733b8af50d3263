//! ISET3d's `Camera "raytransfer"`: camera rays mapped through the Pixel 4a rear lens's
//! ray-transfer function (Goossens et al. 2022, ISET/isetcornellbox), weighted by their projected
//! solid angle, so a uniform scene images with the irradiance and the relative illumination the
//! RTF implies.

use camsim_core::WavelengthGrid;
use camsim_lens::Rtf;
use camsim_pbrt::parse_str;
use camsim_render::*;
use camsim_scene3d::*;
use std::path::Path;

use crate::common;
const LENS_DIR: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../../shared/data/isetcornellbox/lens"
);

fn rtf_path() -> String {
    format!("{LENS_DIR}/pixel4a-rearcamera-ellipse-raytransfer.json")
}

/// The shipped RTF's `planeoffsetinput`: a `filmdistance` of this puts the film on the input plane.
const INPUT_PLANE_MM: f64 = 0.464135918;

fn scene_text(n: usize, diagonal_mm: f64) -> String {
    sky_scene(
        n,
        diagonal_mm,
        &format!("\"float filmdistance\" {INPUT_PLANE_MM}"),
    )
}

/// A uniform sky through the RTF camera with extra `Camera` parameters `film`.
fn sky_scene(n: usize, diagonal_mm: f64, film: &str) -> String {
    format!(
        "LookAt 0 0 0  0 0 1  0 1 0\nCamera \"raytransfer\" \"string lensfile\" \"{}\" {film}\n\
         Film \"spectral\" \"integer xresolution\" {n} \"integer yresolution\" {n} \"float diagonal\" {diagonal_mm}\n\
         WorldBegin\nLightSource \"infinite\" \"rgb L\" [1 1 1]\n",
        rtf_path()
    )
}

/// Projected solid angle (sr) of the directions the RTF passes from the axial film point `dz` mm
/// behind its input plane, summed over a fine (theta, phi) grid with `Rtf::trace`'s own pass test
/// at each ray's input-plane crossing (cos(theta) sin(theta) dtheta dphi): independent of the
/// ellipse sampling the camera uses.
fn brute_force_axial_sr(rtf: &Rtf, dz: f64) -> f64 {
    let (nt, np) = (600usize, 256usize);
    let theta_max = 0.6f64;
    let mut brute = 0.0;
    for i in 0..nt {
        let t = (i as f64 + 0.5) * theta_max / nt as f64;
        for j in 0..np {
            let ph = (j as f64 + 0.5) * std::f64::consts::TAU / np as f64;
            let d = [t.sin() * ph.cos(), t.sin() * ph.sin(), t.cos()];
            let pin = [d[0] / d[2] * dz, d[1] / d[2] * dz];
            if rtf.trace(pin, d).is_some() {
                brute += t.cos()
                    * t.sin()
                    * (theta_max / nt as f64)
                    * (std::f64::consts::TAU / np as f64);
            }
        }
    }
    brute
}

fn render_scene(mut s: SceneDescription, spp: u32) -> Vec<f64> {
    s.settings.grid = WavelengthGrid::new(400.0, 700.0, 20.0).unwrap();
    s.settings.samples_per_pixel = spp;
    s.settings.seed = 5;
    s.settings.max_depth = 1;
    let out = render(&s, &|_, _| {}).unwrap();
    let img = &out.radiance;
    let mut v = vec![0f64; img.rows * img.cols];
    for b in 0..img.bands() {
        for (a, x) in v.iter_mut().zip(img.band(b)) {
            *a += *x as f64;
        }
    }
    v
}

#[test]
fn uniform_sky_gives_the_camera_equation_and_the_rtf_relative_illumination() {
    let (n, diagonal_mm) = (33usize, 6.0);
    let scene = parse_str(&scene_text(n, diagonal_mm), "/tmp/rtf.pbrt").unwrap();
    let Some(CameraLens::RayTransfer(lens)) = scene.camera.lens.clone() else {
        panic!("a ray-transfer camera")
    };
    // The focal length the RTF implies (Abbe sine condition): the lens is a 4.38 mm lens.
    assert!(
        (lens.focal_length_mm / 4.38 - 1.0).abs() < 0.01,
        "f = {} mm",
        lens.focal_length_mm
    );
    let mut pinhole = scene.clone();
    pinhole.camera.lens = None;
    let l_ref = render_scene(pinhole, 2);
    let l_mean = l_ref.iter().sum::<f64>() / l_ref.len() as f64;
    let e = render_scene(scene, 256);

    // Centre against an independent integral (the film on the input plane).
    let rtf = Rtf::from_file(Path::new(&rtf_path())).unwrap();
    assert_eq!(lens.film_offset_mm, 0.0);
    let brute = brute_force_axial_sr(&rtf, 0.0);
    let omega = rtf.irradiance(0.0, 400).unwrap();
    let c = n / 2;
    let centre = (c - 1..=c + 1)
        .flat_map(|r| (c - 1..=c + 1).map(move |q| r * n + q))
        .map(|i| e[i])
        .sum::<f64>()
        / 9.0
        / l_mean;
    // For the record: the camera equation at Zemax's axial working f-number 1.8308 would give
    // pi / (4 N^2) = 0.234 sr; this RTF's pass ellipse (radius 0.38 mm at 2.589 mm) passes only
    // a cone of NA 0.146 (about f/3.4), so its absolute irradiance is 3.5x lower (its relative
    // illumination agrees with Zemax within 0.014).
    eprintln!("centre E/L {centre:.5} sr; RTF ellipse integral {omega:.5} sr; brute-force pass test {brute:.5} sr");
    assert!(
        (omega / brute - 1.0).abs() < 0.01,
        "ellipse integral {omega} vs brute force {brute}"
    );
    assert!(
        (centre / brute - 1.0).abs() < 0.02,
        "rendered {centre} vs {brute}"
    );

    // Fall-off with film height, binned, against Rtf::relative_illumination.
    let half = camera::film_half_extent_mm(diagonal_mm, n, n);
    let r_max = half[0].hypot(half[1]);
    let bins = 5;
    let (mut got, mut want, mut cnt) = (vec![0f64; bins], vec![0f64; bins], vec![0usize; bins]);
    for r in 0..n {
        for q in 0..n {
            let fx = (2.0 * (q as f64 + 0.5) / n as f64 - 1.0) * half[0];
            let fy = (2.0 * (r as f64 + 0.5) / n as f64 - 1.0) * half[1];
            let h = fx.hypot(fy);
            let b = ((h / r_max) * bins as f64).floor().min(bins as f64 - 1.0) as usize;
            got[b] += e[r * n + q] / l_mean / omega;
            want[b] += rtf.relative_illumination(&[h], 100)[0].unwrap();
            cnt[b] += 1;
        }
    }
    for b in 0..bins {
        let (g, w) = (got[b] / cnt[b] as f64, want[b] / cnt[b] as f64);
        eprintln!("film height bin {b}: rendered RI {g:.4}, RTF {w:.4}");
        assert!((g / w - 1.0).abs() < 0.02, "bin {b}: {g} vs {w}");
    }
    // The corners are dimmer than the centre by the lens's fall-off (about 0.5 at 3 mm).
    assert!(want[bins - 1] / (cnt[bins - 1] as f64) < 0.7);
}

#[test]
fn a_film_larger_than_the_rtf_field_is_refused_naming_the_camera() {
    let e = parse_str(&scene_text(8, 8.0), "/tmp/rtf-big.pbrt")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("rtf-big.pbrt:2:") && e.contains("raytransfer") && e.contains("diagonal"),
        "{e}"
    );
    // Film placement: both ways at once, a film behind the pass plane, and a focus too near.
    for (params, want) in [
        (
            "\"float filmdistance\" 0.5 \"float focusdistance\" 1",
            "not both",
        ),
        ("\"float filmdistance\" -3", "filmdistance"),
        ("\"float focusdistance\" 0", "focusdistance"),
        ("\"float focusdistance\" 0.005", "inside the lens"),
    ] {
        let e = parse_str(&sky_scene(8, 1.0, params), "/tmp/rtf-film.pbrt")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("rtf-film.pbrt:2:") && e.contains(want),
            "{params}: {e}"
        );
    }
    let missing = "LookAt 0 0 0  0 0 1  0 1 0\nCamera \"raytransfer\" \"string lensfile\" \"nowhere.json\"\nWorldBegin\n";
    let e = parse_str(missing, "/tmp/rtf-missing.pbrt")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("rtf-missing.pbrt:2:") && e.contains("nowhere.json"),
        "{e}"
    );
}

/// The film off the input plane: autofocus at infinity (the default) and at 0.1 m, and an explicit
/// `filmdistance`. The centre's irradiance of a uniform sky must equal the brute-force pass-test
/// integral from the displaced film point (which checks that the camera's enlarged sampling
/// ellipse holds every ray that passes: a ray it missed would make the render darker).
#[test]
fn a_film_off_the_input_plane_keeps_the_irradiance_of_the_rays_that_pass() {
    let n = 9usize;
    let rtf = Rtf::from_file(Path::new(&rtf_path())).unwrap();
    for film in [
        "",
        "\"float focusdistance\" 0.1",
        "\"float filmdistance\" 0.52",
    ] {
        let scene = parse_str(&sky_scene(n, 0.05, film), "/tmp/rtf-film.pbrt").unwrap();
        let Some(CameraLens::RayTransfer(lens)) = scene.camera.lens.clone() else {
            panic!("a ray-transfer camera")
        };
        let dz = lens.film_offset_mm;
        let mut pinhole = scene.clone();
        pinhole.camera.lens = None;
        let l_ref = render_scene(pinhole, 1);
        let l_mean = l_ref.iter().sum::<f64>() / l_ref.len() as f64;
        let e = render_scene(scene, 1024);
        let centre = e[(n / 2) * n + n / 2] / l_mean;
        let brute = brute_force_axial_sr(&rtf, dz);
        eprintln!("film {film:?}: {:.2} um behind the input plane; centre E/L {centre:.5} sr, brute force {brute:.5} sr", dz * 1e3);
        assert!(
            (centre / brute - 1.0).abs() < 0.01,
            "{film}: rendered {centre} vs {brute}"
        );
        if film.contains("filmdistance") {
            assert!((dz - (0.52 - INPUT_PLANE_MM)).abs() < 1e-12, "{dz}");
        }
    }
}

/// Width (pixels) between the 10 % and 90 % points of a dark-to-bright edge along the rows of an
/// `n` x `n` image (mean profile over the middle half of the rows).
fn edge_width_px(img: &[f64], n: usize) -> f64 {
    let mut prof = vec![0f64; n];
    for r in n / 4..3 * n / 4 {
        for (c, p) in prof.iter_mut().enumerate() {
            *p += img[r * n + c];
        }
    }
    let (lo, hi) = (
        prof[..4].iter().sum::<f64>() / 4.0,
        prof[n - 4..].iter().sum::<f64>() / 4.0,
    );
    let cross = |level: f64| -> f64 {
        let t = lo + level * (hi - lo);
        let i = (1..n)
            .find(|&i| (prof[i - 1] - t) * (prof[i] - t) <= 0.0 && prof[i] != prof[i - 1])
            .expect("the edge crosses the level");
        (i - 1) as f64 + (t - prof[i - 1]) / (prof[i] - prof[i - 1])
    };
    (cross(0.9) - cross(0.1)).abs()
}

/// Focus: an emitting half-plane's edge at infinity (100 m) and at 0.3 m, imaged on 1.1 um
/// pixels. The film on the RTF's input plane is 16.6 um from the infinity focus: a blur circle of
/// 16.6 um / f/3.44 = 4.8 um, about 4 pixels; the autofocused film images the edge within about a
/// pixel (the RTF's own spot is 0.27 um RMS; pixel footprint and the edge's sampling remain). A
/// plane at 0.3 m is sharp with `focusdistance 0.3` and blurred by the infinity focus (the film
/// moves f^2 / d = 64 um: a 19 um blur circle).
#[test]
fn autofocus_sharpens_the_edge_the_input_plane_film_blurs() {
    let n = 48usize;
    let diag_mm = 2f64.sqrt() * n as f64 * 1.1e-3;
    let edge = |z: f64, film: &str| -> (f64, f64) {
        let w = 2.0 * z;
        let text = format!(
            "LookAt 0 0 0  0 0 1  0 1 0\nCamera \"raytransfer\" \"string lensfile\" \"{}\" {film}\n\
             Film \"spectral\" \"integer xresolution\" {n} \"integer yresolution\" {n} \"float diagonal\" {diag_mm}\n\
             PixelFilter \"box\"\nWorldBegin\nAttributeBegin\nAreaLightSource \"diffuse\" \"rgb L\" [1 1 1] \"bool twosided\" true\n\
             Shape \"bilinearmesh\" \"point3 P\" [0 {m} {z}  {w} {m} {z}  0 {w} {z}  {w} {w} {z}]\nAttributeEnd\n",
            rtf_path(),
            m = -w
        );
        let scene = parse_str(&text, "/tmp/rtf-edge.pbrt").unwrap();
        let Some(CameraLens::RayTransfer(lens)) = scene.camera.lens.clone() else {
            panic!("a ray-transfer camera")
        };
        (
            edge_width_px(&render_scene(scene, 256), n),
            lens.film_offset_mm,
        )
    };
    let input_plane = format!("\"float filmdistance\" {INPUT_PLANE_MM}");
    let (far_on_input, _) = edge(100.0, &input_plane);
    let (far_focused, dz_inf) = edge(100.0, "");
    let (near_focused, dz_near) = edge(0.3, "\"float focusdistance\" 0.3");
    let (near_at_inf, _) = edge(0.3, "");
    eprintln!(
        "10-90 % edge width, px: infinity: film on the input plane {far_on_input:.2}, autofocus ({:.2} um) {far_focused:.2}; \
         0.3 m: focused ({:.2} um) {near_focused:.2}, at the infinity focus {near_at_inf:.2}",
        dz_inf * 1e3,
        dz_near * 1e3
    );
    assert!(
        (dz_inf - 0.0166).abs() < 0.001,
        "infinity focus {dz_inf} mm"
    );
    // Newton's lens equation: the film moves f^2 / x for an object x in front of the front focal
    // point (x = 0.3 m less about f and the lens: within 5 %).
    let newton = 4.38f64.powi(2) / (300.0 - 4.38 - 5.0);
    assert!(
        ((dz_near - dz_inf) / newton - 1.0).abs() < 0.05,
        "near focus moved {} mm vs f^2/x = {newton} mm",
        dz_near - dz_inf
    );
    assert!(
        far_focused < 1.6 && far_on_input > 2.0 * far_focused,
        "{far_focused} vs {far_on_input}"
    );
    assert!(
        near_focused < 1.6 && near_at_inf > 4.0 * near_focused,
        "{near_focused} vs {near_at_inf}"
    );
}

/// The depth map (and so the object ids, which come from the same pinhole rays) lines up with the
/// image through the lens when the film is focused near: the pinhole-equivalent image distance is
/// the focal length plus the film's move from the infinity focus (Newton), not the focal length.
/// The pinhole sits at the entrance pupil (4.67 mm in front of the film for the Pixel 4a RTF at
/// this focus: the centre of perspective) with the image distance of a chief ray near the axis.
/// An emitting half-plane at 0.3 m whose edge sits 90 % of the way to the right border, on a 320 x
/// 4 film of 5 um pixels: the lens image's 50 % crossing and the depth map's first finite pixel
/// agree within a pixel (the lens's distortion at 0.73 mm, +0.3 %, is 0.4 px of it); a pinhole
/// on the film at the focal length would be 2.3 % (3.3 px) off, and one at the focal length plus
/// the film's move, but on the film, 1.5 % (the pupil's 4.7 mm of 300).
#[test]
fn the_depth_map_lines_up_with_the_near_focused_lens_image() {
    let (w, h) = (320usize, 4usize);
    let pitch_mm = 5e-3;
    let diag_mm = (w as f64).hypot(h as f64) * pitch_mm;
    let z = 0.3;
    let text = format!(
        "LookAt 0 0 0  0 0 1  0 1 0\nCamera \"raytransfer\" \"string lensfile\" \"{}\" \"float focusdistance\" {z}\n\
         Film \"spectral\" \"integer xresolution\" {w} \"integer yresolution\" {h} \"float diagonal\" {diag_mm}\nPixelFilter \"box\"\nWorldBegin\nAttributeBegin\n\
         AreaLightSource \"diffuse\" \"rgb L\" [1 1 1] \"bool twosided\" true\n\
         Shape \"bilinearmesh\" \"point3 P\" [X -1 {z}  1 -1 {z}  X 1 {z}  1 1 {z}]\nAttributeEnd\n",
        rtf_path()
    );
    // The edge's x at 0.3 m for 90 % of the half film width through the (near-focus) pinhole at
    // the entrance pupil.
    let probe = parse_str(&text.replace('X', "0.5"), "/tmp/rtf-depth.pbrt").unwrap();
    let Some(CameraLens::RayTransfer(lens)) = probe.camera.lens.clone() else {
        panic!("a ray-transfer camera")
    };
    let x0 =
        0.9 * (w as f64 / 2.0) * pitch_mm / lens.image_distance_mm * (z - lens.pupil_z_mm * 1e-3);
    let mut scene = parse_str(&text.replace('X', &format!("{x0}")), "/tmp/rtf-depth.pbrt").unwrap();
    scene.settings.grid = WavelengthGrid::new(500.0, 600.0, 50.0).unwrap();
    scene.settings.samples_per_pixel = 64;
    scene.settings.max_depth = 1;
    let out = render(&scene, &|_, _| {}).unwrap();
    let mut prof = vec![0f64; w];
    for b in 0..out.radiance.bands() {
        for (i, v) in out.radiance.band(b).iter().enumerate() {
            prof[i % w] += *v as f64;
        }
    }
    let lens_x = common::half_crossing_px(&prof);
    let depth_x = common::first_finite_px(&out.depth_m, w, 1);
    let focal_scale_px =
        (lens.image_distance_mm / lens.focal_length_mm - 1.0) * 0.9 * w as f64 / 2.0;
    eprintln!(
        "edge: lens image {lens_x:.2} px, depth map {depth_x:.0} px (pinhole {:.3} mm before the film, v = {:.4} mm; f = {:.4} mm would move it {focal_scale_px:.2} px)",
        lens.pupil_z_mm, lens.image_distance_mm, lens.focal_length_mm
    );
    assert!(
        focal_scale_px > 2.0,
        "the test must tell the two scales apart: {focal_scale_px}"
    );
    assert!(
        (lens_x - depth_x).abs() < 1.0,
        "lens edge {lens_x} px vs depth edge {depth_x} px"
    );
}
