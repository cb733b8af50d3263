//! Datasets: determinism (same bytes for any worker count, shard split and order), the variation
//! rules, resume after damage, failures recorded per sample, and specs refused before any work.

use camsim_dataset::{run, run_shard, shard_complete, DatasetSpec, ShardSelect};
use std::path::Path;

/// A tiny spec: 32 x 48 ColorChecker captures, 7 samples in shards of 3 (the last one short).
fn spec_text(extra: &str) -> String {
    format!(
        r#"
[dataset]
samples = 7
shard_size = 3
seed = 11
outputs = ["raw", "raw-npy", "preview", "noise-free", "irradiance"]

[base]
wavelengths = {{ start_nm = 400.0, step_nm = 20.0, count = 16 }}
scene = {{ kind = "macbeth", illuminant = "D65" }}
sensor = {{ preset = "pixel4a", rows = 32, cols = 48 }}

[[vary]]
key = "scene.illuminant"
values = ["D65", "A"]

[[vary]]
key = "optics.config.f_number"
values = [1.73, 2.8, 4.0]

[[vary]]
key = "capture.exposure_ms"
log_uniform = [1.0, 10.0]
{extra}
"#
    )
}

fn spec(extra: &str) -> DatasetSpec {
    DatasetSpec::from_toml_str(&spec_text(extra), "test spec", Path::new(".")).unwrap()
}

fn bytes(dir: &Path, name: &str) -> Vec<u8> {
    std::fs::read(dir.join(name)).unwrap_or_else(|e| panic!("{name}: {e}"))
}

#[test]
fn grids_cycle_in_mixed_radix_and_random_draws_depend_on_the_index_only() {
    let s = spec("");
    for i in 0..7u64 {
        let a = s.sample(i).unwrap();
        // First grid fastest: illuminant = i mod 2, f-number = (i / 2) mod 3.
        assert_eq!(
            a.params[0].1.as_str().unwrap(),
            ["D65", "A"][(i % 2) as usize]
        );
        assert_eq!(
            a.params[1].1.as_float().unwrap(),
            [1.73, 2.8, 4.0][((i / 2) % 3) as usize]
        );
        let t = a.params[2].1.as_float().unwrap();
        assert!((1.0..10.0).contains(&t), "{t}");
        // The effective config carries the drawn values.
        assert_eq!(a.config.capture.exposure_ms, Some(t));
        assert_eq!(
            a.config.optics.config.as_ref().unwrap().f_number,
            a.params[1].1.as_float().unwrap()
        );
        assert_eq!(a.config.seed, a.seed);
        // Drawn again, in another order: identical.
        let again = s.sample(i).unwrap();
        assert_eq!(again.params, a.params);
        assert_eq!(again.seed, a.seed);
    }
    // A different master seed draws other values.
    let other = DatasetSpec::from_toml_str(
        &spec_text("").replace("seed = 11", "seed = 12"),
        "t",
        Path::new("."),
    )
    .unwrap();
    assert_ne!(
        other.sample(0).unwrap().params[2],
        s.sample(0).unwrap().params[2]
    );
}

#[test]
fn log_uniform_and_normal_draws_follow_their_distributions() {
    let s = DatasetSpec::from_toml_str(
        &spec_text(
            r#"
[[vary]]
key = "scene.mean_luminance_cd_m2"
normal = { mean = 100.0, std = 20.0, min = 80.0, max = 200.0 }
"#,
        )
        .replace("samples = 7", "samples = 4000"),
        "t",
        Path::new("."),
    )
    .unwrap();
    let n = 4000;
    let (mut log_sum, mut norm) = (0.0, Vec::new());
    for i in 0..n {
        let p = s.sample(i).unwrap().params;
        log_sum += p[2].1.as_float().unwrap().ln();
        let x = p[3].1.as_float().unwrap();
        assert!((80.0..=200.0).contains(&x));
        norm.push(x);
    }
    // log of a log-uniform draw on [1, 10) is uniform on [0, ln 10): mean ln(10)/2, s.d. of the
    // mean ln(10)/sqrt(12 n).
    let m = log_sum / n as f64;
    let se = 10f64.ln() / (12.0 * n as f64).sqrt();
    assert!((m - 10f64.ln() / 2.0).abs() < 4.0 * se, "mean log {m}");
    // A normal truncated to [mean - 1 sd, mean + 5 sd]: mean = mu + sd phi(-1) / (1 - Phi(-1))
    // = 100 + 20 x 0.24197 / 0.84134 = 105.752 (Johnson, Kotz & Balakrishnan, truncated normal).
    let mean = norm.iter().sum::<f64>() / n as f64;
    assert!(
        (mean - 105.752).abs() < 4.0 * 20.0 * 0.8 / (n as f64).sqrt(),
        "truncated normal mean {mean}"
    );
}

