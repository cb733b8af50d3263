//! Motion in the renderer (issue 28), against closed forms: a bright bar moving at v pixels per
//! second under a shutter open for T seconds images as the bar convolved with a box of length
//! v T (10-90 % edge width 0.8 v T, integral conserved) in x and in y; a spinning spoke blurs
//! along arcs (the blur's full width at half maximum is r w T at radius r); a rolling shutter
//! skews a moving vertical bar by v x line time per row and leaves a static scene bit for bit;
//! optical flow follows translation and camera rotation in closed form; and a scene whose only
//! moving object never takes part in the image renders byte for byte as the static scene.

use crate::common;
use camsim_core::Spectrum;
use camsim_render::render;
use camsim_scene3d::motion::{Motion, MotionPart, RowReadout, Shutter, TimeSettings};
use camsim_scene3d::{
    AreaLight, Camera, Geometry, Material, SceneDescription, Shape, Texture, Transform,
};

/// Metres per pixel on the plane z = 1 m (the camera looks down +z from the origin).
const PX_M: f64 = 1e-3;

fn flat(v: f64) -> Spectrum {
    Spectrum::from_pairs(&[(300.0, v), (900.0, v)])
}

/// A `w` x `h` camera at the origin looking down +z: one pixel spans `PX_M` on the plane z = 1
/// (raster x along world +x, raster y along world -y).
fn camera(w: usize, h: usize) -> Camera {
    let short = w.min(h) as f64;
    Camera {
        camera_to_world: Transform::identity(),
        fov_deg: 2.0 * (short / 2.0 * PX_M).atan().to_degrees(),
        width: w,
        height: h,
        lens: None,
    }
}

/// An emitting two-sided rectangle in the plane z = 1 m: x in [x0, x1], y in [y0, y1] (pixels
/// from the image centre, raster orientation: y grows downwards), radiance 1.
fn bar(x0: f64, x1: f64, y0: f64, y1: f64) -> Shape {
    let p = |x: f64, y: f64| [x * PX_M, -y * PX_M, 1.0];
    Shape {
        name: Some("bar".into()),
        geometry: Geometry::Triangles {
            positions: vec![p(x0, y0), p(x1, y0), p(x1, y1), p(x0, y1)],
            indices: vec![[0, 1, 2], [0, 2, 3]],
            uvs: None,
            normals: None,
            colors: None,
            uvs1: None,
            tangents: None,
        },
        material: 0,
        area_light: Some(AreaLight {
            radiance: flat(1.0),
            two_sided: true,
            image: None,
        }),
        reverse_orientation: false,
        tags: Default::default(),
    }
}

fn scene(w: usize, h: usize, shapes: Vec<Shape>, spp: u32, time: TimeSettings) -> SceneDescription {
    let mut s = common::origin_scene(w, h, camera(w, h).fov_deg, shapes, spp, time);
    s.settings.seed = 3;
    s
}

/// A velocity in pixels per second (raster x right, y down) as a world velocity on z = 1.
fn velocity_px(vx: f64, vy: f64) -> MotionPart {
    MotionPart::Velocity {
        velocity_m_s: [vx * PX_M, -vy * PX_M, 0.0],
        angular_velocity_deg_s: [0.0; 3],
        pivot_m: [0.0; 3],
    }
}

fn moving(shape: usize, part: MotionPart, open_s: f64, close_s: f64) -> TimeSettings {
    TimeSettings {
        shutter: Shutter {
            open_s,
            close_s,
            rolling: None,
        },
        shapes: vec![(shape, Motion::single(part))],
        ..TimeSettings::default()
    }
}

/// Band 0 of a render, row-major.
fn image(s: &SceneDescription) -> Vec<f64> {
    let out = render(s, &|_, _| {}).unwrap();
    let n = s.camera.width * s.camera.height;
    out.radiance.data[..n].iter().map(|v| *v as f64).collect()
}

/// Mean of the rows `rows` of a `w`-wide image: a profile along x.
fn row_profile(img: &[f64], w: usize, rows: std::ops::Range<usize>) -> Vec<f64> {
    let n = rows.len() as f64;
    (0..w)
        .map(|x| rows.clone().map(|y| img[y * w + x]).sum::<f64>() / n)
        .collect()
}

fn col_profile(img: &[f64], w: usize, h: usize, cols: std::ops::Range<usize>) -> Vec<f64> {
    let n = cols.len() as f64;
    (0..h)
        .map(|y| cols.clone().map(|x| img[y * w + x]).sum::<f64>() / n)
        .collect()
}

/// Position (pixels, pixel k's value at k + 0.5, linear between) where a profile first rises
/// through `level` after index `from`.
fn rise(p: &[f64], level: f64, from: usize) -> f64 {
    let i = (from + 1..p.len())
        .find(|&i| p[i - 1] < level && p[i] >= level)
        .expect("a rising edge");
    i as f64 - 0.5 + (level - p[i - 1]) / (p[i] - p[i - 1])
}

