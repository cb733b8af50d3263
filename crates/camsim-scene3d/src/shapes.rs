//! Shapes made into triangle meshes at load time: pbrt-v4 `disk` and `cylinder` (tessellated)
//! and `loopsubdiv` (Loop subdivision).
//!
//! Tessellation of the analytic quadrics is area-preserving: a circle of radius `r` split into
//! segments of angle `d` is replaced by a polygon whose vertices lie at `r * k`, with
//! `k^2 = d / sin d` for the disk's triangle fans (fan area `r^2 sin(d) / 2` per segment) and
//! `k = (d / 2) / sin(d / 2)` for the cylinder's planar side quads (chord = arc length). The
//! tessellated area, and with it an area light's emitted power `pi L A`, therefore equals the
//! analytic one to rounding; the surface moves by at most `r (k - 1) ~ r d^2 / 12` (2.7e-5 r
//! for the 256 segments of a full circle) inward/outward of the true quadric.

use crate::scene::Geometry;
use std::collections::HashMap;
use std::f64::consts::PI;

/// Segments for a full circle (the angular step is `phimax / ceil(SEGMENTS phimax / 2 pi)`).
pub const SEGMENTS_PER_TURN: usize = 256;

fn segments(phimax_rad: f64) -> usize {
    ((SEGMENTS_PER_TURN as f64 * phimax_rad / (2.0 * PI)).ceil() as usize).max(4)
}

fn check_phimax(phimax_deg: f64) -> Result<f64, String> {
    if !(phimax_deg > 0.0 && phimax_deg.is_finite()) {
        return Err(format!("phimax {phimax_deg} deg must be positive"));
    }
    Ok(phimax_deg.clamp(0.0, 360.0).to_radians())
}

/// pbrt-v4 `disk`: the annulus `innerradius <= r <= radius`, `0 <= phi <= phimax` in the plane
/// z = `height` (object space), normal +z. uv as pbrt-v4: `u = phi / phimax`,
/// `v = (radius - r) / (radius - innerradius)`. Analytic area `phimax / 2 (R^2 - Ri^2)`.
pub fn disk(
    height: f64,
    radius: f64,
    inner_radius: f64,
    phimax_deg: f64,
) -> Result<Geometry, String> {
    if !(radius > 0.0 && radius.is_finite() && height.is_finite()) {
        return Err(format!(
            "disk radius {radius} must be positive (height {height})"
        ));
    }
    if !(inner_radius >= 0.0 && inner_radius < radius) {
        return Err(format!(
            "disk innerradius {inner_radius} must be in [0, radius {radius})"
        ));
    }
    let phimax = check_phimax(phimax_deg)?;
    let n = segments(phimax);
    let d = phimax / n as f64;
    let k = (d / d.sin()).sqrt();
    let (ro, ri) = (radius * k, inner_radius * k);
    let mut positions = Vec::new();
    let mut uvs = Vec::new();
    let mut indices = Vec::new();
    let ring = |r: f64, i: usize| {
        let (s, c) = (i as f64 * d).sin_cos();
        [r * c, r * s, height]
    };
    if inner_radius == 0.0 {
        // Fans with one centre vertex per segment (so each carries its own u).
        for i in 0..=n {
            positions.push(ring(ro, i));
            uvs.push([(i as f64 / n as f64) as f32, 0.0]);
        }
        for i in 0..n {
            let c = positions.len() as u32;
            positions.push([0.0, 0.0, height]);
            uvs.push([((i as f64 + 0.5) / n as f64) as f32, 1.0]);
            indices.push([c, i as u32, i as u32 + 1]);
        }
    } else {
        for i in 0..=n {
            positions.push(ring(ro, i));
            uvs.push([(i as f64 / n as f64) as f32, 0.0]);
            positions.push(ring(ri, i));
            uvs.push([(i as f64 / n as f64) as f32, 1.0]);
        }
        for i in 0..n as u32 {
            let (o0, i0, o1, i1) = (2 * i, 2 * i + 1, 2 * i + 2, 2 * i + 3);
            indices.push([i0, o0, o1]);
            indices.push([i0, o1, i1]);
        }
    }
    Ok(Geometry::mesh(positions, indices, Some(uvs), None))
}

