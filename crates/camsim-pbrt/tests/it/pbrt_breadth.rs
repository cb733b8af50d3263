//! pbrt-v4 breadth, issue 12: shape `alpha` cut-outs (pbrt-v4 4th ed. §7.1.1) and partial
//! spheres (`zmin`, `zmax`, `phimax`; §6.2), read from `.pbrt` text and rendered. Every render
//! is checked against a closed form (areas, solid angles, irradiance of a disk opening) or
//! against the same scene without the feature, never against a stored image.

use camsim_core::units::LUMINOUS_EFFICACY_LM_PER_W;
use camsim_core::WavelengthGrid;
use camsim_render::*;
use camsim_scene3d::*;
use std::f64::consts::PI;

fn parse(text: &str) -> Result<SceneDescription, camsim_pbrt::PbrtError> {
    camsim_pbrt::parse_str(text, "/tmp/virtual/breadth.pbrt")
}

/// Parse, coarsen the wavelength grid (tests stay fast) and render.
fn render_text(text: &str) -> RenderOutput {
    let mut s = parse(text).unwrap_or_else(|e| panic!("{e}"));
    s.settings.grid = WavelengthGrid::new(400.0, 700.0, 100.0).unwrap();
    render(&s, &|_, _| {}).unwrap_or_else(|e| panic!("{e}"))
}

/// Mean over every pixel and band.
fn mean(out: &RenderOutput) -> f64 {
    let img = &out.radiance;
    let n = (img.bands() * img.pixels()) as f64;
    (0..img.bands())
        .map(|b| img.band(b).iter().map(|v| *v as f64).sum::<f64>())
        .sum::<f64>()
        / n
}

/// Measure of `{x in [0, b] : floor(x) even}`.
fn even_measure(b: f64) -> f64 {
    let q = (b / 2.0).floor();
    q + (b - 2.0 * q).min(1.0)
}

// ---------------------------------------------------------------------------------------------
// Alpha

const ALPHA_HEADER: &str = "LookAt 0 0 0  0 0 1  0 1 0\nCamera \"perspective\" \"float fov\" 30\n\
    Film \"rgb\" \"integer xresolution\" 32 \"integer yresolution\" 32\n\
    Sampler \"sobol\" \"integer pixelsamples\" 16\nIntegrator \"path\" \"integer maxdepth\" 1\n\
    WorldBegin\n\
    Texture \"half\" \"float\" \"constant\" \"float value\" 0.5\n\
    Texture \"zero\" \"float\" \"constant\" \"float value\" 0\n\
    Texture \"ones\" \"float\" \"checkerboard\" \"float tex1\" 1 \"float tex2\" 1\n\
    Texture \"checks\" \"float\" \"checkerboard\" \"float uscale\" 3.3 \"float vscale\" 4.7 \"float tex1\" 1 \"float tex2\" 0\n\
    AttributeBegin\nAreaLightSource \"diffuse\" \"spectrum L\" [300 1 900 1] \"bool twosided\" true\n\
    Material \"diffuse\" \"rgb reflectance\" [0 0 0]\n\
    Shape \"trianglemesh\" \"point3 P\" [-5 -5 3  5 -5 3  5 5 3  -5 5 3] \"integer indices\" [0 1 2 0 2 3]\n\
    AttributeEnd\n\
    Material \"diffuse\" \"rgb reflectance\" [0 0 0]\n";

/// A black plane at z = 1 between the camera and a flat emitter, with `alpha` given by `param`.
fn blocker(param: &str) -> String {
    format!(
        "{ALPHA_HEADER}Shape \"trianglemesh\" \"point3 P\" [-1 -1 1  1 -1 1  1 1 1  -1 1 1] \
         \"integer indices\" [0 1 2 0 2 3] \"point2 uv\" [0 0 1 0 1 1 0 1] {param}\n"
    )
}