/// The 10-90 % width of the rising edge of a profile whose plateau is `top`.
fn edge_10_90(p: &[f64], top: f64) -> f64 {
    let a = rise(p, 0.1 * top, 0);
    rise(p, 0.9 * top, 0) - a
}

/// A bar 40 px wide moving right at 500 px/s for 40 ms: blurred by a 20 px box. The rising
/// edge's 10-90 % width is 0.8 x 20 = 16 px (a ramp convolved with the 1-px pixel keeps its
/// 10-90 % points when the ramp is over 5 px long), the plateau stays at the bar's radiance (the
/// bar is wider than the blur) and the row's integral is the bar's width.
#[test]
fn bar_moving_in_x_is_a_box_convolution() {
    let (w, h) = (128, 16);
    let v_px_s = 500.0;
    let t_s = 0.04;
    let s = scene(
        w,
        h,
        vec![bar(-40.0, 0.0, -20.0, 20.0)],
        64,
        moving(0, velocity_px(v_px_s, 0.0), 0.0, t_s),
    );
    let p = row_profile(&image(&s), w, 0..h);
    let top = p[50..58].iter().sum::<f64>() / 8.0;
    assert!((top - 1.0).abs() < 0.01, "plateau {top}");
    let width = edge_10_90(&p, 1.0);
    let want = 0.8 * v_px_s * t_s;
    assert!(
        (width - want).abs() < 0.3,
        "10-90 % edge {width} px, want {want}"
    );
    // The bar starts at the image centre minus 40 px and its left edge moves 20 px: the half
    // level of the rising edge lies at 24 + 10 px.
    let half = rise(&p, 0.5, 0);
    assert!((half - 34.0).abs() < 0.2, "half level at {half}");
    let integral: f64 = p.iter().sum();
    assert!((integral - 40.0).abs() < 0.1, "integral {integral} px");
    // The static bar: a sharp edge (under 1 px) with the same integral.
    let still = scene(
        w,
        h,
        vec![bar(-40.0, 0.0, -20.0, 20.0)],
        64,
        TimeSettings::default(),
    );
    let q = row_profile(&image(&still), w, 0..h);
    assert!(edge_10_90(&q, 1.0) < 1.0);
    assert!((q.iter().sum::<f64>() - 40.0).abs() < 0.1);
}

/// The same in y: a bar moving down at 250 px/s for 40 ms blurs over 10 px (edge 8 px).
#[test]
fn bar_moving_in_y_is_a_box_convolution() {
    let (w, h) = (16, 96);
    let s = scene(
        w,
        h,
        vec![bar(-20.0, 20.0, -30.0, 0.0)],
        64,
        moving(0, velocity_px(0.0, 250.0), 0.0, 0.04),
    );
    let p = col_profile(&image(&s), w, h, 0..w);
    let width = edge_10_90(&p, 1.0);
    assert!((width - 8.0).abs() < 0.3, "10-90 % edge {width} px");
    assert!((p.iter().sum::<f64>() - 30.0).abs() < 0.1);
}

/// A spoke 3 px wide from the centre to 60 px, spinning at 90 deg/s about the image centre
/// (the optical axis) for 100 ms, sweeps 9 degrees: at radius r the arc it sweeps is r x
/// 0.157 rad, and the angular profile at that radius is a box of the spoke's width convolved
/// with a box of that arc: its full width at half maximum is the arc length (wider than the
/// spoke), its integral the spoke's width. Measured at r = 30 and 50 px (4.7 and 7.9 px).
#[test]
fn spinning_spoke_blurs_along_arcs() {
    let (w, h) = (128, 128);
    let omega_deg_s = 90.0;
    let t_s = 0.1;
    let spin = MotionPart::Velocity {
        velocity_m_s: [0.0; 3],
        angular_velocity_deg_s: [0.0, 0.0, omega_deg_s],
        pivot_m: [0.0, 0.0, 1.0],
    };
    let s = scene(
        w,
        h,
        vec![bar(0.0, 60.0, -1.5, 1.5)],
        256,
        moving(0, spin, 0.0, t_s),
    );
    let img = image(&s);
    // Bilinear sample at raster (x, y).
    let at = |x: f64, y: f64| {
        let (x, y) = (x - 0.5, y - 0.5);
        let (x0, y0) = (x.floor() as usize, y.floor() as usize);
        let (fx, fy) = (x - x0 as f64, y - y0 as f64);
        let v = |i: usize, j: usize| img[j * w + i];
        (1.0 - fx) * (1.0 - fy) * v(x0, y0)
            + fx * (1.0 - fy) * v(x0 + 1, y0)
            + (1.0 - fx) * fy * v(x0, y0 + 1)
            + fx * fy * v(x0 + 1, y0 + 1)
    };
    for r in [30.0, 50.0] {
        // Angle from -10 to +20 degrees (counter-clockwise in the world is toward -y in the
        // raster), 0.02-degree steps; arc length s = r theta.
        let step = 0.02f64.to_radians();
        let prof: Vec<f64> = (0..1500)
            .map(|k| {
                let th = (-10.0f64).to_radians() + k as f64 * step;
                at(64.0 + r * th.cos(), 64.0 - r * th.sin())
            })
            .collect();
        let peak = prof.iter().cloned().fold(0.0, f64::max);
        let arc = r * omega_deg_s.to_radians() * t_s;
        // Plateau of box(3) * box(arc) is 3 / arc.
        assert!(
            (peak - 3.0 / arc).abs() < 0.06,
            "r {r}: peak {peak} vs {}",
            3.0 / arc
        );
        let above: Vec<usize> = (0..prof.len()).filter(|&k| prof[k] >= peak / 2.0).collect();
        let fwhm = (above[above.len() - 1] - above[0]) as f64 * step * r;
        assert!(
            (fwhm - arc).abs() < 0.6,
            "r {r}: FWHM {fwhm} px vs arc {arc}"
        );
        let integral: f64 = prof.iter().sum::<f64>() * step * r;
        assert!((integral - 3.0).abs() < 0.15, "r {r}: integral {integral}");
    }
}

