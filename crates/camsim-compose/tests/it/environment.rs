//! Environment maps and the spectral sky (`[compose.environment]`): illuminance in closed form
//! and by quadrature independent of the code that scaled the map, the Preetham zenith values
//! from the paper's equations, the sky's per-direction spectra against the model's
//! chromaticity, and the draws' determinism.

use camsim_compose::environment::{
    apply, preetham_zenith, Draw, EnvironmentKind, EnvironmentSpec, PreethamSky, SkyMap, SunModel,
};
use camsim_core::colorimetry;
use camsim_core::units::LUMINOUS_EFFICACY_LM_PER_W;
use camsim_scene3d::*;
use std::collections::HashMap;
use std::f64::consts::PI;
use std::path::Path;

fn empty_scene() -> SceneDescription {
    SceneDescription {
        camera: Camera {
            camera_to_world: Transform::identity(),
            fov_deg: 40.0,
            width: 8,
            height: 8,
            lens: None,
        },
        shapes: vec![],
        materials: vec![],
        named_materials: HashMap::new(),
        lights: vec![Light::Infinite {
            radiance: camsim_core::Spectrum::from_pairs(&[(300.0, 1.0), (900.0, 1.0)]),
        }],
        settings: RenderSettings::default(),
        focus_distance_m: None,
        notes: vec![],
        media: Default::default(),
        light_groups: vec![Some("old".into())],
    }
}

/// A little-endian RGB PFM file (rows bottom to top).
fn write_pfm(path: &Path, w: usize, h: usize, texel: impl Fn(usize, usize) -> [f32; 3]) {
    let mut bytes = format!("PF\n{w} {h}\n-1.0\n").into_bytes();
    for y in (0..h).rev() {
        for x in 0..w {
            for v in texel(x, y) {
                bytes.extend_from_slice(&v.to_le_bytes());
            }
        }
    }
    std::fs::write(path, bytes).unwrap();
}

/// A flat (uncompressed) Radiance RGBE file (Ward, "Real pixels", Graphics Gems II, 1991):
/// mantissas `v 256 / 2^e` with `2^e` the power of two just above the largest component.
fn write_hdr(path: &Path, w: usize, h: usize, texel: impl Fn(usize, usize) -> [f32; 3]) {
    let mut bytes = format!("#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y {h} +X {w}\n").into_bytes();
    for y in 0..h {
        for x in 0..w {
            let c = texel(x, y);
            let m = c[0].max(c[1]).max(c[2]);
            if m < 1e-30 {
                bytes.extend_from_slice(&[0, 0, 0, 0]);
                continue;
            }
            let e = m.log2().floor() as i32 + 1;
            let k = 256.0 / 2f32.powi(e);
            bytes.extend_from_slice(&[
                (c[0] * k) as u8,
                (c[1] * k) as u8,
                (c[2] * k) as u8,
                (e + 128) as u8,
            ]);
        }
    }
    std::fs::write(path, bytes).unwrap();
}

/// The environment light `apply` added (the last one).
fn env_map(scene: &SceneDescription) -> &EnvironmentMap {
    scene
        .lights
        .iter()
        .rev()
        .find_map(|l| match l {
            Light::Environment(m) => Some(m),
            _ => None,
        })
        .expect("an environment light")
}

