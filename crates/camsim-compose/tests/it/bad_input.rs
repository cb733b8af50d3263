//! Bad input is an error naming the file, line or key: a missing asset, a bad manifest line,
//! an asset without triangles, an impossible placement, a bad key.

use crate::common;
use camsim_compose::{compose, ComposeSpec};

fn spec(toml_text: &str) -> ComposeSpec {
    toml::from_str(toml_text).unwrap()
}

fn run(spec: &ComposeSpec, dir: &std::path::Path) -> String {
    let mut scene = common::empty_scene();
    scene.shapes.push(common::box_shape(
        "floor",
        [-1.0, -0.1, -1.0],
        [1.0, 0.0, 1.0],
    ));
    let before = scene.clone();
    let e = compose(&mut scene, spec, 1, dir).expect_err("bad input accepted");
    assert!(scene == before, "a failed compose changed the scene");
    e.to_string()
}

fn plane_spawn(extra: &str) -> String {
    format!(
        "[[spawn]]\nname = \"clutter\"\non = {{ point_m = [0.0, 0.0, 0.0], normal = [0.0, 1.0, 0.0], extent_m = [0.5, 0.5] }}\n{extra}\n"
    )
}

#[test]
fn a_missing_asset_is_named_with_its_manifest_line() {
    let dir = tempfile::tempdir().unwrap();
    let cube = common::trimesh_dir().join("cube.OBJ");
    std::fs::write(
        dir.path().join("m.csv"),
        format!(
            "path,category\n{},cube\nmissing.glb,ghost\n",
            cube.display()
        ),
    )
    .unwrap();
    let e = run(
        &spec(&format!("assets = [\"m.csv\"]\n{}", plane_spawn(""))),
        dir.path(),
    );
    assert!(e.contains("m.csv:3"), "{e}");
    assert!(e.contains("missing.glb"), "{e}");
}

#[test]
fn a_bad_manifest_line_is_named_with_its_column() {
    let dir = tempfile::tempdir().unwrap();
    let cube = common::trimesh_dir().join("cube.OBJ");
    std::fs::write(
        dir.path().join("m.csv"),
        format!(
            "path,category,scale_to_m\n{0},cube,0.1\n{0},cube,ten\n",
            cube.display()
        ),
    )
    .unwrap();
    let e = run(
        &spec(&format!("assets = [\"m.csv\"]\n{}", plane_spawn(""))),
        dir.path(),
    );
    assert!(e.contains("m.csv:3"), "{e}");
    assert!(e.contains("scale_to_m") && e.contains("ten"), "{e}");
    // A bad up axis and an unknown column too; and a JSON entry with a bad field.
    std::fs::write(
        dir.path().join("m.csv"),
        format!("path,up_axis\n{},x\n", cube.display()),
    )
    .unwrap();
    let e = run(
        &spec(&format!("assets = [\"m.csv\"]\n{}", plane_spawn(""))),
        dir.path(),
    );
    assert!(e.contains("m.csv:2") && e.contains("up_axis"), "{e}");
    std::fs::write(dir.path().join("m.csv"), "path,colour\nx.obj,red\n").unwrap();
    let e = run(
        &spec(&format!("assets = [\"m.csv\"]\n{}", plane_spawn(""))),
        dir.path(),
    );
    assert!(e.contains("m.csv:1") && e.contains("colour"), "{e}");
    std::fs::write(
        dir.path().join("m.json"),
        format!(
            "[{{\"path\": \"{}\"}}, {{\"path\": \"a.obj\", \"scale\": 2}}]",
            cube.display()
        ),
    )
    .unwrap();
    let e = run(
        &spec(&format!("assets = [\"m.json\"]\n{}", plane_spawn(""))),
        dir.path(),
    );
    assert!(
        e.contains("m.json: assets[1]") && e.contains("scale"),
        "{e}"
    );
}

#[test]
fn an_asset_without_triangles_is_refused_with_its_reason() {
    let dir = tempfile::tempdir().unwrap();
    let empty = common::trimesh_dir().join("empty.obj");
    let e = run(
        &spec(&format!(
            "assets = [\"{}\"]\n{}",
            empty.display(),
            plane_spawn("")
        )),
        dir.path(),
    );
    assert!(e.contains("empty.obj") && e.contains("no triangles"), "{e}");
    // A missing source and a glob that matches nothing.
    let e = run(
        &spec(&format!("assets = [\"nowhere/\"]\n{}", plane_spawn(""))),
        dir.path(),
    );
    assert!(
        e.contains("compose.assets[0]") && e.contains("nowhere"),
        "{e}"
    );
    let e = run(
        &spec(&format!(
            "assets = [\"{}/*.nothing\"]\n{}",
            common::trimesh_dir().display(),
            plane_spawn("")
        )),
        dir.path(),
    );
    assert!(
        e.contains("compose.assets[0]") && e.contains("matches no file"),
        "{e}"
    );
}

