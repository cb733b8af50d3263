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

const LENS_DIR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data/isetcornellbox/lens");

fn rtf_path() -> String {
    format!("{LENS_DIR}/pixel4a-rearcamera-ellipse-raytransfer.json")
}

fn scene_text(n: usize, diagonal_mm: f64) -> String {
    format!(
        "LookAt 0 0 0  0 0 1  0 1 0\nCamera \"raytransfer\" \"string lensfile\" \"{}\"\n\
         Film \"spectral\" \"integer xresolution\" {n} \"integer yresolution\" {n} \"float diagonal\" {diagonal_mm}\n\
         WorldBegin\nLightSource \"infinite\" \"rgb L\" [1 1 1]\n",
        rtf_path()
    )
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
    let Some(CameraLens::RayTransfer(lens)) = scene.camera.lens.clone() else { panic!("a ray-transfer camera") };
    // The focal length the RTF implies (Abbe sine condition): the lens is a 4.38 mm lens.
    assert!((lens.focal_length_mm / 4.38 - 1.0).abs() < 0.01, "f = {} mm", lens.focal_length_mm);
    let mut pinhole = scene.clone();
    pinhole.camera.lens = None;
    let l_ref = render_scene(pinhole, 2);
    let l_mean = l_ref.iter().sum::<f64>() / l_ref.len() as f64;
    let e = render_scene(scene, 256);

    // Centre against an independent integral: the projected solid angle of the directions the
    // RTF passes from the film centre, summed over a fine (theta, phi) grid of directions with
    // Rtf::trace's own pass test (cos(theta) sin(theta) dtheta dphi), not the ellipse sampling
    // the camera uses.
    let rtf = Rtf::from_file(Path::new(&rtf_path())).unwrap();
    let (nt, np) = (600usize, 256usize);
    let theta_max = 0.6f64;
    let mut brute = 0.0;
    for i in 0..nt {
        let t = (i as f64 + 0.5) * theta_max / nt as f64;
        for j in 0..np {
            let ph = (j as f64 + 0.5) * std::f64::consts::TAU / np as f64;
            if rtf.trace([0.0, 0.0], [t.sin() * ph.cos(), t.sin() * ph.sin(), t.cos()]).is_some() {
                brute += t.cos() * t.sin() * (theta_max / nt as f64) * (std::f64::consts::TAU / np as f64);
            }
        }
    }
    let omega = rtf.irradiance(0.0, 400).unwrap();
    let c = n / 2;
    let centre = (c - 1..=c + 1).flat_map(|r| (c - 1..=c + 1).map(move |q| r * n + q)).map(|i| e[i]).sum::<f64>() / 9.0 / l_mean;
    // For the record: the camera equation at Zemax's axial working f-number 1.8308 would give
    // pi / (4 N^2) = 0.234 sr; this RTF's pass ellipse (radius 0.38 mm at 2.589 mm) passes only
    // a cone of NA 0.146 (about f/3.4), so its absolute irradiance is 3.5x lower (its relative
    // illumination agrees with Zemax within 0.014).
    eprintln!("centre E/L {centre:.5} sr; RTF ellipse integral {omega:.5} sr; brute-force pass test {brute:.5} sr");
    assert!((omega / brute - 1.0).abs() < 0.01, "ellipse integral {omega} vs brute force {brute}");
    assert!((centre / brute - 1.0).abs() < 0.02, "rendered {centre} vs {brute}");

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
    let e = parse_str(&scene_text(8, 8.0), "/tmp/rtf-big.pbrt").unwrap_err().to_string();
    assert!(e.contains("rtf-big.pbrt:2:") && e.contains("raytransfer") && e.contains("diagonal"), "{e}");
    let missing = "LookAt 0 0 0  0 0 1  0 1 0\nCamera \"raytransfer\" \"string lensfile\" \"nowhere.json\"\nWorldBegin\n";
    let e = parse_str(missing, "/tmp/rtf-missing.pbrt").unwrap_err().to_string();
    assert!(e.contains("rtf-missing.pbrt:2:") && e.contains("nowhere.json"), "{e}");
}
