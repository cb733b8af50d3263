//! pbrt-v4's procedural textures read from a scene file and rendered: `wrinkled`, `fbm` and
//! `windy` (solid noises, float), `marble` (spectrum) and `dots` (2D polka dots). A diffuse
//! square at z = 1 under a uniform sky reflects L_sky times its albedo (direct light only), so the
//! ratio of its render to that of a white square is the albedo at each pixel, compared with the
//! noise functions of `camsim_render::noise` evaluated at the point each pixel's centre sees (the
//! functions themselves are tested against Perlin's construction in the crate's unit tests).

use camsim_core::WavelengthGrid;
use camsim_pbrt::parse_str;
use camsim_render::noise;
use camsim_render::*;

const N: usize = 40;
/// tan(20 deg): half the field at z = 1 of the 40-degree camera.
const HALF: f64 = 0.363_970_234_266_202_4;

fn render_band_sums(world: &str, grid: WavelengthGrid) -> Vec<Vec<f64>> {
    let text = format!(
        "LookAt 0 0 0  0 0 1  0 1 0\nCamera \"perspective\" \"float fov\" 40\n\
         Film \"spectral\" \"integer xresolution\" {N} \"integer yresolution\" {N}\nPixelFilter \"box\"\nWorldBegin\n\
         LightSource \"infinite\" \"rgb L\" [1 1 1]\n{world}\n\
         Shape \"bilinearmesh\" \"point3 P\" [-1 -1 1  1 -1 1  -1 1 1  1 1 1]\n"
    );
    let mut s = parse_str(&text, "/tmp/procedural.pbrt").unwrap();
    s.settings.grid = grid;
    s.settings.samples_per_pixel = 64;
    s.settings.max_depth = 1;
    s.settings.seed = 3;
    let out = render(&s, &|_, _| {}).unwrap();
    (0..out.radiance.bands())
        .map(|b| out.radiance.band(b).iter().map(|v| *v as f64).collect())
        .collect()
}

/// Per pixel albedo: the textured square's band-summed radiance over the white square's.
fn albedo(world: &str) -> Vec<f64> {
    let grid = WavelengthGrid::new(400.0, 700.0, 50.0).unwrap();
    let t = render_band_sums(world, grid);
    let w = render_band_sums("Material \"diffuse\" \"rgb reflectance\" [1 1 1]", grid);
    (0..N * N)
        .map(|i| t.iter().map(|b| b[i]).sum::<f64>() / w.iter().map(|b| b[i]).sum::<f64>())
        .collect()
}

/// The world point (on z = 1) that pixel (column c, row r)'s centre sees.
fn pixel_point(c: usize, r: usize) -> [f64; 3] {
    let x = (2.0 * (c as f64 + 0.5) / N as f64 - 1.0) * HALF;
    let y = (1.0 - 2.0 * (r as f64 + 0.5) / N as f64) * HALF;
    [x, y, 1.0]
}

/// The mean of `f` over pixel (column c, row r) of the square at z = 1, on 8 x 8 points (the
/// film's pixel filter is a box): the reference where a texture changes within a pixel.
fn pixel_mean(c: usize, r: usize, f: impl Fn([f64; 3]) -> f64) -> f64 {
    let k = 8;
    let mut sum = 0.0;
    for a in 0..k {
        for b in 0..k {
            let x = (2.0 * (c as f64 + (a as f64 + 0.5) / k as f64) / N as f64 - 1.0) * HALF;
            let y = (1.0 - 2.0 * (r as f64 + (b as f64 + 0.5) / k as f64) / N as f64) * HALF;
            sum += f([x, y, 1.0]);
        }
    }
    sum / (k * k) as f64
}

/// Mean and largest |rendered - expected| over the pixels.
fn compare(got: &[f64], want: impl Fn([f64; 3]) -> f64) -> (f64, f64) {
    let (mut sum, mut max) = (0.0f64, 0.0f64);
    for r in 0..N {
        for c in 0..N {
            let e = (got[r * N + c] - want(pixel_point(c, r))).abs();
            sum += e;
            max = max.max(e);
        }
    }
    (sum / (N * N) as f64, max)
}

