//! The camera in time through the whole pipeline (issue 28): the sensor's exposure windows drive
//! the render, a rolling shutter's rows map to render rows through the optics (the lens turns
//! the image over: the sensor's top row sees the bottom of the scene), flow comes on the sensor
//! grid, and a video of a static scene has frames of the same mean with independent noise.

use camsim::{simulate, SimulateConfig, SimulateOptions};

fn quiet(_: &str, _: u64, _: u64) {}

/// An emitting vertical bar 3 cm wide and 4 m tall, 10 m in front of the camera, nothing else.
const BAR: &str = r#"
LookAt 0 0 -10  0 0 0  0 1 0
Camera "perspective" "float fov" 5
Film "rgb" "integer xresolution" 80 "integer yresolution" 60
WorldBegin
AttributeBegin
  #ObjectName bar
  AreaLightSource "diffuse" "blackbody L" 5000 "float scale" 3000 "bool twosided" true
  Shape "trianglemesh" "point3 P" [ -0.015 -2 0  0.015 -2 0  0.015 2 0  -0.015 2 0 ]
      "integer indices" [ 0 1 2 0 2 3 ]
AttributeEnd
"#;

/// The config of the bar moving right at `v_m_s` on a 120 x 160 pixel4a window, rendered at
/// 80 x 60 (2 sensor pixels per render pixel), exposed 0.2 ms with `shutter`.
fn bar_config(dir: &std::path::Path, v_m_s: f64, shutter: &str) -> SimulateConfig {
    bar_config_with(dir, v_m_s, shutter, "exposure_ms = 0.2")
}

/// [`bar_config`] with `capture` (more `[capture]` keys) instead of the 0.2 ms exposure.
fn bar_config_with(
    dir: &std::path::Path,
    v_m_s: f64,
    shutter: &str,
    capture: &str,
) -> SimulateConfig {
    bar_config_moving(dir, [v_m_s, 0.0, 0.0], shutter, capture)
}

/// [`bar_config_with`] with the bar's velocity `[x, y, z]`, m/s.
fn bar_config_moving(
    dir: &std::path::Path,
    v_m_s: [f64; 3],
    shutter: &str,
    capture: &str,
) -> SimulateConfig {
    bar_config_full(dir, v_m_s, shutter, capture, "")
}

/// [`bar_config_moving`] with `render` (more `[render]` keys, or tables under it) after the
/// resolution.
fn bar_config_full(
    dir: &std::path::Path,
    v_m_s: [f64; 3],
    shutter: &str,
    capture: &str,
    render: &str,
) -> SimulateConfig {
    let [vx, vy, vz] = v_m_s;
    std::fs::write(dir.join("bar.pbrt"), BAR).unwrap();
    let text = format!(
        r#"
seed = 2
[render]
pbrt = "bar.pbrt"
samples_per_pixel = 16
resolution = [80, 60]
{render}
[[render.overlay_inline.object]]
name = "bar"
velocity_m_s = [{vx:?}, {vy:?}, {vz:?}]
[sensor]
preset = "pixel4a"
rows = 120
cols = 160
[capture]
{capture}
shutter = {shutter}
"#
    );
    let path = dir.join("bar.toml");
    std::fs::write(&path, text).unwrap();
    SimulateConfig::load(&path).unwrap()
}

/// Per sensor row, the centroid column of the noise-free signal above black.
fn row_centroids(sim: &camsim::Simulation) -> Vec<f64> {
    row_centroids_of(sim, 0)
}

/// [`row_centroids`] of frame `i`'s noise-free image.
fn row_centroids_of(sim: &camsim::Simulation, i: usize) -> Vec<f64> {
    let raw = &sim.frames[i];
    let nf = sim.noise_free_frame(i).unwrap();
    (0..raw.rows)
        .map(|r| {
            let row = &nf[r * raw.cols..(r + 1) * raw.cols];
            let w: Vec<f64> = row
                .iter()
                .map(|v| (*v as f64 - raw.black_level_dn).max(0.0))
                .collect();
            let s: f64 = w.iter().sum();
            w.iter()
                .enumerate()
                .map(|(c, v)| (c as f64 + 0.5) * v)
                .sum::<f64>()
                / s
        })
        .collect()
}