#[test]
fn same_bytes_for_any_worker_count_and_shard_split_and_resume_redoes_only_damaged_shards() {
    let s = spec("");
    let a = tempfile::tempdir().unwrap();
    let b = tempfile::tempdir().unwrap();
    let ra = run(
        &s,
        a.path(),
        ShardSelect::default(),
        Some(1),
        true,
        &|_, _, _| {},
    )
    .unwrap();
    assert!(
        ra.complete && ra.shards_written == 3 && ra.samples_run == 7 && ra.samples_failed == 0,
        "{ra:?}"
    );
    // Two parts of two, the second first, with two workers.
    for part in [1, 0] {
        let r = run(
            &s,
            b.path(),
            ShardSelect {
                index: part,
                count: 2,
            },
            Some(2),
            true,
            &|_, _, _| {},
        )
        .unwrap();
        assert_eq!(r.complete, part == 0);
    }
    for stem in [
        "shard-00000000-00000002",
        "shard-00000003-00000005",
        "shard-00000006-00000006",
    ] {
        assert_eq!(
            bytes(a.path(), &format!("{stem}.tar")),
            bytes(b.path(), &format!("{stem}.tar")),
            "{stem}"
        );
    }
    // The manifest: one line per sample, in index order, each with its files.
    let manifest = String::from_utf8(bytes(a.path(), "manifest.jsonl")).unwrap();
    let lines: Vec<serde_json::Value> = manifest
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(lines.len(), 7);
    for (i, l) in lines.iter().enumerate() {
        assert_eq!(l["index"], i as u64);
        let files: Vec<&str> = l["files"]
            .as_array()
            .unwrap()
            .iter()
            .map(|f| f.as_str().unwrap())
            .collect();
        let key = format!("{i:08}");
        for ext in ["json", "dng", "raw.npy", "preview.png", "noise_free.exr"] {
            assert!(
                files.contains(&format!("{key}.{ext}").as_str()),
                "{files:?}"
            );
        }
    }

    // Damage the middle shard and leave a killed run's temporary beside it: a re-run redoes that
    // shard alone, removes the temporary, and gets the same bytes back.
    let mid = a.path().join("shard-00000003-00000005.tar");
    let good = std::fs::read(&mid).unwrap();
    std::fs::write(&mid, &good[..good.len() / 2]).unwrap();
    let stale = a
        .path()
        .join(".shard-00000003-00000005.tar.camsim-tmp-999999-0");
    std::fs::write(&stale, b"partial").unwrap();
    assert!(shard_complete(&s, a.path(), 1, true).is_none());
    let r = run(
        &s,
        a.path(),
        ShardSelect::default(),
        None,
        true,
        &|_, _, _| {},
    )
    .unwrap();
    assert_eq!((r.shards_written, r.shards_skipped), (1, 2), "{r:?}");
    assert_eq!(std::fs::read(&mid).unwrap(), good);
    assert!(!stale.exists());
    // Same size, one byte changed: caught by the checksum.
    let mut flipped = good.clone();
    flipped[600] ^= 1;
    std::fs::write(&mid, &flipped).unwrap();
    assert!(
        shard_complete(&s, a.path(), 1, false).is_some(),
        "size-only check passes"
    );
    assert!(
        shard_complete(&s, a.path(), 1, true).is_none(),
        "checksum catches it"
    );
}