/// pbrt-v4 `cylinder`: radius `radius` around the z axis, `zmin <= z <= zmax`,
/// `0 <= phi <= phimax`, normal pointing away from the axis; no caps. uv as pbrt-v4:
/// `u = phi / phimax`, `v = (z - zmin) / (zmax - zmin)`. Analytic area `phimax r (zmax - zmin)`.
pub fn cylinder(radius: f64, zmin: f64, zmax: f64, phimax_deg: f64) -> Result<Geometry, String> {
    if !(radius > 0.0 && radius.is_finite()) {
        return Err(format!("cylinder radius {radius} must be positive"));
    }
    let (z0, z1) = (zmin.min(zmax), zmin.max(zmax));
    if !(z1 > z0 && z0.is_finite() && z1.is_finite()) {
        return Err(format!("cylinder zmin {zmin} and zmax {zmax} must differ"));
    }
    let phimax = check_phimax(phimax_deg)?;
    let n = segments(phimax);
    let d = phimax / n as f64;
    let r = radius * (d / 2.0) / (d / 2.0).sin();
    let mut positions = Vec::with_capacity(2 * (n + 1));
    let mut uvs = Vec::with_capacity(2 * (n + 1));
    for i in 0..=n {
        let (s, c) = (i as f64 * d).sin_cos();
        let u = (i as f64 / n as f64) as f32;
        positions.push([r * c, r * s, z0]);
        uvs.push([u, 0.0]);
        positions.push([r * c, r * s, z1]);
        uvs.push([u, 1.0]);
    }
    let mut indices = Vec::with_capacity(2 * n);
    for i in 0..n as u32 {
        let (b0, t0, b1, t1) = (2 * i, 2 * i + 1, 2 * i + 2, 2 * i + 3);
        // (p1 - p0) x (p2 - p0) = tangent x up-ish = outward.
        indices.push([b0, b1, t1]);
        indices.push([b0, t1, t0]);
    }
    Ok(Geometry::mesh(positions, indices, Some(uvs), None))
}

/// Loop's even-vertex weight beta(n) for valence n (Loop 1987; Warren's 3/(8n) for n > 3, as
/// pbrt-v4 `beta`).
fn loop_beta(valence: usize) -> f64 {
    if valence == 3 {
        3.0 / 16.0
    } else {
        3.0 / (8.0 * valence as f64)
    }
}

/// Weight of the one-ring in the limit position (pbrt-v4 `loopGamma`: 1 / (n + 3 / (8 beta))).
fn loop_gamma(valence: usize) -> f64 {
    1.0 / (valence as f64 + 3.0 / (8.0 * loop_beta(valence)))
}

/// Per-vertex topology of a triangle mesh: neighbours, and for boundary vertices the two
/// neighbours along the boundary.
struct Topology {
    /// Edge (lo, hi) -> the opposite vertex of each face that uses it (1 or 2 of them).
    edges: HashMap<(u32, u32), Vec<u32>>,
    neighbours: Vec<Vec<u32>>,
    boundary_neighbours: Vec<Vec<u32>>,
}

fn key(a: u32, b: u32) -> (u32, u32) {
    (a.min(b), a.max(b))
}