#[test]
fn an_impossible_placement_names_the_entry_and_the_constraint() {
    let dir = tempfile::tempdir().unwrap();
    let cube = common::trimesh_dir().join("cube.OBJ");
    std::fs::write(
        dir.path().join("m.csv"),
        format!("path,category,scale_to_m\n{},cube,0.2\n", cube.display()),
    )
    .unwrap();
    // 40 cubes of 0.2 m, 0.1 m apart, on a 0.5 m square: they cannot all fit.
    let e = run(
        &spec(&format!(
            "assets = [\"m.csv\"]\n{}",
            plane_spawn("count = [40, 40]\nmin_separation_m = 0.1\nmax_tries = 50")
        )),
        dir.path(),
    );
    assert!(e.contains("compose.spawn[0] (\"clutter\")"), "{e}");
    assert!(e.contains("min_separation_m"), "{e}");
    // A box smaller than the object.
    let e = run(
        &spec(
            "assets = [\"m.csv\"]\n[[spawn]]\ninside = { min_m = [0.0, 0.5, 0.0], max_m = [0.1, 0.6, 0.1] }\nmax_tries = 5\n",
        ),
        dir.path(),
    );
    assert!(
        e.contains("compose.spawn[0]") && e.contains("does not fit inside"),
        "{e}"
    );
    // A support that does not exist.
    let e = run(
        &spec("assets = [\"m.csv\"]\n[[spawn]]\non = \"table\"\n"),
        dir.path(),
    );
    assert!(
        e.contains("compose.spawn[0].on") && e.contains("floor"),
        "{e}"
    );
    // Keys: no sampler, a count without enough grid cells, a weight for an absent category.
    let e = run(&spec("assets = [\"m.csv\"]\n[[spawn]]\n"), dir.path());
    assert!(
        e.contains("compose.spawn[0]") && e.contains("on, inside and grid"),
        "{e}"
    );
    let e = run(
        &spec("assets = [\"m.csv\"]\n[[spawn]]\ncount = [5, 5]\ngrid = { origin_m = [0.0, 1.0, 0.0], spacing_m = [0.3, 0.3, 0.3], count = [2, 1, 2] }\n"),
        dir.path(),
    );
    assert!(e.contains("compose.spawn[0].grid.count"), "{e}");
    let e = run(
        &spec(&format!(
            "assets = [\"m.csv\"]\n{}",
            plane_spawn("weights = { duck = 1.0 }")
        )),
        dir.path(),
    );
    assert!(
        e.contains("compose.spawn[0] (\"clutter\").weights.duck"),
        "{e}"
    );
    let e = run(
        &spec(&format!(
            "assets = [\"m.csv\"]\n{}\n[physics]\ntimestep_s = 0.0\n",
            plane_spawn("")
        )),
        dir.path(),
    );
    assert!(e.contains("compose.physics.timestep_s"), "{e}");
    // Unknown keys are refused by the parser, naming them.
    let err = toml::from_str::<ComposeSpec>("[[spawn]]\ncuont = [1, 2]\n").unwrap_err();
    assert!(err.to_string().contains("cuont"), "{err}");
}

#[test]
fn bad_keypoints_are_named_with_the_asset_and_the_reason() {
    let dir = tempfile::tempdir().unwrap();
    let cube = common::trimesh_dir().join("cube.OBJ");
    let assets = format!("assets = [\"m.csv\"]\n{}", plane_spawn(""));
    // A keypoint file with a point missing, named with its manifest line.
    std::fs::write(
        dir.path().join("k.json"),
        r#"{ "names": ["a", "b"], "points": [[0, 0, 0]] }"#,
    )
    .unwrap();
    std::fs::write(
        dir.path().join("m.csv"),
        format!("path,category,keypoints\n{},cube,k.json\n", cube.display()),
    )
    .unwrap();
    let e = run(&spec(&assets), dir.path());
    assert!(
        e.contains("m.csv:2") && e.contains("k.json") && e.contains("one point per name"),
        "{e}"
    );
    // An edge to a point that is not there; a name given twice.
    for (k, want) in [
        (
            r#"{ "names": ["a", "b"], "points": [[0, 0, 0], [1, 0, 0]], "skeleton": [[0, 2]] }"#,
            "skeleton[0]",
        ),
        (
            r#"{ "names": ["a", "a"], "points": [[0, 0, 0], [1, 0, 0]] }"#,
            "given twice",
        ),
        (r#"{ "names": ["a"], "points": [[0, 0]] }"#, "k.json:1"),
    ] {
        std::fs::write(dir.path().join("k.json"), k).unwrap();
        let e = run(&spec(&assets), dir.path());
        assert!(e.contains("m.csv:2") && e.contains(want), "{want}: {e}");
    }
    // Two assets of one category, one with keypoints and one without.
    std::fs::write(
        dir.path().join("k.json"),
        r#"{ "names": ["a"], "points": [[0, 0, 0]] }"#,
    )
    .unwrap();
    std::fs::write(
        dir.path().join("m.csv"),
        format!(
            "path,category,keypoints\n{0},cube,k.json\n{0},cube,\n",
            cube.display()
        ),
    )
    .unwrap();
    let e = run(&spec(&assets), dir.path());
    assert!(
        e.contains("m.csv:3") && e.contains("\"cube\"") && e.contains("share one keypoint list"),
        "{e}"
    );
}