#[test]
fn the_raw_npy_holds_the_dng_values() {
    let s = spec("");
    let d = tempfile::tempdir().unwrap();
    run_shard(&s, d.path(), 2, &|_| {}).unwrap();
    let mut ar = tar::Archive::new(
        std::fs::File::open(d.path().join("shard-00000006-00000006.tar")).unwrap(),
    );
    let mut files = std::collections::BTreeMap::new();
    for e in ar.entries().unwrap() {
        let mut e = e.unwrap();
        let name = e.path().unwrap().to_string_lossy().into_owned();
        let mut v = Vec::new();
        std::io::Read::read_to_end(&mut e, &mut v).unwrap();
        files.insert(name, v);
    }
    let npy = &files["00000006.raw.npy"];
    let header_len = u16::from_le_bytes([npy[8], npy[9]]) as usize;
    let header = std::str::from_utf8(&npy[10..10 + header_len]).unwrap();
    assert!(
        header.contains("'descr': '<u2'") && header.contains("'shape': (32, 48)"),
        "{header}"
    );
    assert_eq!((10 + header_len) % 64, 0);
    let values: Vec<u16> = npy[10 + header_len..]
        .chunks(2)
        .map(|c| u16::from_le_bytes([c[0], c[1]]))
        .collect();
    let dng_path = d.path().join("x.dng");
    std::fs::write(&dng_path, &files["00000006.dng"]).unwrap();
    let (raw, _) = camsim_io::dng::read_dng(&dng_path).unwrap();
    assert_eq!(values, raw.dn);
    let record: serde_json::Value = serde_json::from_slice(&files["00000006.json"]).unwrap();
    assert_eq!(record["index"], 6);
    assert!(
        record.get("times").is_none(),
        "the per-sample record holds no timings"
    );
}

#[test]
fn a_sample_that_fails_is_recorded_and_the_others_complete() {
    let d = tempfile::tempdir().unwrap();
    // A scene file that exists (so the spec passes its check) but is not an EXR.
    std::fs::write(d.path().join("broken.exr"), b"not an exr").unwrap();
    let text = spec_text(
        r#"
[[vary]]
key = "scene"
values = [{ kind = "macbeth" }, { kind = "file", path = "broken.exr" }]
"#,
    );
    let s = DatasetSpec::from_toml_str(&text, "t", d.path()).unwrap();
    let out = d.path().join("ds");
    let r = run(&s, &out, ShardSelect::default(), None, true, &|_, _, _| {}).unwrap();
    assert!(r.complete);
    let manifest = std::fs::read_to_string(out.join("manifest.jsonl")).unwrap();
    let lines: Vec<serde_json::Value> = manifest
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    // The 4th variation is the slowest grid: samples 0-5 use macbeth... with 2 x 3 x 2 grid
    // points, index i takes the file scene when (i / 6) mod 2 == 1: sample 6.
    for l in &lines {
        let i = l["index"].as_u64().unwrap();
        if (i / 6) % 2 == 1 {
            assert_eq!(l["status"], "error", "{l}");
            assert!(l["error"].as_str().unwrap().contains("broken.exr"), "{l}");
        } else {
            assert_eq!(l["status"], "ok", "{l}");
        }
    }
}

#[test]
fn bad_specs_are_refused_before_any_work_naming_the_key() {
    let cases: Vec<(String, &str)> = vec![
        (spec_text("[[vary]]\nkey = \"optics.config.f_numbr\"\nvalues = [2.0]\n"), "f_numbr"),
        (spec_text("[[vary]]\nkey = \"capture.exposure_ms\"\nuniform = [5.0, 1.0]\n"), "min < max"),
        (spec_text("[[vary]]\nkey = \"capture.exposure_ms\"\nlog_uniform = [0.0, 1.0]\n"), "min > 0"),
        (spec_text("[[vary]]\nkey = \"sensor.preset\"\nchoice = [\"pixel4a\", \"nosuchsensor\"]\n"), "nosuchsensor"),
        (spec_text("[[vary]]\nkey = \"scene\"\nvalues = [{ kind = \"file\", path = \"missing.exr\" }]\n"), "missing.exr"),
        (spec_text("[[vary]]\nkey = \"capture.exposure_ms\"\nvalues = [1.0]\nuniform = [1.0, 2.0]\n"), "exactly one"),
        (spec_text("").replace("samples = 7", "samples = 0"), "samples"),
        (spec_text("").replace("[base]", "[base]\nseed = 3"), "seed"),
        (spec_text("").replace("\"irradiance\"]", "\"irradiance\", \"hdr\"]"), "hdr"),
        (spec_text("").replace("[dataset]", "[dataset]\nsample = 3"), "sample"),
    ];
    for (text, needle) in cases {
        let e = DatasetSpec::from_toml_str(&text, "my-spec.toml", Path::new("."))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("my-spec.toml") && e.contains(needle),
            "expected {needle:?} in: {e}"
        );
    }
    // A folder of another spec is refused.
    let d = tempfile::tempdir().unwrap();
    run_shard(&spec(""), d.path(), 2, &|_| {}).unwrap();
    let other = DatasetSpec::from_toml_str(
        &spec_text("").replace("seed = 11", "seed = 5"),
        "t",
        Path::new("."),
    )
    .unwrap();
    let e = run(
        &other,
        d.path(),
        ShardSelect::default(),
        None,
        true,
        &|_, _, _| {},
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("spec.json") && e.contains("another spec"), "{e}");
    assert!(ShardSelect::parse("2/2").is_err() && ShardSelect::parse("x").is_err());
    assert_eq!(
        ShardSelect::parse("1/3").unwrap(),
        ShardSelect { index: 1, count: 3 }
    );
}