fn topology(n_vertices: usize, indices: &[[u32; 3]]) -> Result<Topology, String> {
    let mut edges: HashMap<(u32, u32), Vec<u32>> = HashMap::new();
    for (fi, t) in indices.iter().enumerate() {
        if t.iter().any(|&i| i as usize >= n_vertices)
            || t[0] == t[1]
            || t[1] == t[2]
            || t[0] == t[2]
        {
            return Err(format!(
                "loopsubdiv: triangle {fi} {t:?} is degenerate or out of range"
            ));
        }
        for k in 0..3 {
            let e = edges.entry(key(t[k], t[(k + 1) % 3])).or_default();
            e.push(t[(k + 2) % 3]);
            if e.len() > 2 {
                return Err(format!(
                    "loopsubdiv: edge {:?} is shared by more than two faces (non-manifold)",
                    key(t[k], t[(k + 1) % 3])
                ));
            }
        }
    }
    let mut neighbours = vec![Vec::new(); n_vertices];
    let mut boundary_neighbours = vec![Vec::new(); n_vertices];
    let mut sorted: Vec<_> = edges.iter().collect();
    sorted.sort_by_key(|(k, _)| **k);
    for ((a, b), opp) in sorted {
        neighbours[*a as usize].push(*b);
        neighbours[*b as usize].push(*a);
        if opp.len() == 1 {
            boundary_neighbours[*a as usize].push(*b);
            boundary_neighbours[*b as usize].push(*a);
        }
    }
    Ok(Topology {
        edges,
        neighbours,
        boundary_neighbours,
    })
}

fn add(a: [f64; 3], b: [f64; 3], k: f64) -> [f64; 3] {
    [a[0] + k * b[0], a[1] + k * b[1], a[2] + k * b[2]]
}

fn scaled(a: [f64; 3], k: f64) -> [f64; 3] {
    [a[0] * k, a[1] * k, a[2] * k]
}

/// `(1 - n w) p + w sum(neighbours)` (pbrt-v4 `weightOneRing`), or for boundary vertices
/// `(1 - 2 w_b) p + w_b (b0 + b1)`; vertices where more than two boundary edges meet stay put.
fn one_ring(
    p: &[[f64; 3]],
    topo: &Topology,
    v: usize,
    weight: impl Fn(usize) -> f64,
    boundary_weight: f64,
) -> [f64; 3] {
    let b = &topo.boundary_neighbours[v];
    if b.is_empty() {
        let nb = &topo.neighbours[v];
        let w = weight(nb.len());
        let mut out = scaled(p[v], 1.0 - nb.len() as f64 * w);
        for &q in nb {
            out = add(out, p[q as usize], w);
        }
        out
    } else if b.len() == 2 {
        let out = scaled(p[v], 1.0 - 2.0 * boundary_weight);
        add(
            add(out, p[b[0] as usize], boundary_weight),
            p[b[1] as usize],
            boundary_weight,
        )
    } else {
        p[v]
    }
}