/// Centroid x of each row of an image (the bar's position per row).
fn row_centroids(img: &[f64], w: usize, h: usize) -> Vec<f64> {
    (0..h)
        .map(|y| {
            let row = &img[y * w..(y + 1) * w];
            let s: f64 = row.iter().sum();
            row.iter()
                .enumerate()
                .map(|(x, v)| (x as f64 + 0.5) * v)
                .sum::<f64>()
                / s
        })
        .collect()
}

/// Least-squares slope of `v` against its index.
fn slope(v: &[f64]) -> f64 {
    let n = v.len() as f64;
    let mx = (n - 1.0) / 2.0;
    let my = v.iter().sum::<f64>() / n;
    let num: f64 = v
        .iter()
        .enumerate()
        .map(|(i, y)| (i as f64 - mx) * (y - my))
        .sum();
    let den: f64 = (0..v.len()).map(|i| (i as f64 - mx).powi(2)).sum();
    num / den
}

/// A vertical bar moving right at v = 2000 px/s under a rolling shutter whose rows start 50 us
/// apart (top row first): each row sees the bar 0.1 px further right, a skew of v x line time
/// per row; under the global shutter the bar stays vertical. With a line time of 0 the rolling
/// shutter is the global one, bit for bit.
#[test]
fn rolling_shutter_skews_a_moving_bar_by_v_times_line_time() {
    let (w, h) = (96, 64);
    let (v, exposure_s, line_s) = (2000.0, 1e-3, 50e-6);
    let shapes = vec![bar(-4.0, 4.0, -40.0, 40.0)];
    let with = |rolling: Option<RowReadout>| {
        let mut t = moving(0, velocity_px(v, 0.0), 0.0, exposure_s);
        t.shutter.rolling = rolling;
        image(&scene(w, h, shapes.clone(), 32, t))
    };
    let rolling = with(Some(RowReadout {
        row0_delay_s: 0.0,
        per_row_delay_s: line_s,
        global_reset: false,
    }));
    let skew = slope(&row_centroids(&rolling, w, h));
    assert!(
        (skew - v * line_s).abs() < 0.005,
        "skew {skew} px/row, want {}",
        v * line_s
    );
    let global = with(None);
    let skew0 = slope(&row_centroids(&global, w, h));
    assert!(skew0.abs() < 0.005, "global shutter skew {skew0}");
    let zero_line = with(Some(RowReadout {
        row0_delay_s: 0.0,
        per_row_delay_s: 0.0,
        global_reset: false,
    }));
    assert!(
        global == zero_line,
        "line time 0 must equal the global shutter"
    );
}