#[test]
fn a_bad_output_name_lists_every_output_a_dataset_takes() {
    let text = spec_text("").replace("\"irradiance\"]", "\"irradiance\", \"rwa\"]");
    let e = DatasetSpec::from_toml_str(&text, "my-spec.toml", Path::new("."))
        .unwrap_err()
        .to_string();
    assert!(e.contains("my-spec.toml") && e.contains("'rwa'"), "{e}");
    // Every name of both tables the spec dispatches on: a run's outputs and the dataset's own.
    let names = camsim_pipeline::outputs::OUTPUTS
        .names()
        .into_iter()
        .chain(camsim_dataset::spec::DATASET_OUTPUTS.names());
    for name in names {
        assert!(e.contains(name), "{name} missing from: {e}");
    }
    assert!(e.contains("raw-npy") && e.contains("xyz"), "{e}");
}

#[test]
fn the_xyz_ground_truth_has_the_scene_luminance_and_the_illuminant_white_point() {
    // A uniform white field under D65 at 100 cd/m^2 on 380-780 nm: Y = 100 cd/m^2 everywhere and
    // the chromaticity of CIE D65, (0.3127, 0.3290) (CIE 015:2018 table 1).
    let text = r#"
[dataset]
samples = 1
outputs = ["xyz"]
[base]
wavelengths = { start_nm = 380.0, step_nm = 5.0, count = 81 }
scene = { kind = "uniform", illuminant = "D65", mean_luminance_cd_m2 = 100.0, reflectance = 1.0, rows = 16, cols = 16 }
sensor = { preset = "pixel4a", rows = 16, cols = 16 }
capture = { exposure_ms = 1.0 }
"#;
    let s = DatasetSpec::from_toml_str(text, "t", Path::new(".")).unwrap();
    let d = tempfile::tempdir().unwrap();
    let rec = run_shard(&s, d.path(), 0, &|_| {}).unwrap();
    assert_eq!(rec.samples[0].status, "ok", "{:?}", rec.samples[0].error);
    let mut ar = tar::Archive::new(std::fs::File::open(d.path().join(&rec.tar)).unwrap());
    let mut exr = None;
    for e in ar.entries().unwrap() {
        let mut e = e.unwrap();
        if e.path().unwrap().to_string_lossy() == "00000000.xyz.exr" {
            let mut v = Vec::new();
            std::io::Read::read_to_end(&mut e, &mut v).unwrap();
            exr = Some(v);
        }
    }
    let p = d.path().join("xyz.exr");
    std::fs::write(&p, exr.expect("the tar holds KEY.xyz.exr")).unwrap();
    let plane = |c: &str| camsim_io::exr::read_gray_exr(&p, Some(c)).unwrap().2;
    let (x, y, z) = (plane("X"), plane("Y"), plane("Z"));
    let mean = |v: &[f32]| v.iter().map(|a| *a as f64).sum::<f64>() / v.len() as f64;
    let (mx, my, mz) = (mean(&x), mean(&y), mean(&z));
    assert!((my - 100.0).abs() < 0.01, "Y {my}");
    let (cx, cy) = (mx / (mx + my + mz), my / (mx + my + mz));
    assert!(
        (cx - 0.3127).abs() < 0.0005 && (cy - 0.3290).abs() < 0.0005,
        "xy {cx} {cy}"
    );
}

