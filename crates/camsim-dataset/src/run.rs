//! Running a dataset: shards of samples, each written atomically as a WebDataset tar file with a
//! JSON record beside it; resuming; and the manifest of every sample.
//!
//! Layout of a dataset folder:
//! - `spec.json`: the checked spec (its fingerprint ties the folder to one spec);
//! - `shard-00000000-00000063.tar`: samples 0..=63, WebDataset style: for each sample the files
//!   `00000012.json` (its record: index, seed, varied parameters, effective config, results),
//!   `00000012.dng`, `00000012.preview.png`, `00000012.raw.npy`, `00000012.noise_free.exr`, ...
//!   (an `[hdr]` sensor adds `00000012.raw_low.dng` and `00000012.merged.exr`);
//! - `shard-00000000-00000063.json`: the shard's record (sha256 and size of the tar, every
//!   sample's status, parameters, files and timings); written after the tar, so its presence with
//!   a matching checksum marks the shard complete;
//! - `manifest.jsonl`: one JSON line per sample (pandas: `pd.read_json(path, lines=True)`),
//!   gathered when every shard is complete.
//!
//! Ownership and concurrency: a dataset folder is one that holds camsim's `spec.json`; any other
//! non-empty folder is refused (naming its first entry), and nothing but the names above (and
//! their temporaries) is ever written or removed in it. Several processes may run into one folder
//! at once (`--shard i/n`): each shard is written under its own lock (`.shard-A-B.camsim-lock`),
//! a shard another process is writing is skipped, and the temporaries a killed run left for a
//! shard (`shard-A-B.camsim-tmp-PID/`, `.shard-A-B.tar.camsim-tmp-PID-N`) are removed when the
//! shard is next taken.

use crate::spec::{DatasetSpec, Sample};
use crate::{DatasetError, Result};
use camsim_io::atomic::{write_atomic, write_json_atomic, OutputDir, ScratchDir};
use camsim_io::exr::ExrOptions;
use camsim_io::lock::{remove_stale_temporaries, OutputLock};
use camsim_pipeline::{simulate, RunInfo, SimulateOptions};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};
use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

/// Which shards this process runs: shard s belongs to part `index` of `count` when
/// s mod count == index (`--shard i/n`, a Slurm array task or a Kubernetes indexed Job).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ShardSelect {
    pub index: u64,
    pub count: u64,
}

impl Default for ShardSelect {
    fn default() -> Self {
        ShardSelect { index: 0, count: 1 }
    }
}

impl ShardSelect {
    /// Parse `i/n` with 0 <= i < n.
    pub fn parse(text: &str) -> std::result::Result<ShardSelect, String> {
        let (i, n) = text
            .split_once('/')
            .ok_or_else(|| format!("--shard {text:?}: write i/n, e.g. 0/4"))?;
        let index: u64 = i
            .trim()
            .parse()
            .map_err(|_| format!("--shard {text:?}: {i:?} is not a whole number"))?;
        let count: u64 = n
            .trim()
            .parse()
            .map_err(|_| format!("--shard {text:?}: {n:?} is not a whole number"))?;
        if count == 0 || index >= count {
            return Err(format!("--shard {text:?}: needs 0 <= i < n"));
        }
        Ok(ShardSelect { index, count })
    }

    /// Whether shard `s` is this part's.
    pub fn owns(&self, s: u64) -> bool {
        s % self.count == self.index
    }
}

/// One sample's line in a shard record and in the manifest.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct SampleRecord {
    pub index: u64,
    /// WebDataset key: the index, 8 digits.
    pub key: String,
    /// "ok" or "error".
    pub status: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
    pub seed: u64,
    /// The varied keys and their values.
    pub params: serde_json::Map<String, serde_json::Value>,
    /// File names inside the shard's tar.
    pub files: Vec<String>,
    /// The shard's tar file name.
    pub shard: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub exposure_s: Option<f64>,
    /// Seconds per stage.
    pub times_s: serde_json::Map<String, serde_json::Value>,
}

/// A shard's record (`shard-FIRST-LAST.json`).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ShardRecord {
    pub shard: u64,
    pub first: u64,
    /// One past the last index.
    pub end: u64,
    pub tar: String,
    pub sha256: String,
    pub bytes: u64,
    /// The spec's fingerprint.
    pub spec: String,
    pub seconds: f64,
    pub samples: Vec<SampleRecord>,
}