fn slope(v: &[f64]) -> f64 {
    let n = v.len() as f64;
    let (mx, my) = ((n - 1.0) / 2.0, v.iter().sum::<f64>() / n);
    let num: f64 = v
        .iter()
        .enumerate()
        .map(|(i, y)| (i as f64 - mx) * (y - my))
        .sum();
    num / (0..v.len()).map(|i| (i as f64 - mx).powi(2)).sum::<f64>()
}

/// The bar moves right at v sensor pixels per second; rows are read 20 us apart. Top-down (the
/// sensor's top row first, which the lens points at the bottom of the scene: raw.dng's last
/// row) the bar in raw.dng leans by -v x line time per row; bottom-up by +v x line time; under
/// the global shutter it stands straight. The render has half the sensor's rows, so the rows
/// map through the optics' scale. The flow on the bar is v x exposure in sensor pixels.
#[test]
fn rolling_shutter_rows_follow_the_lens_inversion_and_flow_is_in_sensor_pixels() {
    let dir = tempfile::tempdir().unwrap();
    let v_m_s = 6.0;
    let line_s = 20e-6;
    let opts = SimulateOptions {
        noise_free: true,
        flow: true,
        ..Default::default()
    };
    let run = |shutter: &str| {
        let cfg = bar_config(dir.path(), v_m_s, shutter);
        simulate(&cfg, &opts, &quiet).unwrap()
    };
    let global = run("\"global\"");
    // Sensor pixels per metre at 10 m: the lens's image distance (infinity focus: f) over the
    // distance, divided by the pitch.
    let f_m = global.optics.focal_length_mm * 1e-3;
    let v_px_s = v_m_s * f_m / 10.0 / (global.sensor.pixel_pitch_um * 1e-6);
    let s0 = slope(&row_centroids(&global));
    assert!(
        s0.abs() < 0.003,
        "global shutter: the bar leans {s0} px/row"
    );
    let top_down = run("{ rolling = { line_time_us = 20.0, direction = \"top-down\" } }");
    let s = slope(&row_centroids(&top_down));
    let want = v_px_s * line_s;
    assert!(
        (s + want).abs() < 0.03 * want,
        "top-down: {s} px/row, want {}",
        -want
    );
    let bottom_up = run("{ rolling = { line_time_us = 20.0, direction = \"bottom-up\" } }");
    let s = slope(&row_centroids(&bottom_up));
    assert!(
        (s - want).abs() < 0.03 * want,
        "bottom-up: {s} px/row, want {want}"
    );
    // run.json records the shutter.
    let meta = bottom_up.metadata(&Default::default(), &Default::default());
    let sh = &meta["results"]["shutter"];
    assert_eq!(sh["kind"], "rolling");
    assert!((sh["readout_s"].as_f64().unwrap() - 119.0 * line_s).abs() < 1e-12);
    // Flow: v T on the bar's pixels (the middle row), 0 beside it (nothing there moves).
    let flow = &global.flow.as_ref().unwrap()[0].exposure;
    let raw = &global.frames[0];
    let mid = &flow[60 * raw.cols..61 * raw.cols];
    let dx: Vec<f32> = mid.iter().map(|f| f[0]).filter(|v| *v != 0.0).collect();
    assert!(!dx.is_empty());
    let t_s = 0.2e-3;
    for v in &dx {
        assert!(
            (*v as f64 / (v_px_s * t_s) - 1.0).abs() < 1e-3,
            "flow {v} vs {}",
            v_px_s * t_s
        );
    }
    assert!(mid.iter().all(|f| f[1] == 0.0));
    assert!(global.moving);
}