/// A global reset read row by row (rows 50 us apart, top row first): every row starts when the
/// shutter opens and row y integrates T + y x line time, so a bar moving right at v is smeared
/// over v (T + y line time) in row y: its trailing edge stays put, its centroid moves by
/// v x line time / 2 per row (a rolling shutter's skew is v x line time), its 10-90 % edge
/// widens by 0.8 v x line time per row, and each row's time average keeps the bar's width.
#[test]
fn global_reset_smears_each_row_over_its_own_integration() {
    let (w, h) = (128, 64);
    let (v, exposure_s, line_s) = (4000.0, 2e-3, 50e-6);
    let mut t = moving(0, velocity_px(v, 0.0), 0.0, exposure_s);
    t.shutter.rolling = Some(RowReadout {
        row0_delay_s: 0.0,
        per_row_delay_s: line_s,
        global_reset: true,
    });
    // The bar's left edge starts 24 px from the left (the centre minus 40), 32 px wide.
    let img = image(&scene(w, h, vec![bar(-40.0, -8.0, -40.0, 40.0)], 32, t));
    let c = row_centroids(&img, w, h);
    let skew = slope(&c);
    assert!(
        (skew - v * line_s / 2.0).abs() < 0.005,
        "centroid moves {skew} px/row, want {}",
        v * line_s / 2.0
    );
    // Row y's centroid: 24 + 16 + v (T + y line time) / 2.
    for (y, cy) in c.iter().enumerate() {
        let want = 40.0 + v * (exposure_s + y as f64 * line_s) / 2.0;
        assert!(
            (cy - want).abs() < 0.15,
            "row {y}: centroid {cy}, want {want}"
        );
    }
    let integral = img.iter().sum::<f64>() / h as f64;
    assert!((integral - 32.0).abs() < 0.1, "row integral {integral}");
    // The trailing edge's foot (where the time average first rises through 2 %) stays at 24
    // px within the 2 % of the ramp; the ramp widens row by row.
    let band = |rows: std::ops::Range<usize>| row_profile(&img, w, rows);
    let (top, bottom) = (band(0..8), band(56..64));
    for p in [&top, &bottom] {
        let foot = rise(p, 0.02, 0);
        assert!((foot - 24.0).abs() < 0.5, "trailing edge foot at {foot} px");
    }
    let grow = edge_10_90(&bottom, 1.0) - edge_10_90(&top, 1.0);
    let want = 0.8 * v * line_s * 56.0;
    assert!(
        (grow - want).abs() < 0.4,
        "edge widens by {grow} px over 56 rows, want {want}"
    );
}

/// A static scene (nothing moves) is the same bytes under a global or rolling shutter, any
/// window, and with motions that do not move (the time machinery builds nothing).
#[test]
fn static_scenes_ignore_the_shutter() {
    let (w, h) = (48, 32);
    // Edges inside pixels, so that the image depends on every film sample.
    let shapes = vec![bar(-10.3, 9.6, -5.4, 4.7)];
    // The independent sampler: a time drawn for nothing would shift every later number.
    let indep = |mut s: SceneDescription| {
        s.settings.sampler = camsim_scene3d::SamplerKind::Independent;
        s
    };
    let base = image(&indep(scene(
        w,
        h,
        shapes.clone(),
        16,
        TimeSettings::default(),
    )));
    let t = TimeSettings {
        shutter: Shutter {
            open_s: 0.3,
            close_s: 0.9,
            rolling: Some(RowReadout {
                row0_delay_s: 0.01,
                per_row_delay_s: 1e-3,
                global_reset: false,
            }),
        },
        shapes: vec![(0, Motion::single(velocity_px(0.0, 0.0)))],
        camera: Some(Motion::single(MotionPart::Fixed(Transform::identity()))),
        ..TimeSettings::default()
    };
    assert!(base == image(&indep(scene(w, h, shapes, 16, t))));
}

/// The Cornell box with a small triangle inside the (closed) short block that moves: no ray can
/// reach it, so the render must be the static box's, byte for byte, although every path now
/// draws a time and tests the moving group.
#[test]
fn hidden_moving_object_leaves_the_render_bit_identical() {
    use camsim_scene3d::builtin::{scene as builtin, BuiltinOptions};
    let opts = BuiltinOptions {
        resolution: Some((40, 40)),
        samples_per_pixel: 8,
        ..BuiltinOptions::default()
    };
    let base = builtin("cornell-box", &opts).unwrap();
    let a = render(&base, &|_, _| {}).unwrap();
    let mut moved = base.clone();
    moved.shapes.push(common::hidden_in_cornell_block());
    let k = moved.shapes.len() - 1;
    moved.settings.time = moving(k, velocity_px(1.0, 1.0), 0.0, 1.0);
    moved.settings.time.flow_intervals_s = vec![0.5];
    let b = render(&moved, &|_, _| {}).unwrap();
    assert!(a.radiance.data == b.radiance.data, "radiance differs");
    assert!(a.depth_m == b.depth_m && a.ids.object_id == b.ids.object_id);
    // Nothing visible moves: the flow is 0 everywhere.
    assert!(b.flow[0].xy_px.iter().all(|f| *f == [0.0, 0.0]));
}