/// Loop subdivision (C. Loop, "Smooth Subdivision Surfaces Based on Triangles", 1987; the
/// scheme of pbrt-v4's `loopsubdiv`): `levels` rounds of 1-to-4 splits with Loop's masks
/// (interior even vertices `beta`, boundary even `1/8, 3/4, 1/8`, interior odd `3/8, 3/8, 1/8,
/// 1/8`, boundary odd `1/2, 1/2`), then, if `to_limit`, every vertex moved to its limit
/// position (interior `gamma`, boundary `1/5, 3/5, 1/5`) as pbrt-v4 does. Returns positions,
/// triangles (orientation kept) and area-weighted vertex normals (pbrt-v4 computes limit
/// tangents instead; the difference is in the shading normals only).
#[allow(clippy::type_complexity)]
pub fn loop_subdivide(
    positions: &[[f64; 3]],
    indices: &[[u32; 3]],
    levels: u32,
    to_limit: bool,
) -> Result<(Vec<[f64; 3]>, Vec<[u32; 3]>, Vec<[f64; 3]>), String> {
    if levels > 12 {
        return Err(format!("loopsubdiv: {levels} levels is more than 12"));
    }
    let faces_out = (indices.len() as u64).saturating_mul(1u64 << (2 * levels));
    camsim_core::mem::check_alloc(faces_out.saturating_mul(120), "loopsubdiv mesh")
        .map_err(|e| e.to_string())?;
    if positions.iter().flatten().any(|v| !v.is_finite()) {
        return Err("loopsubdiv: a vertex is not finite".into());
    }
    let mut p = positions.to_vec();
    let mut tris = indices.to_vec();
    for _ in 0..levels {
        let topo = topology(p.len(), &tris)?;
        let mut next: Vec<[f64; 3]> = (0..p.len())
            .map(|v| one_ring(&p, &topo, v, loop_beta, 1.0 / 8.0))
            .collect();
        // Odd vertices, one per edge, numbered in sorted edge order (deterministic).
        let mut keys: Vec<(u32, u32)> = topo.edges.keys().copied().collect();
        keys.sort_unstable();
        let mut edge_vertex: HashMap<(u32, u32), u32> = HashMap::with_capacity(keys.len());
        for k in keys {
            let (a, b) = (p[k.0 as usize], p[k.1 as usize]);
            let opp = &topo.edges[&k];
            let q = if opp.len() == 2 {
                add(
                    scaled(add(a, b, 1.0), 3.0 / 8.0),
                    add(p[opp[0] as usize], p[opp[1] as usize], 1.0),
                    1.0 / 8.0,
                )
            } else {
                scaled(add(a, b, 1.0), 0.5)
            };
            edge_vertex.insert(k, next.len() as u32);
            next.push(q);
        }
        let mut nt = Vec::with_capacity(tris.len() * 4);
        for t in &tris {
            let m = [
                edge_vertex[&key(t[0], t[1])],
                edge_vertex[&key(t[1], t[2])],
                edge_vertex[&key(t[2], t[0])],
            ];
            nt.push([t[0], m[0], m[2]]);
            nt.push([m[0], t[1], m[1]]);
            nt.push([m[2], m[1], t[2]]);
            nt.push([m[0], m[1], m[2]]);
        }
        p = next;
        tris = nt;
    }
    if to_limit {
        let topo = topology(p.len(), &tris)?;
        p = (0..p.len())
            .map(|v| one_ring(&p, &topo, v, loop_gamma, 1.0 / 5.0))
            .collect();
    }
    let mut normals = vec![[0.0; 3]; p.len()];
    for t in &tris {
        let (a, b, c) = (p[t[0] as usize], p[t[1] as usize], p[t[2] as usize]);
        let n = crate::xform::cross(crate::xform::sub(b, a), crate::xform::sub(c, a));
        for &i in t {
            normals[i as usize] = add(normals[i as usize], n, 1.0);
        }
    }
    let normals = normals.into_iter().map(crate::xform::normalize).collect();
    Ok((p, tris, normals))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An open mesh (a square fan around a centre vertex): a planar one stays planar, its
    /// boundary stays one loop of boundary edges (doubling per level), and lifting the interior
    /// vertex never moves a boundary vertex (Loop's boundary masks use boundary neighbours
    /// only, so the boundary is the B-spline of the boundary polygon).
    #[test]
    fn open_mesh_boundary_rules() {
        let mut p = vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.5, 0.5, 0.0],
        ];
        let t = [[0u32, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]];
        for level in 1..=3u32 {
            let (flat, tris, _) = loop_subdivide(&p, &t, level, true).unwrap();
            assert!(flat.iter().all(|v| v[2] == 0.0));
            let topo = topology(flat.len(), &tris).unwrap();
            let boundary = topo.edges.values().filter(|o| o.len() == 1).count();
            assert_eq!(boundary, 4 << level, "level {level}");
            p[4][2] = 0.7;
            let (lifted, _, _) = loop_subdivide(&p, &t, level, true).unwrap();
            p[4][2] = 0.0;
            for (v, b) in topo.boundary_neighbours.iter().enumerate() {
                if !b.is_empty() {
                    assert_eq!(
                        flat[v], lifted[v],
                        "level {level}: boundary vertex {v} moved with the interior"
                    );
                } else {
                    assert!(lifted[v][2] > 0.0);
                }
            }
        }
        assert!(loop_subdivide(&p, &[[0, 1, 1]], 1, false).is_err());
    }
}