/// What [`run`] did.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct RunSummary {
    pub shards_total: u64,
    /// Shards this run wrote.
    pub shards_written: u64,
    /// Shards found complete and skipped.
    pub shards_skipped: u64,
    /// Samples this run simulated, and how many of them failed.
    pub samples_run: u64,
    pub samples_failed: u64,
    pub seconds: f64,
    /// Whether every shard of the dataset is now complete (and manifest.jsonl written).
    pub complete: bool,
    /// Shards another process was writing (locked), left to it.
    #[serde(default)]
    pub shards_busy: u64,
    /// Temporaries of killed runs this run removed.
    #[serde(default)]
    pub removed_temporaries: Vec<PathBuf>,
}

/// File stem of shard `s`.
pub fn shard_stem(spec: &DatasetSpec, s: u64) -> String {
    let r = spec.shard_range(s);
    format!("shard-{:08}-{:08}", r.start, r.end - 1)
}

/// What an export (`what`: COCO, BOP) needs of the dataset in `out`: the outputs preview,
/// instances and boxes (`more` adds to the message), and every shard complete.
pub(crate) fn require_labelled_and_complete(
    spec: &DatasetSpec,
    out: &Path,
    what: &str,
    more: &str,
) -> Result<()> {
    for need in ["preview", "instances", "boxes"] {
        if !spec.output_names.iter().any(|o| o == need) {
            return Err(DatasetError::spec(
                &spec.source,
                format!("{what} export needs the output {need:?} in dataset.outputs (preview, instances and boxes{more})"),
            ));
        }
    }
    if gather(spec, out, false)?.is_none() {
        return Err(DatasetError::file(
            out,
            format!("the dataset is not complete: run it to the end before the {what} export"),
        ));
    }
    Ok(())
}

/// One image of a complete dataset as the exports see it: a sample, or one rig camera's
/// capture of a sample, with its files by the name after `KEY.` (or `KEY.CAMERA.`).
pub(crate) struct View {
    pub key: String,
    /// The sample's index times the rig's cameras plus the camera's (the sample's index
    /// without a rig): COCO's image id, BOP's im_id.
    pub image_id: u64,
    /// The rig camera's name.
    pub camera: Option<String>,
    /// `KEY` or `KEY.CAMERA`: the files' common stem.
    pub stem: String,
    pub files: std::collections::BTreeMap<String, Vec<u8>>,
}

/// The views of shard `s` of the complete dataset in `out` ([`View`]), in key then camera order,
/// with the files among `wanted` (`preview.png`, `boxes.json`, ...; a failed sample has none).
pub(crate) fn shard_views(
    spec: &DatasetSpec,
    out: &Path,
    s: u64,
    wanted: &[&str],
) -> Result<(PathBuf, Vec<View>)> {
    let tar_path = out.join(format!("{}.tar", shard_stem(spec, s)));
    let file = std::fs::File::open(&tar_path).map_err(|e| DatasetError::io(&tar_path, e))?;
    let mut archive = tar::Archive::new(file);
    let cams: Vec<&str> = spec.rig.iter().map(|c| c.name.as_str()).collect();
    let mut views = std::collections::BTreeMap::<(String, usize), View>::new();
    let entries = archive
        .entries()
        .map_err(|e| DatasetError::io(&tar_path, e))?;
    for entry in entries {
        let mut entry = entry.map_err(|e| DatasetError::io(&tar_path, e))?;
        let name = entry
            .path()
            .map_err(|e| DatasetError::io(&tar_path, e))?
            .to_string_lossy()
            .into_owned();
        let Some((key, ext)) = name.split_once('.') else {
            continue;
        };
        let (c, ext) = if cams.is_empty() {
            (0, ext)
        } else {
            match ext
                .split_once('.')
                .and_then(|(cam, rest)| Some((cams.iter().position(|c| *c == cam)?, rest)))
            {
                Some(x) => x,
                None => continue, // the sample's own record
            }
        };
        if !wanted.contains(&ext) {
            continue;
        }
        let index: u64 = key
            .parse()
            .map_err(|_| DatasetError::file(&tar_path, format!("sample key {key:?}")))?;
        let mut bytes = Vec::new();
        entry
            .read_to_end(&mut bytes)
            .map_err(|e| DatasetError::io(&tar_path, e))?;
        let view = views.entry((key.to_string(), c)).or_insert_with(|| View {
            key: key.to_string(),
            image_id: index * cams.len().max(1) as u64 + c as u64,
            camera: cams.get(c).map(|c| c.to_string()),
            stem: match cams.get(c) {
                Some(cam) => format!("{key}.{cam}"),
                None => key.to_string(),
            },
            files: Default::default(),
        });
        view.files.insert(ext.to_string(), bytes);
    }
    Ok((tar_path, views.into_values().collect()))
}