#[test]
fn overlay_variations_move_objects_and_scale_the_light_of_a_rendered_scene() {
    // The Cornell box with an inline overlay: the light's luminance drawn from a grid, the short
    // block's x position from a uniform draw (an array element of an array-of-tables entry). The
    // overlay fixes the render seed, so two samples differ only by what was varied.
    let text = r#"
[dataset]
samples = 4
shard_size = 4
outputs = ["radiance"]
[base]
wavelengths = { start_nm = 400.0, step_nm = 50.0, count = 7 }
sensor = { preset = "pixel4a", rows = 24, cols = 24 }
capture = { exposure_ms = 1.0 }
[base.render]
builtin = "cornell-box"
samples_per_pixel = 2
resolution = [24, 24]
[base.render.overlay_inline.render]
seed = 5
[base.render.overlay_inline.light]
luminance_cd_m2 = 1000.0
[[base.render.overlay_inline.object]]
name = "short_block"
translate_m = [0.0, 0.0, 0.0]

[[vary]]
key = "render.overlay_inline.light.luminance_cd_m2"
values = [1000.0, 2000.0]

[[vary]]
key = "render.overlay_inline.object.0.translate_m.0"
values = [0.0, 0.08]
"#;
    let s = DatasetSpec::from_toml_str(text, "t", Path::new(".")).unwrap();
    let p1 = s.sample(1).unwrap();
    let ov = p1
        .config
        .render
        .as_ref()
        .unwrap()
        .overlay_inline
        .as_ref()
        .unwrap();
    assert_eq!(ov["light"]["luminance_cd_m2"].as_float(), Some(2000.0));
    assert_eq!(
        s.sample(2)
            .unwrap()
            .config
            .render
            .unwrap()
            .overlay_inline
            .unwrap()["object"][0]["translate_m"][0]
            .as_float(),
        Some(0.08)
    );
    let d = tempfile::tempdir().unwrap();
    let r = run(
        &s,
        d.path(),
        ShardSelect::default(),
        None,
        true,
        &|_, _, _| {},
    )
    .unwrap();
    assert_eq!(r.samples_failed, 0);
    let lines: Vec<serde_json::Value> = std::fs::read_to_string(d.path().join("manifest.jsonl"))
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    // Radiance is linear in the only light's luminance: with the same random stream, exactly 2x.
    let mut ar = tar::Archive::new(
        std::fs::File::open(d.path().join(lines[0]["shard"].as_str().unwrap())).unwrap(),
    );
    let mut means = std::collections::BTreeMap::new();
    for e in ar.entries().unwrap() {
        let mut e = e.unwrap();
        let name = e.path().unwrap().to_string_lossy().into_owned();
        if name.ends_with(".radiance.exr") {
            let p = d.path().join(&name);
            let mut f = std::fs::File::create(&p).unwrap();
            std::io::copy(&mut e, &mut f).unwrap();
            let img = camsim_io::exr::read_spectral_exr(&p).unwrap();
            let m: f64 = (0..img.bands())
                .map(|b| img.band(b).iter().map(|v| *v as f64).sum::<f64>())
                .sum();
            means.insert(name[..8].to_string(), m);
        }
    }
    let ratio = means["00000001"] / means["00000000"];
    assert!(
        (ratio - 2.0).abs() < 1e-4,
        "light 2000 / 1000 cd/m^2: radiance ratio {ratio}"
    );
    // Moving the block changes the image; the light does not move it back.
    let moved = means["00000002"] / means["00000000"];
    assert!(
        (moved - 1.0).abs() > 1e-4,
        "the block moved but the image did not change: {moved}"
    );
    // An index past the array is refused before any work.
    let bad = text.replace("object.0.translate_m.0", "object.3.translate_m.0");
    let e = DatasetSpec::from_toml_str(&bad, "t", Path::new("."))
        .unwrap_err()
        .to_string();
    assert!(e.contains("no index 3"), "{e}");
}

