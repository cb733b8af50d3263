//! Labels on the raw image's pixel grid (issue 29, step 2), against the image itself and against
//! geometry: the edge of a bright object in the sensor-geometry instance map lies where the
//! noise-free raw image's edge is, through a shift-invariant lens and through a traced double
//! Gauss with its distortion; a box's sensor-geometry 2D box equals its corners' traced chief
//! rays on the sensor, and without distortion its corners projected through the sensor's K.

use camsim_optics::traced::{ObjectField, TracedLens};
use camsim_pipeline::{simulate, SimulateConfig, SimulateOptions};
use std::path::{Path, PathBuf};

fn shared(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared")
        .join(rel)
}

const DGAUSS: &str = "data/isetcornellbox/lens/dgauss.82deg.4.38mm.json";

/// The double Gauss at f/2.8 as the shift-variant optics stage takes it.
fn dgauss_optics() -> String {
    format!(
        r#"[optics.config]
f_number = 2.8
focal_length_mm = 4.38
shading = "none"
[optics.config.blur]
method = "shift-variant"
field_heights = 6
lens_file = "{}"
"#,
        shared(DGAUSS).display()
    )
}

/// Run `scene` (pbrt text) through the pipeline with `optics` (TOML tables) on a `cols` x `rows`
/// pixel4a window, noise-free, with labels.
fn run(
    scene: &str,
    optics: &str,
    cols: usize,
    rows: usize,
    spp: u32,
) -> camsim_pipeline::Simulation {
    let dir = tempfile::tempdir().unwrap();
    let pbrt = dir.path().join("scene.pbrt");
    std::fs::write(&pbrt, scene).unwrap();
    let text = format!(
        r#"seed = 1
[wavelengths]
start_nm = 400.0
step_nm = 30.0
count = 11
[render]
pbrt = "{}"
samples_per_pixel = {spp}
{optics}
[sensor]
preset = "pixel4a"
rows = {rows}
cols = {cols}
[capture]
exposure_ms = 5.0
"#,
        pbrt.display()
    );
    let cfg = SimulateConfig::from_toml_str(&text, std::path::Path::new("")).unwrap();
    let opts = SimulateOptions {
        noise_free: true,
        labels: Some(camsim_render::LabelRequest::default()),
        ..Default::default()
    };
    simulate(&cfg, &opts, &|_, _, _| {}).unwrap()
}

/// A glowing square right of an edge through x = `edge_x` (m, at z = 1) 5 degrees from the
/// vertical (so the label's pixel quantization varies along it), black elsewhere.
fn edge_scene(edge_x: f64) -> String {
    let t = 5f64.to_radians().tan() * 2.0;
    format!(
        r#"LookAt 0 0 0  0 0 1  0 1 0
Camera "perspective" "float fov" 30
Film "rgb" "integer xresolution" 320 "integer yresolution" 240
WorldBegin
AttributeBegin
  AreaLightSource "diffuse" "rgb L" [1 1 1] "float scale" 2
  Shape "trianglemesh" "point3 P" [{} -2 1  3 -2 1  3 2 1  {} 2 1]
    "integer indices" [0 2 1 0 3 2]
AttributeEnd
"#,
        edge_x - t,
        edge_x + t
    )
}

