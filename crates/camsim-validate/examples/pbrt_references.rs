//! camsim against pbrt-v4's own renders of real pbrt-v4 scenes (issue 27): for each scene with
//! a reference in `../shared/scenes/references/`, render the same file twice (seeds 1 and 2) at
//! the references' setup (see `camsim_validate::pbrt_reference`), compare, and print one
//! markdown table: the mean-radiance ratio over the unit factor, the luminance blocks beyond 4
//! standard errors, the worst 10 nm band, pass/fail, and the speed figures (camsim's and
//! pbrt-v4's CPU seconds per seed, relative luminance variance per sample, and camsim's time to
//! pbrt-v4's error as a fraction of pbrt-v4's time). Scenes camsim cannot read are listed with
//! the reader's message.
//!
//! Run (release; a few minutes per scene on 2 cores):
//! `cargo run --release -p camsim-validate --example pbrt_references -- [OPTIONS] [SCENE ...]`
//! - `SCENE ...`: scene names (folders of `--scenes`); default: every scene in the references'
//!   `INDEX.md`. Any list works, so scenes that load later are added by naming them.
//! - `--spp N`: camsim's samples per pixel (default 32, the references').
//! - `--seeds K`: seeds 1 to K of each renderer (default 2, the stored references'; a
//!   `--references` folder with more pbrt-v4 seeds estimates a heavy-tailed scene's noise better).
//! - `--block B`: render at B times the stored size (default 2: the references' 320 px; 1
//!   renders at the stored size with a quarter of the samples per unit area).
//! - `--scenes DIR` (default `../shared/scenes/bitterli`), `--references DIR` (default
//!   `../shared/scenes/references`), paths relative to the current folder.
//! - `--light-sampler bvh|power|uniform`: how camsim chooses lights (default: the file's
//!   `lightsampler`, as pbrt-v4 rendered it; `power` to measure what the spatial sampler gains).
//! - `--layered-exit-weight unbiased|pbrt-v4`: how camsim's coated BSDFs weigh a sample leaving
//!   through a rough coating (default `unbiased`; `pbrt-v4` reproduces pbrt-v4 5f7a606's biased
//!   `LayeredBxDF::f`, which is what `staircase` differs by: see docs/src/validation.md).
//! - `--out DIR`: also write per scene `<scene>.png`: camsim (scaled by the unit factor),
//!   pbrt-v4, and the blocks' differences in standard errors (grey 0, white +8: pbrt brighter,
//!   black -8), each tone-mapped the same way.
//!
//! Exit code 0 whatever the outcome (a report, not a test; `tests/it/pbrt_references.rs` is the
//! CI check on a fast subset).

use camsim_core::colorimetry::Cmfs;
use camsim_core::SpectralImage;
use camsim_validate::pbrt_reference::{
    compare_scene, read_index, scene_integrator, Criteria, SceneOptions, PBRT_UNIT_FACTOR,
    REFERENCE_BLOCK,
};
use std::path::{Path, PathBuf};

struct Args {
    scenes: Vec<String>,
    spp: u32,
    seeds: usize,
    block: usize,
    scenes_dir: PathBuf,
    references_dir: PathBuf,
    out: Option<PathBuf>,
    light_sampler: Option<camsim_render::LightSampler>,
    layered_exit_weight: camsim_scene3d::scene::LayeredExitWeight,
}

fn parse_args() -> Result<Args, String> {
    let mut a = Args {
        scenes: Vec::new(),
        spp: 32,
        seeds: 2,
        block: REFERENCE_BLOCK,
        scenes_dir: PathBuf::from("../shared/scenes/bitterli"),
        references_dir: PathBuf::from("../shared/scenes/references"),
        out: None,
        light_sampler: None,
        layered_exit_weight: Default::default(),
    };
    let mut it = std::env::args().skip(1);
    while let Some(arg) = it.next() {
        let mut value = |name: &str| it.next().ok_or(format!("{name} needs a value"));
        match arg.as_str() {
            "--spp" => a.spp = value("--spp")?.parse().map_err(|e| format!("--spp: {e}"))?,
            "--seeds" => {
                a.seeds = value("--seeds")?
                    .parse()
                    .map_err(|e| format!("--seeds: {e}"))?
            }
            "--block" => {
                a.block = value("--block")?
                    .parse()
                    .map_err(|e| format!("--block: {e}"))?
            }
            "--scenes" => a.scenes_dir = value("--scenes")?.into(),
            "--references" => a.references_dir = value("--references")?.into(),
            "--out" => a.out = Some(value("--out")?.into()),
            "--light-sampler" => {
                let v = value("--light-sampler")?;
                a.light_sampler = Some(
                    camsim_render::LightSampler::from_name(&v)
                        .ok_or(format!("--light-sampler: {v} is not bvh, power or uniform"))?,
                )
            }
            "--layered-exit-weight" => {
                use camsim_scene3d::scene::LayeredExitWeight as W;
                a.layered_exit_weight = match value("--layered-exit-weight")?.as_str() {
                    "unbiased" => W::Unbiased,
                    "pbrt-v4" => W::PbrtV4,
                    v => {
                        return Err(format!(
                            "--layered-exit-weight: {v} is not unbiased or pbrt-v4"
                        ))
                    }
                }
            }
            s if s.starts_with("--") => return Err(format!("unknown option {s}")),
            s => a.scenes.push(s.to_string()),
        }
    }
    if a.block == 0 || a.spp == 0 {
        return Err("--block and --spp must be positive".into());
    }
    if a.seeds < 2 {
        return Err("--seeds must be at least 2 (the noise comes from the seeds)".into());
    }
    Ok(a)
}