#[test]
fn id_maps_of_a_rendered_scene_follow_the_objects_moved_by_a_variation() {
    // Segmentation ground truth beside each raw image: the Cornell box's short block moved by
    // 8 cm between two samples; its region in the object id map (found by its name in the
    // legend) keeps about its size and moves.
    let text = r#"
[dataset]
samples = 2
shard_size = 2
outputs = ["raw", "ids"]
[base]
wavelengths = { start_nm = 400.0, step_nm = 50.0, count = 7 }
sensor = { preset = "pixel4a", rows = 1536, cols = 1536 }
capture = { exposure_ms = 1.0 }
[base.render]
builtin = "cornell-box"
samples_per_pixel = 1
resolution = [48, 48]
[[base.render.overlay_inline.object]]
name = "short_block"
translate_m = [0.0, 0.0, 0.0]

[[vary]]
key = "render.overlay_inline.object.0.translate_m.0"
values = [0.0, 0.08]
"#;
    let s = DatasetSpec::from_toml_str(text, "t", Path::new(".")).unwrap();
    let d = tempfile::tempdir().unwrap();
    let r = run(
        &s,
        d.path(),
        ShardSelect::default(),
        None,
        true,
        &|_, _, _| {},
    )
    .unwrap();
    assert_eq!(r.samples_failed, 0);
    let files = shard_files(d.path());
    let mut regions = Vec::new();
    for key in ["00000000", "00000001"] {
        let legend: serde_json::Value =
            serde_json::from_slice(&files[&format!("{key}.ids.json")]).unwrap();
        let block_id: u16 = legend["objects"]
            .as_object()
            .unwrap()
            .iter()
            .find(|(_, v)| v == &"short_block")
            .map(|(k, _)| k.parse().unwrap())
            .unwrap_or_else(|| panic!("short_block not in the legend {legend}"));
        let p = d.path().join(format!("{key}.object_id.png"));
        std::fs::write(&p, &files[&format!("{key}.object_id.png")]).unwrap();
        let (rows, cols, ids) = camsim_io::raster::read_mosaic_16(&p).unwrap();
        assert_eq!((rows, cols), (48, 48));
        let px: Vec<usize> = (0..ids.len()).filter(|&i| ids[i] == block_id).collect();
        let cx = px.iter().map(|&i| (i % cols) as f64).sum::<f64>() / px.len() as f64;
        regions.push((px.len() as f64, cx));
        // The material map agrees: the block's pixels share one material id.
        let m = d.path().join(format!("{key}.material_id.png"));
        std::fs::write(&m, &files[&format!("{key}.material_id.png")]).unwrap();
        let mat = camsim_io::raster::read_mosaic_16(&m).unwrap().2;
        assert!(px.iter().all(|&i| mat[i] == mat[px[0]] && mat[i] != 0));
    }
    let ((a0, x0), (a1, x1)) = (regions[0], regions[1]);
    assert!(
        a0 > 40.0 && (a1 / a0 - 1.0).abs() < 0.25,
        "block area {a0} -> {a1} px"
    );
    // 8 cm of a 55 cm box seen across ~48 px: several pixels.
    assert!((x1 - x0).abs() > 3.0, "block centroid column {x0} -> {x1}");
}

/// A run killed while it wrote `spec.json` leaves only `.spec.json.camsim-tmp-PID-N` in the
/// folder: the next run removes it (its process is gone), reports it, and writes the dataset
/// instead of refusing the folder as foreign (issue 25, found by the kill-and-rerun CLI test).
#[test]
fn a_spec_temporary_of_a_killed_run_does_not_make_the_folder_foreign() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("ds");
    std::fs::create_dir(&out).unwrap();
    // The id of a process that has exited.
    let mut child = std::process::Command::new("true").spawn().unwrap();
    let dead = child.id();
    child.wait().unwrap();
    let tmp = out.join(format!(".spec.json.camsim-tmp-{dead}-0"));
    std::fs::write(&tmp, b"{\"fingerprint\": \"half").unwrap();
    let s = spec("");
    let r = run(&s, &out, ShardSelect::default(), None, false, &|_, _, _| {}).unwrap();
    assert!(!tmp.exists(), "the killed run's temporary is removed");
    assert!(
        r.removed_temporaries.contains(&tmp),
        "{:?}",
        r.removed_temporaries
    );
    assert!(out.join("spec.json").is_file());
}

/// Every file of every shard in `dir`, by name.
fn shard_files(dir: &Path) -> std::collections::BTreeMap<String, Vec<u8>> {
    let mut files = std::collections::BTreeMap::new();
    for p in std::fs::read_dir(dir).unwrap().filter_map(|e| e.ok()) {
        let p = p.path();
        if p.extension().is_some_and(|x| x == "tar") {
            let mut ar = tar::Archive::new(std::fs::File::open(&p).unwrap());
            for e in ar.entries().unwrap() {
                let mut e = e.unwrap();
                let name = e.path().unwrap().to_string_lossy().into_owned();
                let mut bytes = Vec::new();
                std::io::Read::read_to_end(&mut e, &mut bytes).unwrap();
                files.insert(name, bytes);
            }
        }
    }
    files
}

