//! MikkTSpace tangents for normal-mapped triangle meshes that carry none (glTF 2.0 sec. 3.7.2.1:
//! "When tangents are not specified, client implementations SHOULD calculate tangents using
//! default MikkTSpace algorithms with the specified vertex positions, normals, and texture
//! coordinates associated with the normal texture"), through the `mikktspace` crate.

use camsim_scene3d::Geometry;
use std::collections::HashMap;

/// The mesh as MikkTSpace reads it: every face a triangle, attributes through the indices.
struct Faces<'a> {
    /// Positions relative to `origin`, m (so world-space offsets keep f32 precision).
    positions: &'a [[f64; 3]],
    origin: [f64; 3],
    normals: Option<&'a [[f64; 3]]>,
    uvs: &'a [[f32; 2]],
    indices: &'a [[u32; 3]],
    /// The tangent of each face corner, `[x, y, z, w]`.
    out: Vec<[f32; 4]>,
}

impl Faces<'_> {
    fn p(&self, face: usize, vert: usize) -> [f64; 3] {
        let p = self.positions[self.indices[face][vert] as usize];
        std::array::from_fn(|k| p[k] - self.origin[k])
    }
}

impl mikktspace::Geometry for Faces<'_> {
    fn num_faces(&self) -> usize {
        self.indices.len()
    }

    fn num_vertices_of_face(&self, _face: usize) -> usize {
        3
    }

    fn position(&self, face: usize, vert: usize) -> [f32; 3] {
        self.p(face, vert).map(|x| x as f32)
    }

    fn normal(&self, face: usize, vert: usize) -> [f32; 3] {
        match self.normals {
            Some(n) => n[self.indices[face][vert] as usize].map(|x| x as f32),
            None => {
                // Flat shading (sec. 3.7.2.1 without NORMAL): the face normal.
                let (a, b, c) = (self.p(face, 0), self.p(face, 1), self.p(face, 2));
                let e1: [f64; 3] = std::array::from_fn(|k| b[k] - a[k]);
                let e2: [f64; 3] = std::array::from_fn(|k| c[k] - a[k]);
                let n = [
                    e1[1] * e2[2] - e1[2] * e2[1],
                    e1[2] * e2[0] - e1[0] * e2[2],
                    e1[0] * e2[1] - e1[1] * e2[0],
                ];
                let l = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
                if l > 0.0 {
                    n.map(|x| (x / l) as f32)
                } else {
                    [0.0, 0.0, 1.0]
                }
            }
        }
    }

    fn tex_coord(&self, face: usize, vert: usize) -> [f32; 2] {
        self.uvs[self.indices[face][vert] as usize]
    }

    fn set_tangent_encoded(&mut self, tangent: [f32; 4], face: usize, vert: usize) {
        self.out[3 * face + vert] = tangent;
    }
}