/// Illuminance on the world plane facing `up` of a lat-long RGB map of grey texels, lux, by
/// midpoint quadrature over the upper hemisphere (`n` x `2n` points in theta, phi of the world
/// frame), each direction's texel found through the map's own transform and the lat-long
/// mapping, its luminance `683 v int y_bar illuminant` (a grey texel's uplifted spectrum is
/// `v` times the illuminant). Independent of the code that scaled the map.
fn grey_map_illuminance(map: &EnvironmentMap, up: [f64; 3], n: usize) -> f64 {
    let lum_per_unit =
        LUMINOUS_EFFICACY_LM_PER_W * camsim_scene3d::spectra::photometric(&map.illuminant);
    let inv = camsim_scene3d::transform::inverse(&map.light_to_world).unwrap();
    // An orthonormal world frame around up.
    let u = up;
    let a = if u[0].abs() < 0.9 {
        [1.0, 0.0, 0.0]
    } else {
        [0.0, 0.0, 1.0]
    };
    let d = a[0] * u[0] + a[1] * u[1] + a[2] * u[2];
    let r = [a[0] - d * u[0], a[1] - d * u[1], a[2] - d * u[2]];
    let rl = (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt();
    let r = r.map(|v| v / rl);
    let s = [
        u[1] * r[2] - u[2] * r[1],
        u[2] * r[0] - u[0] * r[2],
        u[0] * r[1] - u[1] * r[0],
    ];
    let (dt, dp) = (PI / 2.0 / n as f64, 2.0 * PI / (2 * n) as f64);
    let mut e = 0.0;
    for j in 0..n {
        let t = (j as f64 + 0.5) * dt;
        for i in 0..2 * n {
            let p = (i as f64 + 0.5) * dp;
            let w: [f64; 3] = std::array::from_fn(|k| {
                t.sin() * (p.cos() * r[k] + p.sin() * s[k]) + t.cos() * u[k]
            });
            let l = inv.apply_vector(w);
            let (uu, vv) = camsim_scene3d::envmap::sphere_to_latlong(l);
            let x = ((uu * map.width as f64) as usize).min(map.width - 1);
            let y = ((vv * map.height as f64) as usize).min(map.height - 1);
            let v = map.rgb[y * map.width + x][1] as f64;
            e += v * lum_per_unit * t.cos() * t.sin() * dt * dp;
        }
    }
    e
}

/// A uniform map of luminance L (grey texels of value L: the map's own units are cd/m^2 per
/// unit RGB) gives E = pi L on an upward plane: the record's figure in closed form, and the
/// independent quadrature of the map as placed in the scene. The scene's old infinite light
/// and its light group are replaced.
#[test]
fn uniform_map_gives_pi_l() {
    let dir = tempfile::tempdir().unwrap();
    let l = 250.0f32;
    write_pfm(&dir.path().join("uniform.pfm"), 64, 32, |_, _| [l; 3]);
    let mut scene = empty_scene();
    let spec = EnvironmentSpec {
        path: Some("uniform.pfm".into()),
        rotate_deg: Draw::Range([0.0, 360.0]),
        ..EnvironmentSpec::default()
    };
    let rec = apply(&mut scene, &spec, 5, dir.path()).unwrap();
    assert_eq!(scene.lights.len(), 1);
    assert_eq!(scene.light_groups, vec![None]);
    let want = PI * l as f64;
    eprintln!(
        "uniform map L = {l} cd/m^2: record {:.4} lux, closed form pi L = {want:.4} lux",
        rec.illuminance_lux
    );
    assert!((rec.illuminance_lux - want).abs() < 1e-9 * want);
    let quad = grey_map_illuminance(env_map(&scene), spec.up, 400);
    eprintln!(
        "  quadrature of the placed map: {quad:.4} lux ({:+.4} %)",
        100.0 * (quad / want - 1.0)
    );
    assert!((quad / want - 1.0).abs() < 0.01);
}

/// `illuminance_lux` normalises an HDR (Radiance RGBE) map with a bright glow and a gradient, drawn from a folder of two maps, tilted up axis: the quadrature of the scaled map
/// as placed in the scene gives the requested illuminance within 1 %.
#[test]
fn illuminance_lux_normalises_an_hdr_map() {
    let dir = tempfile::tempdir().unwrap();
    let (w, h) = (128, 64);
    // A gradient and a bright glow 8 degrees wide (Gaussian in the angle from a point at 50
    // degrees from the pole), smooth enough for the quadrature's nearest-texel steps.
    let texel = |x: usize, y: usize| {
        let (th, ph) = (
            PI * (y as f64 + 0.5) / h as f64,
            2.0 * PI * (x as f64 + 0.5) / w as f64,
        );
        let (t0, p0) = (50f64.to_radians(), 2.0f64);
        let c = th.cos() * t0.cos() + th.sin() * t0.sin() * (ph - p0).cos();
        let a = c.clamp(-1.0, 1.0).acos().to_degrees();
        let v = 0.2
            + 3.0 * (1.0 - y as f64 / h as f64)
            + 0.5 * (x as f64 / w as f64)
            + 400.0 * (-(a * a) / (2.0 * 8.0 * 8.0)).exp();
        [v as f32; 3]
    };
    write_hdr(&dir.path().join("a.hdr"), w, h, texel);
    write_hdr(&dir.path().join("b.HDR"), w, h, |x, y| {
        texel((x + 30) % w, y)
    });
    std::fs::write(dir.path().join("notes.txt"), "not a map").unwrap();
    let up = [0.2, 1.0, -0.1];
    for (seed, lux) in [(1u64, 20_000.0), (2, 350.0), (3, 90_000.0)] {
        let mut scene = empty_scene();
        let spec = EnvironmentSpec {
            path: Some(dir.path().to_path_buf()),
            illuminance_lux: Some(Draw::Fixed(lux)),
            rotate_deg: Draw::Range([-180.0, 180.0]),
            up,
            ..EnvironmentSpec::default()
        };
        let rec = apply(&mut scene, &spec, seed, Path::new("/nonexistent")).unwrap();
        let ul = (up[0] * up[0] + up[1] * up[1] + up[2] * up[2]).sqrt();
        let quad = grey_map_illuminance(env_map(&scene), up.map(|v| v / ul), 600);
        eprintln!(
            "{}: rotate {:.1} deg, scale {:.4}, want {lux} lux, quadrature {quad:.2} lux ({:+.3} %)",
            rec.file.as_ref().unwrap().display(),
            rec.rotate_deg,
            rec.scale,
            100.0 * (quad / lux - 1.0)
        );
        assert!((quad / lux - 1.0).abs() < 0.01);
        assert!((rec.illuminance_lux / lux - 1.0).abs() < 1e-9);
    }
}

/// Bad input fails with the key named, never a panic.
#[test]
fn bad_environment_input_names_the_key() {
    let dir = tempfile::tempdir().unwrap();
    let err = |spec: EnvironmentSpec| apply(&mut empty_scene(), &spec, 0, dir.path()).unwrap_err();
    assert_eq!(
        err(EnvironmentSpec::default()).key,
        "compose.environment.path"
    );
    assert!(err(EnvironmentSpec {
        path: Some("missing.exr".into()),
        ..Default::default()
    })
    .message
    .contains("does not exist"));
    assert!(err(EnvironmentSpec {
        path: Some(".".into()),
        ..Default::default()
    })
    .message
    .contains("no .hdr, .exr or .pfm"));
    write_pfm(&dir.path().join("odd.pfm"), 30, 20, |_, _| [1.0; 3]);
    assert!(err(EnvironmentSpec {
        path: Some("odd.pfm".into()),
        ..Default::default()
    })
    .message
    .contains("twice as wide"));
    let sky = |f: fn(&mut EnvironmentSpec)| {
        let mut s = EnvironmentSpec {
            kind: EnvironmentKind::Sky,
            ..Default::default()
        };
        f(&mut s);
        err(s).key
    };
    assert_eq!(
        sky(|s| s.turbidity = Draw::Fixed(12.0)),
        "compose.environment.turbidity"
    );
    assert_eq!(
        sky(|s| s.sun_elevation_deg = Draw::Range([-5.0, 10.0])),
        "compose.environment.sun_elevation_deg"
    );
    assert_eq!(
        sky(|s| s.ground_albedo = 1.5),
        "compose.environment.ground_albedo"
    );
    assert_eq!(sky(|s| s.up = [0.0; 3]), "compose.environment.up");
}

/// Preetham, Shirley and Smits 1999, Appendix A.2, written out here from the paper:
/// chi = (4/9 - T/120)(pi - 2 theta_s); Y_z = (4.0453 T - 4.9710) tan(chi) - 0.2155 T + 2.4192
/// (kcd/m^2); x_z = (0.00166 ts^3 - 0.00375 ts^2 + 0.00209 ts) T^2 + (-0.02903 ts^3 + 0.06377
/// ts^2 - 0.03202 ts + 0.00394) T + (0.11693 ts^3 - 0.21196 ts^2 + 0.06052 ts + 0.25886);
/// y_z = (0.00275 ts^3 - 0.00610 ts^2 + 0.00317 ts) T^2 + (-0.04214 ts^3 + 0.08970 ts^2 -
/// 0.04153 ts + 0.00516) T + (0.15346 ts^3 - 0.26756 ts^2 + 0.06670 ts + 0.26688).
/// E.g. T = 2, sun at 30 deg elevation (ts = 60 deg): Y_z = 3.487 kcd/m^2, (x, y) = (0.2380,
/// 0.2420) (evaluated separately from the equations above). The built sky's zenith texel
/// carries them.
#[test]
fn preetham_zenith_values_match_the_paper() {
    let paper = |t: f64, ts: f64| {
        let chi = (4.0 / 9.0 - t / 120.0) * (PI - 2.0 * ts);
        let y = (4.0453 * t - 4.9710) * chi.tan() - 0.2155 * t + 2.4192;
        let x = (0.00166 * ts.powi(3) - 0.00375 * ts.powi(2) + 0.00209 * ts) * t * t
            + (-0.02903 * ts.powi(3) + 0.06377 * ts.powi(2) - 0.03202 * ts + 0.00394) * t
            + (0.11693 * ts.powi(3) - 0.21196 * ts.powi(2) + 0.06052 * ts + 0.25886);
        let yc = (0.00275 * ts.powi(3) - 0.00610 * ts.powi(2) + 0.00317 * ts) * t * t
            + (-0.04214 * ts.powi(3) + 0.08970 * ts.powi(2) - 0.04153 * ts + 0.00516) * t
            + (0.15346 * ts.powi(3) - 0.26756 * ts.powi(2) + 0.06670 * ts + 0.26688);
        [1000.0 * y, x, yc]
    };
    let hand = paper(2.0, 60f64.to_radians());
    eprintln!(
        "T 2, elevation 30 deg: Y_z {:.1} cd/m^2, x {:.4}, y {:.4}",
        hand[0], hand[1], hand[2]
    );
    assert!(
        (hand[0] - 3487.3).abs() < 0.1
            && (hand[1] - 0.2380).abs() < 1e-4
            && (hand[2] - 0.2420).abs() < 1e-4
    );
    for (t, elev) in [
        (2.0, 30.0),
        (3.0, 60.0),
        (6.0, 10.0),
        (10.0, 45.0),
        (2.5, 85.0),
    ] {
        let ts = (90.0f64 - elev).to_radians();
        let want = paper(t, ts);
        let got = preetham_zenith(t, ts);
        for k in 0..3 {
            assert!(
                (got[k] - want[k]).abs() < 1e-9 * want[k].abs(),
                "T {t}, elevation {elev}: {got:?} vs {want:?}"
            );
        }
        // The distribution is the zenith value at the zenith (F(0, theta_s) / F(0, theta_s)).
        let z = PreethamSky::new(t, ts).xyy(0.0, ts);
        assert!((0..3).all(|k| (z[k] - want[k]).abs() < 1e-9 * want[k]));
        // The map's first row (theta = pi / 512) decodes to within 2 % of the zenith luminance
        // (1.1 % off with the sun 5 degrees from the zenith).
        let sky = SkyMap::build(t, elev, 0.0, 0.2, SunModel::Distant, 256).unwrap();
        let c = sky.coeffs[0];
        let b = daylight::basis_xyz();
        let lum = LUMINOUS_EFFICACY_LM_PER_W * (c[0] * b[0][1] + c[1] * b[1][1] + c[2] * b[2][1]);
        eprintln!("T {t}, elevation {elev} deg: Y_z {:.1} cd/m^2 (x {:.4}, y {:.4}); zenith texel {lum:.1} cd/m^2", want[0], want[1], want[2]);
        assert!((lum / want[0] - 1.0).abs() < 0.02);
    }
}

/// Each sky texel's spectrum max(0, k (S0 + M1 S1 + M2 S2)), integrated with the CIE 1931 CMFs at 1 nm,
/// has the model's chromaticity within 0.005 and its luminance within 0.5 %, across the sky,
/// for several suns and turbidities.
#[test]
fn sky_spectra_have_the_models_chromaticity() {
    let grid = camsim_core::WavelengthGrid::new(360.0, 830.0, 1.0).unwrap();
    let b = daylight::basis();
    let (mut worst, mut worst_moved, mut moved): (f64, f64, usize) = (0.0, 0.0, 0);
    for (t, elev, az) in [
        (2.0, 20.0, 30.0),
        (4.0, 55.0, 200.0),
        (8.0, 5.0, 100.0),
        (10.0, 0.0, 0.0),
        (10.0, 2.0, 50.0),
        (2.0, 0.5, 300.0),
        (6.0, 89.0, 10.0),
    ] {
        let h = 32;
        let sky = SkyMap::build(t, elev, az, 0.2, SunModel::Distant, h).unwrap();
        let model = PreethamSky::new(t, (90.0f64 - elev).to_radians());
        let s = sky.sun_dir_light;
        for yy in (0..h / 2).step_by(3) {
            for xx in (0..2 * h).step_by(7) {
                let th = PI * (yy as f64 + 0.5) / h as f64;
                let ph = 2.0 * PI * (xx as f64 + 0.5) / (2 * h) as f64;
                let d = [th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos()];
                let gamma = (d[0] * s[0] + d[1] * s[1] + d[2] * s[2])
                    .clamp(-1.0, 1.0)
                    .acos();
                let want = model.xyy(th, gamma);
                let c = sky.coeffs[yy * 2 * h + xx];
                let spec: Vec<f64> = (0..grid.len())
                    .map(|i| {
                        let l = grid.wavelength_nm(i);
                        c[0] * b[0].eval(l) + c[1] * b[1].eval(l) + c[2] * b[2].eval(l)
                    })
                    .collect();
                // Warm skies (low sun) may dip below zero in the UV below 380 nm (S0 is near
                // 0 there); the renderer clamps the sum at 0, as here. From 380 nm on the
                // spectra are non-negative.
                let neg = spec.iter().enumerate().find(|(i, v)| *i >= 20 && **v < 0.0);
                assert!(
                    neg.is_none(),
                    "negative sky spectrum at T {t}, ({th}, {ph}): {neg:?}"
                );
                // Chromaticities the basis reaches only with a negative visible spectrum (next
                // to a sun on the horizon) were moved toward the daylight locus.
                let reachable =
                    daylight::non_negative_visible(daylight::m1_m2(want[1], want[2]).unwrap());
                let spec: Vec<f64> = spec.into_iter().map(|v| v.max(0.0)).collect();
                let xyz = colorimetry::xyz(&spec, &grid);
                let xy = colorimetry::chromaticity_xy(xyz);
                let lum = LUMINOUS_EFFICACY_LM_PER_W * xyz[1];
                if !reachable {
                    // Moved: the texel has the chromaticity the non-negative solve chose, a
                    // valid spectrum from 380 nm, the model's luminance, and lies within 0.05
                    // of the model's chromaticity.
                    let (_, used) = daylight::m1_m2_non_negative(want[1], want[2]).unwrap();
                    assert!(
                        (xy[0] - used[0]).abs() < 1e-4 && (xy[1] - used[1]).abs() < 1e-4,
                        "T {t}: {xy:?} vs {used:?}"
                    );
                    let shift = (xy[0] - want[1]).hypot(xy[1] - want[2]);
                    assert!(shift < 0.05, "T {t}: moved {shift} from {want:?}");
                    moved += 1;
                    worst_moved = worst_moved.max(shift);
                    assert!((lum / want[0] - 1.0).abs() < 0.005);
                    continue;
                }
                let e = (xy[0] - want[1]).abs().max((xy[1] - want[2]).abs());
                worst = worst.max(e);
                assert!(
                    e < 0.005,
                    "T {t}: xy {xy:?} vs model ({}, {})",
                    want[1],
                    want[2]
                );
                assert!(
                    (lum / want[0] - 1.0).abs() < 0.005,
                    "T {t}: luminance {lum} vs {}",
                    want[0]
                );
            }
        }
    }
    eprintln!("largest chromaticity difference, spectrum vs model: {worst:.2e}; {moved} texels moved toward the daylight locus, by at most {worst_moved:.4} in xy");
}

/// The sky with `illuminance_lux`: its map (quadrature of each texel's spectral luminance
/// over the upper hemisphere) plus the sun (its distant light's photometric irradiance times
/// the cosine of its zenith angle) give the requested illuminance within 1 %; the draws are
/// the same for a seed and within their ranges; the sun light points down from the sun.
#[test]
fn sky_illuminance_and_draws() {
    let spec = EnvironmentSpec {
        kind: EnvironmentKind::Sky,
        sun_elevation_deg: Draw::Range([15.0, 75.0]),
        turbidity: Draw::Range([2.0, 6.0]),
        illuminance_lux: Some(Draw::Fixed(40_000.0)),
        sky_height_px: 64,
        up: [0.0, 0.0, 1.0],
        ..EnvironmentSpec::default()
    };
    let grid = camsim_core::WavelengthGrid::new(360.0, 830.0, 1.0).unwrap();
    let cmfs = colorimetry::Cmfs::on(&grid);
    let b = daylight::basis();
    let ybar: [f64; 3] = std::array::from_fn(|k| cmfs.xyz(&b[k].sample(&grid))[1]);
    for seed in [3u64, 4] {
        let mut scene = empty_scene();
        let rec = apply(&mut scene, &spec, seed, Path::new(".")).unwrap();
        let again = apply(&mut empty_scene(), &spec, seed, Path::new(".")).unwrap();
        assert_eq!(rec, again);
        let (el, t) = (rec.sun_elevation_deg.unwrap(), rec.turbidity.unwrap());
        assert!((15.0..=75.0).contains(&el) && (2.0..=6.0).contains(&t));
        let map = env_map(&scene);
        // Quadrature over the upper hemisphere, nearest texel (light frame = world, z up).
        let n = 300;
        let (dt, dp) = (PI / 2.0 / n as f64, PI / n as f64);
        let mut e_sky = 0.0;
        for j in 0..n {
            let th = (j as f64 + 0.5) * dt;
            for i in 0..2 * n {
                let ph = (i as f64 + 0.5) * dp;
                let w = [th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos()];
                let l = camsim_scene3d::transform::inverse(&map.light_to_world)
                    .unwrap()
                    .apply_vector(w);
                let (u, v) = camsim_scene3d::envmap::sphere_to_latlong(l);
                let x = ((u * map.width as f64) as usize).min(map.width - 1);
                let y = ((v * map.height as f64) as usize).min(map.height - 1);
                let c = map.rgb[y * map.width + x];
                let lum =
                    LUMINOUS_EFFICACY_LM_PER_W * (0..3).map(|k| c[k] as f64 * ybar[k]).sum::<f64>();
                e_sky += lum * th.cos() * th.sin() * dt * dp;
            }
        }
        let (dir, irr) = scene
            .lights
            .iter()
            .find_map(|l| match l {
                Light::Distant {
                    direction,
                    irradiance,
                } => Some((*direction, irradiance.clone())),
                _ => None,
            })
            .expect("a sun");
        assert!(
            (-dir[2] - el.to_radians().sin()).abs() < 1e-9,
            "sun direction {dir:?} vs elevation {el}"
        );
        let e_sun = LUMINOUS_EFFICACY_LM_PER_W * cmfs.xyz(&irr.sample(&grid))[1] * -dir[2];
        let total = e_sky + e_sun;
        eprintln!(
            "seed {seed}: T {t:.2}, sun {el:.1} deg: sky {e_sky:.0} + sun {e_sun:.0} = {total:.0} lux (want 40000, {:+.3} %)",
            100.0 * (total / 40_000.0 - 1.0)
        );
        assert!((total / 40_000.0 - 1.0).abs() < 0.01);
    }
    // Unscaled, the clear noon sky is physically plausible: 60-130 klux of sun at 60 deg, a
    // sky of 5-30 klux (CIE clear-sky daylight measurements span these).
    let clear = EnvironmentSpec {
        kind: EnvironmentKind::Sky,
        sun_elevation_deg: Draw::Fixed(60.0),
        turbidity: Draw::Fixed(2.5),
        sky_height_px: 64,
        ..EnvironmentSpec::default()
    };
    let rec = apply(&mut empty_scene(), &clear, 0, Path::new(".")).unwrap();
    let sun = rec.sun_illuminance_lux.unwrap();
    let sky = rec.illuminance_lux - sun;
    eprintln!(
        "clear sky, sun at 60 deg, T 2.5: sun {sun:.0} lux, sky {sky:.0} lux, zenith {:.0} cd/m^2",
        rec.zenith_luminance_cd_m2.unwrap()
    );
    assert!((60_000.0..130_000.0).contains(&sun) && (5_000.0..30_000.0).contains(&sky));
}

/// `choices` picks an entry per sample in proportion to its weight (3 : 1 here, 400 samples:
/// the map's share within 0.06 of 0.75, about 3 standard deviations), the record names it, and
/// the choice is the same for a seed.
#[test]
fn choices_are_drawn_by_weight() {
    let dir = tempfile::tempdir().unwrap();
    write_pfm(&dir.path().join("m.pfm"), 32, 16, |_, _| [1.0; 3]);
    let spec = EnvironmentSpec {
        choices: vec![
            EnvironmentSpec {
                path: Some("m.pfm".into()),
                weight: 3.0,
                ..EnvironmentSpec::default()
            },
            EnvironmentSpec {
                kind: EnvironmentKind::Sky,
                sky_height_px: 16,
                ..EnvironmentSpec::default()
            },
        ],
        ..EnvironmentSpec::default()
    };
    let n = 400;
    let mut maps = 0;
    for seed in 0..n {
        let rec = apply(&mut empty_scene(), &spec, seed, dir.path()).unwrap();
        let again = apply(&mut empty_scene(), &spec, seed, dir.path()).unwrap();
        assert_eq!(rec.choice, again.choice);
        match rec.choice {
            Some(0) => {
                assert_eq!(rec.kind, EnvironmentKind::Map);
                maps += 1;
            }
            Some(1) => assert_eq!(rec.kind, EnvironmentKind::Sky),
            c => panic!("choice {c:?}"),
        }
    }
    let share = maps as f64 / n as f64;
    eprintln!("map chosen in {maps} of {n} samples ({share:.3}, weight share 0.75)");
    assert!((share - 0.75).abs() < 0.06);
    let bad = EnvironmentSpec {
        choices: vec![EnvironmentSpec {
            weight: 0.0,
            ..EnvironmentSpec::default()
        }],
        ..EnvironmentSpec::default()
    };
    assert_eq!(
        apply(&mut empty_scene(), &bad, 0, dir.path())
            .unwrap_err()
            .key,
        "compose.environment.choices.0.weight"
    );
}

/// `sun = "disc"`: no distant light; the sun's texel carries the sun's illuminance (its
/// luminance times the texel's cosine-weighted solid angle, by 64 x 64 points in the texel,
/// equals the record's sun illuminance within 1 %), the texel lies toward the sun, and its
/// added chromaticity is the sun's (warmer than the zenith sky).
#[test]
fn sun_disc_lives_in_the_map() {
    let spec = EnvironmentSpec {
        kind: EnvironmentKind::Sky,
        sun: SunModel::Disc,
        sun_elevation_deg: Draw::Fixed(35.0),
        sun_azimuth_deg: Draw::Fixed(120.0),
        sky_height_px: 128,
        up: [0.0, 0.0, 1.0],
        ..EnvironmentSpec::default()
    };
    let mut scene = empty_scene();
    let rec = apply(&mut scene, &spec, 0, Path::new(".")).unwrap();
    assert!(!scene
        .lights
        .iter()
        .any(|l| matches!(l, Light::Distant { .. })));
    let sky = SkyMap::build(3.0, 35.0, 120.0, 0.2, SunModel::Disc, 128).unwrap();
    let with = sky.sun_texel.unwrap();
    let none = SkyMap::build(3.0, 35.0, 120.0, 0.2, SunModel::None, 128).unwrap();
    let b = daylight::basis_xyz();
    let (h, w) = (128usize, 256usize);
    let (row, col) = (with / w, with % w);
    let d: [f64; 3] = std::array::from_fn(|k| sky.coeffs[with][k] - none.coeffs[with][k]);
    let xyz: [f64; 3] = std::array::from_fn(|j| (0..3).map(|k| d[k] * b[k][j]).sum());
    let lum = LUMINOUS_EFFICACY_LM_PER_W * xyz[1];
    let q = 64;
    let mut cos_sa = 0.0;
    for jj in 0..q {
        let th = PI * (row as f64 + (jj as f64 + 0.5) / q as f64) / h as f64;
        cos_sa += th.cos() * th.sin() * (PI / (h * q) as f64) * (2.0 * PI / w as f64);
    }
    let e = lum * cos_sa;
    let sun = rec.sun_illuminance_lux.unwrap();
    eprintln!("sun texel ({row}, {col}): {lum:.3e} cd/m^2 x {cos_sa:.3e} sr = {e:.0} lux; record {sun:.0} lux");
    assert!((e / sun - 1.0).abs() < 0.01);
    // The texel points at the sun.
    let th = PI * (row as f64 + 0.5) / h as f64;
    let ph = 2.0 * PI * (col as f64 + 0.5) / w as f64;
    assert!((th.to_degrees() - 55.0).abs() < 1.0 && (ph.to_degrees() - 120.0).abs() < 1.0);
    let s = xyz[0] + xyz[1] + xyz[2];
    let z = none.coeffs[0];
    let zx: [f64; 3] = std::array::from_fn(|j| (0..3).map(|k| z[k] * b[k][j]).sum());
    assert!(
        xyz[0] / s > zx[0] / (zx[0] + zx[1] + zx[2]) + 0.03,
        "the sun should be warmer than the zenith sky"
    );
}
