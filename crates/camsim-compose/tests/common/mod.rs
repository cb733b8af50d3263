//! Shared scene builders and mesh-level checks of the compose tests.
#![allow(dead_code)]

pub mod tabletop;

use camsim_scene3d::{Geometry, Material, SceneDescription, Shape, Texture};
use nalgebra::Point3;
use parry3d_f64::shape::{TriMesh, TriMeshFlags};
use std::path::PathBuf;

/// `shared/assets/trimesh/` beside the repository (tests never copy it).
pub fn trimesh_dir() -> PathBuf {
    PathBuf::from(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../../shared/assets/trimesh"
    ))
}

/// An empty scene with one grey material.
pub fn empty_scene() -> SceneDescription {
    SceneDescription {
        camera: camsim_assets::framing_camera([-1.0; 3], [1.0; 3], 64),
        shapes: Vec::new(),
        materials: vec![Material::Diffuse {
            reflectance: Texture::Constant(camsim_core::Spectrum::from_pairs(&[
                (300.0, 0.5),
                (900.0, 0.5),
            ])),
        }],
        named_materials: Default::default(),
        lights: Vec::new(),
        settings: Default::default(),
        focus_distance_m: None,
        notes: Vec::new(),
        media: Default::default(),
        light_groups: Vec::new(),
    }
}

/// An axis-aligned box `lo..hi` as 12 outward-wound triangles.
pub fn box_shape(name: &str, lo: [f64; 3], hi: [f64; 3]) -> Shape {
    let p = |i: usize| {
        [
            if i & 1 == 0 { lo[0] } else { hi[0] },
            if i & 2 == 0 { lo[1] } else { hi[1] },
            if i & 4 == 0 { lo[2] } else { hi[2] },
        ]
    };
    let positions: Vec<[f64; 3]> = (0..8).map(p).collect();
    // Faces of the cube, counter-clockwise seen from outside.
    let quads = [
        [0, 2, 3, 1], // -z
        [4, 5, 7, 6], // +z
        [0, 1, 5, 4], // -y
        [2, 6, 7, 3], // +y
        [0, 4, 6, 2], // -x
        [1, 3, 7, 5], // +x
    ];
    let mut indices = Vec::new();
    for q in quads {
        indices.push([q[0], q[1], q[2]]);
        indices.push([q[0], q[2], q[3]]);
    }
    Shape {
        name: Some(name.into()),
        geometry: Geometry::mesh(positions, indices, None, None),
        material: 0,
        area_light: None,
        reverse_orientation: false,
        tags: Default::default(),
    }
}

/// The world triangles of the shapes named `name`.
pub fn object_mesh(scene: &SceneDescription, name: &str) -> (Vec<Point3<f64>>, Vec<[u32; 3]>) {
    let mut v = Vec::new();
    let mut ix = Vec::new();
    for s in scene
        .shapes
        .iter()
        .filter(|s| s.name.as_deref() == Some(name))
    {
        if let Geometry::Triangles {
            positions, indices, ..
        } = &s.geometry
        {
            let base = v.len() as u32;
            v.extend(positions.iter().map(|p| Point3::new(p[0], p[1], p[2])));
            ix.extend(indices.iter().map(|t| t.map(|i| i + base)));
        }
    }
    (v, ix)
}

/// A triangle mesh that can tell inside from outside (merged vertices, pseudo-normals).
pub fn solid(v: &[Point3<f64>], ix: &[[u32; 3]]) -> TriMesh {
    TriMesh::with_flags(
        v.to_vec(),
        ix.to_vec(),
        TriMeshFlags::MERGE_DUPLICATE_VERTICES
            | TriMeshFlags::DELETE_DEGENERATE_TRIANGLES
            | TriMeshFlags::ORIENTED,
    )
    .expect("a closed mesh")
}

/// Sample points of a mesh: its vertices and points along its edges (quarter points).
pub fn samples(v: &[Point3<f64>], ix: &[[u32; 3]]) -> Vec<Point3<f64>> {
    let mut out = v.to_vec();
    for t in ix {
        for e in 0..3 {
            let (a, b) = (v[t[e] as usize], v[t[(e + 1) % 3] as usize]);
            for f in [0.25, 0.5, 0.75] {
                out.push(a + (b - a) * f);
            }
        }
    }
    out
}

/// How deep the points `pts` reach inside the closed mesh `m`, m (0 when none is inside).
pub fn depth_inside(pts: &[Point3<f64>], m: &TriMesh) -> f64 {
    use parry3d_f64::query::PointQuery;
    let aabb = m.local_aabb();
    pts.iter()
        .filter(|p| (0..3).all(|k| p[k] >= aabb.mins[k] && p[k] <= aabb.maxs[k]))
        .map(|p| {
            let proj = m.project_local_point(p, false);
            if proj.is_inside {
                (proj.point - p).norm().max(f64::MIN_POSITIVE)
            } else {
                0.0
            }
        })
        .fold(0.0, f64::max)
}