/// A video of the static Cornell box: the frames' windows are 1/fps apart (run.json), the scene
/// is rendered once, every frame has the same mean within its noise and the frames' noise is
/// uncorrelated; a rolling shutter changes nothing in a static scene (the same raw values).
#[test]
fn video_of_a_static_scene_has_one_mean_and_independent_noise() {
    let text = |shutter: &str| {
        format!(
            r#"
seed = 5
[render]
builtin = "cornell-box"
samples_per_pixel = 4
resolution = [64, 48]
[sensor]
preset = "pixel4a"
rows = 96
cols = 128
[capture]
exposure_ms = 30.0
frames = 4
fps = 25.0
start_ms = 100.0
shutter = {shutter}
"#
        )
    };
    let opts = SimulateOptions {
        noise_free: true,
        flow: false,
        ..Default::default()
    };
    let cfg = SimulateConfig::from_toml_str(&text("\"global\""), std::path::Path::new("")).unwrap();
    let sim = simulate(&cfg, &opts, &quiet).unwrap();
    assert!(!sim.moving);
    let starts: Vec<f64> = sim.frame_times.iter().map(|f| f.start_s).collect();
    for (k, s) in starts.iter().enumerate() {
        assert!((s - (0.1 + 0.04 * k as f64)).abs() < 1e-12, "{starts:?}");
    }
    let meta = sim.metadata(&Default::default(), &Default::default());
    assert_eq!(meta["results"]["frame_times"].as_array().unwrap().len(), 4);
    // Differences of frames: the scene and the fixed pattern (DSNU, PRNU) cancel, the temporal
    // noise stays. Every pair has mean 0 within 4 standard errors, and the differences of
    // disjoint pairs are uncorrelated (independent frames).
    let f: Vec<Vec<f64>> = sim
        .frames
        .iter()
        .map(|r| r.dn.iter().map(|d| *d as f64).collect())
        .collect();
    let n = f[0].len() as f64;
    let diff =
        |a: usize, b: usize| -> Vec<f64> { f[a].iter().zip(&f[b]).map(|(x, y)| x - y).collect() };
    for (a, b) in [(0, 1), (1, 2), (2, 3), (0, 3)] {
        let d = diff(a, b);
        let m = d.iter().sum::<f64>() / n;
        let sd = (d.iter().map(|v| (v - m).powi(2)).sum::<f64>() / n).sqrt();
        assert!(sd > 1.0, "frames {a} and {b} must differ by their noise");
        assert!(
            m.abs() < 4.0 * sd / n.sqrt(),
            "frames {a}, {b}: mean difference {m} DN (sd {sd})"
        );
    }
    let (d01, d23) = (diff(0, 1), diff(2, 3));
    let dot = |x: &[f64], y: &[f64]| x.iter().zip(y).map(|(a, b)| a * b).sum::<f64>();
    let rho = dot(&d01, &d23) / (dot(&d01, &d01) * dot(&d23, &d23)).sqrt();
    assert!(rho.abs() < 0.03, "correlation of frame differences {rho}");
    let rolling = SimulateConfig::from_toml_str(
        &text("{ rolling = { line_time_us = 50.0, direction = \"top-down\" } }"),
        std::path::Path::new(""),
    )
    .unwrap();
    let sim_r = simulate(&rolling, &opts, &quiet).unwrap();
    for (a, b) in sim.frames.iter().zip(&sim_r.frames) {
        assert!(
            a.dn == b.dn,
            "a rolling shutter must not change a static scene"
        );
    }
}

/// A video of a moving scene renders every frame at its own time: the frames differ beyond the
/// noise, and the flow to the next frame is what the motion says at a blade tip.
#[test]
fn video_of_a_moving_scene_renders_each_frame_at_its_time() {
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/fan-video.toml");
    let mut cfg = SimulateConfig::load(&path).unwrap();
    cfg.capture.frames = 3;
    let opts = SimulateOptions {
        noise_free: true,
        flow: true,
        ..Default::default()
    };
    let sim = simulate(&cfg, &opts, &quiet).unwrap();
    assert!(sim.moving);
    assert_eq!(sim.frames.len(), 3);
    let mean_abs_diff = |a: &[u16], b: &[u16]| {
        a.iter()
            .zip(b)
            .map(|(x, y)| (*x as f64 - *y as f64).abs())
            .sum::<f64>()
            / a.len() as f64
    };
    let d = mean_abs_diff(&sim.frames[0].dn, &sim.frames[1].dn);
    assert!(d > 10.0, "frames 0 and 1 differ by {d} DN on average");
    let flows = sim.flow.as_ref().unwrap();
    assert!(flows[0].to_next.is_some() && flows[2].to_next.is_none());
    // The largest flow to the next frame: a blade's outer corner (25 cm out, 4.5 cm aside)
    // turning 12 degrees (1/30 s at 360 deg/s) moves a chord of 2 r sin(6 deg), in sensor pixels.
    let f_m = sim.optics.focal_length_mm * 1e-3;
    let px_per_m = f_m / 7.0 / (sim.sensor.pixel_pitch_um * 1e-6);
    let chord = 2.0 * 0.25f64.hypot(0.045) * 6f64.to_radians().sin() * px_per_m;
    let max = flows[0]
        .to_next
        .as_ref()
        .unwrap()
        .iter()
        .map(|f| (f[0] as f64).hypot(f[1] as f64))
        .filter(|v| v.is_finite())
        .fold(0.0, f64::max);
    assert!(
        max > 0.97 * chord && max < 1.005 * chord,
        "largest flow {max} px, tip chord {chord}"
    );
}