/// Per row: the label's edge (the left border of the first object pixel) and the noise-free
/// raw's edge (each pixel normalized between its CFA colour's dark and bright levels of that
/// row; the edge where the normalized profile's area puts it), both in pixel edges; the largest
/// and the mean difference. The label's
/// edge is a whole pixel (within half a pixel of the true edge); along the slanted edge that
/// rounding averages out, so the mean measures any shift between labels and image.
fn edge_offsets(sim: &camsim_pipeline::Simulation) -> (f64, f64) {
    let labels = sim.labels.as_ref().unwrap();
    let (w, h) = (labels.sensor.width, labels.sensor.height);
    let nf = sim.noise_free_frame(0).unwrap();
    let (mut worst, mut sum, mut n) = (0f64, 0f64, 0);
    for y in (8..h - 8).step_by(3) {
        let row = &labels.sensor.instance_id[y * w..(y + 1) * w];
        let Some(xl) = row.iter().position(|&i| i != 0) else {
            continue;
        };
        if xl < 24 || xl + 24 > w {
            continue;
        }
        let v = |c: usize| nf[y * w + c] as f64;
        // Same-colour neighbours two columns apart: dark and bright levels of each parity.
        // Index 0: even columns, 1: odd columns.
        let level =
            |c0: usize| [0, 1].map(|p| (0..6).map(|k| v((c0 & !1) + p + 2 * k)).sum::<f64>() / 6.0);
        let (dark, bright) = (level(xl - 22), level(xl + 10));
        let p = |c: usize| (v(c) - dark[c % 2]) / (bright[c % 2] - dark[c % 2]);
        // A blurred step's normalized profile integrates to the distance from the edge to the
        // window's right end (the blur conserves the area of the step): x = b - sum p.
        let (a, b) = (xl - 9, xl + 9);
        let xr = b as f64 - (a..b).map(p).sum::<f64>();
        let d = xl as f64 - xr;
        if std::env::var("DEBUG_EDGE").is_ok() {
            eprintln!("row {y}: label {xl} raw {xr:.3} d {d:.3}");
        }
        worst = worst.max(d.abs());
        sum += d;
        n += 1;
    }
    assert!(n > 40, "{n} rows measured");
    (worst, sum / n as f64)
}

#[test]
fn label_edges_lie_on_the_raw_image_edges() {
    // Through the default lens (shift-invariant defocus blur), the edge near the axis; then
    // through the traced double Gauss with its distortion, the edge at 80 % of the half width.
    for (optics, edge_x, cols, rows) in [
        (
            String::from("[optics]\npreset = \"pixel4a\"\n"),
            0.01,
            320,
            240,
        ),
        (dgauss_optics(), 0.08, 640, 480),
    ] {
        let sim = run(&edge_scene(edge_x), &optics, cols, rows, 64);
        let (worst, mean) = edge_offsets(&sim);
        assert!(
            worst <= 0.55 && mean.abs() < 0.1,
            "{optics}: label edge - raw edge: worst {worst:.3} px, mean {mean:.3} px"
        );
    }
}

const CUBE: &str = r#"Shape "trianglemesh" "point3 P" [-0.5 -0.5 -0.5  0.5 -0.5 -0.5  0.5 0.5 -0.5  -0.5 0.5 -0.5
      -0.5 -0.5 0.5  0.5 -0.5 0.5  0.5 0.5 0.5  -0.5 0.5 0.5]
    "integer indices" [0 1 2 0 2 3  4 6 5 4 7 6  0 4 5 0 5 1  3 2 6 3 6 7  0 3 7 0 7 4  1 5 6 1 6 2]"#;

/// A box turned about the vertical near the corner of the field, seen by a level camera.
fn box_scene() -> String {
    format!(
        r#"LookAt 0 0 0  0 0 1  0 1 0
Camera "perspective" "float fov" 30
Film "rgb" "integer xresolution" 1280 "integer yresolution" 960
WorldBegin
LightSource "infinite" "rgb L" [1 1 1]
AttributeBegin
  Translate 0.36 0.2 3
  Rotate 25 0 1 0
  Scale 0.3 0.2 0.25
  {CUBE}
AttributeEnd
"#
    )
}

/// The box's 8 corners in the camera frame (OpenCV: y down).
fn box_corners() -> Vec<[f64; 3]> {
    let (s, c) = 25f64.to_radians().sin_cos();
    (0..8)
        .map(|i| {
            let l = [
                if i & 1 == 1 { 0.15 } else { -0.15 },
                if i & 2 == 2 { 0.1 } else { -0.1 },
                if i & 4 == 4 { 0.125 } else { -0.125 },
            ];
            let p = [
                c * l[0] + s * l[2] + 0.36,
                l[1] + 0.2,
                -s * l[0] + c * l[2] + 3.0,
            ];
            [p[0], -p[1], p[2]]
        })
        .collect()
}

fn bbox(points: &[[f64; 2]]) -> [f64; 4] {
    points.iter().fold(
        [
            f64::INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NEG_INFINITY,
        ],
        |b, p| {
            [
                b[0].min(p[0]),
                b[1].min(p[1]),
                b[2].max(p[0]),
                b[3].max(p[1]),
            ]
        },
    )
}