/// Prepare `out` for `spec`: create it and write `spec.json`, or check that the `spec.json`
/// already there is the same spec (a folder holds one dataset). A path that is not a folder, or
/// a non-empty folder without camsim's `spec.json`, is refused naming what is there. A
/// `spec.json` temporary that a killed run left is removed first (and returned), so a run killed
/// while it wrote the spec does not make the folder look foreign.
pub fn prepare(spec: &DatasetSpec, out: &Path) -> Result<Vec<PathBuf>> {
    if let Some(parent) = out.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(parent)
            .map_err(|e| camsim_io::lock::cannot_write_beside(out, e))?;
    }
    // Runs sharing the folder (--shard i/n) take this step in turn.
    let _lock = OutputLock::acquire_waiting(out)?;
    let path = out.join("spec.json");
    let removed = if out.is_dir() {
        remove_stale_temporaries(&path)
    } else {
        Vec::new()
    };
    match std::fs::symlink_metadata(out) {
        Ok(m) if !m.is_dir() => {
            return Err(DatasetError::file(
                out,
                "exists and is not a folder; a dataset is written into a folder: choose a new or empty folder for --out",
            ))
        }
        Ok(_) if !path.is_file() => {
            if let Some(first) = first_entry(out)? {
                return Err(DatasetError::file(
                    out,
                    format!("is a folder camsim did not write (it holds {first} and no spec.json); choose a new or empty folder for the dataset"),
                ));
            }
        }
        _ => {}
    }
    std::fs::create_dir_all(out).map_err(|e| DatasetError::io(out, e))?;
    if path.is_file() {
        let text = std::fs::read_to_string(&path).map_err(|e| DatasetError::io(&path, e))?;
        let v: serde_json::Value = serde_json::from_str(&text).map_err(|e| {
            DatasetError::file(&path, format!("is not camsim's dataset spec record ({e}); this folder holds something else: choose a new or empty folder"))
        })?;
        if v["fingerprint"].as_str() != Some(spec.fingerprint.as_str()) {
            return Err(DatasetError::file(
                &path,
                "holds a dataset of another spec; write this one to a new folder (or delete the old one)",
            ));
        }
        return Ok(removed);
    }
    let json = serde_json::json!({
        "fingerprint": spec.fingerprint,
        "source": spec.source,
        "samples": spec.samples,
        "shard_size": spec.shard_size,
        "shards": spec.shards(),
        "seed": spec.seed,
        "outputs": spec.output_names,
        "base": spec.base,
        "vary": spec.vary.iter().map(|v| v.key.clone()).collect::<Vec<_>>(),
        "camsim_version": env!("CARGO_PKG_VERSION"),
    });
    write_json_atomic(&path, &json)?;
    Ok(removed)
}

/// The first entry of folder `dir` by name, if any.
fn first_entry(dir: &Path) -> Result<Option<String>> {
    let entries = std::fs::read_dir(dir).map_err(|e| DatasetError::io(dir, e))?;
    Ok(entries
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .min())
}

/// Whether shard `s` is complete in `out`: its record names this spec, and its tar has the
/// recorded size and SHA-256 (`verify` false checks the size only).
pub fn shard_complete(spec: &DatasetSpec, out: &Path, s: u64, verify: bool) -> Option<ShardRecord> {
    let stem = shard_stem(spec, s);
    let text = std::fs::read_to_string(out.join(format!("{stem}.json"))).ok()?;
    let rec: ShardRecord = serde_json::from_str(&text).ok()?;
    if rec.spec != spec.fingerprint || rec.tar != format!("{stem}.tar") {
        return None;
    }
    let tar = out.join(&rec.tar);
    let meta = std::fs::metadata(&tar).ok()?;
    if meta.len() != rec.bytes {
        return None;
    }
    if verify && sha256_file(&tar).ok()? != rec.sha256 {
        return None;
    }
    Some(rec)
}