/// Solid noises under a texture transform: `Scale 0.25` before `Texture` makes texture space
/// 4 x world space (pbrt-v4's `TransformMapping3D` is the inverse of the texture's CTM). A mix
/// of two constant albedos with the noise as its amount shows the noise as albedo.
#[test]
fn solid_noises_render_as_their_functions() {
    let scaled = |p: [f64; 3]| p.map(|v| 4.0 * v);
    type Albedo = Box<dyn Fn([f64; 3]) -> f64>;
    let cases: [(&str, &str, Albedo); 3] = [
        (
            "wrinkled",
            "\"integer octaves\" 2",
            Box::new(move |p| noise::turbulence(scaled(p), 0.5, 2)),
        ),
        (
            "fbm",
            "\"integer octaves\" 3 \"float roughness\" 0.4",
            Box::new(move |p| 0.5 + 0.5 * noise::fbm(scaled(p), 0.4, 3)),
        ),
        (
            "windy",
            "",
            Box::new(move |p| 0.5 + 0.5 * noise::windy(scaled(p))),
        ),
    ];
    for (class, params, want) in cases {
        // wrinkled is >= 0: albedo = amount; fbm and windy lie in [-1, 1]: albedo 0.5 + amount / 2.
        let lo = if class == "wrinkled" { 0.0 } else { 0.5 };
        let world = format!(
            "AttributeBegin\nScale 0.25 0.25 0.25\nTexture \"n\" \"float\" \"{class}\" {params}\nAttributeEnd\n\
             Texture \"m\" \"spectrum\" \"mix\" \"rgb tex1\" [{lo} {lo} {lo}] \"rgb tex2\" [1 1 1] \"texture amount\" \"n\"\n\
             Material \"diffuse\" \"texture reflectance\" \"m\""
        );
        let got = albedo(&world);
        let (mean, max) = compare(&got, &want);
        let spread = {
            let m = got.iter().sum::<f64>() / got.len() as f64;
            (got.iter().map(|v| (v - m).powi(2)).sum::<f64>() / got.len() as f64).sqrt()
        };
        eprintln!("{class}: |rendered - function| mean {mean:.4}, max {max:.4}; albedo std over the image {spread:.3}");
        assert!(
            spread > 0.05,
            "{class}: the pattern must vary across the image ({spread})"
        );
        assert!(mean < 0.01 && max < 0.06, "{class}: mean {mean}, max {max}");
    }
    // Without the transform the pattern is 4 x coarser in texture space: it no longer matches.
    let world = "Texture \"n\" \"float\" \"wrinkled\" \"integer octaves\" 2\n\
                 Texture \"m\" \"spectrum\" \"mix\" \"rgb tex1\" [0 0 0] \"rgb tex2\" [1 1 1] \"texture amount\" \"n\"\n\
                 Material \"diffuse\" \"texture reflectance\" \"m\"";
    let (mean, _) = compare(&albedo(world), move |p| {
        noise::turbulence(scaled(p), 0.5, 2)
    });
    assert!(
        mean > 0.05,
        "a texture without its transform matched the transformed one ({mean})"
    );
}

