//! pbrt-v4's pixel filters through the whole chain (pbrt file -> `PixelFilter` -> filter
//! importance sampling in the film): a straight emitting edge, rendered through each filter at
//! pbrt-v4's default radius, gives the analytic filtered edge, `1 - F(d)` with `F` the filter's
//! normalised cumulative profile and `d` the edge's offset from the pixel centre (pbrt-v4 4th ed.
//! sec. 8.8; the profiles are written out here from the book's definitions and integrated by
//! Simpson's rule, independently of the renderer's tables).

use camsim_pbrt as pbrt;
use camsim_render::render;

/// Image width in pixels (8 rows); the edge crosses row after row at raster x = `EDGE_PX`.
const W: usize = 32;
const EDGE_PX: f64 = 16.4;

fn normal(x: f64, s: f64) -> f64 {
    (-(x * x) / (2.0 * s * s)).exp() / ((2.0 * std::f64::consts::PI).sqrt() * s)
}

fn sinc(x: f64) -> f64 {
    if x.abs() < 1e-9 {
        1.0
    } else {
        (std::f64::consts::PI * x).sin() / (std::f64::consts::PI * x)
    }
}

/// Mitchell and Netravali (1988) cubic, B = C = 1/3, of |x| in [0, 2].
fn mitchell(x: f64) -> f64 {
    let (b, c) = (1.0 / 3.0, 1.0 / 3.0);
    let x = x.abs();
    if x < 1.0 {
        ((12.0 - 9.0 * b - 6.0 * c) * x.powi(3) + (-18.0 + 12.0 * b + 6.0 * c) * x * x + 6.0
            - 2.0 * b)
            / 6.0
    } else if x < 2.0 {
        ((-b - 6.0 * c) * x.powi(3)
            + (6.0 * b + 30.0 * c) * x * x
            + (-12.0 * b - 48.0 * c) * x
            + 8.0 * b
            + 24.0 * c)
            / 6.0
    } else {
        0.0
    }
}

/// (pbrt `PixelFilter` line, radius, 1D profile) at pbrt-v4's default parameters.
type Profile = (&'static str, f64, fn(f64) -> f64);

fn profiles() -> Vec<Profile> {
    vec![
        ("PixelFilter \"box\"", 0.5, |_| 1.0),
        ("PixelFilter \"triangle\"", 2.0, |x| 2.0 - x.abs()),
        ("PixelFilter \"gaussian\"", 1.5, |x| {
            (normal(x, 0.5) - normal(1.5, 0.5)).max(0.0)
        }),
        ("PixelFilter \"mitchell\"", 2.0, |x| mitchell(2.0 * x / 2.0)),
        ("PixelFilter \"sinc\"", 4.0, |x| sinc(x) * sinc(x / 3.0)),
        ("", 1.5, |x| (normal(x, 0.5) - normal(1.5, 0.5)).max(0.0)),
    ]
}

/// `int_a^b f` by Simpson's rule (4000 intervals).
fn integrate(f: fn(f64) -> f64, a: f64, b: f64) -> f64 {
    if b <= a {
        return 0.0;
    }
    let n = 4000;
    let h = (b - a) / n as f64;
    (0..=n)
        .map(|i| {
            let w = match i {
                0 => 1.0,
                i if i == n => 1.0,
                i if i % 2 == 1 => 4.0,
                _ => 2.0,
            };
            w * f(a + i as f64 * h)
        })
        .sum::<f64>()
        * h
        / 3.0
}

/// A W x 8 film looking down +z at an emitting plane at z = 1 that covers camera-space
/// x > x_e: fov 90 across the 8 rows, so 1/4 unit of x per pixel at z = 1 and the edge at raster
/// x = 16 + 4 x_e.
fn scene(filter_line: &str) -> String {
    let x_e = (EDGE_PX - 16.0) / 4.0;
    format!(
        "Camera \"perspective\" \"float fov\" 90\n\
         Film \"rgb\" \"integer xresolution\" {W} \"integer yresolution\" 8\n\
         Sampler \"sobol\" \"integer pixelsamples\" 1024\nIntegrator \"path\" \"integer maxdepth\" 0\n\
         {filter_line}\nWorldBegin\n\
         AreaLightSource \"diffuse\" \"rgb L\" [1 1 1] \"bool twosided\" true\n\
         Shape \"trianglemesh\" \"point3 P\" [{x_e} -50 1  50 -50 1  50 50 1  {x_e} 50 1] \"integer indices\" [0 1 2 0 2 3]\n"
    )
}

#[test]
fn an_edge_through_each_filter_matches_the_analytic_filtered_edge() {
    for (line, r, f) in profiles() {
        let mut s = pbrt::parse_str(&scene(line), "edge.pbrt").unwrap();
        s.settings.grid = camsim_core::WavelengthGrid::new(500.0, 600.0, 50.0).unwrap();
        let out = render(&s, &|_, _| {}).unwrap();
        let img = &out.radiance;
        // Column means over the rows and bands.
        let col = |c: usize| -> f64 {
            let mut sum = 0.0;
            for b in 0..img.bands() {
                for y in 0..8 {
                    sum += img.band(b)[y * W + c] as f64;
                }
            }
            sum / (8 * img.bands()) as f64
        };
        // The far right is fully lit for every filter (radius <= 4).
        let lit = (26..W).map(col).sum::<f64>() / (W - 26) as f64;
        let total = integrate(f, -r, r);
        let mut worst = 0f64;
        for c in 8..24 {
            // Pixel centre c + 0.5; lit where the sample's raster x exceeds the edge, i.e. at
            // filter offsets t > EDGE_PX - (c + 0.5).
            let d = EDGE_PX - (c as f64 + 0.5);
            let want = integrate(f, d.clamp(-r, r), r) / total;
            let got = col(c) / lit;
            worst = worst.max((got - want).abs());
            assert!(
                (got - want).abs() < 0.01,
                "{line:?}: column {c}: {got:.4} vs analytic {want:.4}"
            );
        }
        eprintln!("{line:?}: largest |rendered - analytic| over the edge {worst:.2e}");
    }
}