#[test]
fn alpha_parameters_become_masked_materials() {
    let s = parse(&blocker("\"texture alpha\" \"checks\"")).unwrap();
    let m = s.shapes[1].material;
    let Material::AlphaMasked { material, alpha } = &s.materials[m] else {
        panic!("{:?}", s.materials[m])
    };
    assert!(matches!(s.materials[*material], Material::Diffuse { .. }));
    let FloatTexture::Checkerboard { mapping, .. } = alpha else {
        panic!("{alpha:?}")
    };
    assert_eq!((mapping.uscale, mapping.vscale), (3.3, 4.7));
    // A fraction is a constant mask; 1 is opaque (no mask); 0 drops the shape (noted).
    let s = parse(&blocker("\"float alpha\" 0.25")).unwrap();
    assert!(matches!(&s.materials[s.shapes[1].material],
        Material::AlphaMasked { alpha: FloatTexture::Constant(a), .. } if *a == 0.25));
    let s = parse(&blocker("\"float alpha\" 1")).unwrap();
    assert!(matches!(
        s.materials[s.shapes[1].material],
        Material::Diffuse { .. }
    ));
    let s = parse(&blocker("\"float alpha\" 0")).unwrap();
    assert_eq!(s.shapes.len(), 1);
    assert!(
        s.notes.iter().any(|n| n.contains("alpha 0")),
        "{:?}",
        s.notes
    );
    // Shapes sharing material and alpha share one mask.
    let two = format!(
        "{}Shape \"sphere\" \"texture alpha\" \"checks\"\n",
        blocker("\"texture alpha\" \"checks\"")
    );
    let s = parse(&two).unwrap();
    assert_eq!(s.shapes[1].material, s.shapes[2].material);
    // Errors name the place: a spectrum texture, an unknown name.
    let e = parse(&format!("{ALPHA_HEADER}Texture \"sp\" \"spectrum\" \"constant\" \"rgb value\" [1 1 1]\nShape \"sphere\" \"texture alpha\" \"sp\"\n")).unwrap_err();
    assert!(
        e.to_string().contains("breadth.pbrt:") && e.to_string().contains("spectrum texture"),
        "{e}"
    );
    let e = parse(&format!(
        "{ALPHA_HEADER}Shape \"sphere\" \"texture alpha\" \"nope\"\n"
    ))
    .unwrap_err();
    assert!(
        e.to_string().contains("no float texture named \"nope\""),
        "{e}"
    );
    // Alpha on an area light (pbrt-v4 `DiffuseAreaLight::AlphaMasked`): the emitter's material
    // is masked like any other shape's; the renderer gates its emission with the same test.
    let s = parse(&format!(
        "{ALPHA_HEADER}AreaLightSource \"diffuse\"\nShape \"sphere\" \"float alpha\" 0.5\n"
    ))
    .unwrap();
    let lit = s
        .shapes
        .last()
        .filter(|sh| sh.area_light.is_some())
        .expect("the emitter is kept");
    assert!(
        matches!(s.materials[lit.material], Material::AlphaMasked { alpha: FloatTexture::Constant(a), .. } if a == 0.5),
        "{:?}",
        s.materials[lit.material]
    );
}

#[test]
fn alpha_zero_is_invisible_one_opaque_and_checks_pass_their_area() {
    let open = render_text(ALPHA_HEADER);
    let l_flat = mean(&open);
    assert!(l_flat > 0.0);
    // Alpha 0 (a texture, so the per-hit test runs): the same image, bit for bit.
    let zero = render_text(&blocker("\"texture alpha\" \"zero\""));
    assert_eq!(zero.radiance.band(0), open.radiance.band(0));
    assert_eq!(zero.radiance.band(2), open.radiance.band(2));
    // The depth map looks through the cut-out too (to the emitter 3 m away).
    let c = 16 * 32 + 16;
    assert!((zero.depth_m[c] - 3.0).abs() < 1e-3, "{}", zero.depth_m[c]);
    // Alpha 1 (a texture that is 1 everywhere): opaque, and the black plane sends nothing.
    let one = render_text(&blocker("\"texture alpha\" \"ones\""));
    assert_eq!(mean(&one), 0.0);
    assert!((one.depth_m[c] - 1.0).abs() < 1e-4, "{}", one.depth_m[c]);
    // Checkerboard 1/0 (uscale 3.3, vscale 4.7) over the plane's uv: the transmitted fraction
    // is the area of the cut (odd) checks inside the visible (s, t) window, in closed form.
    let checks = render_text(&blocker("\"texture alpha\" \"checks\""));
    let w = (15f64).to_radians().tan(); // half-width of the view at z = 1
    let window = |scale: f64| (scale * (1.0 - w) / 2.0, scale * (1.0 + w) / 2.0);
    let ((sa, sb), (ta, tb)) = (window(3.3), window(4.7));
    let (es, et) = (
        even_measure(sb) - even_measure(sa),
        even_measure(tb) - even_measure(ta),
    );
    let (os, ot) = ((sb - sa) - es, (tb - ta) - et);
    let opaque = (es * et + os * ot) / ((sb - sa) * (tb - ta));
    let want = 1.0 - opaque;
    let got = mean(&checks) / l_flat;
    eprintln!("alpha checkerboard: transmitted {got:.4}, analytic {want:.4}");
    assert!((got - want).abs() < 0.01, "{got} vs {want}");
    assert!(
        (want - 0.5).abs() > 0.03,
        "the window must not give one half by symmetry"
    );
}