/// `marble`: the albedo at 550 nm is the Jakob-Hanika uplift of pbrt-v4's marble colour at the
/// point (texture scale 4, variation 0.5).
#[test]
fn marble_renders_its_palette() {
    let world = "Texture \"m\" \"spectrum\" \"marble\" \"float scale\" 4 \"float variation\" 0.5 \"integer octaves\" 4\n\
                 Material \"diffuse\" \"texture reflectance\" \"m\"";
    let grid = WavelengthGrid::new(545.0, 555.0, 10.0).unwrap();
    let t = render_band_sums(world, grid);
    let w = render_band_sums("Material \"diffuse\" \"rgb reflectance\" [1 1 1]", grid);
    let got: Vec<f64> = (0..N * N).map(|i| t[0][i] / w[0][i]).collect();
    let want = |p: [f64; 3]| {
        let rgb =
            noise::marble_rgb(p.map(|v| 4.0 * v), 0.5, 0.5, 4).map(|v| v.clamp(0.0, 1.0) as f32);
        camsim_scene3d::uplift::rgb_to_coefficients(rgb).eval(550.0)
    };
    // pbrt's palette spline jumps where t crosses from one four-colour window to the next (the
    // windows overlap, the curve is not continuous): pixels straddling a jump average two colours,
    // so the reference is the palette averaged over each pixel (8 x 8 points; camsim's pixel
    // filter is a box).
    let avg: Vec<f64> = (0..N * N).map(|i| pixel_mean(i % N, i / N, want)).collect();
    let errs: Vec<f64> = (0..N * N).map(|i| (got[i] - avg[i]).abs()).collect();
    let mean = errs.iter().sum::<f64>() / errs.len() as f64;
    let max = errs.iter().cloned().fold(0.0, f64::max);
    let (_, centre_max) = compare(&got, want);
    let (lo, hi) = got
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), v| (a.min(*v), b.max(*v)));
    eprintln!(
        "marble at 550 nm: |rendered - pixel-averaged palette| mean {mean:.4}, max {max:.4} (against the centre value: max {centre_max:.3}); albedo {lo:.3} to {hi:.3}"
    );
    assert!(hi - lo > 0.2, "the stripes must show ({lo} to {hi})");
    assert!(mean < 0.01 && max < 0.06, "mean {mean}, max {max}");
}

/// `dots`: inside albedo 0.8, outside 0.1, on the square's uv scaled 8 x: the pixels whose centre
/// lies in a dot by `noise::inside_polka_dot` are the bright ones (edge pixels aside).
#[test]
fn dots_render_where_the_polka_dots_are() {
    let world = "Texture \"d\" \"spectrum\" \"dots\" \"float uscale\" 8 \"float vscale\" 8 \"rgb inside\" [0.8 0.8 0.8] \"rgb outside\" [0.1 0.1 0.1]\n\
                 Material \"diffuse\" \"texture reflectance\" \"d\"";
    let got = albedo(world);
    let (mut agree, mut inside) = (0usize, 0usize);
    for r in 0..N {
        for c in 0..N {
            let p = pixel_point(c, r);
            // The square spans [-1, 1]^2 with uv (0, 0) at (-1, -1).
            let (u, v) = ((p[0] + 1.0) / 2.0, (p[1] + 1.0) / 2.0);
            let want = noise::inside_polka_dot(8.0 * u, 8.0 * v);
            inside += want as usize;
            agree += ((got[r * N + c] > 0.45) == want) as usize;
        }
    }
    let frac = agree as f64 / (N * N) as f64;
    eprintln!(
        "dots: {inside} of {} pixel centres inside a dot; rendered agrees at {:.1} %",
        N * N,
        100.0 * frac
    );
    assert!(inside > 50 && inside < N * N - 50, "{inside}");
    assert!(frac > 0.93, "{frac}");
}

/// Bad parameters name the directive.
#[test]
fn bad_procedural_texture_parameters_are_refused() {
    for (tex, want) in [
        (
            "Texture \"n\" \"float\" \"fbm\" \"integer octaves\" 0",
            "octaves",
        ),
        (
            "Texture \"n\" \"float\" \"wrinkled\" \"float roughnes\" 0.3",
            "roughnes",
        ),
        ("Texture \"n\" \"spectrum\" \"wrinkled\"", "not supported"),
    ] {
        let text =
            format!("LookAt 0 0 0  0 0 1  0 1 0\nCamera \"perspective\"\nWorldBegin\n{tex}\n");
        let e = parse_str(&text, "/tmp/bad-tex.pbrt")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("bad-tex.pbrt:4:") && e.contains(want),
            "{tex}: {e}"
        );
    }
}