fn sha256_file(path: &Path) -> std::io::Result<String> {
    let mut f = std::fs::File::open(path)?;
    let mut h = Sha256::new();
    let mut buf = vec![0u8; 1 << 20];
    loop {
        let n = f.read(&mut buf)?;
        if n == 0 {
            break;
        }
        h.update(&buf[..n]);
    }
    Ok(format!("{:x}", h.finalize()))
}

/// A writer that hashes what passes through it.
struct Hashing<W: Write> {
    inner: W,
    hash: Sha256,
    bytes: u64,
}

impl<W: Write> Write for Hashing<W> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let n = self.inner.write(buf)?;
        self.hash.update(&buf[..n]);
        self.bytes += n as u64;
        Ok(n)
    }
    fn flush(&mut self) -> std::io::Result<()> {
        self.inner.flush()
    }
}

/// One simulated sample's files, in memory, named as inside the tar.
struct SampleFiles {
    record: SampleRecord,
    files: Vec<(String, Vec<u8>)>,
}

/// Simulate sample `i` and collect its files (staged in `scratch`, then read back).
fn run_sample(
    spec: &DatasetSpec,
    sample: &Sample,
    scratch: &Path,
    shard_name: &str,
) -> SampleFiles {
    let key = format!("{:08}", sample.index);
    let params: serde_json::Map<String, serde_json::Value> = sample
        .params
        .iter()
        .map(|(k, v)| {
            (
                k.clone(),
                serde_json::to_value(v).unwrap_or(serde_json::Value::Null),
            )
        })
        .collect();
    let mut record = SampleRecord {
        index: sample.index,
        key: key.clone(),
        status: "ok".into(),
        error: None,
        seed: sample.seed,
        params: params.clone(),
        files: Vec::new(),
        shard: shard_name.to_string(),
        exposure_s: None,
        times_s: serde_json::Map::new(),
    };
    let result = (|| -> std::result::Result<Vec<(String, Vec<u8>)>, String> {
        if sample.rig.is_empty() {
            let c = capture_files(spec, &sample.config, &key, None, sample, &params, scratch)?;
            record.exposure_s = Some(c.exposure_s);
            record.times_s = c.times_s;
            return Ok(c.files);
        }
        // A rig: each camera's capture under KEY.NAME.*, and the sample's own record.
        let mut files = Vec::new();
        let mut cameras = Vec::new();
        let mut reference: Option<serde_json::Value> = None;
        for (c, (name, cfg)) in sample.rig.iter().enumerate() {
            let cap = capture_files(spec, cfg, &key, Some(name), sample, &params, scratch)
                .map_err(|e| format!("rig camera {name:?}: {e}"))?;
            // Every camera must see the one composition from the one rig pose (a camera sampler's
            // view validation could redraw differently through another camera's frame).
            let drawn = cap
                .files
                .first()
                .and_then(|(_, b)| serde_json::from_slice::<serde_json::Value>(b).ok())
                .map(|m| {
                    let cam = &m["compose"]["camera"];
                    serde_json::json!([
                        m["compose"]["objects"],
                        cam["position_m"],
                        cam["target_m"],
                        cam["roll_deg"]
                    ])
                });
            match (&reference, drawn) {
                (None, d) => reference = d,
                (Some(r), Some(d)) if *r != d => {
                    return Err(format!(
                        "rig camera {name:?} drew another composition or rig pose than {:?} (its field of view made the camera sampler's view validation redraw): give the rig's cameras the same field of view, or loosen [render.compose.camera]'s min_visible_objects",
                        sample.rig[0].0
                    ))
                }
                _ => {}
            }
            if c == 0 {
                record.exposure_s = Some(cap.exposure_s);
            }
            for (k, v) in cap.times_s {
                let t = record.times_s.entry(k).or_insert(0.0.into());
                *t = (t.as_f64().unwrap_or(0.0) + v.as_f64().unwrap_or(0.0)).into();
            }
            cameras.push(serde_json::json!({
                "name": name,
                "offset": spec.rig[c].offset,
                "seed": cfg.seed,
                "files": format!("{key}.{name}.*"),
            }));
            files.extend(cap.files);
        }
        let meta = serde_json::json!({
            "index": sample.index,
            "seed": sample.seed,
            "params": params,
            "rig": cameras,
            "note": "A rig sample: each camera's record, raw, preview and labels are KEY.NAME.json, KEY.NAME.dng, ... (one composed scene, render.compose_seed = seed, seen by every camera; each camera's render and noise from its own seed).",
        });
        files.insert(
            0,
            (
                format!("{key}.json"),
                serde_json::to_vec_pretty(&meta).map_err(|e| e.to_string())?,
            ),
        );
        Ok(files)
    })();
    match result {
        Ok(files) => {
            record.files = files.iter().map(|(n, _)| n.clone()).collect();
            SampleFiles { record, files }
        }
        Err(e) => {
            record.status = "error".into();
            record.error = Some(e);
            SampleFiles {
                record,
                files: Vec::new(),
            }
        }
    }
}