/// An emitting vertical bar 3 cm wide and 4 m tall, 10 m in front of the camera (40 x 30).
const BAR_PBRT: &str = r#"LookAt 0 0 -10  0 0 0  0 1 0
Camera "perspective" "float fov" 5
Film "rgb" "integer xresolution" 40 "integer yresolution" 30
WorldBegin
AttributeBegin
  #ObjectName bar
  AreaLightSource "diffuse" "blackbody L" 5000 "float scale" 3000 "bool twosided" true
  Shape "trianglemesh" "point3 P" [ -0.015 -2 0  0.015 -2 0  0.015 2 0  -0.015 2 0 ]
      "integer indices" [ 0 1 2 0 2 3 ]
AttributeEnd
"#;

/// Run `s` (`samples` samples, none may fail) with one worker and with `workers`: the shards'
/// files, which must be the same bytes both times.
fn same_files_for_one_worker_and(
    s: &DatasetSpec,
    workers: usize,
    samples: u64,
) -> std::collections::BTreeMap<String, Vec<u8>> {
    let (a, b) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    for (out, w) in [(a.path(), 1), (b.path(), workers)] {
        let r = run(s, out, ShardSelect::default(), Some(w), true, &|_, _, _| {}).unwrap();
        let m = std::fs::read_to_string(out.join("manifest.jsonl")).unwrap_or_default();
        assert_eq!((r.samples_run, r.samples_failed), (samples, 0), "{r:?} {m}");
    }
    let (fa, fb) = (shard_files(a.path()), shard_files(b.path()));
    assert_eq!(fa, fb, "one worker and {workers} give different bytes");
    fa
}

#[test]
fn motion_keys_vary_per_sample_deterministically() {
    // An emitting vertical bar 10 m away moving right: per sample its speed is drawn (an
    // element of the overlay object's velocity_m_s) and the shutter cycles through global,
    // rolling and global reset (a whole inline table per value). Each sample's flow on the bar
    // is its own v x exposure, its record names its shutter, and the shards are the same bytes
    // for one worker or three.
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("bar.pbrt"), BAR_PBRT).unwrap();
    let text = r#"
[dataset]
samples = 3
shard_size = 2
seed = 4
outputs = ["raw", "flow"]
[base]
wavelengths = { start_nm = 400.0, step_nm = 50.0, count = 7 }
sensor = { preset = "pixel4a", rows = 60, cols = 80 }
capture = { exposure_ms = 0.5 }
[base.render]
pbrt = "bar.pbrt"
samples_per_pixel = 4
resolution = [40, 30]
[[base.render.overlay_inline.object]]
name = "bar"
velocity_m_s = [0.0, 0.0, 0.0]

[[vary]]
key = "render.overlay_inline.object.0.velocity_m_s.0"
uniform = [2.0, 8.0]

[[vary]]
key = "capture.shutter"
values = ["global", { rolling = { line_time_us = 20.0 } }, { global_reset = { line_time_us = 20.0, mechanical_shutter = true } }]
"#;
    let s = DatasetSpec::from_toml_str(text, "t", dir.path()).unwrap();
    let fa = same_files_for_one_worker_and(&s, 3, 3);
    let mut speeds = Vec::new();
    for (i, kind) in ["global", "rolling", "global_reset"].iter().enumerate() {
        let key = format!("{i:08}");
        let rec: serde_json::Value = serde_json::from_slice(&fa[&format!("{key}.json")]).unwrap();
        assert_eq!(rec["results"]["shutter"]["kind"], *kind, "sample {i}");
        let v_m_s = rec["params"]["render.overlay_inline.object.0.velocity_m_s.0"]
            .as_f64()
            .unwrap();
        assert!((2.0..8.0).contains(&v_m_s));
        speeds.push(v_m_s);
        // The flow on the bar: v x exposure, in sensor pixels (the image distance of a lens
        // focused at infinity is f; 10 m away).
        let f_m = rec["optics"]["focal_length_mm"].as_f64().unwrap() * 1e-3;
        let pitch_m = rec["sensor"]["pixel_pitch_um"].as_f64().unwrap() * 1e-6;
        let want = v_m_s * f_m / 10.0 / pitch_m * 0.5e-3;
        let p = dir.path().join(format!("{key}.flow.exr"));
        std::fs::write(&p, &fa[&format!("{key}.flow.exr")]).unwrap();
        let (_, _, dx) = camsim_io::exr::read_gray_exr(&p, Some("X")).unwrap();
        let max = dx.iter().fold(0f32, |m, v| m.max(*v)) as f64;
        assert!(
            (max / want - 1.0).abs() < 1e-3,
            "sample {i}: flow {max} px, want v T = {want}"
        );
    }
    assert!(speeds[0] != speeds[1] && speeds[1] != speeds[2]);
}

