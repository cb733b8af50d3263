//! Convergence benchmark of the path tracer (issue 12): time to reach 5 % relative RMSE of
//! luminance against a high-sample reference on the built-in `cornell-box` at 256 x 256, on 2
//! threads, for the old configuration (independent sampler, Russian roulette from depth 2) and
//! the new default (Sobol sampler, Russian roulette from depth 5), plus the two mixed ones to
//! separate the effects.
//!
//! Relative RMSE of luminance: `sqrt(mean_p (Y_p - Yref_p)^2 / (Yref_p^2 + eps^2))` with
//! `eps = 0.01 mean_p Yref_p` (the per-pixel relative error of Rousselle et al. 2011 "Adaptive
//! sampling and reconstruction using greedy error minimization", `eps` for black pixels), with
//! `Y` the luminance `683 sum L(lambda) ybar(lambda) dlambda` of each pixel, cd/m^2. The RMSE
//! over the image divided by its mean luminance is printed too; it is dominated by the few
//! pixels on the light's edge. For each configuration the scene is rendered at 4, 8, 16, ...
//! samples per pixel (new seed each, so the errors are independent) until the error falls
//! below 5 % or MAX_SPP is reached; the time and sample count to 5 % are interpolated between
//! the two bracketing renders in log-log, or, when 5 % is not reached, extrapolated from the
//! last render with error^2 ~ 1/time (Monte Carlo; conservative for Sobol). Times are the
//! renders' wall clock (scene compile and BVH build included), which depends on other load on
//! a shared machine, and the process CPU time (user + system), which barely does.
//!
//! The reference (independent sampler, Russian roulette from depth 5, a seed no measured render
//! uses, all threads) is rendered once and cached, luminance and its per-pixel variance of the
//! mean, in `target/convergence-reference-<spp>spp-256x256.bin`. The independent sampler makes
//! that variance an unbiased estimate of the reference's own squared error, which is subtracted
//! from every measured squared error (E[measured^2] = error^2 + reference^2).
//!
//! Run: `cargo run --release -p camsim-render --example convergence [REF_SPP] [THREADS]
//! [MAX_SPP]` (defaults 4096, 2 and 4096: the largest sample count tried per configuration).

use camsim_core::colorimetry::Cmfs;
use camsim_render::render;
use camsim_scene3d::builtin::{scene, BuiltinOptions};
use camsim_scene3d::{SamplerKind, SceneDescription};
use std::io::{Read, Write};
use std::path::PathBuf;

const SIZE: usize = 256;
const TARGET_REL_RMSE: f64 = 0.05;

/// Per-pixel luminance of a render, cd/m^2.
fn luminance(sc: &SceneDescription, out: &camsim_render::RenderOutput) -> Vec<f64> {
    let cmfs = Cmfs::on(&sc.settings.grid);
    let img = &out.radiance;
    let nb = img.bands();
    let mut buf = vec![0f64; nb];
    (0..img.pixels())
        .map(|p| {
            for (b, v) in buf.iter_mut().enumerate() {
                *v = img.band(b)[p] as f64;
            }
            cmfs.luminance_cd_m2(&buf)
        })
        .collect()
}

fn rel_rmse(y: &[f64], reference: &[f64]) -> f64 {
    let n = y.len() as f64;
    let eps = 0.01 * reference.iter().sum::<f64>() / n;
    let mse = y
        .iter()
        .zip(reference)
        .map(|(a, b)| (a - b) * (a - b) / (b * b + eps * eps))
        .sum::<f64>()
        / n;
    mse.sqrt()
}

/// RMSE over the pixels divided by the mean reference luminance (dominated by the few pixels
/// on the light's edge, whose luminance is ~100x the image mean); reported, not the target.
fn global_rel_rmse(y: &[f64], reference: &[f64]) -> f64 {
    let n = y.len() as f64;
    let mse = y
        .iter()
        .zip(reference)
        .map(|(a, b)| (a - b) * (a - b))
        .sum::<f64>()
        / n;
    mse.sqrt() / (reference.iter().sum::<f64>() / n)
}

fn cornell(spp: u32, seed: u64, sampler: SamplerKind, rr_depth: u32) -> SceneDescription {
    let opts = BuiltinOptions {
        resolution: Some((SIZE, SIZE)),
        samples_per_pixel: spp,
        seed,
        ..BuiltinOptions::default()
    };
    let mut sc = scene("cornell-box", &opts).expect("built-in cornell-box");
    sc.settings.sampler = sampler;
    sc.settings.russian_roulette_depth = rr_depth;
    sc
}

fn cpu_s() -> f64 {
    let (u, s) = camsim_core::mem::process_cpu_s();
    u + s
}