/// One camera's capture of a sample.
struct Capture {
    files: Vec<(String, Vec<u8>)>,
    exposure_s: f64,
    times_s: serde_json::Map<String, serde_json::Value>,
}

/// Simulate `config` for `sample` and collect its files, named `KEY.*` (or `KEY.CAMERA.*` for
/// a rig's camera), staged in `scratch` and read back.
fn capture_files(
    spec: &DatasetSpec,
    config: &camsim_pipeline::SimulateConfig,
    key: &str,
    camera: Option<&str>,
    sample: &Sample,
    params: &serde_json::Map<String, serde_json::Value>,
    scratch: &Path,
) -> std::result::Result<Capture, String> {
    let stem = match camera {
        Some(c) => format!("{key}.{c}"),
        None => key.to_string(),
    };
    let opts = SimulateOptions {
        noise_free: spec.outputs.contains(camsim_pipeline::Output::NoiseFree),
        labels: spec.outputs.label_request(),
        flow: spec.outputs.contains(camsim_pipeline::Output::Flow),
    };
    let sim = simulate(config, &opts, &|_, _, _| {}).map_err(|e| e.to_string())?;
    let dir = OutputDir::create(scratch.join(&stem)).map_err(|e| e.to_string())?;
    sim.write_into(
        &dir,
        &spec.outputs,
        ExrOptions::default(),
        &RunInfo::default(),
    )
    .map_err(|e| e.to_string())?;
    let mut files = Vec::new();
    // The sample's record: deterministic (no timings, no command line): the same bytes for
    // the same (spec, index) on any machine.
    let mut meta = sim.metadata(&RunInfo::default(), &spec.outputs);
    if let Some(m) = meta.as_object_mut() {
        for k in ["times", "command", "config_file", "files"] {
            m.remove(k);
        }
        m.insert("index".into(), sample.index.into());
        m.insert("seed".into(), config.seed.into());
        m.insert("params".into(), serde_json::Value::Object(params.clone()));
        if let Some(c) = camera {
            m.insert("rig_camera".into(), c.into());
        }
    }
    files.push((
        format!("{stem}.json"),
        serde_json::to_vec_pretty(&meta).map_err(|e| e.to_string())?,
    ));
    let mut names: Vec<String> = std::fs::read_dir(dir.path())
        .map_err(|e| e.to_string())?
        .filter_map(|e| e.ok().map(|e| e.file_name().to_string_lossy().into_owned()))
        // run.json is replaced by the record above; dot files are the folder's own markers.
        .filter(|n| n != "run.json" && !n.starts_with('.'))
        .collect();
    names.sort();
    for n in names {
        let bytes = std::fs::read(dir.join(&n)).map_err(|e| format!("{n}: {e}"))?;
        // raw.dng -> KEY.dng (the WebDataset extension); the others keep their names.
        let name = if n == "raw.dng" {
            format!("{stem}.dng")
        } else {
            format!("{stem}.{n}")
        };
        files.push((name, bytes));
    }
    drop(dir); // not committed: the staging folder is removed
    if spec.xyz {
        let path = scratch.join(format!("{stem}.xyz.exr"));
        let radiance = sim.radiance.as_ref().ok_or(
            "xyz = true needs the scene's radiance, but the scene's lens camera (realistic or raytransfer) renders sensor-plane irradiance: set xyz = false or use a pinhole camera",
        )?;
        let [x, y, z] = scene_xyz(radiance);
        camsim_io::exr::write_channels_exr(
            &path,
            radiance.rows,
            radiance.cols,
            &[("X", &x), ("Y", &y), ("Z", &z)],
        )
        .map_err(|e| e.to_string())?;
        files.push((
            format!("{stem}.xyz.exr"),
            std::fs::read(&path).map_err(|e| e.to_string())?,
        ));
        let _ = std::fs::remove_file(&path);
    }
    if spec.raw_npy {
        let f = &sim.frames[0];
        files.push((format!("{stem}.raw.npy"), npy_u16(&f.dn, f.rows, f.cols)));
    }
    Ok(Capture {
        files,
        exposure_s: sim.exposure_s,
        times_s: sim.times_s.clone(),
    })
}