#[test]
fn fractional_alpha_is_a_stochastic_test_on_camera_and_shadow_rays() {
    // Camera rays: a constant alpha 0.3 passes 70 % of the rays (hash of the ray, pbrt-v4).
    let open = mean(&render_text(ALPHA_HEADER));
    let frac = mean(&render_text(&blocker("\"float alpha\" 0.3"))) / open;
    eprintln!("alpha 0.3: transmitted {frac:.4} (want 0.7)");
    // 16384 Bernoulli samples: sigma 0.0036.
    assert!((frac - 0.7).abs() < 0.02, "{frac}");
    // Shadow and bounce rays: a white floor lit through a plane of alpha 0.5 between it and a
    // one-sided emitter; the camera sits below the plane, so only light paths cross it.
    let scene = |alpha: &str| {
        format!(
            "LookAt 0 0 1  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" 30\n\
             Film \"rgb\" \"integer xresolution\" 24 \"integer yresolution\" 24\n\
             Sampler \"sobol\" \"integer pixelsamples\" 32\nIntegrator \"path\" \"integer maxdepth\" 1\n\
             WorldBegin\n\
             AttributeBegin\nAreaLightSource \"diffuse\" \"spectrum L\" [300 1 900 1]\n\
             Material \"diffuse\" \"rgb reflectance\" [0 0 0]\n\
             Shape \"trianglemesh\" \"point3 P\" [-2 -2 3  -2 2 3  2 2 3  2 -2 3] \"integer indices\" [0 1 2 0 2 3]\n\
             AttributeEnd\n\
             Material \"diffuse\" \"rgb reflectance\" [0 0 0]\n\
             Shape \"trianglemesh\" \"point3 P\" [-9 -9 2  9 -9 2  9 9 2  -9 9 2] \"integer indices\" [0 1 2 0 2 3] {alpha}\n\
             Material \"diffuse\" \"spectrum reflectance\" [300 0.5 900 0.5]\n\
             Shape \"trianglemesh\" \"point3 P\" [-9 -9 0  9 -9 0  9 9 0  -9 9 0] \"integer indices\" [0 1 2 0 2 3]\n"
        )
    };
    let clear = mean(&render_text(&scene("\"float alpha\" 0")));
    let opaque = mean(&render_text(&scene("")));
    let half = mean(&render_text(&scene("\"float alpha\" 0.5")));
    eprintln!(
        "floor through alpha 0.5: {:.4} of the unblocked light",
        half / clear
    );
    assert!(clear > 0.0 && opaque == 0.0, "{clear} {opaque}");
    assert!((half / clear - 0.5).abs() < 0.03, "{}", half / clear);
}

// ---------------------------------------------------------------------------------------------
// Partial spheres

#[test]
fn partial_sphere_parameters_frame_and_area() {
    let s = parse(
        "WorldBegin\nAttributeBegin\nTranslate 1 2 3\nRotate 90 1 0 0\nScale 2 2 2\n\
         AreaLightSource \"diffuse\" \"spectrum L\" [300 1 900 1] \"float power\" 100\n\
         Shape \"sphere\" \"float radius\" 0.5 \"float zmin\" 0 \"float phimax\" 90\nAttributeEnd\n\
         Shape \"sphere\" \"float radius\" 2 \"float zmin\" -3 \"float zmax\" 5\n",
    )
    .unwrap();
    let Geometry::PartialSphere {
        center,
        radius,
        axes,
        z_min,
        z_max,
        phi_max_deg,
    } = s.shapes[0].geometry
    else {
        panic!("{:?}", s.shapes[0].geometry)
    };
    assert_eq!(
        (center, radius, z_min, z_max, phi_max_deg),
        ([1.0, 2.0, 3.0], 1.0, 0.0, 1.0, 90.0)
    );
    // Rotate 90 about x: object x stays, y goes to +z, z to -y.
    let want = [[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]];
    for k in 0..3 {
        for j in 0..3 {
            assert!((axes[k][j] - want[k][j]).abs() < 1e-12, "{axes:?}");
        }
    }
    // pbrt-v4 Sphere::Area = phi_max r (z_max - z_min) = (pi / 2) 1 1; power P gives
    // L_v = P / (pi A) (one-sided).
    let area = PI / 2.0;
    let l = s.shapes[0].area_light.as_ref().unwrap();
    let lv = LUMINOUS_EFFICACY_LM_PER_W * camsim_pbrt::spectra::photometric(&l.radiance);
    assert!((lv - 100.0 / (PI * area)).abs() < 1e-6 * lv, "{lv}");
    // A z range beyond the radius is clamped: the whole sphere.
    assert!(matches!(s.shapes[1].geometry, Geometry::Sphere { radius, .. } if radius == 2.0));
    let e = parse("WorldBegin\nShape \"sphere\" \"float zmin\" 2\n").unwrap_err();
    assert!(e.to_string().contains("leave no surface"), "{e}");
}

/// A dome (`zmin` 0, radius 1) seen from below through its open cut, from `h` below the cut.
fn dome(two_sided: bool, shape: &str, camera: &str) -> String {
    format!(
        "{camera}WorldBegin\nAttributeBegin\n\
         AreaLightSource \"diffuse\" \"spectrum L\" [300 1 900 1] \"bool twosided\" {two_sided}\n\
         Material \"diffuse\" \"rgb reflectance\" [0 0 0]\n{shape}\nAttributeEnd\n"
    )
}