/// The flow of a fronto-parallel plane translating at v is v T everywhere (the plane fills the
/// view), and a static background's flow is exactly 0.
#[test]
fn flow_of_a_translating_plane_and_of_static_pixels() {
    let (w, h) = (64, 48);
    let mut t = moving(0, velocity_px(120.0, -80.0), 0.0, 0.01);
    t.flow_intervals_s = vec![0.05];
    let out = render(
        &scene(w, h, vec![bar(-500.0, 500.0, -500.0, 500.0)], 1, t),
        &|_, _| {},
    )
    .unwrap();
    let f = &out.flow[0];
    assert_eq!((f.width, f.height, f.interval_s), (w, h, 0.05));
    for v in &f.xy_px {
        assert!(
            (v[0] - 6.0).abs() < 2e-3 && (v[1] + 4.0).abs() < 2e-3,
            "{v:?}"
        );
    }
    // A small moving bar before a static plane (1 m further): the plane's pixels have flow 0.
    let mut t = moving(0, velocity_px(120.0, 0.0), 0.0, 0.01);
    t.flow_intervals_s = vec![0.05];
    let mut back = bar(-500.0, 500.0, -500.0, 500.0);
    if let Geometry::Triangles { positions, .. } = &mut back.geometry {
        positions.iter_mut().for_each(|p| p[2] = 2.0);
    }
    let out = render(
        &scene(w, h, vec![bar(-5.0, 5.0, -5.0, 5.0), back], 1, t),
        &|_, _| {},
    )
    .unwrap();
    let (ids, f) = (&out.ids.object_id, &out.flow[0].xy_px);
    assert!(ids.contains(&1) && ids.contains(&2));
    for (id, v) in ids.iter().zip(f) {
        match id {
            2 => assert_eq!(*v, [0.0, 0.0]),
            _ => assert!((v[0] - 6.0).abs() < 2e-3 && v[1].abs() < 2e-3, "{v:?}"),
        }
    }
}

/// A camera yawing at `omega_deg_s` about its own y axis under a 1 ms shutter from t = 0, with
/// the flow over `dt_s` asked for.
fn yawing_camera(omega_deg_s: f64, dt_s: f64) -> TimeSettings {
    TimeSettings {
        shutter: Shutter {
            open_s: 0.0,
            close_s: 0.001,
            rolling: None,
        },
        camera: Some(Motion::single(MotionPart::Velocity {
            velocity_m_s: [0.0; 3],
            angular_velocity_deg_s: [0.0, omega_deg_s, 0.0],
            pivot_m: [0.0; 3],
        })),
        flow_intervals_s: vec![dt_s],
        ..TimeSettings::default()
    }
}

/// A camera yawing at w about its own y axis: the flow of every pixel, on the plane or on the
/// empty background alike, is the rotation's closed form (a pinhole of focal length f pixels:
/// a direction (u, -v, f) seen after a yaw phi lands at u' = f (u cos phi - f sin phi) / (u sin
/// phi + f cos phi), v' = f v / (u sin phi + f cos phi)).
#[test]
fn flow_of_a_yawing_camera_is_the_rotational_field() {
    let (w, h) = (80, 60);
    let omega_deg_s = 20.0;
    let dt = 0.1;
    let t = yawing_camera(omega_deg_s, dt);
    // A plane over the left half of the view; the right half sees nothing.
    let out = render(
        &scene(w, h, vec![bar(-500.0, 0.0, -500.0, 500.0)], 1, t),
        &|_, _| {},
    )
    .unwrap();
    let f_px = 1.0 / PX_M;
    let phi = (omega_deg_s * dt).to_radians();
    let mut worst = 0f64;
    for y in 0..h {
        for x in 0..w {
            let (u, v) = (
                x as f64 + 0.5 - w as f64 / 2.0,
                y as f64 + 0.5 - h as f64 / 2.0,
            );
            let den = u * phi.sin() + f_px * phi.cos();
            let (u1, v1) = (
                f_px * (u * phi.cos() - f_px * phi.sin()) / den,
                f_px * v / den,
            );
            let got = out.flow[0].xy_px[y * w + x];
            worst = worst
                .max((got[0] as f64 - (u1 - u)).abs())
                .max((got[1] as f64 - (v1 - v)).abs());
        }
    }
    assert!(
        worst < 0.02,
        "largest deviation from the rotational flow {worst} px"
    );
    assert!(out.ids.object_id[h / 2 * w] == 1 && out.ids.object_id[h / 2 * w + w - 1] == 0);
}