fn sensor_box(sim: &camsim_pipeline::Simulation) -> [f64; 4] {
    let l = sim.labels.as_ref().unwrap();
    let b = camsim_render::labels::boxes_2d(&l.sensor.instance_id, l.sensor.width);
    assert_eq!(b.len(), 1);
    b[0].bbox.map(|v| v as f64)
}

#[test]
fn a_box_lands_on_its_corners_chief_rays_through_a_distorting_lens() {
    let (cols, rows, pitch_mm) = (1280usize, 960usize, 1.4e-3);
    // Through the traced double Gauss (distortion applied by the optics stage): each corner at
    // its traced chief ray's height (the scene lies at infinity for a pbrt file without a focus
    // distance: the field is the corner's direction), along its azimuth.
    let sim = run(&box_scene(), &dgauss_optics(), cols, rows, 1);
    let lens = TracedLens::from_file(&shared(DGAUSS), 2.8, 4.38).unwrap();
    let cam = lens.camera(f64::INFINITY, 10.0).unwrap();
    let (mut traced, mut ideal) = (Vec::new(), Vec::new());
    for p in box_corners() {
        let (tx, ty) = (p[0] / p[2], p[1] / p[2]);
        let t = tx.hypot(ty);
        let h_mm = cam_height(&lens, &cam, t);
        let v_mm = 4.38; // thin-lens image distance at infinity focus
        for (list, r_mm) in [(&mut traced, h_mm), (&mut ideal, v_mm * t)] {
            list.push([
                r_mm * tx / t / pitch_mm + cols as f64 / 2.0,
                r_mm * ty / t / pitch_mm + rows as f64 / 2.0,
            ]);
        }
    }
    let (want, undistorted, got) = (bbox(&traced), bbox(&ideal), sensor_box(&sim));
    assert!(sim.labels.as_ref().unwrap().distorted);
    // The distortion moves the box by more than the tolerance (the test can tell).
    assert!(
        (0..4).any(|k| (want[k] - undistorted[k]).abs() > 1.0),
        "{want:?} against {undistorted:?}"
    );
    for k in 0..4 {
        assert!(
            (got[k] - want[k]).abs() <= 0.5,
            "sensor 2D box {got:?} against the traced corners {want:?}"
        );
    }

    // OpenCV's model fitted to the optics' map reproduces the traced chief rays: each corner
    // through K and the fitted (k1, k2, p1, p2, k3) within 0.1 px of its traced position.
    let l = sim.labels.as_ref().unwrap();
    let d = l
        .sensor_distortion
        .expect("a distorting lens has fitted coefficients");
    assert!(d.rms_px <= 0.1 && d.points > 1000, "{d:?}");
    let cv = camsim_analysis::distortion::OpenCvDistortion {
        k1: d.dist_coeffs[0],
        k2: d.dist_coeffs[1],
        p1: d.dist_coeffs[2],
        p2: d.dist_coeffs[3],
        k3: d.dist_coeffs[4],
    };
    let k = l.sensor_camera.k;
    for (p, t) in box_corners().iter().zip(&traced) {
        let [xd, yd] = cv.apply([p[0] / p[2], p[1] / p[2]]);
        // K's pixel centres at integers; the traced positions in pixel edges.
        let (u, v) = (k[0][0] * xd + k[0][2] + 0.5, k[1][1] * yd + k[1][2] + 0.5);
        assert!(
            (u - t[0]).hypot(v - t[1]) <= 0.1 + 0.05,
            "corner at ({u:.3}, {v:.3}) through OpenCV's model, traced ({:.3}, {:.3}); {d:?}",
            t[0],
            t[1]
        );
    }
    let json = l.cameras_json();
    assert_eq!(
        json["sensor_distortion_opencv"]["dist_coeffs"][0].as_f64(),
        Some(d.dist_coeffs[0])
    );
    // The keypoints (the box's centre and corners) through the optics' inverted map: each
    // corner on its traced chief ray within 0.25 px, the distortion's shift being larger.
    let kp = &l.keypoints[0];
    assert_eq!(kp.len(), 9);
    for t in &traced {
        let e = kp[1..]
            .iter()
            .map(|p| {
                let q = p.xy_px.expect("every corner is imaged");
                (q[0] - t[0]).hypot(q[1] - t[1])
            })
            .fold(f64::INFINITY, f64::min);
        println!("keypoint against its traced chief ray: {e:.4} px");
        assert!(
            e <= 0.25,
            "a corner's keypoint {e} px from its traced chief ray"
        );
    }
    check_corner_visibility(l);

    // Without distortion (the default lens): the corners through the sensor grid's K.
    let sim = run(
        &box_scene(),
        "[optics]\npreset = \"pixel4a\"\n",
        cols,
        rows,
        1,
    );
    let l = sim.labels.as_ref().unwrap();
    assert!(!l.distorted && l.sensor_distortion.is_none());
    let proj: Vec<[f64; 2]> = box_corners()
        .iter()
        .map(|p| l.sensor_camera.project(*p).map(|u| u + 0.5))
        .collect();
    // Without distortion the keypoints are the corners through the sensor K.
    let kp = &l.keypoints[0];
    for p in &proj {
        let e = kp[1..]
            .iter()
            .map(|k| {
                let q = k.xy_px.unwrap();
                (q[0] - p[0]).hypot(q[1] - p[1])
            })
            .fold(f64::INFINITY, f64::min);
        assert!(e <= 1e-6, "keypoint {e} px from the corner through K");
    }
    check_corner_visibility(l);
    let boxes = l.boxes_json();
    let triples = boxes["instances"][0]["keypoints_sensor"]
        .as_array()
        .unwrap();
    assert_eq!(triples.len(), 9);
    assert_eq!(triples[0][2].as_u64(), Some(kp[0].visibility as u64));
    let (want, got) = (bbox(&proj), sensor_box(&sim));
    // Independently: K's focal length is the image distance over the pixel pitch.
    assert!((l.sensor_camera.k[0][0] - 4.38e-3 / 1.4e-6).abs() < 1e-6 * 3129.0);
    for k in 0..4 {
        assert!(
            (got[k] - want[k]).abs() <= 0.5,
            "sensor 2D box {got:?} against the projected corners {want:?}"
        );
    }
}

