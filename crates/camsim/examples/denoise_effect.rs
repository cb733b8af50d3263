//! What denoising the rendered film does to what a camera engineer measures (issue 44,
//! docs/src/adaptive.md "Denoised radiance"): the same captures rendered unbiased at a low sample
//! count, the same denoised, and unbiased at a high count (the reference), compared on
//! - ColorChecker patch colours (`cornell-box-mcc`): CIEDE2000 of each patch's mean XYZ against
//!   the reference's (white: the reference's patch 19), mean and largest over the 24 patches;
//! - the slanted edge's MTF50 (`slanted-edge`, luminance of the radiance, ISO 12233 e-SFR);
//! - the raw: the Pixel 4a's full sensor over the MCC render, one CFA phase inside each patch:
//!   the render's noise in the noise-free raw (its spatial standard
//!   deviation above the reference's, DN) against the sensor's own temporal noise there (raw
//!   minus noise-free raw), DN.
//!
//! Needs Intel Open Image Denoise: CAMSIM_OIDN_LIBRARY=.../libOpenImageDenoise.so.1.4.3
//! (`pip install oidn`).
//!
//!     cargo run --release -p camsim --example denoise_effect -- [LOW_SPP] [REFERENCE_SPP] [color|edge|raw]

use camsim::analysis::{ciede2000, sfr, xyz_to_lab, Plane};
use camsim::render::RenderOutput;
use camsim::scene3d::builtin;
use camsim::scene3d::scene::DenoiseSettings;

fn render(name: &str, w: usize, h: usize, spp: u32, denoise: bool) -> RenderOutput {
    let mut s = builtin::scene(name, &Default::default()).expect("built-in scene");
    s.camera.width = w;
    s.camera.height = h;
    s.settings.samples_per_pixel = spp;
    s.settings.denoise = denoise.then(DenoiseSettings::default);
    camsim::render::render(&s, &|_, _| {}).expect("render")
}

/// Per-pixel CIE XYZ (Y in cd/m^2) of a radiance image.
fn xyz(out: &RenderOutput) -> Vec<[f64; 3]> {
    let g = out.radiance.grid;
    let c = camsim::core::colorimetry::Cmfs::on(&g);
    let px = out.radiance.rows * out.radiance.cols;
    (0..px)
        .map(|p| {
            let mut v = [0.0; 3];
            for b in 0..g.len() {
                let l = out.radiance.data[b * px + p] as f64 * g.step_nm * 683.0;
                v[0] += l * c.x[b];
                v[1] += l * c.y[b];
                v[2] += l * c.z[b];
            }
            v
        })
        .collect()
}

/// Pixels of material `name` whose 8 neighbours are the same material (no patch edges).
fn interior(ids: &camsim::render::IdMaps, name: &str) -> Vec<usize> {
    let Some(m) = ids.materials.iter().position(|n| n == name) else {
        return Vec::new();
    };
    let m = m as u32 + 1;
    let (w, h) = (ids.width, ids.height);
    (0..w * h)
        .filter(|&p| {
            let (x, y) = (p % w, p / w);
            x > 0
                && y > 0
                && x + 1 < w
                && y + 1 < h
                && (0..9).all(|k| ids.material_id[(y + k / 3 - 1) * w + x + k % 3 - 1] == m)
        })
        .collect()
}

fn mean3(v: &[[f64; 3]], idx: &[usize]) -> [f64; 3] {
    let mut s = [0.0; 3];
    for &i in idx {
        for c in 0..3 {
            s[c] += v[i][c];
        }
    }
    s.map(|x| x / idx.len() as f64)
}

fn colorchecker(low: u32, reference: u32) {
    let (w, h) = (320, 240);
    let r = render("cornell-box-mcc", w, h, reference, false);
    let rx = xyz(&r);
    let patches: Vec<Vec<usize>> = (1..=24)
        .map(|k| interior(&r.ids, &format!("mcc_{k:02}")))
        .collect();
    assert!(patches.iter().all(|p| p.len() >= 4), "every patch visible");
    let white = mean3(&rx, &patches[18]);
    let lab = |x: &[[f64; 3]]| -> Vec<_> {
        patches
            .iter()
            .map(|p| xyz_to_lab(mean3(x, p), white))
            .collect()
    };
    let ref_lab = lab(&rx);
    println!("ColorChecker (cornell-box-mcc, {w} x {h}), CIEDE2000 against {reference} spp:");
    for denoise in [false, true] {
        let o = render("cornell-box-mcc", w, h, low, denoise);
        let de: Vec<f64> = lab(&xyz(&o))
            .iter()
            .zip(&ref_lab)
            .map(|(a, b)| ciede2000(*a, *b))
            .collect();
        let mean = de.iter().sum::<f64>() / de.len() as f64;
        let max = de.iter().cloned().fold(0.0, f64::max);
        println!(
            "  {low} spp{}: mean {mean:.3}, max {max:.3}",
            if denoise { " denoised" } else { "" }
        );
    }
}

