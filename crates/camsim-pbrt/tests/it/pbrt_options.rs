//! `Integrator` and `PixelFilter` as pbrt-v4 reads them: integrators that converge to the path
//! tracer's radiance are rendered by it with a note naming the substitution, `ambientocclusion`
//! is refused; every filter with pbrt-v4's parameter names and default radii
//! (src/pbrt/filters.cpp `*Filter::Create`), gaussian when the file has none.

use camsim_pbrt as pbrt;
use camsim_scene3d::scene::PixelFilter;

fn parse(head: &str) -> Result<camsim_scene3d::SceneDescription, pbrt::PbrtError> {
    pbrt::parse_str(
        &format!("{head}\nWorldBegin\nLightSource \"infinite\"\nShape \"sphere\"\n"),
        "opts.pbrt",
    )
}

#[test]
fn integrators_substitute_the_path_tracer_or_are_refused() {
    for ty in [
        "sppm",
        "lightpath",
        "mlt",
        "randomwalk",
        "simplepath",
        "bdpt",
        "volpath",
        "simplevolpath",
    ] {
        let s = parse(&format!("Integrator \"{ty}\" \"integer maxdepth\" 7")).unwrap();
        assert_eq!(s.settings.max_depth, 7, "{ty}");
        // Without participating media the volumetric integrators are the path tracer too.
        let said = |n: &String| {
            n.contains(&format!(
                "Integrator \"{ty}\" rendered with camsim's path tracer"
            )) || (ty.ends_with("volpath")
                && n.contains(&format!("Integrator \"{ty}\": no participating medium"))
                && n.contains("camsim's path tracer"))
        };
        assert!(s.notes.iter().any(said), "{ty}: {:?}", s.notes);
    }
    // The other algorithms' own parameters are noted, not errors.
    let s = parse("Integrator \"sppm\" \"integer photonsperiteration\" 1000 \"float radius\" 0.1")
        .unwrap();
    assert!(
        s.notes.iter().any(|n| n.contains("photonsperiteration")),
        "{:?}",
        s.notes
    );
    let s = parse("Integrator \"path\"").unwrap();
    assert!(
        !s.notes.iter().any(|n| n.contains("Integrator")),
        "{:?}",
        s.notes
    );
    let e = parse("\nIntegrator \"ambientocclusion\"")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("opts.pbrt:2:1") && e.contains("ambient occlusion, not radiance"),
        "{e}"
    );
    let e = parse("Integrator \"photonmap\"").unwrap_err().to_string();
    assert!(e.contains("\"photonmap\" is not supported"), "{e}");
}

/// pbrt-v4's `lightsampler` (`path`, `volpath`; also read from `bdpt` files, which camsim's path
/// tracer renders) sets how the render chooses lights, `bvh` when absent; a misspelt value is
/// refused with the file and line.
#[test]
fn integrator_light_sampler_is_read() {
    use camsim_scene3d::scene::LightSampler;
    let ls = |head: &str| parse(head).unwrap().settings.light_sampler;
    assert_eq!(ls("Integrator \"path\""), LightSampler::Bvh);
    assert_eq!(ls(""), LightSampler::Bvh);
    for (name, want) in [
        ("bvh", LightSampler::Bvh),
        ("power", LightSampler::Power),
        ("uniform", LightSampler::Uniform),
    ] {
        for ty in ["path", "volpath", "bdpt"] {
            let s = parse(&format!(
                "Integrator \"{ty}\" \"string lightsampler\" \"{name}\""
            ))
            .unwrap();
            assert_eq!(s.settings.light_sampler, want, "{ty} {name}");
            assert!(
                !s.notes.iter().any(|n| n.contains("lightsampler")),
                "{:?}",
                s.notes
            );
        }
    }
    // pbrt-v4's exhaustive sampler is the bvh sampler's importance without the tree: noted.
    let s = parse("Integrator \"path\" \"string lightsampler\" \"exhaustive\"").unwrap();
    assert_eq!(s.settings.light_sampler, LightSampler::Bvh);
    assert!(s
        .notes
        .iter()
        .any(|n| n.contains("\"exhaustive\" approximated")));
    let e = parse("\n\nIntegrator \"path\" \"string lightsampler\" \"powr\"")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("opts.pbrt:3:") && e.contains("lightsampler \"powr\" is unknown"),
        "{e}"
    );
}

#[test]
fn pixel_filters_take_pbrt_v4_parameters_and_defaults() {
    let f = |line: &str| parse(line).unwrap().settings.filter;
    assert_eq!(
        f(""),
        PixelFilter::Gaussian {
            radius: [1.5, 1.5],
            sigma: 0.5
        }
    );
    assert_eq!(
        f("PixelFilter \"box\""),
        PixelFilter::Box { radius: [0.5, 0.5] }
    );
    assert_eq!(
        f("PixelFilter \"triangle\" \"float xradius\" 1"),
        PixelFilter::Triangle { radius: [1.0, 2.0] }
    );
    assert_eq!(
        f("PixelFilter \"gaussian\" \"float sigma\" 0.25"),
        PixelFilter::Gaussian {
            radius: [1.5, 1.5],
            sigma: 0.25
        }
    );
    assert_eq!(
        f("PixelFilter \"mitchell\" \"float C\" 0.5"),
        PixelFilter::Mitchell {
            radius: [2.0, 2.0],
            b: 1.0 / 3.0,
            c: 0.5
        }
    );
    for name in ["sinc", "lanczos"] {
        assert_eq!(
            f(&format!("PixelFilter \"{name}\" \"float yradius\" 3")),
            PixelFilter::Lanczos {
                radius: [4.0, 3.0],
                tau: 3.0
            }
        );
    }
    for (line, want) in [
        ("PixelFilter \"cubic\"", "not one of box"),
        ("PixelFilter \"box\" \"float xradius\" 0", "radius"),
        ("PixelFilter \"gaussian\" \"float sigma\" 0", "sigma"),
        ("PixelFilter \"box\" \"float alpha\" 2", "alpha"),
    ] {
        let e = parse(line).unwrap_err().to_string();
        assert!(
            e.contains("opts.pbrt:1:1") && e.contains(want),
            "{line}: {e}"
        );
    }
}