#[test]
fn hemisphere_is_open_below_and_its_inside_shows_through_the_cut() {
    let (r, h) = (1.0f64, 3.0f64);
    let cam = "LookAt 0 0 -3  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" 60\n\
               Film \"rgb\" \"integer xresolution\" 32 \"integer yresolution\" 32\n\
               Sampler \"sobol\" \"integer pixelsamples\" 16\nIntegrator \"path\" \"integer maxdepth\" 1\n";
    let hemi = "Shape \"sphere\" \"float radius\" 1 \"float zmin\" 0";
    let s = parse(&dome(true, hemi, cam)).unwrap();
    let l = s.shapes[0]
        .area_light
        .as_ref()
        .unwrap()
        .radiance
        .eval(550.0);
    // Two-sided: the inside of the dome fills the opening disk, the outside is never seen.
    let two = render_text(&dome(true, hemi, cam));
    let fraction = mean(&two) / l;
    let half = (30f64).to_radians().tan();
    let want = PI * (r / h).powi(2) / (2.0 * half).powi(2);
    eprintln!("dome opening: image fraction {fraction:.4}, analytic {want:.4}");
    assert!(
        (fraction - want).abs() < 0.01 * want.max(0.1) + 0.004,
        "{fraction} vs {want}"
    );
    let c = two.radiance.band(1)[16 * 32 + 16] as f64;
    assert!((c - l).abs() < 1e-5 * l, "centre pixel {c} vs L {l}");
    let d = two.depth_m[16 * 32 + 16] as f64;
    assert!((d - (h + r)).abs() < 1e-2, "far hit on the dome: depth {d}");
    // One-sided (outward): the inside does not emit and the outside is not visible: black.
    assert_eq!(mean(&render_text(&dome(false, hemi, cam))), 0.0);
    // The whole sphere would show its lower outside: pi (r/h)^2-ish, different from above.
    let full = mean(&render_text(&dome(
        false,
        "Shape \"sphere\" \"float radius\" 1",
        cam,
    ))) / l;
    assert!(full > want * 1.05, "{full} vs {want}");
}

#[test]
fn light_through_the_cut_gives_the_irradiance_of_the_opening() {
    // A small transmitting receiver (r = 0, t = 1) at h below the cut of a two-sided dome:
    // E = pi L sin^2(beta), sin^2(beta) = r^2 / (r^2 + h^2) (the opening disk, filled by the
    // dome's inside). Its radiance seen from below is t E / pi = L r^2 / (r^2 + h^2). Next-event
    // estimation samples the dome by area (only points visible through the cut count) and MIS
    // adds BSDF samples through the opening.
    let (r, h) = (1.0f64, 1.5f64);
    let cam = "LookAt 0 0 -2  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" 2\n\
               Film \"rgb\" \"integer xresolution\" 8 \"integer yresolution\" 8\n\
               Sampler \"sobol\" \"integer pixelsamples\" 256\nIntegrator \"path\" \"integer maxdepth\" 1\n";
    let hemi = "Shape \"sphere\" \"float radius\" 1 \"float zmin\" 0 \"float phimax\" 360";
    let receiver = "Material \"diffusetransmission\" \"spectrum reflectance\" [300 0 900 0] \
                    \"spectrum transmittance\" [300 1 900 1]\n\
                    Shape \"trianglemesh\" \"point3 P\" [-0.05 -0.05 -1.5  0.05 -0.05 -1.5  0.05 0.05 -1.5  -0.05 0.05 -1.5] \
                    \"integer indices\" [0 1 2 0 2 3]\n";
    let text = format!("{}{receiver}", dome(true, hemi, cam));
    let s = parse(&text).unwrap();
    let l = s.shapes[0]
        .area_light
        .as_ref()
        .unwrap()
        .radiance
        .eval(550.0);
    let got = mean(&render_text(&text)) / l;
    let want = r * r / (r * r + h * h);
    eprintln!("receiver under the dome: {got:.4} L, analytic {want:.4} L");
    assert!((got - want).abs() < 0.02 * want, "{got} vs {want}");
    // One-sided outward: nothing reaches the receiver.
    let dark = format!("{}{receiver}", dome(false, hemi, cam));
    assert_eq!(mean(&render_text(&dark)), 0.0);
}

// ---------------------------------------------------------------------------------------------
// Float textures for roughness