/// Labels of a moving scene, one set per frame, each a sharp snapshot of the scene at its
/// frame's window start t_k (issue 28 item 1). The bar (3 cm wide, 10 m away) moving right at v
/// in a burst of 3 frames 5 ms apart: in frame k its instance map's edges on the raw grid sit at
/// the closed form (centre + (+-1.5 cm + v t_k) f / (10 m pitch)) within half a pixel (maps
/// sample pixel centres), so consecutive frames shift by v x frame interval; its 2D box moves by
/// the flow to the next frame (within a pixel: two edges of half a pixel each); and a bar
/// receding at vz has depth 10 m + vz t_k in frame k on both grids. The later frames' files
/// are numbered as raw.dng's.
#[test]
fn labels_of_a_moving_scene_are_per_frame_snapshots_at_the_window_start() {
    use camsim::render::labels::boxes_2d;
    let dir = tempfile::tempdir().unwrap();
    let capture = "exposure_ms = 0.2\nframes = 3\nframe_interval_ms = 5.0";
    let opts = SimulateOptions {
        labels: Some(camsim::render::LabelRequest::default()),
        flow: true,
        ..Default::default()
    };
    let v_m_s = 2.0;
    let sim = simulate(
        &bar_config_with(dir.path(), v_m_s, "\"global\"", capture),
        &opts,
        &quiet,
    )
    .unwrap();
    assert!(sim.moving);
    assert_eq!(sim.later_frame_labels.len(), 2);
    let px_per_m = bar_px_per_s(&sim, v_m_s) / v_m_s;
    let (rows, cols) = (sim.frames[0].rows, sim.frames[0].cols);
    let labels: Vec<&camsim::pipeline::labels::SimLabels> =
        std::iter::once(sim.labels.as_ref().unwrap())
            .chain(sim.later_frame_labels.iter().map(|f| &f.labels))
            .collect();
    for (k, l) in labels.iter().enumerate() {
        let t_s = sim.frame_times[k].start_s;
        assert!((t_s - 5e-3 * k as f64).abs() < 1e-12);
        let row = &l.sensor.instance_id[rows / 2 * cols..(rows / 2 + 1) * cols];
        let first = row.iter().position(|i| *i != 0).unwrap() as f64;
        let end = row.iter().rposition(|i| *i != 0).unwrap() as f64 + 1.0;
        let centre = cols as f64 / 2.0;
        let want = [-0.015, 0.015].map(|x| centre + (x + v_m_s * t_s) * px_per_m);
        for (got, want) in [first, end].iter().zip(want) {
            assert!(
                (got - want).abs() <= 0.5,
                "frame {k}: edge at {got}, want {want} +- 0.5 px"
            );
        }
    }
    let flows = sim.flow.as_ref().unwrap();
    for k in 0..2 {
        let (a, b) = (
            boxes_2d(&labels[k].sensor.instance_id, cols)[0].bbox,
            boxes_2d(&labels[k + 1].sensor.instance_id, cols)[0].bbox,
        );
        // The mean flow to the next frame over the bar's pixels in frame k (the flow map is the
        // nearest render pixel's: a sensor pixel at the bar's edge may take the background's 0).
        let next = flows[k].to_next.as_ref().unwrap();
        let on: Vec<f64> = labels[k]
            .sensor
            .instance_id
            .iter()
            .zip(next)
            .filter(|(i, f)| **i != 0 && f[0] != 0.0)
            .map(|(_, f)| f[0] as f64)
            .collect();
        let dx = on.iter().sum::<f64>() / on.len() as f64;
        // (The image distance is f within 0.5 %: the lens is focused far away.)
        let want = v_m_s * 5e-3 * px_per_m;
        assert!((dx / want - 1.0).abs() < 5e-3, "flow {dx} px, want {want}");
        for (e0, e1) in [(a[0], b[0]), (a[2], b[2])] {
            let shift = e1 as f64 - e0 as f64;
            assert!(
                (shift - dx).abs() <= 1.0,
                "frames {k}, {}: box edge moves {shift} px, flow {dx} px",
                k + 1
            );
        }
        assert_eq!((a[1], a[3]), (b[1], b[3]), "the bar spans every row");
    }
    // Depth: a bar receding at vz is 10 m + vz t_k away in frame k (raw and render grids).
    let vz = 20.0;
    let sim = simulate(
        &bar_config_moving(dir.path(), [0.0, 0.0, vz], "\"global\"", capture),
        &opts,
        &quiet,
    )
    .unwrap();
    let depths: Vec<(&[f32], &[f32])> = std::iter::once((
        sim.labels.as_ref().unwrap().sensor.depth_m.as_slice(),
        sim.radiance.as_ref().unwrap().depth_m.as_deref().unwrap(),
    ))
    .chain(
        sim.later_frame_labels
            .iter()
            .map(|f| (f.labels.sensor.depth_m.as_slice(), f.depth_m.as_slice())),
    )
    .collect();
    for (k, (sensor, render)) in depths.iter().enumerate() {
        let want = 10.0 + vz * sim.frame_times[k].start_s;
        for d in sensor.iter().chain(render.iter()).filter(|d| d.is_finite()) {
            assert!(
                (*d as f64 / want - 1.0).abs() < 1e-5,
                "frame {k}: depth {d} m, want {want}"
            );
        }
        assert!(sensor.iter().any(|d| d.is_finite()));
    }
    // The files: frame 1's under the static names, later frames numbered.
    let out = dir.path().join("run");
    let outputs = camsim::OutputSet::parse("raw,instances,boxes,depth,ids").unwrap();
    sim.write(&out, &outputs, Default::default(), &Default::default())
        .unwrap();
    for name in [
        "instances.png",
        "instances_0001.png",
        "instances_0002.scene.png",
        "boxes_0002.json",
        "depth.exr",
        "depth_0001.exr",
        "depth_0002.sensor.exr",
        "object_id_0001.png",
        "material_id_0002.sensor.png",
        "ids.json",
    ] {
        assert!(out.join(name).is_file(), "{name} missing");
    }
    assert!(!out.join("instances_0003.png").exists() && !out.join("ids_0001.json").exists());
}

