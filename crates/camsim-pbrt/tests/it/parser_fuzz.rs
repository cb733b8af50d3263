//! Property tests: malformed or random input never panics the pbrt-v4 reader or the PLY reader.

use camsim_pbrt as pbrt;
use proptest::prelude::*;

const WORDS: &[&str] = &[
    "WorldBegin",
    "AttributeBegin",
    "AttributeEnd",
    "Shape",
    "\"sphere\"",
    "\"trianglemesh\"",
    "\"bilinearmesh\"",
    "\"float radius\"",
    "\"point3 P\"",
    "\"integer indices\"",
    "\"rgb L\"",
    "\"spectrum L\"",
    "\"blackbody L\"",
    "AreaLightSource",
    "\"diffuse\"",
    "Material",
    "MakeNamedMaterial",
    "NamedMaterial",
    "\"string type\"",
    "\"rgb reflectance\"",
    "Translate",
    "Scale",
    "Rotate",
    "LookAt",
    "Transform",
    "ConcatTransform",
    "Camera",
    "\"perspective\"",
    "\"float fov\"",
    "Film",
    "\"rgb\"",
    "\"integer xresolution\"",
    "LightSource",
    "\"infinite\"",
    "ObjectBegin",
    "ObjectEnd",
    "ObjectInstance",
    "\"a\"",
    "Texture",
    "\"spectrum\"",
    "\"constant\"",
    "ReverseOrientation",
    "CoordinateSystem",
    "CoordSysTransform",
    "Identity",
    "[",
    "]",
    "0",
    "1",
    "-1",
    "0.5",
    "1e300",
    "-1e-300",
    "nan",
    "inf",
    "3",
    "7",
    "\"",
    "#c\n",
    "\n",
    "\"bool twosided\"",
    "true",
    "\"stdillum-D65\"",
    "Sampler",
    "Integrator",
    "\"integer maxdepth\"",
    "TransformBegin",
    "TransformEnd",
    "ActiveTransform",
    "EndTime",
    "\"float power\"",
];

fn token_stream() -> impl Strategy<Value = String> {
    prop::collection::vec(prop::sample::select(WORDS), 0..80).prop_map(|v| v.join(" "))
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 400, ..ProptestConfig::default() })]

    #[test]
    fn random_token_streams_never_panic(text in token_stream()) {
        let _ = pbrt::parse_str(&format!("WorldBegin\n{text}"), "/tmp/fuzz.pbrt");
        let _ = pbrt::parse_str(&text, "/tmp/fuzz.pbrt");
    }

    #[test]
    fn random_text_never_panics(text in "\\PC{0,200}") {
        let _ = pbrt::parse_str(&text, "/tmp/fuzz.pbrt");
    }

    #[test]
    fn errors_point_inside_the_text(text in token_stream()) {
        if let Err(e) = pbrt::parse_str(&text, "/tmp/fuzz.pbrt") {
            let lines = text.lines().count().max(1);
            prop_assert!(e.line <= lines + 1, "{e} ({lines} lines)");
        }
    }

    #[test]
    fn random_ply_bytes_never_panic(body in prop::collection::vec(any::<u8>(), 0..300), n in 0usize..5, ascii in any::<bool>()) {
        let fmt = if ascii { "ascii" } else { "binary_little_endian" };
        let mut bytes = format!(
            "ply\nformat {fmt} 1.0\nelement vertex {n}\nproperty float x\nproperty float y\nproperty float z\nelement face {n}\nproperty list uchar int vertex_indices\nend_header\n"
        ).into_bytes();
        bytes.extend_from_slice(&body);
        let _ = pbrt::ply::parse_ply(&bytes);
        let _ = pbrt::ply::parse_ply(&body);
    }
}