#[test]
fn roughness_textures_wrap_the_material() {
    let s = parse(
        "WorldBegin\nTexture \"r\" \"float\" \"checkerboard\" \"float tex1\" 0.1 \"float tex2\" 0.4\n\
         Material \"conductor\" \"texture roughness\" \"r\"\nShape \"sphere\"\n\
         MakeNamedMaterial \"glass\" \"string type\" \"dielectric\" \"texture uroughness\" \"r\" \"float vroughness\" 0.2 \"bool remaproughness\" false\n\
         NamedMaterial \"glass\"\nShape \"sphere\"\n\
         Material \"coateddiffuse\" \"texture roughness\" \"r\"\nShape \"sphere\"\n\
         Material \"conductor\" \"float roughness\" 0.3\nShape \"sphere\"\n",
    )
    .unwrap();
    let base_of = |i: usize| match &s.materials[s.shapes[i].material] {
        Material::VaryingRoughness {
            material,
            u,
            v,
            remap,
        } => (&s.materials[*material], u.clone(), v.clone(), *remap),
        m => panic!("shape {i}: {m:?}"),
    };
    let (m, u, v, remap) = base_of(0);
    assert!(matches!(m, Material::Conductor { .. }) && remap && u == v);
    assert!(matches!(u, FloatTexture::Checkerboard { .. }));
    let (m, u, v, remap) = base_of(1);
    assert!(matches!(m, Material::Dielectric { .. }) && !remap);
    assert!(matches!(u, FloatTexture::Checkerboard { .. }) && v == FloatTexture::Constant(0.2));
    assert!(matches!(base_of(2).0, Material::CoatedDiffuse { .. }));
    // A constant stays a plain roughness.
    assert!(matches!(&s.materials[s.shapes[3].material],
        Material::Conductor { roughness, .. } if roughness.u == 0.3 && roughness.v == 0.3));
    let e = parse("WorldBegin\nMaterial \"conductor\" \"texture roughness\" \"missing\"\n")
        .unwrap_err();
    assert!(
        e.to_string().contains("breadth.pbrt:2:") && e.to_string().contains("missing"),
        "{e}"
    );
}

/// A metal floor (uv halves: u < 1/2 and u >= 1/2, a checkerboard with uscale 2) mirroring a
/// small emitter toward the camera, with roughness `r`.
fn glossy_floor(r: &str) -> String {
    format!(
        "LookAt 0 -2 2  0 0 0  0 0 1\nCamera \"perspective\" \"float fov\" 30\n\
         Film \"rgb\" \"integer xresolution\" 24 \"integer yresolution\" 24\n\
         Sampler \"sobol\" \"integer pixelsamples\" 16\nIntegrator \"path\" \"integer maxdepth\" 1\n\
         WorldBegin\n\
         Texture \"halves\" \"float\" \"checkerboard\" \"float uscale\" 2 \"float vscale\" 1 \"float tex1\" 0.02 \"float tex2\" 0.3\n\
         AttributeBegin\nAreaLightSource \"diffuse\" \"spectrum L\" [300 1 900 1] \"bool twosided\" true\n\
         Translate 0 2 2\nRotate -45 1 0 0\nMaterial \"diffuse\" \"rgb reflectance\" [0 0 0]\n\
         Shape \"trianglemesh\" \"point3 P\" [-0.4 -0.4 0  0.4 -0.4 0  0.4 0.4 0  -0.4 0.4 0] \"integer indices\" [0 1 2 0 2 3]\n\
         AttributeEnd\n\
         Material \"conductor\" \"spectrum eta\" [300 0.2 900 0.2] \"spectrum k\" [300 3 900 3] {r}\n\
         Shape \"trianglemesh\" \"point3 P\" [-3 -3 0  3 -3 0  3 3 0  -3 3 0] \"integer indices\" [0 1 2 0 2 3] \
         \"point2 uv\" [0 0 1 0 1 1 0 1]\n"
    )
}

#[test]
fn checkerboard_roughness_renders_each_half_like_its_constant() {
    let a = render_text(&glossy_floor("\"float roughness\" 0.02"));
    let b = render_text(&glossy_floor("\"float roughness\" 0.3"));
    let c = render_text(&glossy_floor("\"texture roughness\" \"halves\""));
    let (w, h) = (24usize, 24usize);
    let col = |o: &RenderOutput, x: usize| -> f64 {
        (0..o.radiance.bands())
            .map(|k| {
                (0..h)
                    .map(|y| o.radiance.band(k)[y * w + x] as f64)
                    .sum::<f64>()
            })
            .sum()
    };
    // The seam (u = 1/2, world x = 0) runs down the middle columns; which half is on the left
    // depends on the camera's handedness, so both assignments are tried.
    let cols: Vec<usize> = (0..w)
        .filter(|x| !(w / 2 - 1..=w / 2).contains(x))
        .collect();
    let err = |left: &RenderOutput, right: &RenderOutput| -> f64 {
        cols.iter()
            .map(|&x| (col(&c, x) - col(if x < w / 2 { left } else { right }, x)).abs())
            .sum::<f64>()
    };
    let total: f64 = cols.iter().map(|&x| col(&c, x)).sum();
    let (e1, e2) = (err(&a, &b), err(&b, &a));
    let ab: f64 = cols.iter().map(|&x| (col(&a, x) - col(&b, x)).abs()).sum();
    eprintln!("roughness halves: |C - halves| / C = {:.2e} (other assignment {:.2e}); |A - B| / C = {:.3}", e1.min(e2) / total, e1.max(e2) / total, ab / total);
    assert!(
        ab / total > 0.2,
        "the two roughnesses must look different: {}",
        ab / total
    );
    assert!(e1.min(e2) / total < 1e-3, "{} {}", e1 / total, e2 / total);
}