/// Sensor pixels per second of the bar moving at `v_m_s` 10 m away (infinity focus: the image
/// distance is f).
fn bar_px_per_s(sim: &camsim::Simulation, v_m_s: f64) -> f64 {
    let f_m = sim.optics.focal_length_mm * 1e-3;
    v_m_s * f_m / 10.0 / (sim.sensor.pixel_pitch_um * 1e-6)
}

/// Per sensor row, the noise-free signal above black summed over the row.
fn row_sums(sim: &camsim::Simulation) -> Vec<f64> {
    let raw = &sim.frames[0];
    let nf = sim.noise_free_frame(0).unwrap();
    (0..raw.rows)
        .map(|r| {
            nf[r * raw.cols..(r + 1) * raw.cols]
                .iter()
                .map(|v| (*v as f64 - raw.black_level_dn).max(0.0))
                .sum()
        })
        .collect()
}

/// A global reset read top-down (rows 20 us apart, the sensor's top row first: raw.dng's last
/// row): every row starts at the frame's start and stored row r integrates T + (119 - r) line
/// times, so the bar's row signal is the global shutter's times (T + (119 - r) line time) / T,
/// and its centroid moves by -v x line time / 2 per
/// row (half a rolling shutter's skew: only the end of each row's window moves). With a
/// mechanical shutter every row sees the same light: the bar stands straight, the rows' light
/// is the same, and run.json records the mode.
#[test]
fn global_reset_rows_integrate_to_their_readout() {
    let dir = tempfile::tempdir().unwrap();
    let (v_m_s, line_s, t_s) = (6.0, 20e-6, 0.2e-3);
    let opts = SimulateOptions {
        noise_free: true,
        ..Default::default()
    };
    let run = |shutter: &str| {
        let cfg = bar_config(dir.path(), v_m_s, shutter);
        simulate(&cfg, &opts, &quiet).unwrap()
    };
    let sim = run("{ global_reset = { line_time_us = 20.0, direction = \"top-down\" } }");
    let v_px_s = bar_px_per_s(&sim, v_m_s);
    let s = slope(&row_centroids(&sim));
    let want = -v_px_s * line_s / 2.0;
    assert!(
        (s - want).abs() < 0.05 * want.abs(),
        "global reset: the bar leans {s} px/row, want {want}"
    );
    // Each row's signal over the global shutter's (the same bar, the same lens falloff): the
    // row's integration time over the exposure, 1 + (119 - r) line time / T, a line of slope
    // -line time / T (fitted over the rows: each row's ratio carries the renders' sampling
    // noise, a few per cent).
    let plain = row_sums(&run("\"global\""));
    let ratio: Vec<f64> = row_sums(&sim)
        .iter()
        .zip(&plain)
        .map(|(a, b)| a / b)
        .collect();
    let fit = slope(&ratio);
    assert!(
        (fit / (-line_s / t_s) - 1.0).abs() < 0.02,
        "the rows' signal grows by {fit} per row, want {}",
        -line_s / t_s
    );
    let mean = ratio.iter().sum::<f64>() / 120.0;
    let want = 1.0 + 59.5 * line_s / t_s;
    assert!(
        (mean / want - 1.0).abs() < 0.01,
        "mean ratio {mean}, want {want}"
    );
    let meta = sim.metadata(&Default::default(), &Default::default());
    assert_eq!(meta["results"]["shutter"]["kind"], "global_reset");
    assert_eq!(meta["results"]["shutter"]["mechanical_shutter"], false);

    let mech = run(
        "{ global_reset = { line_time_us = 20.0, direction = \"top-down\", mechanical_shutter = true } }",
    );
    let s = slope(&row_centroids(&mech));
    assert!(
        s.abs() < 0.003,
        "mechanical shutter: the bar leans {s} px/row"
    );
    // The same light as the global shutter in every row (the same render): the rows differ
    // only by the dark current of their readout delay.
    let ratio: Vec<f64> = row_sums(&mech)
        .iter()
        .zip(&plain)
        .map(|(a, b)| a / b)
        .collect();
    assert!(
        ratio.iter().all(|q| (q - 1.0).abs() < 0.01),
        "mechanical shutter: rows' signal over the global shutter's {:?}",
        ratio
    );
}