/// Fill `g`'s tangents by MikkTSpace from its positions, normals (the face normal where it has
/// none) and uvs (`uvs1` where `second`, else `uvs`; camsim's uvs, `v` up, so the handedness `w`
/// is glTF's: the bitangent `w n x t` points up the image). MikkTSpace gives one tangent per face
/// corner: a vertex whose corners get different tangents is split (copies appended, the other
/// vertices keep their numbers), every per-vertex array
/// (positions, normals, uvs, colours) copied with it, so the indices stay in step. False (and `g`
/// unchanged) where `g` is not a mesh with those uvs or MikkTSpace fails.
pub(crate) fn mikktspace(g: &mut Geometry, second: bool) -> bool {
    let Geometry::Triangles {
        positions,
        indices,
        uvs,
        normals,
        colors,
        uvs1,
        tangents,
    } = g
    else {
        return false;
    };
    let Some(set) = (if second { uvs1.as_ref() } else { uvs.as_ref() }) else {
        return false;
    };
    if positions.is_empty() || indices.is_empty() {
        return false;
    }
    let mut faces = Faces {
        positions,
        origin: positions[0],
        normals: normals.as_deref(),
        uvs: set,
        indices,
        out: vec![[0.0; 4]; 3 * indices.len()],
    };
    if !mikktspace::generate_tangents(&mut faces) {
        return false;
    }
    let out = faces.out;
    // One vertex per (original vertex, tangent): a vertex keeps its number for the first
    // tangent met at it; one with other tangents at other corners gets copies at the end.
    let n0 = positions.len();
    let mut new_tangents: Vec<[f32; 4]> = vec![[0.0; 4]; n0];
    let mut seen = vec![false; n0];
    let mut extra: HashMap<(u32, [u32; 4]), u32> = HashMap::new();
    let mut old_of_new: Vec<u32> = (0..n0 as u32).collect();
    let mut new_indices = Vec::with_capacity(indices.len());
    for (f, tri) in indices.iter().enumerate() {
        let mut nt = [0u32; 3];
        for v in 0..3 {
            let t = out[3 * f + v];
            let o = tri[v] as usize;
            nt[v] = if !seen[o] {
                seen[o] = true;
                new_tangents[o] = t;
                tri[v]
            } else if new_tangents[o].map(f32::to_bits) == t.map(f32::to_bits) {
                tri[v]
            } else {
                *extra
                    .entry((tri[v], t.map(f32::to_bits)))
                    .or_insert_with(|| {
                        old_of_new.push(tri[v]);
                        new_tangents.push(t);
                        (old_of_new.len() - 1) as u32
                    })
            };
        }
        new_indices.push(nt);
    }
    fn gather<T: Copy>(a: &mut Vec<T>, old_of_new: &[u32]) {
        *a = old_of_new.iter().map(|&o| a[o as usize]).collect();
    }
    gather(positions, &old_of_new);
    if let Some(a) = normals {
        gather(a, &old_of_new);
    }
    if let Some(a) = uvs {
        gather(a, &old_of_new);
    }
    if let Some(a) = uvs1 {
        gather(a, &old_of_new);
    }
    if let Some(a) = colors {
        gather(a, &old_of_new);
    }
    *indices = new_indices;
    *tangents = Some(new_tangents);
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two triangles sharing the edge x = 0 of the xy plane, their uvs mirrored across it (u =
    /// |x|): dp/du is +x on the right and -x on the left, so MikkTSpace gives the shared
    /// vertices two tangents and they are split; every array follows its vertex.
    #[test]
    fn split_vertices_keep_every_array_in_step() {
        let positions = vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [-1.0, 0.0, 0.0],
        ];
        let uvs: Vec<[f32; 2]> = positions
            .iter()
            .map(|p: &[f64; 3]| [p[0].abs() as f32, p[1] as f32])
            .collect();
        let colors: Vec<[f32; 4]> = (0..4).map(|i| [i as f32 / 4.0, 0.5, 1.0, 1.0]).collect();
        let indices = vec![[0, 1, 2], [0, 2, 3]];
        let mut g = Geometry::Triangles {
            positions: positions.clone(),
            indices: indices.clone(),
            uvs: Some(uvs.clone()),
            normals: Some(vec![[0.0, 0.0, 1.0]; 4]),
            colors: Some(colors.clone()),
            uvs1: Some(uvs.clone()),
            tangents: None,
        };
        assert!(mikktspace(&mut g, false));
        let Geometry::Triangles {
            positions: p,
            indices: ix,
            uvs: Some(u),
            normals: Some(n),
            colors: Some(c),
            uvs1: Some(u1),
            tangents: Some(t),
        } = &g
        else {
            panic!("arrays lost")
        };
        // The shared vertices 0 and 2 are split: 6 vertices, the first 4 keep their numbers.
        assert_eq!(p.len(), 6);
        for len in [u.len(), n.len(), c.len(), u1.len(), t.len()] {
            assert_eq!(len, p.len());
        }
        for (f, tri) in indices.iter().enumerate() {
            for v in 0..3 {
                let (old, new) = (tri[v] as usize, ix[f][v] as usize);
                assert_eq!(p[new], positions[old]);
                assert_eq!(u[new], uvs[old]);
                assert_eq!(c[new], colors[old]);
                // Right face: t = +x; left face: t = -x (u grows toward -x).
                let want = if f == 0 { 1.0 } else { -1.0 };
                assert!((t[new][0] - want).abs() < 1e-6, "face {f}: {:?}", t[new]);
            }
        }
        assert_eq!(ix[0], [0, 1, 2]);
    }
}
