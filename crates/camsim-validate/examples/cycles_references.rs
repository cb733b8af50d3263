//! The Cycles table of docs/src/assets.md: every scene of `../shared/scenes/gltf/` rendered by
//! camsim from Blender's glTF/OBJ exports and compared with Cycles' renders.
//!
//! `cargo run --release -p camsim-validate --example cycles_references -- [SPP]` (default 64
//! samples per pixel per seed; Cycles' references have 512).
//!
//! For a reference of your own (made with `bpy` as the README of `../shared/scenes/gltf/`
//! says): `... --example cycles_references -- SPP FILE.glb CYCLES.exr [UNIT_FACTOR]` prints the
//! mean ratio and the 16 x 12 block ratios of one camsim seed against one Cycles render.

use camsim_validate::cycles_reference::{
    compare_scene, load_cycles_luminance, luminance_cd_m2, CYCLES_SCENES,
};
use std::path::Path;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let spp: u32 = args.first().and_then(|s| s.parse().ok()).unwrap_or(64);
    if args.len() >= 3 {
        let unit: f64 = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(1.0);
        let (w, h, y) = load_cycles_luminance(Path::new(&args[2])).expect("the Cycles EXR");
        let opts = camsim_scene3d::builtin::BuiltinOptions {
            resolution: Some((w, h)),
            ..Default::default()
        };
        let mut s = camsim_pipeline::render::read_scene_file(Path::new(&args[1]), &opts)
            .expect("the scene file");
        s.camera.width = w;
        s.camera.height = h;
        s.settings.samples_per_pixel = spp;
        s.settings.max_depth = 8;
        let out = camsim_render::render(&s, &|_, _| {}).expect("render");
        let c = luminance_cd_m2(&out.radiance);
        let (mc, my) = (
            c.iter().sum::<f64>() / c.len() as f64,
            unit * y.iter().sum::<f64>() / y.len() as f64,
        );
        println!("mean ratio camsim / Cycles: {:.4}", mc / my);
        for by in 0..12 {
            let row: Vec<String> = (0..16)
                .map(|bx| {
                    let (mut a, mut b) = (0.0, 0.0);
                    for yy in by * h / 12..(by + 1) * h / 12 {
                        for xx in bx * w / 16..(bx + 1) * w / 16 {
                            a += c[yy * w + xx];
                            b += unit * y[yy * w + xx];
                        }
                    }
                    if b > 0.0 {
                        format!("{:5.2}", a / b)
                    } else {
                        "    -".into()
                    }
                })
                .collect();
            println!("{}", row.join(" "));
        }
        return;
    }
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/scenes/gltf");
    println!("| file | unit factor | camsim / Cycles mean luminance | blocks beyond 4 sigma (of 192) | worst block | pass |");
    println!("|---|---|---|---|---|---|");
    for s in &CYCLES_SCENES {
        match compare_scene(&dir, s, spp) {
            Ok(c) => println!(
                "| `{}` | {} | {:.4} +- {:.4} | {} | {:.1} | {} |",
                s.file,
                s.unit_factor,
                c.mean_ratio,
                c.mean_ratio_se,
                c.blocks_off,
                c.worst_block_sigmas,
                if c.pass() { "yes" } else { "no" }
            ),
            Err(e) => println!("| `{}` | {} | error: {e} | | | |", s.file, s.unit_factor),
        }
    }
}