/// "global = rolling at line time 0" through the whole pipeline: the moving bar with a rolling
/// (or global-reset) shutter of line time 0 gives the global shutter's raw frames, byte for
/// byte.
#[test]
fn a_rolling_shutter_of_line_time_zero_is_the_global_shutter() {
    let dir = tempfile::tempdir().unwrap();
    let opts = SimulateOptions::default();
    let run = |shutter: &str| {
        let cfg = bar_config(dir.path(), 6.0, shutter);
        simulate(&cfg, &opts, &quiet).unwrap()
    };
    let global = run("\"global\"");
    assert!(global.moving);
    for shutter in [
        "{ rolling = { line_time_us = 0.0 } }",
        "{ rolling = { line_time_us = 0.0, direction = \"bottom-up\" } }",
        "{ global_reset = { line_time_us = 0.0 } }",
    ] {
        let other = run(shutter);
        assert!(
            global.frames[0].dn == other.frames[0].dn,
            "{shutter}: the raw frame differs from the global shutter's"
        );
    }
    // And a line time that is not 0 does change them (the comparison can fail).
    let rolling = run("{ rolling = { line_time_us = 20.0 } }");
    assert!(global.frames[0].dn != rolling.frames[0].dn);
}

/// Every frame of a moving scene has its own noise-free image: two frames 5 ms apart of the bar
/// moving at v have noise-free images whose bar is v x 5 ms apart, each frame's raw values
/// scatter around its own noise-free image (not the other's), and the files are written one per
/// frame (noise_free.exr, noise_free_0001.exr).
#[test]
fn every_frame_of_a_moving_scene_has_its_noise_free_image() {
    let dir = tempfile::tempdir().unwrap();
    let v_m_s = 6.0;
    let cfg = bar_config_with(
        dir.path(),
        v_m_s,
        "\"global\"",
        "exposure_ms = 0.2\nframes = 2\nframe_interval_ms = 5.0",
    );
    let opts = SimulateOptions {
        noise_free: true,
        ..Default::default()
    };
    let sim = simulate(&cfg, &opts, &quiet).unwrap();
    let v_px_s = bar_px_per_s(&sim, v_m_s);
    let mean = |c: Vec<f64>| c[30..90].iter().sum::<f64>() / 60.0;
    let shift = mean(row_centroids_of(&sim, 1)) - mean(row_centroids_of(&sim, 0));
    let want = v_px_s * 5e-3;
    assert!(
        (shift / want - 1.0).abs() < 0.02,
        "the bar moves {shift} px between the frames' noise-free images, want {want}"
    );
    // Raw frame 1 lies closer to its own noise-free image than to frame 0's.
    let dist = |raw: &[u16], nf: &[f32]| {
        raw.iter()
            .zip(nf)
            .map(|(a, b)| (*a as f64 - *b as f64).abs())
            .sum::<f64>()
    };
    let (nf0, nf1) = (
        sim.noise_free_frame(0).unwrap(),
        sim.noise_free_frame(1).unwrap(),
    );
    assert!(dist(&sim.frames[1].dn, nf1) < 0.8 * dist(&sim.frames[1].dn, nf0));
    let out = dir.path().join("run");
    let outputs = camsim::OutputSet::parse("raw,noise_free").unwrap();
    sim.write(&out, &outputs, Default::default(), &Default::default())
        .unwrap();
    for (name, nf) in [("noise_free.exr", nf0), ("noise_free_0001.exr", nf1)] {
        let (_, _, v) = camsim::io::exr::read_gray_exr(&out.join(name), Some("Y")).unwrap();
        assert_eq!(v.as_slice(), nf, "{name}");
    }
}