// ---------------------------------------------------------------------------------------------
// Textured area lights

/// A 2 x 2 grey PFM (linear): top row `top`, bottom row `bottom`; returns its path.
fn grey_pfm(dir: &std::path::Path, top: [f32; 2], bottom: [f32; 2]) -> String {
    // PFM: "PF", size, negative scale = little endian, rows stored bottom to top.
    let mut bytes = b"PF\n2 2\n-1.0\n".to_vec();
    for row in [bottom, top] {
        for v in row {
            for _ in 0..3 {
                bytes.extend_from_slice(&v.to_le_bytes());
            }
        }
    }
    let path = dir.join("emit.pfm");
    std::fs::write(&path, bytes).unwrap();
    path.to_string_lossy().into_owned()
}

fn emitter_quad(file: &str, extra: &str) -> String {
    format!(
        "LookAt 0 0 1  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" 90\n\
         Film \"rgb\" \"integer xresolution\" 2 \"integer yresolution\" 2\n\
         Sampler \"sobol\" \"integer pixelsamples\" 256\nIntegrator \"path\" \"integer maxdepth\" 1\n\
         PixelFilter \"box\"\n\
         WorldBegin\nAreaLightSource \"diffuse\" \"string filename\" \"{file}\" {extra}\n\
         Material \"diffuse\" \"rgb reflectance\" [0 0 0]\n\
         Shape \"trianglemesh\" \"point3 P\" [-1 -1 0  1 -1 0  1 1 0  -1 1 0] \"integer indices\" [0 1 2 0 2 3] \
         \"point2 uv\" [0 0 1 0 1 1 0 1]\n"
    )
}

#[test]
fn image_area_light_power_and_radiance_follow_the_texels() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b, c, d) = (0.2f64, 0.4, 0.6, 0.8);
    let file = grey_pfm(dir.path(), [a as f32, b as f32], [c as f32, d as f32]);
    // power: pbrt-v4 k_e = mean Y(rgb) * sides * area * pi, per pbrt shape (each triangle of a
    // mesh, 2 m^2 here): L_v per unit RGB = P / (pi A mean_Y).
    let s = parse(&emitter_quad(&file, "\"float power\" 50")).unwrap();
    assert_eq!(s.shapes.len(), 2, "power on a mesh: one light per triangle");
    let mean_y = (a + b + c + d) / 4.0;
    for sh in &s.shapes {
        let l = sh.area_light.as_ref().unwrap();
        let im = l.image.as_ref().unwrap();
        assert_eq!(
            (im.width, im.height, im.rgb[0][0], im.rgb[3][2]),
            (2, 2, a as f32, d as f32)
        );
        let lv = LUMINOUS_EFFICACY_LM_PER_W * camsim_pbrt::spectra::photometric(&l.radiance);
        let want = 50.0 / (PI * 2.0 * mean_y);
        assert!((lv - want).abs() < 1e-6 * want, "{lv} vs {want}"); // texels are f32
    }
    // Errors: L and filename together. A sphere carries an image over its (u, v) (renderer
    // tests: area_light_breadth).
    let e = parse(&emitter_quad(&file, "\"rgb L\" [1 1 1]")).unwrap_err();
    assert!(
        e.to_string().contains("either \"L\" or \"filename\""),
        "{e}"
    );
    let mut sph =
        parse(&emitter_quad(&file, "").replace("Shape \"trianglemesh\"", "Shape \"sphere\" #"))
            .unwrap();
    sph.settings.samples_per_pixel = 1;
    assert!(render(&sph, &|_, _| {}).is_ok());

    // Seen face-on, each of the 2 x 2 pixels covers one texel's uv square: the bilinear
    // emission with pbrt-v4's clamp wrap (`DiffuseAreaLight::L` bilerps with `Image`'s default
    // `WrapMode::Clamp`) averages, along each axis, 7/8 the texel and 1/8 the neighbour (the
    // outer half of the square reads the texel itself): 49/64 the texel, 7/64 each neighbour
    // along u and v, 1/64 the diagonal one. Grey texels are flat spectra times the illuminant.
    let text = emitter_quad(&file, "");
    let mut s = parse(&text).unwrap();
    s.settings.grid = WavelengthGrid::new(400.0, 700.0, 10.0).unwrap();
    let illum = s.shapes[0].area_light.as_ref().unwrap().radiance.clone();
    let out = render(&s, &|_, _| {}).unwrap();
    // Band averages of the illuminant over each band's interval (centre +- 5 nm), by dense
    // quadrature, then their mean over the bands.
    let nb = out.radiance.bands();
    let band_mean = (0..nb)
        .map(|k| {
            (0..100)
                .map(|j| illum.eval(395.0 + 10.0 * k as f64 + 0.1 * (j as f64 + 0.5)))
                .sum::<f64>()
                / 100.0
        })
        .sum::<f64>()
        / nb as f64;
    let eff =
        |v: f64, h: f64, w: f64, diag: f64| 49.0 / 64.0 * v + 7.0 / 64.0 * (h + w) + diag / 64.0;
    let mut want = [
        eff(a, b, c, d),
        eff(b, a, d, c),
        eff(c, d, a, b),
        eff(d, c, b, a),
    ];
    let mut got: Vec<f64> = (0..4)
        .map(|p| {
            (0..nb).map(|k| out.radiance.band(k)[p] as f64).sum::<f64>() / nb as f64 / band_mean
        })
        .collect();
    want.sort_by(f64::total_cmp);
    got.sort_by(f64::total_cmp);
    eprintln!("image area light pixels / illuminant: {got:.4?}, analytic {want:.4?}");
    for (g, w) in got.iter().zip(want) {
        // Band averages over each band's own interval (centre +- 5 nm): exact to the float
        // sums (a half-band shift of the interval was hidden by a 1.5 % tolerance before).
        assert!((g - w).abs() < 0.002 * w, "{got:?} vs {want:?}");
    }
}