/// A rig turning at w about its reference camera's y axis, seen by its camera offset by b =
/// (0.2, 0, 0.3) m (right and forward; [`SceneDescription::move_camera_in_own_frame`]): the
/// offset camera swings about the rig's centre, so after a yaw phi it sits at R(phi) b, turned
/// by phi. A point P of the plane z = 1 seen at pixel (u, v) at t = 0 (P = b + (1 - b_z) (u /
/// f, -v / f, 1)) is then at R(phi)^-1 P - b in its frame, and its flow is that point's
/// projection minus (u, v). A camera turning about its own centre instead is off by about f b_z
/// phi / (1 - b_z) = 15 px.
#[test]
fn a_turning_rigs_offset_camera_swings_about_the_rig_centre() {
    let (w, h) = (80, 60);
    let (omega_deg_s, dt, b) = (20.0, 0.1, [0.2, 0.0, 0.3]);
    let t = yawing_camera(omega_deg_s, dt);
    let mut s = scene(w, h, vec![bar(-2000.0, 2000.0, -2000.0, 2000.0)], 1, t);
    s.move_camera_in_own_frame(b, 0.0, 0.0, 0.0);
    // The motion's reference pose is still the stored camera (`TimeSettings::camera`).
    let reference = s.settings.time.camera.as_ref().unwrap().reference();
    assert!(
        (0..4).all(|i| (0..4)
            .all(|j| { (reference.m[i][j] - s.camera.camera_to_world.m[i][j]).abs() < 1e-12 })),
        "{reference:?} against {:?}",
        s.camera.camera_to_world
    );
    let out = render(&s, &|_, _| {}).unwrap();
    let f_px = 1.0 / PX_M;
    let (sin, cos) = (omega_deg_s * dt).to_radians().sin_cos();
    let mut worst = 0f64;
    for y in 0..h {
        for x in 0..w {
            let (u, v) = (
                x as f64 + 0.5 - w as f64 / 2.0,
                y as f64 + 0.5 - h as f64 / 2.0,
            );
            let depth_m = 1.0 - b[2];
            let p = [b[0] + depth_m * u / f_px, -depth_m * v / f_px, 1.0];
            // R_y(phi)^-1 p (R_y(phi) turns +z toward +x), less the offset.
            let q = [
                cos * p[0] - sin * p[2] - b[0],
                p[1] - b[1],
                sin * p[0] + cos * p[2] - b[2],
            ];
            let (u1, v1) = (f_px * q[0] / q[2], -f_px * q[1] / q[2]);
            let got = out.flow[0].xy_px[y * w + x];
            worst = worst
                .max((got[0] as f64 - (u1 - u)).abs())
                .max((got[1] as f64 - (v1 - v)).abs());
        }
    }
    assert!(
        worst < 0.02,
        "largest deviation from the rig's swing {worst} px"
    );
}

/// Flow agrees with what the renderer draws: a small bright square moving across and toward
/// the camera, rendered in two short exposures 0.1 s apart; its centroid moves by the mean of
/// the first frame's flow over the square (within 0.1 px).
#[test]
fn flow_matches_the_displacement_between_two_frames() {
    let (w, h) = (96, 96);
    let dt = 0.1;
    let part = MotionPart::Velocity {
        velocity_m_s: [250.0 * PX_M, 150.0 * PX_M, -0.4],
        angular_velocity_deg_s: [0.0, 0.0, 30.0],
        pivot_m: [-0.010, 0.0, 1.0],
    };
    let frame = |t0: f64| {
        let mut t = moving(0, part.clone(), t0, t0 + 1e-6);
        t.flow_intervals_s = vec![dt];
        let s = scene(w, h, vec![bar(-14.0, -6.0, -4.0, 4.0)], 64, t);
        let out = render(&s, &|_, _| {}).unwrap();
        let img: Vec<f64> = out.radiance.data[..w * h]
            .iter()
            .map(|v| *v as f64)
            .collect();
        (img, out.flow)
    };
    let (a, flow) = frame(0.0);
    let (b, _) = frame(dt);
    let centroid = |img: &[f64]| {
        let s: f64 = img.iter().sum();
        let cx = (0..w * h)
            .map(|i| img[i] * ((i % w) as f64 + 0.5))
            .sum::<f64>()
            / s;
        let cy = (0..w * h)
            .map(|i| img[i] * ((i / w) as f64 + 0.5))
            .sum::<f64>()
            / s;
        [cx, cy]
    };
    let (ca, cb) = (centroid(&a), centroid(&b));
    let s: f64 = a.iter().sum();
    let mean_flow = [0, 1].map(|k| {
        (0..w * h)
            .map(|i| a[i] * flow[0].xy_px[i][k] as f64)
            .sum::<f64>()
            / s
    });
    for k in 0..2 {
        let moved = cb[k] - ca[k];
        assert!(
            moved.abs() > 10.0,
            "the square moves (axis {k}: {moved} px)"
        );
        assert!(
            (moved - mean_flow[k]).abs() < 0.1,
            "axis {k}: centroid moved {moved} px, flow says {}",
            mean_flow[k]
        );
    }
}

/// A diffuse floor (reflectance 0.5, the plane z = 0) seen from 2 m above by a `n` x `n` camera
/// with field `fov_deg`.
fn floor_scene(n: usize, fov_deg: f64, spp: u32, extra: Vec<Shape>) -> SceneDescription {
    let mut shapes = vec![common::floor(5.0)];
    shapes.extend(extra);
    let mut sc = scene(n, n, shapes, spp, TimeSettings::default());
    sc.camera.camera_to_world =
        camsim_scene3d::look_at_camera_to_world([0.0, 0.0, 2.0], [0.0; 3], [0.0, 1.0, 0.0], false)
            .unwrap();
    sc.camera.fov_deg = fov_deg;
    sc.materials = vec![Material::Diffuse {
        reflectance: Texture::Constant(flat(0.5)),
    }];
    sc
}