/// Auto-exposure with motion: the camera meters a preview render and every frame is rendered
/// over the exposure it chose, so the window in run.json is the sensor's exposure and the flow
/// on the bar is v x that exposure (not v x the pbrt scene's shutter, 1 s by default).
#[test]
fn auto_exposure_sets_the_render_window() {
    let dir = tempfile::tempdir().unwrap();
    let v_m_s = 6.0;
    let cfg = bar_config_with(dir.path(), v_m_s, "\"global\"", "");
    let opts = SimulateOptions {
        flow: true,
        ..Default::default()
    };
    let sim = simulate(&cfg, &opts, &quiet).unwrap();
    let t_s = sim.exposure_s;
    assert!(t_s > 0.0 && t_s < 0.5, "auto-exposure {t_s} s");
    assert_eq!(sim.frame_times[0].duration_s, t_s);
    let v_px_s = bar_px_per_s(&sim, v_m_s);
    let raw = &sim.frames[0];
    let flow = &sim.flow.as_ref().unwrap()[0].exposure;
    let mid = &flow[60 * raw.cols..61 * raw.cols];
    let dx: Vec<f32> = mid.iter().map(|f| f[0]).filter(|v| *v != 0.0).collect();
    assert!(!dx.is_empty());
    for v in &dx {
        assert!(
            (*v as f64 / (v_px_s * t_s) - 1.0).abs() < 1e-3,
            "flow {v} px vs v T = {}",
            v_px_s * t_s
        );
    }
}