/// The scene's CIE 1931 XYZ per pixel, absolute: X = 683 lm/W sum_b x_bar(l_b) L_b dl (and Y, Z
/// alike; CIE 015:2018 eq. 7.1), so Y is the luminance in cd/m^2 of the radiance in W/(sr m^2
/// nm). Accumulated band by band over whole planes (no per-pixel buffers).
fn scene_xyz(radiance: &camsim_core::SpectralImage) -> [Vec<f32>; 3] {
    let cmfs = camsim_core::colorimetry::Cmfs::on(&radiance.grid);
    let scale = camsim_core::units::LUMINOUS_EFFICACY_LM_PER_W * radiance.grid.step_nm;
    let n = radiance.rows * radiance.cols;
    let weights = [&cmfs.x, &cmfs.y, &cmfs.z];
    let planes: Vec<Vec<f32>> = (0..3)
        .into_par_iter()
        .map(|c| {
            let mut out = vec![0f32; n];
            for b in 0..radiance.bands() {
                let w = (weights[c][b] * scale) as f32;
                if w != 0.0 {
                    for (o, l) in out.iter_mut().zip(radiance.band(b)) {
                        *o += w * l;
                    }
                }
            }
            out
        })
        .collect();
    let mut it = planes.into_iter();
    let mut next = || it.next().unwrap_or_default();
    [next(), next(), next()]
}

/// A 2D uint16 array in NumPy's .npy format, version 1.0 (header: magic, version, little-endian
/// header length, a dict literal padded with spaces to a multiple of 64 bytes and a newline).
fn npy_u16(data: &[u16], rows: usize, cols: usize) -> Vec<u8> {
    let dict = format!("{{'descr': '<u2', 'fortran_order': False, 'shape': ({rows}, {cols}), }}");
    let unpadded = 10 + dict.len() + 1;
    let pad = unpadded.div_ceil(64) * 64 - unpadded;
    let header = format!("{dict}{}\n", " ".repeat(pad));
    let mut out = Vec::with_capacity(10 + header.len() + data.len() * 2);
    out.extend_from_slice(b"\x93NUMPY\x01\x00");
    out.extend_from_slice(&(header.len() as u16).to_le_bytes());
    out.extend_from_slice(header.as_bytes());
    for v in data {
        out.extend_from_slice(&v.to_le_bytes());
    }
    out
}

/// Run shard `s` of `spec` into `out` (samples in parallel on the current rayon pool), writing
/// its tar and record atomically. `on_sample` is called as each sample finishes. Fails at once
/// when another process is writing the shard.
pub fn run_shard(
    spec: &DatasetSpec,
    out: &Path,
    s: u64,
    on_sample: &(dyn Fn(&SampleRecord) + Sync),
) -> Result<ShardRecord> {
    if s >= spec.shards() {
        return Err(DatasetError::spec(
            &spec.source,
            format!(
                "shard {s} is out of range (the dataset has {})",
                spec.shards()
            ),
        ));
    }
    // Like the shard lock's, the spec temporaries removed here are not reported by this
    // single-shard entry point (`run` reports both).
    prepare(spec, out)?;
    let stem = shard_stem(spec, s);
    let lock = try_lock_shard(spec, out, s)?.ok_or_else(|| {
        DatasetError::file(
            &out.join(format!("{stem}.tar")),
            "is being written by another camsim run; wait for it to finish",
        )
    })?;
    run_locked_shard(spec, out, s, &lock, rayon::current_num_threads(), on_sample)
}

/// A shard's lock, with the temporaries killed runs left for it removed.
struct ShardLock {
    _lock: OutputLock,
    removed: Vec<PathBuf>,
}