#[test]
fn image_area_light_lights_a_receiver_with_the_texel_under_it() {
    // A transmitting receiver (r = 0, t = 1) 1 cm above the centre of the top-right texel
    // (uv (0.75, 0.75), value b): nearly its whole cosine-weighted hemisphere sees the light
    // within a few cm, where the bilinear emission averages to the texel value, so its radiance
    // seen from above is E / pi = L(b) (next-event estimation at the light's sampled uv, and
    // BSDF samples hitting the light, combined by MIS). The other texels differ by >= 50 %.
    let dir = tempfile::tempdir().unwrap();
    let (a, b, c, d) = (0.2f64, 0.4, 0.6, 0.8);
    let file = grey_pfm(dir.path(), [a as f32, b as f32], [c as f32, d as f32]);
    let text = format!(
        "LookAt 0.5 0.5 1  0.5 0.5 0  0 1 0\nCamera \"perspective\" \"float fov\" 2\n\
         Film \"rgb\" \"integer xresolution\" 4 \"integer yresolution\" 4\n\
         Sampler \"sobol\" \"integer pixelsamples\" 256\nIntegrator \"path\" \"integer maxdepth\" 1\n\
         WorldBegin\nAttributeBegin\nAreaLightSource \"diffuse\" \"string filename\" \"{file}\"\n\
         Material \"diffuse\" \"rgb reflectance\" [0 0 0]\n\
         Shape \"trianglemesh\" \"point3 P\" [-1 -1 0  1 -1 0  1 1 0  -1 1 0] \"integer indices\" [0 1 2 0 2 3] \
         \"point2 uv\" [0 0 1 0 1 1 0 1]\nAttributeEnd\n\
         Material \"diffusetransmission\" \"spectrum reflectance\" [300 0 900 0] \"spectrum transmittance\" [300 1 900 1]\n\
         Shape \"trianglemesh\" \"point3 P\" [0.47 0.47 0.01  0.53 0.47 0.01  0.53 0.53 0.01  0.47 0.53 0.01] \
         \"integer indices\" [0 1 2 0 2 3]\n"
    );
    let mut s = parse(&text).unwrap();
    s.settings.grid = WavelengthGrid::new(400.0, 700.0, 10.0).unwrap();
    let illum = s.shapes[0].area_light.as_ref().unwrap().radiance.clone();
    let out = render(&s, &|_, _| {}).unwrap();
    let nb = out.radiance.bands();
    let band_mean = (0..nb)
        .map(|k| {
            (0..100)
                .map(|j| illum.eval(395.0 + 10.0 * k as f64 + 0.1 * (j as f64 + 0.5)))
                .sum::<f64>()
                / 100.0
        })
        .sum::<f64>()
        / nb as f64;
    let got = mean(&out) / band_mean;
    eprintln!("receiver over texel b = {b}: {got:.4}");
    assert!((got - b).abs() < 0.015 * b, "{got} vs {b}");
}

// ---------------------------------------------------------------------------------------------
// coatedconductor