/// preview.gif: a burst of three frames of the moving bar becomes a three-frame animation of
/// the previews' size, shown at the frame interval (40 ms), whose frames differ (the bar moves);
/// a run of one frame writes none and run.json says why.
#[test]
fn preview_gif_animates_the_frames() {
    use image::AnimationDecoder;
    let dir = tempfile::tempdir().unwrap();
    let cfg = bar_config_with(
        dir.path(),
        6.0,
        "\"global\"",
        "exposure_ms = 0.2\nframes = 3\nfps = 25.0",
    );
    let sim = simulate(&cfg, &SimulateOptions::default(), &quiet).unwrap();
    let out = dir.path().join("video");
    let outputs = camsim::OutputSet::parse("preview,preview-gif").unwrap();
    sim.write(&out, &outputs, Default::default(), &Default::default())
        .unwrap();
    let file = std::io::BufReader::new(std::fs::File::open(out.join("preview.gif")).unwrap());
    let frames = image::codecs::gif::GifDecoder::new(file)
        .unwrap()
        .into_frames()
        .collect_frames()
        .unwrap();
    assert_eq!(frames.len(), 3);
    for f in &frames {
        let b = f.buffer();
        assert_eq!(
            (b.width() as usize, b.height() as usize),
            (sim.preview.cols, sim.preview.rows)
        );
        assert_eq!(f.delay().numer_denom_ms(), (40, 1));
    }
    assert!(frames[0].buffer() != frames[1].buffer());
    let one = simulate(
        &bar_config(dir.path(), 6.0, "\"global\""),
        &SimulateOptions::default(),
        &quiet,
    )
    .unwrap();
    let out1 = dir.path().join("single");
    one.write(&out1, &outputs, Default::default(), &Default::default())
        .unwrap();
    assert!(!out1.join("preview.gif").exists());
    let run: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out1.join("run.json")).unwrap()).unwrap();
    assert!(run["files"]["preview.gif"]
        .as_str()
        .unwrap()
        .contains("one frame"));
}

/// Light groups and participating media in a moving scene, through the whole pipeline (the
/// renderer refused both with motion before): the bar moving right at 2 m/s, a burst of two
/// frames 5 ms apart.
/// - `light_groups = { default = 0.5 }`: the bar's light is the one group, so each frame's scene
///   image is half the plain run's (same seed and samples), to f32 rounding.
/// - A purely absorbing medium filling the scene, sigma_a = 0.05 / m: the bar, 10 m away (rays
///   within 2.5 degrees of the axis, so 10.00-10.01 m of medium), is seen through exp(-0.5) =
///   0.607 of its light; the render tracks absorption stochastically (about 2,000 samples on
///   the bar, 2 % standard error), so within 6 %. Flow is geometry: the same with and without.
#[test]
fn light_groups_and_media_follow_a_moving_scene_through_the_pipeline() {
    let dir = tempfile::tempdir().unwrap();
    let capture = "exposure_ms = 0.2\nframes = 2\nframe_interval_ms = 5.0";
    let opts = SimulateOptions {
        flow: true,
        ..Default::default()
    };
    let run = |render: &str| {
        let cfg = bar_config_full(dir.path(), [2.0, 0.0, 0.0], "\"global\"", capture, render);
        simulate(&cfg, &opts, &quiet).unwrap()
    };
    let sum = |sim: &camsim::Simulation| -> f64 {
        sim.radiance
            .as_ref()
            .unwrap()
            .data
            .iter()
            .map(|v| *v as f64)
            .sum()
    };
    let plain = run("");
    assert!(plain.moving && plain.frames.len() == 2);
    let grouped = run("light_groups = { default = 0.5 }");
    let (a, b) = (
        plain.radiance.as_ref().unwrap(),
        grouped.radiance.as_ref().unwrap(),
    );
    let worst = a
        .data
        .iter()
        .zip(&b.data)
        .map(|(p, g)| (*g as f64 - 0.5 * *p as f64).abs())
        .fold(0.0f64, f64::max);
    let peak = a.data.iter().fold(0.0f32, |m, v| m.max(*v)) as f64;
    assert!(
        peak > 0.0 && worst <= 1e-5 * peak,
        "light group: {worst} of {peak}"
    );
    let fog = run(
        "[render.overlay_inline.render]\nmedium = { sigma_a_per_m = 0.05, sigma_s_per_m = 0.0 }",
    );
    let ratio = sum(&fog) / sum(&plain);
    let want = (-0.5f64).exp();
    eprintln!(
        "light group worst {worst:.2e} of peak {peak:.3e}; fog ratio {ratio:.4} vs {want:.4}"
    );
    assert!((ratio / want - 1.0).abs() < 0.06, "fog: {ratio} vs {want}");
    let flow = |s: &camsim::Simulation| s.flow.as_ref().unwrap()[0].exposure.clone();
    assert_eq!(flow(&fog), flow(&plain), "flow is geometry");
}
