//! `camsim dataset`: a synthetic dataset from a spec, locally or one part of n.

use crate::common::{self, say};
use anyhow::{Context, Result};
use camsim::dataset::{DatasetSpec, ShardSelect};
use std::path::PathBuf;

/// Simulate a dataset: many captures from one spec, as WebDataset tar shards with a manifest.
///
/// A spec (TOML) is a base `simulate` config plus variations over any of its keys: grids
/// (`values = [...]`) and seeded random draws (`uniform`, `log_uniform`, `choice`, `normal`).
/// Sample i is a function of (spec, i) alone, so the same spec gives the same bytes on any
/// machine, any number of workers, any order. The spec is checked completely (every key, range
/// and file) before any work starts. Without SPEC: the built-in example, 24 ColorChecker
/// captures (examples/datasets/colorchecker.toml).
///
/// --out holds spec.json, shard-FIRST-LAST.tar (per sample KEY.json, KEY.dng, KEY.preview.png,
/// ...), shard-FIRST-LAST.json (checksum, status and parameters of each sample) and, once every
/// shard is complete, manifest.jsonl (one line per sample; pandas.read_json(p, lines=True)).
/// Each shard is written atomically; a re-run skips complete shards (SHA-256 checked) and redoes
/// the rest, so a killed run loses only the shards in flight. A sample that fails is recorded
/// with its error in the manifest and does not stop the others.
#[derive(clap::Args)]
#[command(
    after_help = "Examples:\n  camsim dataset --out out/dataset\n  camsim dataset examples/datasets/colorchecker.toml --out out/dataset-cc --workers 2\n  camsim dataset examples/datasets/colorchecker.toml --out out/dataset-part --shard 1/4\n      (one part of four: a Slurm array task passes $SLURM_ARRAY_TASK_ID/4, a Kubernetes\n      indexed Job $JOB_COMPLETION_INDEX/4; see examples/datasets/ for job files)\n  camsim dataset examples/datasets/colorchecker.toml --plan     (check the spec, print its plan)\n  camsim dataset examples/datasets/detection.toml --coco --out out/detection   (a 3D detection dataset and its COCO file)\n  camsim dataset examples/datasets/tabletop.toml --coco --coco-categories category --bop --out out/tabletop\n      (objects composed from an asset library, with COCO and BOP 6D-pose files)"
)]
pub struct Args {
    /// Dataset spec (TOML). Default: the built-in example.
    pub spec: Option<PathBuf>,
    /// Dataset folder (created; a folder of another spec is refused).
    #[arg(long, default_value = "out/dataset")]
    pub out: PathBuf,
    /// Run only part i of n: the shards s with s mod n == i (0 <= i < n).
    #[arg(long, value_name = "i/n", value_parser = ShardSelect::parse)]
    pub shard: Option<ShardSelect>,
    /// Samples simulated at once (default: one per core). Results do not depend on it.
    #[arg(long)]
    pub workers: Option<usize>,
    /// Trust complete shards by size without re-reading their SHA-256 (faster resume).
    #[arg(long)]
    pub no_verify: bool,
    /// Check the spec and print its plan (samples, shards, the first samples' parameters), then
    /// exit without simulating.
    #[arg(long)]
    pub plan: bool,
    /// Once the dataset is complete, export it as COCO: OUT/coco/annotations.json (instance
    /// masks as RLE, boxes, areas on the raw image's grid) and OUT/coco/images/ (the previews).
    /// Needs the outputs preview, instances and boxes.
    #[arg(long)]
    pub coco: bool,
    /// COCO category names: the instances' material names (`material`), object names
    /// (`object`), or semantic categories (`category`: an overlay's `[[object]] category`, else
    /// the object name).
    #[arg(long, default_value = "material", value_parser = camsim_dataset::CategoryBy::parse)]
    pub coco_categories: camsim_dataset::CategoryBy,
    /// Once the dataset is complete, export its composed objects' 6D poses in the BOP format:
    /// OUT/bop/models/ (each asset as a PLY in mm, models_info.json), OUT/bop/camera.json and
    /// OUT/bop/train_pbr/NNNNNN/ per shard (scene_camera.json, scene_gt.json,
    /// scene_gt_info.json, rgb/, mask_visib/, depth/ with the depth output). Needs
    /// [render.compose] and the outputs preview, instances and boxes.
    #[arg(long)]
    pub bop: bool,
}

pub fn run(a: Args) -> Result<()> {
    let spec = match &a.spec {
        Some(p) => DatasetSpec::from_file(p)?,
        None => DatasetSpec::builtin_default()?,
    };
    if a.workers == Some(0) {
        anyhow::bail!("--workers must be at least 1");
    }
    if a.plan {
        // The plan is the command's output: stdout, so it can be piped or saved.
        println!(
            "{}: {} samples in {} shards of {}",
            spec.source,
            spec.samples,
            spec.shards(),
            spec.shard_size
        );
        for i in 0..spec.samples.min(5) {
            let s = spec.sample(i)?;
            let p: Vec<String> = s.params.iter().map(|(k, v)| format!("{k} = {v}")).collect();
            println!("  sample {i}: seed {}, {}", s.seed, p.join(", "));
        }
        return Ok(());
    }
    let select = a.shard.unwrap_or_default();
    let pb = common::progress(0, "samples");
    pb.set_style(
        indicatif::ProgressStyle::with_template(
            "{msg:>12} [{elapsed_precise}] {wide_bar} {pos}/{len} ({per_sec}, eta {eta})",
        )
        .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    let summary = camsim::dataset::run(
        &spec,
        &a.out,
        select,
        a.workers,
        !a.no_verify,
        &|done, total, failed| {
            pb.set_length(total);
            pb.set_position(done);
            if failed > 0 {
                pb.set_message(format!("{failed} failed"));
            }
        },
    );
    pb.finish_and_clear();
    let s = summary.with_context(|| format!("dataset {}", a.out.display()))?;
    common::report_removed(&s.removed_temporaries);
    if s.shards_busy > 0 {
        eprintln!(
            "camsim: {} shard(s) are being written by another camsim run into {}; left to it",
            s.shards_busy,
            a.out.display()
        );
    }
    say(format!(
        "{} samples ({} failed) in {} shards written, {} complete shards kept, {:.1} s ({:.2} samples/s)",
        s.samples_run,
        s.samples_failed,
        s.shards_written,
        s.shards_skipped,
        s.seconds,
        s.samples_run as f64 / s.seconds.max(1e-9)
    ));
    if s.complete {
        say(format!(
            "complete: {} shards -> {}",
            s.shards_total,
            a.out.join("manifest.jsonl").display()
        ));
        if a.coco {
            let p = camsim_dataset::export_coco(&spec, &a.out, a.coco_categories)?;
            say(format!("COCO: {}", p.display()));
        }
        if a.bop {
            let p = camsim_dataset::export_bop(&spec, &a.out)?;
            say(format!("BOP: {}", p.display()));
        }
    } else {
        say(format!(
            "{} of {} shards are this part's; the manifest is written when all are complete",
            select_count(&select, s.shards_total),
            s.shards_total
        ));
    }
    Ok(())
}

fn select_count(s: &ShardSelect, total: u64) -> u64 {
    (0..total).filter(|i| s.owns(*i)).count() as u64
}