/// A point light 1 m above the floor moving from x = -1 m to +1 m during the exposure: the floor
/// below the path's midpoint receives the time average of I cos(theta) / r^2, I / (h sqrt(a^2 +
/// h^2)) = I / sqrt(2), and reflects rho / pi of it (next-event estimation of a moving delta
/// light).
#[test]
fn a_moving_point_light_gives_the_time_averaged_irradiance() {
    let mut s = floor_scene(4, 0.2, 64, vec![]);
    s.lights = vec![camsim_scene3d::Light::Point {
        position_m: [-1.0, 0.0, 1.0],
        intensity: flat(2.0),
    }];
    s.settings.time = TimeSettings {
        lights: vec![(
            0,
            Motion::single(MotionPart::Velocity {
                velocity_m_s: [2.0, 0.0, 0.0],
                angular_velocity_deg_s: [0.0; 3],
                pivot_m: [0.0; 3],
            }),
        )],
        ..TimeSettings::default()
    };
    let img = image(&s);
    let mean = img.iter().sum::<f64>() / img.len() as f64;
    let want = 0.5 / std::f64::consts::PI * 2.0 / 2f64.sqrt();
    assert!((mean / want - 1.0).abs() < 0.005, "{mean} vs {want}");
}

/// A one-sided square light facing the floor that slides and turns during the exposure lights
/// the floor as the average of the still light at 16 instants (light sampling in the light's own
/// frame and BSDF-sampled hits on the moving emitter, combined by MIS, against the static
/// renderer).
#[test]
fn a_moving_area_light_lights_as_the_average_of_still_ones() {
    let quad = |c: [f64; 3], half: f64| {
        let mut l = bar(0.0, 0.0, 0.0, 0.0);
        l.geometry = Geometry::Triangles {
            // Wound so that (p1 - p0) x (p2 - p0) points down (-z): the emitting side.
            positions: vec![
                [c[0] - half, c[1] - half, c[2]],
                [c[0] - half, c[1] + half, c[2]],
                [c[0] + half, c[1] + half, c[2]],
                [c[0] + half, c[1] - half, c[2]],
            ],
            indices: vec![[0, 1, 2], [0, 2, 3]],
            uvs: None,
            normals: None,
            colors: None,
            uvs1: None,
            tangents: None,
        };
        if let Some(a) = &mut l.area_light {
            a.two_sided = false;
        }
        l
    };
    let part = MotionPart::Velocity {
        velocity_m_s: [0.8, 0.0, 0.0],
        angular_velocity_deg_s: [0.0, 0.0, 60.0],
        pivot_m: [-0.4, 0.0, 0.6],
    };
    let light = quad([-0.4, 0.0, 0.6], 0.15);
    let n = 16;
    let mut moving = floor_scene(n, 70.0, 512, vec![light.clone()]);
    moving.settings.max_depth = 1;
    moving.settings.time = self::moving(1, part.clone(), 0.0, 1.0);
    let got = image(&moving);
    let k = 16;
    let mut avg = vec![0f64; n * n];
    for i in 0..k {
        let t = (i as f64 + 0.5) / k as f64;
        let mut still = floor_scene(n, 70.0, 64, vec![light.clone()]);
        still.settings.max_depth = 1;
        if let Geometry::Triangles { positions, .. } = &mut still.shapes[1].geometry {
            let d = Motion::single(part.clone()).delta(t);
            positions.iter_mut().for_each(|p| *p = d.apply_point(*p));
        }
        still.settings.seed = 100 + i as u64;
        for (a, v) in avg.iter_mut().zip(image(&still)) {
            *a += v / k as f64;
        }
    }
    // Compare 4 x 4 blocks (the noise of one pixel is a few per cent).
    let block = |img: &[f64], bx: usize, by: usize| {
        (0..4)
            .flat_map(|y| (0..4).map(move |x| img[(by * 4 + y) * n + bx * 4 + x]))
            .sum::<f64>()
    };
    for by in 0..4 {
        for bx in 0..4 {
            let (g, w) = (block(&got, bx, by), block(&avg, bx, by));
            assert!((g / w - 1.0).abs() < 0.03, "block ({bx}, {by}): {g} vs {w}");
        }
    }
}

/// The labels of a render at time t (its rows' window start).
fn labels_at(s: &SceneDescription) -> (camsim_render::RenderOutput, camsim_render::Labels) {
    use camsim_render::{render_with, LabelRequest, RenderRequest};
    let req = RenderRequest {
        labels: Some(LabelRequest {
            normals: true,
            albedo: false,
            amodal: false,
        }),
        ..Default::default()
    };
    let mut out = render_with(s, &req, &|_, _| {}).unwrap();
    let l = out.labels.take().unwrap();
    (out, l)
}

