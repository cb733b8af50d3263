//! Bad assets are refused with a message naming the file and what is at fault (the URI, the
//! JSON line and column, the mesh and accessor, the extension), never a panic.

use camsim_assets::{read_scene, ReadOptions};

fn read_text(name: &str, text: &str) -> String {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join(name);
    std::fs::write(&p, text).unwrap();
    read_scene(&p, &ReadOptions::default())
        .unwrap_err()
        .to_string()
}

/// A minimal glTF: one triangle, positions then indices in a data-URI buffer.
fn triangle(positions: [[f32; 3]; 3], indices: [u16; 3], extra: &str, mode: u32) -> String {
    use base64::Engine;
    let mut b = Vec::new();
    for p in positions {
        for v in p {
            b.extend_from_slice(&v.to_le_bytes());
        }
    }
    for i in indices {
        b.extend_from_slice(&i.to_le_bytes());
    }
    let uri = base64::engine::general_purpose::STANDARD.encode(&b);
    format!(
        r#"{{"asset": {{"version": "2.0"}}, {extra}
 "scenes": [{{"nodes": [0]}}], "nodes": [{{"mesh": 0}}],
 "meshes": [{{"name": "tri", "primitives": [{{"attributes": {{"POSITION": 0}}, "indices": 1, "mode": {mode}}}]}}],
 "buffers": [{{"byteLength": {n}, "uri": "data:application/octet-stream;base64,{uri}"}}],
 "bufferViews": [{{"buffer": 0, "byteOffset": 0, "byteLength": 36}}, {{"buffer": 0, "byteOffset": 36, "byteLength": 6}}],
 "accessors": [{{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0,0,0], "max": [1,1,0]}},
               {{"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"}}]}}"#,
        n = b.len()
    )
}

const TRI: [[f32; 3]; 3] = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];

#[test]
fn a_good_triangle_reads() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("ok.gltf");
    std::fs::write(&p, triangle(TRI, [0, 1, 2], "", 4)).unwrap();
    let s = read_scene(&p, &ReadOptions::default()).unwrap();
    assert_eq!(s.shapes.len(), 1);
    // No light in the file: the documented default sky.
    assert_eq!(s.lights.len(), 1);
}

#[test]
fn malformed_json_names_line_and_column() {
    let e = read_text(
        "bad.gltf",
        "{\n  \"asset\": {\"version\": \"2.0\"},\n  \"nodes\": [,]\n}",
    );
    assert!(e.contains("bad.gltf") && e.contains("line 3"), "{e}");
}

#[test]
fn an_index_past_the_vertices_names_mesh_and_accessor() {
    let e = read_text("idx.gltf", &triangle(TRI, [0, 1, 7], "", 4));
    assert!(
        e.contains("mesh \"tri\"") && e.contains("accessor 1") && e.contains("index 7"),
        "{e}"
    );
}

#[test]
fn non_finite_positions_are_refused() {
    let e = read_text(
        "nan.gltf",
        &triangle(
            [[0.0, 0.0, 0.0], [f32::NAN, 0.0, 0.0], [0.0, 1.0, 0.0]],
            [0, 1, 2],
            "",
            4,
        ),
    );
    assert!(
        e.contains("POSITION") && e.contains("accessor 0") && e.contains("not finite"),
        "{e}"
    );
}

#[test]
fn points_and_lines_are_refused_naming_the_mesh() {
    let e = read_text("pts.gltf", &triangle(TRI, [0, 1, 2], "", 0));
    assert!(e.contains("mesh \"tri\"") && e.contains("Points"), "{e}");
}

#[test]
fn an_unsupported_required_extension_is_named() {
    let e = read_text(
        "draco.gltf",
        &triangle(
            TRI,
            [0, 1, 2],
            r#""extensionsUsed": ["KHR_draco_mesh_compression"], "extensionsRequired": ["KHR_draco_mesh_compression"],"#,
            4,
        ),
    );
    assert!(
        e.contains("KHR_draco_mesh_compression") && e.contains("extensionsRequired"),
        "{e}"
    );
    // Only used: read, with a note.
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("used.gltf");
    std::fs::write(
        &p,
        triangle(
            TRI,
            [0, 1, 2],
            r#""extensionsUsed": ["EXT_meshopt_compression"],"#,
            4,
        ),
    )
    .unwrap();
    let s = read_scene(&p, &ReadOptions::default()).unwrap();
    assert!(
        s.notes
            .iter()
            .any(|n| n.contains("EXT_meshopt_compression")),
        "{:?}",
        s.notes
    );
}

#[test]
fn an_accessor_past_its_buffer_view_is_refused() {
    let text = triangle(TRI, [0, 1, 2], "", 4).replace(
        r#""count": 3, "type": "VEC3""#,
        r#""count": 30, "type": "VEC3""#,
    );
    let e = read_text("short.gltf", &text);
    assert!(e.contains("accessor 0") && e.contains("run past"), "{e}");
}

#[test]
fn a_missing_image_names_the_file_and_uri() {
    let text = triangle(TRI, [0, 1, 2], "", 4).replace(
        r#""mode": 4}]"#,
        r#""mode": 4, "material": 0}]"#,
    ).replace(
        r#""buffers""#,
        r#""materials": [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}], "textures": [{"source": 0}], "images": [{"uri": "gone.png"}], "buffers""#,
    );
    let e = read_text("img.gltf", &text);
    assert!(e.contains("gone.png") && e.contains("uri"), "{e}");
}

#[test]
fn obj_errors_name_the_line() {
    let e = read_text("bad.obj", "v 0 0 0\nv 1 0 0\nv 0 1 x\nf 1 2 3\n");
    assert!(e.contains("bad.obj") && e.contains("line 3"), "{e}");
}

#[test]
fn buffers_that_will_not_fit_are_refused_before_reading() {
    // A buffer declaring 100 TB (its file does not even exist): the memory budget refuses the
    // file from its declared sizes before any buffer is read.
    let text = triangle(TRI, [0, 1, 2], "", 4).replacen(
        r#""buffers": [{"byteLength": 42,"#,
        r#""buffers": [{"byteLength": 42}, {"byteLength": 100000000000000, "uri": "huge.bin"}], "unused": [{"#,
        1,
    );
    let e = read_text("huge.gltf", &text);
    assert!(
        e.contains("huge.gltf") && e.contains("MiB") && !e.contains("cannot be read"),
        "{e}"
    );
}