/// The reference luminance and the variance of its per-pixel mean, from the cache or rendered
/// (and cached).
fn reference(spp: u32) -> (Vec<f64>, Vec<f64>) {
    let path = PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../target"))
        .join(format!("convergence-reference-{spp}spp-{SIZE}x{SIZE}.bin"));
    if let Ok(mut f) = std::fs::File::open(&path) {
        let mut bytes = vec![];
        if f.read_to_end(&mut bytes).is_ok() && bytes.len() == 2 * SIZE * SIZE * 8 {
            eprintln!("reference: cached {}", path.display());
            let v: Vec<f64> = bytes
                .chunks_exact(8)
                .map(|c| f64::from_le_bytes(c.try_into().unwrap_or([0; 8])))
                .collect();
            return (v[..SIZE * SIZE].to_vec(), v[SIZE * SIZE..].to_vec());
        }
    }
    eprintln!(
        "reference: rendering {spp} spp on {} threads (cached afterwards) ...",
        rayon::current_num_threads()
    );
    // Independent sampler: its per-pixel sample variance is an unbiased estimate of the
    // reference's own error, which main() subtracts.
    let sc = cornell(spp, 0xC0FFEE, SamplerKind::Independent, 5);
    let out = render(&sc, &|done, total| {
        if done % 64 == 0 {
            eprint!("\r  {done}/{total} tile passes");
        }
    })
    .expect("reference render");
    eprintln!();
    let y = luminance(&sc, &out);
    let mean = y.iter().sum::<f64>() / y.len() as f64;
    // The sample variance of the mean per pixel, in the metric of `rel_rmse`.
    let eps = 0.01 * mean;
    let noise = (out
        .variance
        .iter()
        .zip(&y)
        .map(|(v, r)| *v as f64 / (r * r + eps * eps))
        .sum::<f64>()
        / y.len() as f64)
        .sqrt();
    eprintln!(
        "reference: {:.1} s, {:.3} M samples/s, {:.2} M rays/s; mean luminance {mean:.3} cd/m^2, noise <= {:.3} % relative RMSE",
        out.stats.seconds,
        out.stats.samples_per_second / 1e6,
        out.stats.rays_per_second / 1e6,
        noise * 100.0
    );
    let var: Vec<f64> = out.variance.iter().map(|v| *v as f64).collect();
    let bytes: Vec<u8> = y.iter().chain(&var).flat_map(|v| v.to_le_bytes()).collect();
    if let Some(dir) = path.parent() {
        let _ = std::fs::create_dir_all(dir);
    }
    match std::fs::File::create(&path).and_then(|mut f| f.write_all(&bytes)) {
        Ok(()) => eprintln!("reference: cached in {}", path.display()),
        Err(e) => eprintln!("reference: could not cache in {}: {e}", path.display()),
    }
    (y, var)
}

/// One measured render.
struct Point {
    spp: u32,
    rel_rmse: f64,
    wall_s: f64,
    cpu_s: f64,
    samples_per_s: f64,
    rays_per_s: f64,
}

/// Log-log interpolation of `x` (a time or a sample count) where the error crosses the target.
fn crossing(a: (f64, f64), b: (f64, f64)) -> f64 {
    // a = (x0, err0) above the target, b = (x1, err1) below it.
    let t = (TARGET_REL_RMSE.ln() - a.1.ln()) / (b.1.ln() - a.1.ln());
    (a.0.ln() + t * (b.0.ln() - a.0.ln())).exp()
}