/// Luminance of each pixel (y-bar weighted band sum), in the image's own units.
fn luminance(img: &SpectralImage) -> Vec<f64> {
    let cmfs = Cmfs::on(&img.grid);
    (0..img.pixels())
        .map(|p| {
            (0..img.bands())
                .map(|b| cmfs.y[b] * img.band(b)[p] as f64)
                .sum()
        })
        .collect()
}

/// camsim | pbrt-v4 | block z-map, side by side, tone-mapped by the pbrt image's mean.
fn write_png(
    out: &Path,
    scene: &str,
    cam: [&SpectralImage; 2],
    pbrt: [&SpectralImage; 2],
) -> Result<(), String> {
    let (w, h) = (pbrt[0].cols, pbrt[0].rows);
    let yc: Vec<f64> = luminance(cam[0])
        .iter()
        .zip(luminance(cam[1]))
        .map(|(a, b)| PBRT_UNIT_FACTOR * (a + b) / 2.0)
        .collect();
    let yp0 = luminance(pbrt[0]);
    let yp1 = luminance(pbrt[1]);
    let yp: Vec<f64> = yp0.iter().zip(&yp1).map(|(a, b)| (a + b) / 2.0).collect();
    let mean = yp.iter().sum::<f64>() / yp.len() as f64;
    let tone = |v: f64| {
        let x = v / (2.0 * mean.max(1e-30));
        (255.0 * (x / (1.0 + x)).powf(1.0 / 2.2)).round() as u8
    };
    // Per-block z (same blocks as the comparison).
    let (nx, ny) = camsim_validate::pbrt_reference::block_grid(w, h);
    let yc0 = luminance(cam[0]);
    let yc1 = luminance(cam[1]);
    let mut zmap = vec![128u8; w * h];
    for by in 0..ny {
        for bx in 0..nx {
            let (r0, r1) = (by * h / ny, (by + 1) * h / ny);
            let (c0, c1) = (bx * w / nx, (bx + 1) * w / nx);
            let n = ((r1 - r0) * (c1 - c0)) as f64;
            let (mut d, mut v) = (0.0, 0.0);
            for r in r0..r1 {
                for c in c0..c1 {
                    let p = r * w + c;
                    d += yp[p] - yc[p];
                    let dc = PBRT_UNIT_FACTOR * (yc0[p] - yc1[p]);
                    let dp = yp0[p] - yp1[p];
                    v += dc * dc + dp * dp;
                }
            }
            let z = if v > 0.0 {
                (d / n) / (v.sqrt() / (2.0 * n))
            } else {
                0.0
            };
            let g = (128.0 + 16.0 * z.clamp(-8.0, 8.0)).clamp(0.0, 255.0) as u8;
            for r in r0..r1 {
                for c in c0..c1 {
                    zmap[r * w + c] = g;
                }
            }
        }
    }
    let mut img = image::GrayImage::new((3 * w + 8) as u32, h as u32);
    for r in 0..h {
        for c in 0..w {
            let p = r * w + c;
            img.put_pixel(c as u32, r as u32, image::Luma([tone(yc[p])]));
            img.put_pixel((w + 4 + c) as u32, r as u32, image::Luma([tone(yp[p])]));
            img.put_pixel((2 * w + 8 + c) as u32, r as u32, image::Luma([zmap[p]]));
        }
    }
    std::fs::create_dir_all(out).map_err(|e| format!("{}: {e}", out.display()))?;
    let p = out.join(format!("{scene}.png"));
    img.save(&p).map_err(|e| format!("{}: {e}", p.display()))
}