/// Lock shard `s`: `None` when another process is writing it.
fn try_lock_shard(spec: &DatasetSpec, out: &Path, s: u64) -> Result<Option<ShardLock>> {
    let stem = shard_stem(spec, s);
    let Some(lock) = OutputLock::try_acquire(&out.join(&stem))? else {
        return Ok(None);
    };
    let mut removed = Vec::new();
    for name in [stem.clone(), format!("{stem}.tar"), format!("{stem}.json")] {
        removed.extend(remove_stale_temporaries(&out.join(name)));
    }
    Ok(Some(ShardLock {
        _lock: lock,
        removed,
    }))
}

fn run_locked_shard(
    spec: &DatasetSpec,
    out: &Path,
    s: u64,
    _lock: &ShardLock,
    lanes: usize,
    on_sample: &(dyn Fn(&SampleRecord) + Sync),
) -> Result<ShardRecord> {
    let t0 = Instant::now();
    let stem = shard_stem(spec, s);
    let tar_name = format!("{stem}.tar");
    // Each sample's files are staged here (removed on drop, on SIGINT/SIGTERM, and after a
    // SIGKILL by the next run that takes this shard).
    let scratch_dir = ScratchDir::create(&out.join(&stem))?;
    let scratch = scratch_dir.path().to_path_buf();
    let range = spec.shard_range(s);
    // `lanes` samples at once, each lane taking the next sample when it finishes one; a
    // sample's own parallel work (render tiles, bands) runs on every thread of the pool, so one
    // lane still uses the whole machine. The results go to their index's slot.
    let next = std::sync::atomic::AtomicU64::new(range.start);
    let slots: Vec<std::sync::Mutex<Option<SampleFiles>>> =
        range.clone().map(|_| std::sync::Mutex::new(None)).collect();
    let lanes = lanes.clamp(1, slots.len().max(1));
    (0..lanes).into_par_iter().for_each(|_| loop {
        let i = next.fetch_add(1, Ordering::Relaxed);
        if i >= range.end {
            break;
        }
        let sf = {
            let sf = match spec.sample(i) {
                Ok(sample) => run_sample(spec, &sample, &scratch, &tar_name),
                Err(e) => SampleFiles {
                    record: SampleRecord {
                        index: i,
                        key: format!("{i:08}"),
                        status: "error".into(),
                        error: Some(e.to_string()),
                        seed: 0,
                        params: Default::default(),
                        files: Vec::new(),
                        shard: tar_name.clone(),
                        exposure_s: None,
                        times_s: Default::default(),
                    },
                    files: Vec::new(),
                },
            };
            on_sample(&sf.record);
            sf
        };
        if let Ok(mut slot) = slots[(i - range.start) as usize].lock() {
            *slot = Some(sf);
        }
    });
    let samples: Vec<SampleFiles> = slots
        .into_iter()
        .filter_map(|m| m.into_inner().ok().flatten())
        .collect();
    if samples.len() as u64 != range.end - range.start {
        return Err(DatasetError::file(
            &out.join(&tar_name),
            "a sample of the shard did not finish",
        ));
    }
    drop(scratch_dir);

    // The tar: entries in index order, fixed metadata (mode 0644, mtime 0, uid/gid 0), so its
    // bytes depend on the samples alone.
    let tar_path = out.join(&tar_name);
    let mut digest = (String::new(), 0u64);
    write_atomic(&tar_path, |w| {
        let mut hw = Hashing {
            inner: w,
            hash: Sha256::new(),
            bytes: 0,
        };
        {
            let mut b = tar::Builder::new(&mut hw);
            b.mode(tar::HeaderMode::Deterministic);
            for sf in &samples {
                for (name, bytes) in &sf.files {
                    let mut h = tar::Header::new_gnu();
                    h.set_size(bytes.len() as u64);
                    h.set_mode(0o644);
                    h.set_mtime(0);
                    h.set_cksum();
                    b.append_data(&mut h, name, bytes.as_slice())?;
                }
            }
            b.finish()?;
        }
        digest = (format!("{:x}", hw.hash.clone().finalize()), hw.bytes);
        Ok(())
    })?;
    let record = ShardRecord {
        shard: s,
        first: range.start,
        end: range.end,
        tar: tar_name,
        sha256: digest.0,
        bytes: digest.1,
        spec: spec.fingerprint.clone(),
        seconds: t0.elapsed().as_secs_f64(),
        samples: samples.into_iter().map(|s| s.record).collect(),
    };
    // The record last: its presence (with the checksum) marks the shard complete.
    write_json_atomic(&out.join(format!("{stem}.json")), &record)?;
    Ok(record)
}