fn mtf50(out: &RenderOutput) -> f64 {
    let y: Vec<f32> = xyz(out).iter().map(|v| v[1] as f32).collect();
    let plane = Plane {
        rows: out.radiance.rows,
        cols: out.radiance.cols,
        data: y,
    };
    let roi = sfr::find_edge_roi(&plane).expect("edge");
    sfr::sfr(&plane, Some(roi), &Default::default())
        .expect("sfr")
        .mtf50_cyc_per_sample
        .unwrap_or(f64::NAN)
}

fn slanted_edge(low: u32, reference: u32) {
    let n = 256;
    let r = mtf50(&render("slanted-edge", n, n, reference, false));
    println!("Slanted edge ({n} x {n}), MTF50 of the radiance's luminance, cycles/pixel:");
    println!("  {reference} spp: {r:.4}");
    for denoise in [false, true] {
        let m = mtf50(&render("slanted-edge", n, n, low, denoise));
        println!(
            "  {low} spp{}: {m:.4} ({:+.1} %)",
            if denoise { " denoised" } else { "" },
            100.0 * (m / r - 1.0)
        );
    }
}

fn raw_noise(low: u32, reference: u32) {
    let (w, h) = (320, 240);
    let config = |spp: u32, denoise: bool| {
        let text = format!(
            "seed = 1\n[render]\nbuiltin = \"cornell-box-mcc\"\nsamples_per_pixel = {spp}\nresolution = [{w}, {h}]\n{}\
             [optics]\npreset = \"pixel4a\"\n[sensor]\npreset = \"pixel4a\"\n",
            if denoise { "[render.denoise]\n" } else { "" }
        );
        camsim::SimulateConfig::from_toml_str(&text, std::path::Path::new(".")).expect("config")
    };
    let run = |spp, denoise| {
        camsim::simulate(
            &config(spp, denoise),
            &camsim::SimulateOptions {
                noise_free: true,
                ..Default::default()
            },
            &|_, _, _| {},
        )
        .expect("simulate")
    };
    // One CFA phase (one colour filter) of the sensor pixels whose render pixel lies inside a
    // patch (the render spans the sensor: render pixel = sensor pixel times w / cols).
    let select = |sim: &camsim::Simulation, patch: usize| -> Vec<usize> {
        let ids = sim.ids.as_ref().expect("ids");
        assert_eq!((ids.width, ids.height), (w, h));
        let (rows, cols) = (sim.frames[0].rows, sim.frames[0].cols);
        let inside: std::collections::HashSet<usize> = interior(ids, &format!("mcc_{patch:02}"))
            .into_iter()
            .collect();
        (0..rows * cols)
            .filter(|p| {
                let (r, c) = (p / cols, p % cols);
                r % 2 == 0 && c % 2 == 0 && inside.contains(&((r * h / rows) * w + c * w / cols))
            })
            .collect()
    };
    let stats = |v: &[f64]| {
        let m = v.iter().sum::<f64>() / v.len() as f64;
        (
            m,
            v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (v.len() - 1) as f64,
        )
    };
    let reference_sim = run(reference, false);
    println!(
        "Raw (Pixel 4a, full sensor over a {w} x {h} render, one CFA phase, auto-exposure), DN:"
    );
    println!("  patch  mean  render noise {low} spp / denoised  sensor temporal noise");
    let cases = [run(low, false), run(low, true)];
    for patch in 1..=24 {
        let idx = select(&reference_sim, patch);
        // The patches the window sees well enough for a standard deviation.
        if idx.len() < 100 {
            continue;
        }
        let nf = |sim: &camsim::Simulation| -> Vec<f64> {
            let f = sim.noise_free_frame(0).expect("noise-free frame");
            idx.iter().map(|&p| f[p] as f64).collect()
        };
        let (m, var_ref) = stats(&nf(&reference_sim));
        let render_noise: Vec<f64> = cases
            .iter()
            .map(|s| (stats(&nf(s)).1 - var_ref).max(0.0).sqrt())
            .collect();
        let raw = &reference_sim.frames[0].dn;
        let f = reference_sim.noise_free_frame(0).expect("noise-free frame");
        let temporal: Vec<f64> = idx.iter().map(|&p| raw[p] as f64 - f[p] as f64).collect();
        println!(
            "  {patch:5}  {m:6.1}  {:6.2} / {:6.2}  {:6.2}",
            render_noise[0],
            render_noise[1],
            stats(&temporal).1.sqrt()
        );
    }
}

fn main() {
    let arg = |i: usize, d: u32| {
        std::env::args()
            .nth(i)
            .and_then(|a| a.parse().ok())
            .unwrap_or(d)
    };
    let (low, reference) = (arg(1, 16), arg(2, 1024));
    if let Err(e) = camsim::render::denoise::Oidn::load(None) {
        eprintln!("{e}");
        std::process::exit(2);
    }
    let only = std::env::args().nth(3).unwrap_or_default();
    if only.is_empty() || only == "color" {
        colorchecker(low, reference);
    }
    if only.is_empty() || only == "edge" {
        slanted_edge(low, reference);
    }
    if only.is_empty() || only == "raw" {
        raw_noise(low, reference);
    }
}