fn main() {
    let args = match parse_args() {
        Ok(a) => a,
        Err(e) => {
            eprintln!("pbrt_references: {e}");
            std::process::exit(2);
        }
    };
    let index = match read_index(&args.references_dir) {
        Ok(i) => i,
        Err(e) => {
            eprintln!("pbrt_references: {e}");
            std::process::exit(2);
        }
    };
    let scenes: Vec<String> = if args.scenes.is_empty() {
        index.iter().map(|r| r.scene.clone()).collect()
    } else {
        args.scenes.clone()
    };
    let criteria = Criteria::default();
    println!(
        "camsim {} spp x {} seeds at {}x the stored size, {} light sampler; pbrt-v4 from {}",
        args.spp,
        args.seeds,
        args.block,
        args.light_sampler.map_or("the file's", |l| l.name()),
        args.references_dir.display()
    );
    println!();
    println!("| scene | integrator | compared on | mean ratio / unit factor | blocks > 4 SE | worst band | result | camsim CPU s | pbrt-v4 CPU s | rel. variance per sample camsim / pbrt-v4 | time to equal error (x pbrt-v4) |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|");
    let opts = SceneOptions {
        spp: args.spp,
        seeds: args.seeds,
        block: args.block,
        light_sampler: args.light_sampler,
        layered_exit_weight: args.layered_exit_weight,
        criteria,
    };
    for scene in &scenes {
        let integrator =
            scene_integrator(&args.scenes_dir, &index, scene).unwrap_or_else(|| "?".into());
        let run = match compare_scene(&args.scenes_dir, &args.references_dir, &index, scene, &opts)
        {
            Ok(r) => r,
            Err(e) => {
                let e = e.to_string();
                let first = e.lines().next().unwrap_or("").replace('|', "/");
                let more = e.lines().count().saturating_sub(1);
                let more = if more > 0 {
                    format!(" (+{more} more)")
                } else {
                    String::new()
                };
                println!("| {scene} | {integrator} | | {first}{more} | | | fail | | | | |");
                continue;
            }
        };
        let c = &run.comparison;
        let (cam_cpu, pbrt_cpu, eq) = (run.camsim_cpu_s, run.pbrt_cpu_s, run.equal_error_time());
        let fmt_pass = |p: bool| if p { "" } else { " **x**" };
        println!(
            "| {scene} | {integrator} | {} | {:.4} +- {:.4}{} | {}/{} (worst {:.1}){} | {:.0} nm {:+.1} % +- {:.1}{} | {} | {:.1} | {} | {:.3} / {:.3} | {} |",
            if c.luminance_from_rgb { "RGB luminance" } else { "spectral" },
            c.mean_ratio,
            c.mean_ratio_se,
            fmt_pass(c.passes[0]),
            c.blocks_off,
            c.blocks.0 * c.blocks.1,
            c.worst_block_sigmas,
            fmt_pass(c.passes[1]),
            c.worst_band.0,
            100.0 * (c.worst_band.1 - 1.0),
            100.0 * c
                .band_ratios
                .iter()
                .position(|b| b.0 == c.worst_band.0)
                .map_or(0.0, |i| c.band_ratio_se[i]),
            if c.luminance_from_rgb { " (not judged)" } else { fmt_pass(c.passes[2]) },
            if c.pass() { "pass" } else { "fail" },
            cam_cpu,
            pbrt_cpu.map_or("?".into(), |v| format!("{v:.1}")),
            c.camsim_rel_variance_per_sample,
            c.pbrt_rel_variance_per_sample,
            eq.map_or("?".into(), |v| format!("{v:.2}")),
        );
        if c.masked_pixels > 0 {
            eprintln!(
                "{scene}: {} pixel(s) of a sub-pixel emitter left out (one sample brighter than {} x the mean luminance)",
                c.masked_pixels, criteria.emitter_pixel_factor
            );
        }
        if !c.pass() {
            let bands: Vec<String> = c
                .band_ratios
                .iter()
                .zip(&c.band_ratio_se)
                .map(|((l, r), se)| format!("{l:.0}:{:+.1}+-{:.1}%", 100.0 * (r - 1.0), 100.0 * se))
                .collect();
            eprintln!(
                "{scene}: band ratios {}; blocks off {:+.1} % on average",
                bands.join(" "),
                100.0 * c.blocks_off_mean_rel
            );
        }
        if let Some(out) = &args.out {
            let (cam, pbrt) = (&run.camsim, &run.pbrt);
            // The picture shows the first two seeds of each.
            if let Err(e) = write_png(out, scene, [&cam[0], &cam[1]], [&pbrt[0], &pbrt[1]]) {
                eprintln!("pbrt_references: {e}");
            }
        }
    }
}