/// The chief ray's film height, mm, of a field at tan(theta) = `t` (object at infinity).
fn cam_height(lens: &TracedLens, cam: &camsim_lens::LensCamera, t: f64) -> f64 {
    lens.chief_image_point_mm(cam, ObjectField::Infinity { tan_theta: t })
        .unwrap()[0]
}

/// A convex box seen from outside: a corner is visible when one of its three faces faces the
/// camera (at the origin), hidden behind the box otherwise, as is the box's centre; all are in
/// the frame.
fn check_corner_visibility(l: &camsim_pipeline::labels::SimLabels) {
    let kp = &l.keypoints[0];
    let corners = l.scene.instances[0].box_3d.as_ref().unwrap().corners_m;
    let (s, c) = 25f64.to_radians().sin_cos();
    // The box's unit axes in the camera frame (OpenCV, y down).
    let axes = [[c, 0.0, -s], [0.0, -1.0, 0.0], [s, 0.0, c]];
    let mut seen = [0; 3];
    for (i, want) in box_corners().iter().enumerate() {
        let j = (0..8)
            .min_by(|&a, &b| {
                let d = |k: usize| {
                    (0..3)
                        .map(|m| (corners[k][m] - want[m]).powi(2))
                        .sum::<f64>()
                };
                d(a).total_cmp(&d(b))
            })
            .unwrap();
        // Corner i's faces: outward normals sign_k axis_k.
        let front = (0..3).any(|k| {
            let sign = if i & (1 << k) != 0 { 1.0 } else { -1.0 };
            let n: Vec<f64> = axes[k].iter().map(|a| sign * a).collect();
            (0..3).map(|m| n[m] * want[m]).sum::<f64>() < 0.0
        });
        let v = kp[1 + j].visibility;
        assert_eq!(v, if front { 2 } else { 1 }, "corner {want:?}: {kp:?}");
        seen[v as usize] += 1;
    }
    assert!(seen[1] > 0 && seen[2] > 0, "{seen:?}");
    assert_eq!(kp[0].visibility, 1, "the centre is inside the box: {kp:?}");
}