/// Progress of a [`run`]: samples done (of this run), samples this run will do, failures so far.
pub type RunProgress<'a> = dyn Fn(u64, u64, u64) + Sync + 'a;

/// Run every shard `select` owns that is not already complete, then gather the manifest if the
/// whole dataset is complete. `workers` samples run at once (None: one per core), each sample's
/// own parallel work spread over every thread of the current pool (so `workers = 1` still uses
/// the whole machine for its one sample).
pub fn run(
    spec: &DatasetSpec,
    out: &Path,
    select: ShardSelect,
    workers: Option<usize>,
    verify: bool,
    progress: &RunProgress<'_>,
) -> Result<RunSummary> {
    let t0 = Instant::now();
    let limit = camsim_core::mem::thread_limit();
    if let Some(w) = workers.filter(|w| *w > limit) {
        return Err(DatasetError::spec(
            &spec.source,
            format!("--workers {w}: at most 4 per core, 1..={limit} on this machine (the output does not depend on the count)"),
        ));
    }
    let removed_spec = prepare(spec, out)?;
    let owned: Vec<u64> = (0..spec.shards()).filter(|s| select.owns(*s)).collect();
    let todo: Vec<u64> = owned
        .iter()
        .copied()
        .filter(|s| shard_complete(spec, out, *s, verify).is_none())
        .collect();
    let total: u64 = todo
        .iter()
        .map(|s| spec.shard_range(*s).count() as u64)
        .sum();
    let done = AtomicU64::new(0);
    let failed = AtomicU64::new(0);
    progress(0, total, 0);
    // Every thread of the machine (or of --threads) for the samples' own work, and at least one
    // per worker; `workers` samples at once.
    let lanes = workers.unwrap_or_else(rayon::current_num_threads).max(1);
    let builder =
        rayon::ThreadPoolBuilder::new().num_threads(rayon::current_num_threads().max(lanes));
    let pool = builder.build().map_err(|e| {
        DatasetError::spec(
            &spec.source,
            format!("cannot start {workers:?} workers: {e}"),
        )
    })?;
    let (mut written, mut busy, mut removed) = (0u64, 0u64, removed_spec);
    for s in &todo {
        // Another process writing this shard keeps it; one that completed it meanwhile is kept.
        let Some(lock) = try_lock_shard(spec, out, *s)? else {
            busy += 1;
            continue;
        };
        removed.extend(lock.removed.iter().cloned());
        if shard_complete(spec, out, *s, false).is_some() {
            continue;
        }
        pool.install(|| {
            run_locked_shard(spec, out, *s, &lock, lanes, &|r| {
                if r.status != "ok" {
                    failed.fetch_add(1, Ordering::Relaxed);
                }
                let d = done.fetch_add(1, Ordering::Relaxed) + 1;
                progress(d, total, failed.load(Ordering::Relaxed));
            })
        })?;
        written += 1;
    }
    let complete = gather(spec, out, false)?.is_some();
    Ok(RunSummary {
        shards_total: spec.shards(),
        shards_written: written,
        shards_skipped: owned.len() as u64 - written - busy,
        samples_run: done.load(Ordering::Relaxed),
        samples_failed: failed.load(Ordering::Relaxed),
        seconds: t0.elapsed().as_secs_f64(),
        complete,
        shards_busy: busy,
        removed_temporaries: removed,
    })
}

/// If every shard is complete, write `manifest.jsonl` (one line per sample, index order) and
/// return its path; else None. `verify` re-checks every tar's checksum.
pub fn gather(spec: &DatasetSpec, out: &Path, verify: bool) -> Result<Option<PathBuf>> {
    let mut records = Vec::new();
    for s in 0..spec.shards() {
        match shard_complete(spec, out, s, verify) {
            Some(r) => records.push(r),
            None => return Ok(None),
        }
    }
    let path = out.join("manifest.jsonl");
    write_atomic(&path, |w| {
        for r in &records {
            for s in &r.samples {
                serde_json::to_writer(&mut *w, s).map_err(|e| {
                    camsim_io::IoError::invalid(Path::new("manifest.jsonl"), e.to_string())
                })?;
                w.write_all(b"\n")?;
            }
        }
        Ok(())
    })?;
    Ok(Some(path))
}