/// 3D `checkerboard` (`dimension 3`): in texture space (10 x world here) the cell parity of
/// floor(x) + floor(y) + floor(z) picks `tex2`; on the square at z = 1 the texture z is 10 (even),
/// and translating the texture by 0.05 along z makes it 9.5 (odd), which inverts the pattern. The
/// reference is the albedo averaged over each pixel (8 x 8 points; the pixel filter is a box).
#[test]
fn checkerboard_in_3d_follows_the_cell_parity() {
    for (shift, flip) in [("", 0), ("Translate 0 0 0.05\n", 1)] {
        let world = format!(
            "AttributeBegin\n{shift}Scale 0.1 0.1 0.1\nTexture \"c\" \"spectrum\" \"checkerboard\" \"integer dimension\" 3 \
             \"rgb tex1\" [0.1 0.1 0.1] \"rgb tex2\" [0.8 0.8 0.8]\nAttributeEnd\nMaterial \"diffuse\" \"texture reflectance\" \"c\""
        );
        let got = albedo(&world);
        let mut err = 0.0;
        for r in 0..N {
            for c in 0..N {
                let odd = pixel_mean(c, r, |p| {
                    (((10.0 * p[0]).floor() + (10.0 * p[1]).floor()) as i64 & 1 ^ flip) as f64
                });
                err += (got[r * N + c] - (0.1 + 0.7 * odd)).abs();
            }
        }
        let mean = err / (N * N) as f64;
        eprintln!(
            "3D checkerboard{}: |rendered - pixel-averaged cells| mean {mean:.4}",
            if flip == 1 { " (shifted)" } else { "" }
        );
        assert!(mean < 0.01, "{mean}");
    }
}

/// pbrt-v4's 2D mappings other than uv, on the hit point in texture space: a float `bilerp` with
/// v00 = v01 = 0 and v10 = v11 = 1 returns s, shown as albedo. The texture is moved 1 m left
/// (`Translate -1 0 0` before `Texture`: texture space is world + (1, 0, 0), so no seam is in
/// view). Planar (v1 = (1, 0, 0), udelta -0.5): s = -0.5 + (x + 1); spherical: s = theta / pi of
/// the direction from the texture origin; cylindrical: s = (pi + atan2(y, x + 1)) / (2 pi).
#[test]
fn planar_spherical_and_cylindrical_mappings_give_their_coordinates() {
    type Case = (&'static str, &'static str, fn([f64; 3]) -> f64);
    let cases: [Case; 3] = [
        (
            "planar",
            "\"float udelta\" -0.5 \"vector3 v1\" [1 0 0]",
            |p| 0.5 + p[0],
        ),
        ("spherical", "", |p| {
            let q = [p[0] + 1.0, p[1], p[2]];
            (q[2] / (q[0] * q[0] + q[1] * q[1] + q[2] * q[2]).sqrt()).acos() / std::f64::consts::PI
        }),
        ("cylindrical", "", |p| {
            (std::f64::consts::PI + p[1].atan2(p[0] + 1.0)) / std::f64::consts::TAU
        }),
    ];
    for (mapping, params, want) in cases {
        let world = format!(
            "AttributeBegin\nTranslate -1 0 0\nTexture \"b\" \"float\" \"bilerp\" \"string mapping\" \"{mapping}\" {params} \
             \"float v00\" 0 \"float v01\" 0 \"float v10\" 1 \"float v11\" 1\nAttributeEnd\n\
             Texture \"m\" \"spectrum\" \"mix\" \"rgb tex1\" [0 0 0] \"rgb tex2\" [1 1 1] \"texture amount\" \"b\"\n\
             Material \"diffuse\" \"texture reflectance\" \"m\""
        );
        let got = albedo(&world);
        let (mean, max) = compare(&got, want);
        let (lo, hi) = got
            .iter()
            .fold((f64::MAX, f64::MIN), |(a, b), v| (a.min(*v), b.max(*v)));
        eprintln!("{mapping} mapping: |rendered - s| mean {mean:.4}, max {max:.4}; s from {lo:.3} to {hi:.3}");
        assert!(hi - lo > 0.05, "{mapping}: s must vary over the image");
        assert!(
            mean < 0.003 && max < 0.02,
            "{mapping}: mean {mean}, max {max}"
        );
    }
    // An unknown mapping names the directive.
    let text = "LookAt 0 0 0  0 0 1  0 1 0\nCamera \"perspective\"\nWorldBegin\nTexture \"b\" \"float\" \"bilerp\" \"string mapping\" \"conical\"\n";
    let e = parse_str(text, "/tmp/bad-map.pbrt")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("bad-map.pbrt:4:") && e.contains("conical"),
        "{e}"
    );
}