/// Labels of a moving scene in a dataset (issue 28): a burst of two frames of an emitting bar
/// moving right; each sample holds both frames' labels (instances, boxes, depth, ids; the second
/// frame's numbered _0001), the bar's 2D box moves right between them, and the shards are the
/// same bytes for one worker or two.
#[test]
fn labels_of_a_moving_scene_are_per_frame_and_deterministic() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("bar.pbrt"), BAR_PBRT).unwrap();
    let text = r#"
[dataset]
samples = 2
shard_size = 1
seed = 4
outputs = ["raw", "instances", "boxes", "depth", "ids"]
[base]
wavelengths = { start_nm = 400.0, step_nm = 50.0, count = 7 }
sensor = { preset = "pixel4a", rows = 60, cols = 80 }
capture = { exposure_ms = 0.5, frames = 2, frame_interval_ms = 10.0 }
[base.render]
pbrt = "bar.pbrt"
samples_per_pixel = 2
resolution = [40, 30]
[[base.render.overlay_inline.object]]
name = "bar"
velocity_m_s = [0.0, 0.0, 0.0]

[[vary]]
key = "render.overlay_inline.object.0.velocity_m_s.0"
uniform = [2.0, 4.0]
"#;
    let s = DatasetSpec::from_toml_str(text, "t", dir.path()).unwrap();
    let fa = same_files_for_one_worker_and(&s, 2, 2);
    for i in 0..2 {
        let key = format!("{i:08}");
        for name in [
            "instances.png",
            "instances_0001.png",
            "instances_0001.scene.png",
            "depth_0001.exr",
            "depth_0001.sensor.exr",
            "object_id_0001.png",
            "boxes_0001.json",
        ] {
            assert!(fa.contains_key(&format!("{key}.{name}")), "{key}.{name}");
        }
        let bbox = |name: &str| {
            let v: serde_json::Value =
                serde_json::from_slice(&fa[&format!("{key}.{name}")]).unwrap();
            v["instances"][0]["bbox_sensor"].as_array().unwrap()[0]
                .as_u64()
                .unwrap()
        };
        assert!(
            bbox("boxes_0001.json") > bbox("boxes.json"),
            "sample {i}: the bar's box must move right between the frames"
        );
    }
}

/// Issue 41 item 4: an `[hdr]` sensor (examples/sensor-dcg.toml) in a dataset spec: each sample
/// holds both readouts and the merged frame, the sample's record the merge's figures, and the
/// bytes are the same for one worker and two.
#[test]
fn an_hdr_sensor_in_a_dataset_writes_both_readouts_and_the_merge_per_sample() {
    let text = r#"
[dataset]
samples = 3
shard_size = 3
seed = 4
outputs = ["raw", "preview"]

[base]
wavelengths = { start_nm = 400.0, step_nm = 20.0, count = 16 }
scene = { kind = "macbeth", illuminant = "D65" }
sensor = { file = "sensor-dcg.toml", rows = 32, cols = 48 }

[[vary]]
key = "capture.exposure_ms"
log_uniform = [1.0, 100.0]
"#;
    let examples = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples");
    let s = DatasetSpec::from_toml_str(text, "hdr spec", &examples).unwrap();
    let files = same_files_for_one_worker_and(&s, 2, 3);
    for i in 0..3 {
        for ext in ["dng", "raw_low.dng", "merged.exr", "preview.png", "json"] {
            let name = format!("{i:08}.{ext}");
            assert!(files.contains_key(&name), "{name} in {:?}", files.keys());
        }
        let rec: serde_json::Value =
            serde_json::from_slice(&files[&format!("{i:08}.json")]).unwrap();
        let db = rec["results"]["hdr"]["dynamic_range_db"].as_f64().unwrap();
        assert!((db - 85.8).abs() < 0.2, "sample {i}: {db} dB");
    }
}