#[test]
fn coated_conductor_is_read_with_pbrt_names_and_conserves_energy_in_a_furnace() {
    let s = parse(
        "WorldBegin\nMaterial \"coatedconductor\" \"float interface.roughness\" 0.1 \"float interface.eta\" 1.4 \
         \"float thickness\" 0.02 \"spectrum conductor.eta\" \"metal-Au-eta\" \"spectrum conductor.k\" \"metal-Au-k\" \
         \"float conductor.uroughness\" 0.2 \"float conductor.vroughness\" 0.3 \"integer maxdepth\" 10\nShape \"sphere\"\n\
         Material \"coatedconductor\" \"rgb reflectance\" [0.9 0.5 0.2]\nShape \"sphere\"\n",
    )
    .unwrap();
    let Material::CoatedConductor {
        interface_eta,
        interface_roughness,
        thickness,
        conductor,
        conductor_roughness,
        walk,
    } = &s.materials[s.shapes[0].material]
    else {
        panic!("{:?}", s.materials[s.shapes[0].material])
    };
    assert_eq!(
        (*interface_eta, interface_roughness.u, *thickness),
        (1.4, 0.1, 0.02)
    );
    assert_eq!((conductor_roughness.u, conductor_roughness.v), (0.2, 0.3));
    assert!(matches!(conductor, ConductorOptics::EtaK { .. }));
    assert_eq!((walk.max_depth, walk.n_samples), (10, 1));
    assert!(matches!(&s.materials[s.shapes[1].material],
        Material::CoatedConductor { conductor: ConductorOptics::Reflectance(_), interface_eta, thickness, .. }
            if *interface_eta == 1.5 && *thickness == 0.01));
    // A scattering layer (pbrt-v4 `albedo`, `g`) is read.
    let s = parse("WorldBegin\nMaterial \"coatedconductor\" \"rgb albedo\" [0.5 0.5 0.5] \"float g\" 0.3 \"integer nsamples\" 4\nShape \"sphere\"\n")
        .unwrap();
    let Material::CoatedConductor { walk, .. } = &s.materials[s.shapes[0].material] else {
        panic!()
    };
    assert_eq!((walk.g, walk.n_samples), (0.3, 4));
    let e = parse("WorldBegin\nMaterial \"coatedconductor\" \"rgb reflectance\" [0.5 0.5 0.5] \"spectrum conductor.eta\" \"metal-Au-eta\"\n").unwrap_err();
    assert!(e.to_string().contains("not both"), "{e}");

    // White furnace: a coated near-perfect reflector (reflectance 0.999) under a uniform sky
    // never looks brighter than the sky (nor does the bare metal).
    let furnace = |mat: &str| {
        let text = format!(
            "LookAt 0 0 -4  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" 20\n\
             Film \"rgb\" \"integer xresolution\" 12 \"integer yresolution\" 12\n\
             Sampler \"sobol\" \"integer pixelsamples\" 64\nIntegrator \"path\" \"integer maxdepth\" 20\n\
             WorldBegin\nLightSource \"infinite\" \"spectrum L\" [300 1 900 1]\n{mat}\nShape \"sphere\"\n"
        );
        let mut s = parse(&text).unwrap();
        s.settings.russian_roulette_depth = 100;
        let sky = match &s.lights[0] {
            Light::Infinite { radiance } => radiance.eval(550.0),
            l => panic!("{l:?}"),
        };
        let mut s2 = s.clone();
        s2.settings.grid = WavelengthGrid::new(400.0, 700.0, 100.0).unwrap();
        let out = render(&s2, &|_, _| {}).unwrap();
        let img = &out.radiance;
        let (mut mx, mut sum) = (0f64, 0f64);
        for p in 0..img.pixels() {
            let v =
                (0..img.bands()).map(|b| img.band(b)[p] as f64).sum::<f64>() / img.bands() as f64;
            mx = mx.max(v);
            sum += v;
        }
        (mx / sky, sum / img.pixels() as f64 / sky)
    };
    let (coated_max, coated_mean) = furnace("Material \"coatedconductor\" \"rgb reflectance\" [0.999 0.999 0.999] \"float conductor.roughness\" 0.1 \"float thickness\" 0");
    let (bare_max, bare_mean) = furnace(
        "Material \"conductor\" \"rgb reflectance\" [0.999 0.999 0.999] \"float roughness\" 0.1",
    );
    let (white_max, white_mean) =
        furnace("Material \"diffuse\" \"spectrum reflectance\" [300 1 900 1]");
    eprintln!("furnace: white diffuse max {white_max:.4} mean {white_mean:.4}");
    eprintln!("furnace: coated conductor max {coated_max:.4} mean {coated_mean:.4}; bare conductor max {bare_max:.4} mean {bare_mean:.4}");
    // The furnace itself: a white Lambertian sphere reads the sky (per-pixel noise ~2 %).
    assert!((white_mean - 1.0).abs() < 0.01, "{white_mean}");
    assert!(
        coated_mean <= 1.0 && coated_max <= 1.05,
        "{coated_mean} {coated_max}"
    );
    assert!(
        bare_mean <= 1.0 && bare_max <= 1.05,
        "{bare_mean} {bare_max}"
    );
    // pbrt-v4's random walk releases the light the coating traps by total internal reflection:
    // the coated metal keeps most of the bare metal's light (camsim's former one-pass closed
    // form lost about 40 %); it stays below it (each bounce on the rough metal loses some).
    assert!(
        coated_mean > 0.8 * bare_mean && coated_mean < bare_mean + 0.01,
        "{coated_mean} vs {bare_mean}"
    );
}
