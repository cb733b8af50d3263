//! Quick timing of the renderer benchmark scene (issue 4): the built-in `cornell-box` at
//! 512 x 512, 16 spp, 4 wavelengths per path, maximum depth 8, rendered in memory three times.
//! Prints rays/s of wall time and rays per CPU-second (user + system), the second being the
//! per-core figure that is robust to other load on the machine.
//!
//! Run: `cargo run --release -p camsim-render --example time_render [SPP] [SIZE] [RUNS] [SAMPLER]`
//! (defaults 16, 512, 3, sobol; SAMPLER `independent` or `sobol`; a small SIZE and one run suit
//! `valgrind --tool=callgrind` or `perf record`).
use camsim_render::render;
use camsim_scene3d::builtin::{scene, BuiltinOptions};

fn main() {
    let arg = |i: usize, default: u32| {
        std::env::args()
            .nth(i)
            .and_then(|s| s.parse().ok())
            .unwrap_or(default)
    };
    let (spp, size, runs) = (arg(1, 16), arg(2, 512) as usize, arg(3, 3));
    let opts = BuiltinOptions {
        resolution: Some((size, size)),
        samples_per_pixel: spp,
        ..BuiltinOptions::default()
    };
    let mut sc = scene("cornell-box", &opts).expect("built-in scene");
    sc.settings.max_depth = 8;
    sc.settings.wavelengths_per_path = 4;
    if let Some(name) = std::env::args().nth(4) {
        sc.settings.sampler = camsim_scene3d::scene::SamplerKind::from_name(&name)
            .expect("sampler: independent or sobol");
    }
    for _ in 0..runs {
        let (u0, s0) = camsim_core::mem::process_cpu_s();
        let out = render(&sc, &|_, _| {}).expect("render");
        let (u1, s1) = camsim_core::mem::process_cpu_s();
        let st = out.stats;
        let rays = (st.camera_rays + st.bounce_rays + st.shadow_rays) as f64;
        println!(
            "{:.2} s wall, {:.2} M rays/s on {} threads, {:.2} M rays per CPU-second (camera {}, bounce {}, shadow {})",
            st.seconds,
            st.rays_per_second / 1e6,
            rayon::current_num_threads(),
            rays / (u1 - u0 + s1 - s0) / 1e6,
            st.camera_rays,
            st.bounce_rays,
            st.shadow_rays
        );
    }
}