/// The first column of row `y` an instance map marks (its left edge in pixel edges).
fn left_edge(map: &[u32], w: usize, y: usize) -> usize {
    (0..w).find(|x| map[y * w + x] != 0).unwrap()
}

/// Labels of a moving scene describe the scene at the start of the shutter window (the instant
/// of the depth and id maps and of flow's first hit): a bar moving at v px/s under a window
/// [t0, t0 + T] has its instance map's left edge at x0 + v t0 (within half a pixel: maps are
/// sampled at pixel centres), not at x0 nor at the window's middle; the labels equal the
/// render's own id and depth maps; its 3D box is moved by v t0; and a plane receding along the
/// view axis at vz has depth z0 + vz t0.
#[test]
fn labels_of_a_moving_scene_are_the_scene_at_the_window_start() {
    let (w, h) = (64, 8);
    let (x0, v) = (-20.3, 150.0);
    let still = scene(
        w,
        h,
        vec![bar(x0, x0 + 6.0, -10.0, 10.0)],
        1,
        Default::default(),
    );
    let (_, l_still) = labels_at(&still);
    for (t0, big_t) in [(0.0, 0.02), (0.04, 0.02), (0.1, 0.05)] {
        let s = scene(
            w,
            h,
            vec![bar(x0, x0 + 6.0, -10.0, 10.0)],
            1,
            moving(0, velocity_px(v, 0.0), t0, t0 + big_t),
        );
        let (out, l) = labels_at(&s);
        let want = w as f64 / 2.0 + x0 + v * t0;
        for y in 0..h {
            let e = left_edge(&l.instance_id, w, y) as f64;
            assert!(
                (e - want).abs() <= 0.5,
                "t0 = {t0}: edge at {e}, want {want} +- 0.5"
            );
        }
        // The same instant as the render's own depth and id maps.
        assert_eq!(l.object_id, out.ids.object_id);
        for (a, b) in l.depth_m.iter().zip(&out.depth_m) {
            assert!(a == b || (a - b).abs() < 1e-5 * b, "{a} vs {b}");
        }
        // The 3D box (camera frame, x right) moved with the bar to t0.
        let (c, c0) = (
            l.instances[0].box_3d.as_ref().unwrap().center_m,
            l_still.instances[0].box_3d.as_ref().unwrap().center_m,
        );
        let dx = v * t0 * PX_M;
        assert!(
            (c[0] - c0[0] - dx).abs() < 1e-9 && (c[1] - c0[1]).abs() < 1e-9,
            "box centre {c:?} vs still {c0:?} + {dx}"
        );
    }
    // A plane filling the view recedes at vz: depth z0 + vz t0 everywhere.
    let vz = 2.0;
    let recede = MotionPart::Velocity {
        velocity_m_s: [0.0, 0.0, vz],
        angular_velocity_deg_s: [0.0; 3],
        pivot_m: [0.0; 3],
    };
    for t0 in [0.0, 0.1, 0.25] {
        let s = scene(
            w,
            h,
            vec![bar(-5000.0, 5000.0, -5000.0, 5000.0)],
            1,
            moving(0, recede.clone(), t0, t0 + 0.05),
        );
        let (_, l) = labels_at(&s);
        let want = 1.0 + vz * t0;
        for d in &l.depth_m {
            assert!(
                (*d as f64 - want).abs() < 1e-5,
                "t0 = {t0}: depth {d}, want {want}"
            );
        }
        // The plane faces the camera: its camera-frame normal is the optical axis.
        for n in l.normal_camera.as_ref().unwrap() {
            assert!(n[2].abs() > 0.99999, "{n:?}");
        }
    }
}

/// A camera translating sideways at v: the labels see the scene from the camera at the window
/// start, so a static bar's instance edge moves by -v t0 in pixels, and the labels' extrinsics
/// are the camera's at t0 (the world origin moves by -v t0 in the camera frame).
#[test]
fn labels_follow_a_moving_camera() {
    let (w, h) = (64, 8);
    let (x0, v) = (-10.2, 100.0);
    for t0 in [0.0, 0.05, 0.12] {
        let t = TimeSettings {
            shutter: Shutter {
                open_s: t0,
                close_s: t0 + 0.01,
                rolling: None,
            },
            camera: Some(Motion::single(velocity_px(v, 0.0))),
            ..TimeSettings::default()
        };
        let s = scene(w, h, vec![bar(x0, x0 + 6.0, -10.0, 10.0)], 1, t);
        let (_, l) = labels_at(&s);
        let want = w as f64 / 2.0 + x0 - v * t0;
        let e = left_edge(&l.instance_id, w, 3) as f64;
        assert!((e - want).abs() <= 0.5, "t0 = {t0}: edge {e}, want {want}");
        let origin = l.camera.to_camera([0.0; 3]);
        assert!(
            (origin[0] + v * t0 * PX_M).abs() < 1e-9,
            "t0 = {t0}: world origin at {origin:?} in the camera frame"
        );
    }
}