fn main() {
    let ref_spp: u32 = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(4096);
    let threads: usize = std::env::args()
        .nth(2)
        .and_then(|s| s.parse().ok())
        .unwrap_or(2);
    let max_spp: u32 = std::env::args()
        .nth(3)
        .and_then(|s| s.parse().ok())
        .unwrap_or(4096);
    let (y_ref, var_ref) = reference(ref_spp);
    // The reference's own squared error in the metric of `rel_rmse` (its sample variance of the
    // mean): E[measured^2] = error^2 + this, so it is subtracted.
    let eps = 0.01 * y_ref.iter().sum::<f64>() / y_ref.len() as f64;
    let ref_mse = var_ref
        .iter()
        .zip(&y_ref)
        .map(|(v, r)| v / (r * r + eps * eps))
        .sum::<f64>()
        / y_ref.len() as f64;
    println!(
        "reference noise {:.2} % (subtracted in quadrature)",
        ref_mse.sqrt() * 100.0
    );
    if max_spp == 0 {
        return;
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("thread pool");
    let configs = [
        (
            "independent, RR from depth 2 (before)",
            SamplerKind::Independent,
            2,
        ),
        ("independent, RR from depth 5", SamplerKind::Independent, 5),
        ("sobol, RR from depth 2", SamplerKind::Sobol, 2),
        ("sobol, RR from depth 5 (after)", SamplerKind::Sobol, 5),
    ];
    let mut rows = vec![];
    let mut csv =
        String::from("config,spp,rel_rmse,global_rel_rmse,wall_s,cpu_s,samples_per_s,rays_per_s\n");
    for (ci, (name, sampler, rr)) in configs.iter().enumerate() {
        println!("{name}:");
        let mut pts: Vec<Point> = vec![];
        let mut spp = 4u32;
        loop {
            let sc = cornell(spp, 1000 * ci as u64 + spp as u64, *sampler, *rr);
            let c0 = cpu_s();
            let out = pool.install(|| render(&sc, &|_, _| {})).expect("render");
            let cpu = cpu_s() - c0;
            let y = luminance(&sc, &out);
            let (em, eg) = (rel_rmse(&y, &y_ref), global_rel_rmse(&y, &y_ref));
            let e = (em * em - ref_mse).max(1e-12).sqrt();
            let st = out.stats;
            println!(
                "  {spp:5} spp: rel. RMSE {:6.2} % (measured {:6.2} %, global {:6.2} %), {:7.2} s wall, {:7.2} CPU-s, {:.3} M samples/s, {:.2} M rays/s",
                e * 100.0,
                em * 100.0,
                eg * 100.0,
                st.seconds,
                cpu,
                st.samples_per_second / 1e6,
                st.rays_per_second / 1e6
            );
            csv += &format!(
                "\"{name}\",{spp},{e},{eg},{},{cpu},{},{}\n",
                st.seconds, st.samples_per_second, st.rays_per_second
            );
            pts.push(Point {
                spp,
                rel_rmse: e,
                wall_s: st.seconds,
                cpu_s: cpu,
                samples_per_s: st.samples_per_second,
                rays_per_s: st.rays_per_second,
            });
            if e < TARGET_REL_RMSE && pts.len() >= 2 || spp >= max_spp {
                break;
            }
            spp *= 2;
        }
        let n = pts.len();
        let (a, b) = (&pts[n.saturating_sub(2)], &pts[n - 1]);
        let bracketed = a.rel_rmse >= TARGET_REL_RMSE && b.rel_rmse < TARGET_REL_RMSE;
        let at5 = |xa: f64, xb: f64| {
            if bracketed {
                crossing((xa, a.rel_rmse), (xb, b.rel_rmse))
            } else {
                // Monte Carlo: error^2 x time is constant (conservative for Sobol, whose error
                // falls faster); from the last render.
                xb * (b.rel_rmse / TARGET_REL_RMSE).powi(2)
            }
        };
        if !bracketed {
            println!(
                "  (5 % not reached by {} spp ({:.2} %): extrapolated with error^2 ~ 1/samples)",
                b.spp,
                b.rel_rmse * 100.0
            );
        }
        let spp5 = at5(a.spp as f64, b.spp as f64);
        let wall5 = at5(a.wall_s, b.wall_s);
        let cpu5 = at5(a.cpu_s, b.cpu_s);
        // Throughput of the longest render (least dominated by set-up).
        println!(
            "  -> 5 % at {spp5:.1} spp, {wall5:.2} s wall, {cpu5:.2} CPU-s; {:.3} M samples/s, {:.2} M rays/s",
            b.samples_per_s / 1e6,
            b.rays_per_s / 1e6
        );
        rows.push((
            name.to_string(),
            spp5,
            wall5,
            cpu5,
            b.samples_per_s,
            b.rays_per_s,
        ));
    }
    let out_csv = PathBuf::from(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../target/convergence.csv"
    ));
    if std::fs::write(&out_csv, &csv).is_ok() {
        eprintln!("measurements: {}", out_csv.display());
    }
    println!();
    println!("Time to 5 % relative RMSE of luminance, cornell-box 256 x 256, {threads} threads, reference {ref_spp} spp:");
    println!();
    println!("| configuration | spp to 5 % | wall s to 5 % | CPU s to 5 % | samples/s | rays/s |");
    println!("| --- | ---: | ---: | ---: | ---: | ---: |");
    for (name, spp5, wall5, cpu5, sps, rps) in &rows {
        println!(
            "| {name} | {spp5:.1} | {wall5:.2} | {cpu5:.2} | {:.3} M | {:.2} M |",
            sps / 1e6,
            rps / 1e6
        );
    }
    let (before, after) = (&rows[0], &rows[rows.len() - 1]);
    println!();
    println!(
        "after / before: {:.2}x the samples, {:.2}x the wall time, {:.2}x the CPU time ({:.0} % less CPU time)",
        after.1 / before.1,
        after.2 / before.2,
        after.3 / before.3,
        (1.0 - after.3 / before.3) * 100.0
    );
}