/// A rig camera ([render.camera_offset]) against closed forms, with the box's keypoints: a
/// camera moved right by the baseline B sees each point shifted left by the disparity f B / Z
/// (rows unchanged); yawing by atan(X / Z) centres the box's centre across, pitching by
/// atan(Y / Z) centres it down, and a 90-degree roll turns its right axis to its up. A rig that
/// turns during the exposure takes its offset camera along (its swing about the rig's centre:
/// `camsim-render`'s `a_turning_rigs_offset_camera_swings_about_the_rig_centre`).
#[test]
fn rig_offsets_move_the_camera_in_its_own_frame() {
    let (cols, rows) = (320usize, 240usize);
    let optics = |offset: &str| {
        format!("[render.camera_offset]\n{offset}\n[optics]\npreset = \"pixel4a\"\n")
    };
    let keypoints = |offset: &str| {
        let sim = run(&box_scene(), &optics(offset), cols, rows, 1);
        // The set-up's seconds (reading, overlays, offset) are a part of the scene stage's.
        let time = |k: &str| sim.times_s.get(k).and_then(|v| v.as_f64()).unwrap();
        assert!(time("scene_setup_s") > 0.0 && time("scene_setup_s") <= time("scene_s"));
        let l = sim.labels.unwrap();
        (l.keypoints[0].clone(), l.sensor_camera.k)
    };
    let (left, k) = keypoints("");
    let baseline_m = 0.12;
    let (right, _) = keypoints(&format!("translation_m = [{baseline_m}, 0.0, 0.0]"));
    let mut worst = 0.0f64;
    for (l, r) in left.iter().zip(&right) {
        let (pl, pr) = (l.xy_px.unwrap(), r.xy_px.unwrap());
        let disparity = pl[0] - pr[0];
        let want = k[0][0] * baseline_m / l.depth_m;
        worst = worst.max((disparity - want).abs());
        assert!((pl[1] - pr[1]).abs() < 1e-6, "rows differ: {pl:?} {pr:?}");
        assert!(
            (l.depth_m - r.depth_m).abs() < 1e-12,
            "depth along the shared axis"
        );
    }
    println!(
        "stereo disparity against f B / Z: worst {worst:.2e} px (f B / Z ~ {:.1} px)",
        k[0][0] * baseline_m / 3.0
    );
    assert!(worst <= 1e-6, "disparity off f B / Z by {worst} px");
    // A rig that turns during the exposure carries its right camera with it (was refused): the
    // labels are the scene at the window start (t = 0, before it turned), so they are the
    // still rig's.
    let turning = "[render.overlay_inline.camera]\nangular_velocity_deg_s = [0.0, 20.0, 0.0]\n";
    let moving_right = |offset: &str| {
        let sim = run(
            &box_scene(),
            &format!("{turning}{}", optics(offset)),
            cols,
            rows,
            1,
        );
        sim.labels.unwrap().keypoints[0].clone()
    };
    let moved = moving_right(&format!("translation_m = [{baseline_m}, 0.0, 0.0]"));
    for (m, r) in moved.iter().zip(&right) {
        let (pm, pr) = (m.xy_px.unwrap(), r.xy_px.unwrap());
        assert!(
            (pm[0] - pr[0]).hypot(pm[1] - pr[1]) < 1e-9,
            "turning rig's right camera {pm:?}, still {pr:?}"
        );
    }
    // The box's centre: (0.36, 0.2, 3) m in the camera frame (x right, y up).
    let (cx, cy) = (k[0][2] + 0.5, k[1][2] + 0.5);
    let yaw = 0.12f64.atan().to_degrees();
    let (yawed, _) = keypoints(&format!("yaw_deg = {yaw}"));
    assert!(
        (yawed[0].xy_px.unwrap()[0] - cx).abs() < 1e-6,
        "{:?}",
        yawed[0]
    );
    let pitch = 0.2f64.atan2(3.0).to_degrees();
    let (pitched, _) = keypoints(&format!("pitch_deg = {pitch}"));
    assert!(
        (pitched[0].xy_px.unwrap()[1] - cy).abs() < 1e-6,
        "{:?}",
        pitched[0]
    );
    let (rolled, _) = keypoints("roll_deg = 90.0");
    let p = rolled[0].xy_px.unwrap();
    let want = [k[0][0] * 0.2 / 3.0 + cx, k[1][1] * 0.36 / 3.0 + cy];
    assert!(
        (p[0] - want[0]).hypot(p[1] - want[1]) < 1e-6,
        "{p:?} against {want:?}"
    );
}
