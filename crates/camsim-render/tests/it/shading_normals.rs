//! Vertex (shading) normals that disagree with the geometric surface, as pbrt-v4 handles them
//! (4th ed. sec. 9.1.1 and 10.1; `BSDF::f`, `BSDF::Sample_f`, `SurfaceInteraction::SpawnRay`):
//! the BSDF, in the shading frame, alone decides what scatters, and a ray leaves from the side
//! of the surface its direction geometrically goes to, with the medium there. A quad in the
//! plane z = 0 (geometric normal +z, the camera above it) whose vertex normals are all tilted
//! by 60 degrees to `n_s = (sin 60, 0, cos 60)`:
//! - a diffuse quad lit by a distant light 10 degrees below its plane but 40 degrees from `n_s`
//!   has the radiance of an untilted quad lit from 40 degrees above: `rho / pi E cos 40` both;
//! - a smooth dielectric quad (eta 1.5) under a uniform sky, seen along -z (`cos(wo, n_s)` =
//!   0.5): its mirror direction about `n_s` goes below the plane, as does the refracted one,
//!   and both reach the sky, so its radiance is `(R + T / eta^2) L` with `R` the Fresnel
//!   reflectance at cos 0.5 (the `1 / eta^2` of radiance entering glass, pbrt-v4 radiance
//!   mode). A renderer that ends the reflected paths instead (pbrt-v3's geometric-side test)
//!   gives `T / eta^2 L`, 18 % less.
//!
//! Both with the path tracer and, with a clear medium behind the quad, the volumetric one.

fn mean_radiance(text: &str) -> f64 {
    let scene = camsim_pbrt::parse_str(text, "/tmp/virtual/shading_normals.pbrt").unwrap();
    let out = camsim_render::render(&scene, &|_, _| {}).unwrap();
    let d = &out.radiance.data;
    d.iter().map(|v| *v as f64).sum::<f64>() / d.len() as f64
}

/// Camera 1 m above the origin looking down -z, `fov` degrees.
fn camera(fov: f64, integrator: &str) -> String {
    format!(
        "LookAt 0 0 1  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" {fov}\n\
         Film \"rgb\" \"integer xresolution\" 16 \"integer yresolution\" 16\n\
         Sampler \"sobol\" \"integer pixelsamples\" 256\n\
         Integrator \"{integrator}\" \"integer maxdepth\" 4\nWorldBegin\n\
         MakeNamedMedium \"clear\" \"string type\" \"homogeneous\" \
         \"rgb sigma_a\" [0 0 0] \"rgb sigma_s\" [0 0 0]\n"
    )
}

/// The 2 m quad in z = 0, wound so its geometric normal is +z, with vertex normals `n` (none
/// when `None`), the clear medium on its inside (below) when `medium`.
fn quad(material: &str, n: Option<[f64; 3]>, medium: bool) -> String {
    let normals = n.map_or(String::new(), |[x, y, z]| {
        format!("\"normal N\" [{x} {y} {z}  {x} {y} {z}  {x} {y} {z}  {x} {y} {z}]")
    });
    let mi = if medium {
        "MediumInterface \"clear\" \"\"\n"
    } else {
        ""
    };
    format!(
        "AttributeBegin\n{mi}{material}\nShape \"trianglemesh\" \"point3 P\" [-1 -1 0  1 -1 0  1 1 0  -1 1 0] \
         \"integer indices\" [0 1 2 0 2 3] {normals}\nAttributeEnd\n"
    )
}

fn tilted() -> [f64; 3] {
    let (s, c) = 60f64.to_radians().sin_cos();
    [s, 0.0, c]
}

/// Fresnel reflectance of a dielectric interface, light arriving from the side of index 1 at
/// `cos_i` (Hecht, Optics, eq. 4.34 and 4.40; unpolarised).
fn fresnel(cos_i: f64, eta: f64) -> f64 {
    let cos_t = (1.0 - (1.0 - cos_i * cos_i) / (eta * eta)).sqrt();
    let r_par = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let r_perp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    0.5 * (r_par * r_par + r_perp * r_perp)
}

fn distant(phi_deg: f64) -> String {
    let (s, c) = phi_deg.to_radians().sin_cos();
    format!("LightSource \"distant\" \"point3 from\" [{s} 0 {c}] \"point3 to\" [0 0 0] \"rgb L\" [1 1 1]\n")
}

#[test]
fn a_light_below_the_surface_but_above_the_shading_normal_lights_a_diffuse_quad() {
    let diffuse = "Material \"diffuse\" \"rgb reflectance\" [0.5 0.5 0.5]";
    for (integrator, medium) in [("path", false), ("volpath", true)] {
        // 40 degrees above the untilted quad's normal.
        let flat = mean_radiance(&format!(
            "{}{}{}",
            camera(30.0, integrator),
            distant(40.0),
            quad(diffuse, None, medium)
        ));
        // 100 degrees from +z (10 below the plane), 40 from the tilted shading normal.
        let tilted = mean_radiance(&format!(
            "{}{}{}",
            camera(30.0, integrator),
            distant(100.0),
            quad(diffuse, Some(tilted()), medium)
        ));
        eprintln!("{integrator}: tilted {tilted:.6e}, flat {flat:.6e}");
        assert!(flat > 0.0);
        let r = tilted / flat;
        assert!(
            (r - 1.0).abs() < 1e-3,
            "{integrator}: tilted / flat = {r:.5}, want 1"
        );
    }
}

#[test]
fn a_reflection_through_the_surface_goes_on_below_it() {
    let eta = 1.5f64;
    let glass = format!("Material \"dielectric\" \"float eta\" [{eta}]");
    let sky = "LightSource \"infinite\" \"rgb L\" [1 1 1]\n";
    // cos(wo, n_s) = cos 60 for the central ray; a 1-degree field keeps every ray within 0.5
    // degrees of it.
    let want = {
        let r = fresnel(0.5, eta);
        r + (1.0 - r) / (eta * eta)
    };
    for (integrator, medium) in [("path", false), ("volpath", true)] {
        let l_sky = mean_radiance(&format!("{}{sky}", camera(1.0, integrator)));
        let seen = mean_radiance(&format!(
            "{}{sky}{}",
            camera(1.0, integrator),
            quad(&glass, Some(tilted()), medium)
        ));
        let got = seen / l_sky;
        eprintln!("{integrator}: quad / sky {got:.5}, closed form R + T / eta^2 = {want:.5}");
        assert!(
            (got / want - 1.0).abs() < 0.01,
            "{integrator}: quad / sky = {got:.5}, want {want:.5}"
        );
    }
}
