//! Transform helpers the scene readers share: inverse, determinant, pbrt-v4's `LookAt`, and
//! moving a [`Shape`] by a transform (positions, normals, sphere centre/radius, curve control
//! points and widths, handedness).

// `!(x > 0.0)` comparisons are deliberate: they also reject NaN.

use crate::scene::{Geometry, Shape};
use crate::transform::Transform;

pub use crate::transform::{det3, inverse};

/// Transform a normal: (M^-1)^T n, normalised. `inv` is the inverse of the point transform.
pub fn apply_normal(inv: &Transform, n: [f64; 3]) -> [f64; 3] {
    let m = &inv.m;
    let v = [
        m[0][0] * n[0] + m[1][0] * n[1] + m[2][0] * n[2],
        m[0][1] * n[0] + m[1][1] * n[1] + m[2][1] * n[2],
        m[0][2] * n[0] + m[1][2] * n[1] + m[2][2] * n[2],
    ];
    normalize(v)
}

pub fn normalize(v: [f64; 3]) -> [f64; 3] {
    let l = dot(v, v).sqrt();
    if l > 0.0 {
        [v[0] / l, v[1] / l, v[2] / l]
    } else {
        v
    }
}
pub fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
pub fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
pub fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// pbrt-v4 `LookAt(pos, look, up)`: the camera-from-world transform (camera looks down +z,
/// +y up, +x = up x dir). Error text if `up` is parallel to the viewing direction.
pub fn look_at(pos: [f64; 3], look: [f64; 3], up: [f64; 3]) -> Result<Transform, String> {
    let dir = normalize(sub(look, pos));
    if dot(dir, dir) == 0.0 || !dir.iter().all(|v| v.is_finite()) {
        return Err("LookAt: the eye and the look-at point coincide".into());
    }
    let upn = normalize(up);
    if cross(upn, dir).iter().map(|v| v * v).sum::<f64>().sqrt() < 1e-9 {
        return Err("LookAt: the up vector and the viewing direction are parallel".into());
    }
    let right = normalize(cross(upn, dir));
    let new_up = cross(dir, right);
    let mut world_from_camera = Transform::identity();
    for r in 0..3 {
        world_from_camera.m[r][0] = right[r];
        world_from_camera.m[r][1] = new_up[r];
        world_from_camera.m[r][2] = dir[r];
        world_from_camera.m[r][3] = pos[r];
    }
    inverse(&world_from_camera).ok_or_else(|| "LookAt: degenerate transform".to_string())
}

/// Centre and uniform scale factor of a transform applied to a sphere; error text for
/// non-uniform scale or shear (a sphere must stay a sphere).
pub fn sphere_under(
    t: &Transform,
    center: [f64; 3],
    radius: f64,
) -> Result<([f64; 3], f64), String> {
    let cols: Vec<[f64; 3]> = (0..3).map(|c| [t.m[0][c], t.m[1][c], t.m[2][c]]).collect();
    let lens: Vec<f64> = cols.iter().map(|c| dot(*c, *c).sqrt()).collect();
    let s = lens[0];
    let tol = 1e-6 * s.max(1e-300);
    let ortho = dot(cols[0], cols[1]).abs() <= tol * s
        && dot(cols[0], cols[2]).abs() <= tol * s
        && dot(cols[1], cols[2]).abs() <= tol * s;
    if !(s > 0.0) || (lens[1] - s).abs() > tol || (lens[2] - s).abs() > tol || !ortho {
        return Err(format!(
            "a sphere under a non-uniform scale or shear is not a sphere (axis scales {:.6}, {:.6}, {:.6})",
            lens[0], lens[1], lens[2]
        ));
    }
    if t.m[3] != [0.0, 0.0, 0.0, 1.0] {
        return Err("a sphere under a projective transform is not supported".into());
    }
    Ok((t.apply_point(center), radius * s))
}

/// Move `shape` by `t` (world -> world): positions, normals (inverse transpose), sphere centre
/// and radius; a handedness-swapping `t` flips the shape's orientation (pbrt-v4
/// `transformSwapsHandedness`). Error text for a non-uniform scale of a sphere or a singular `t`.
pub fn transform_shape(shape: &mut Shape, t: &Transform) -> Result<(), String> {
    let inv = inverse(t).ok_or_else(|| "singular transform".to_string())?;
    let swaps = det3(t) < 0.0;
    match &mut shape.geometry {
        Geometry::Triangles {
            positions,
            indices,
            normals,
            tangents,
            ..
        } => {
            positions.iter_mut().for_each(|p| *p = t.apply_point(*p));
            // Tangents are directions on the surface (they move as vectors); the bitangent
            // `w n x t` keeps its side when a mirror flips `n x t`, so `w` flips with it.
            if let Some(ts) = tangents {
                for v in ts.iter_mut() {
                    let m = normalize(t.apply_vector([v[0] as f64, v[1] as f64, v[2] as f64]));
                    let w = if swaps { -v[3] } else { v[3] };
                    *v = [m[0] as f32, m[1] as f32, m[2] as f32, w];
                }
            }
            if let Some(ns) = normals {
                ns.iter_mut().for_each(|n| *n = apply_normal(&inv, *n));
                // With shading normals the geometric normal follows them (pbrt-v4 Triangle):
                // a mirror flips the winding, so swap it back to keep the emitting side.
                if swaps {
                    indices.iter_mut().for_each(|tri| tri.swap(1, 2));
                }
            } else if swaps {
                shape.reverse_orientation = !shape.reverse_orientation;
            }
        }
        Geometry::Sphere { center, radius } => {
            let (c, r) = sphere_under(t, *center, *radius)?;
            *center = c;
            *radius = r;
            if swaps {
                shape.reverse_orientation = !shape.reverse_orientation;
            }
        }
        Geometry::PartialSphere {
            center,
            radius,
            axes,
            z_min,
            z_max,
            ..
        } => {
            let (c, r) = sphere_under(t, *center, *radius)?;
            let s = r / *radius;
            *center = c;
            *radius = r;
            *z_min *= s;
            *z_max *= s;
            for a in axes.iter_mut() {
                let v = t.apply_vector(*a);
                *a = [v[0] / s, v[1] / s, v[2] / s];
            }
            if swaps {
                shape.reverse_orientation = !shape.reverse_orientation;
            }
        }
        Geometry::Curves(c) => {
            // A Bezier curve is affine invariant: its control points carry it exactly. The width
            // scales with the transform's mean linear scale |det|^(1/3) (exact for similarities;
            // pbrt-v4 keeps it in object space, where a non-uniform scale has no single width).
            let s = det3(t).abs().cbrt();
            if !(s > 0.0 && s.is_finite()) {
                return Err("singular transform".into());
            }
            for p in c.points.iter_mut() {
                let q = t.apply_point([p[0] as f64, p[1] as f64, p[2] as f64]);
                *p = [q[0] as f32, q[1] as f32, q[2] as f32];
            }
            for n in c.normals.iter_mut() {
                let q = apply_normal(&inv, [n[0] as f64, n[1] as f64, n[2] as f64]);
                *n = [q[0] as f32, q[1] as f32, q[2] as f32];
            }
            c.width_m = c.width_m.map(|w| (w as f64 * s) as f32);
            if swaps {
                shape.reverse_orientation = !shape.reverse_orientation;
            }
        }
        #[allow(unreachable_patterns)]
        _ => return Err("this geometry cannot be transformed by the scene reader".into()),
    }
    // The shape's placement moves with it (the orientation of its 3D box label).
    if let Some(m) = &mut shape.tags.object_to_world {
        *m = t.then_apply_to(m);
    }
    // So do its keypoints.
    if let Some(k) = &mut shape.tags.keypoints {
        let mut moved = (**k).clone();
        for p in moved.points_m.iter_mut() {
            *p = t.apply_point(*p);
        }
        *k = std::sync::Arc::new(moved);
    }
    Ok(())
}

/// Surface area of a shape, m^2.
pub fn shape_area(g: &Geometry) -> f64 {
    match g {
        Geometry::Triangles {
            positions, indices, ..
        } => indices
            .iter()
            .map(|t| {
                let (a, b, c) = (
                    positions[t[0] as usize],
                    positions[t[1] as usize],
                    positions[t[2] as usize],
                );
                0.5 * dot(cross(sub(b, a), sub(c, a)), cross(sub(b, a), sub(c, a))).sqrt()
            })
            .sum(),
        Geometry::Sphere { radius, .. } => 4.0 * std::f64::consts::PI * radius * radius,
        // pbrt-v4 Sphere::Area (4th ed. §6.2.4): phi_max r (z_max - z_min).
        Geometry::PartialSphere {
            radius,
            z_min,
            z_max,
            phi_max_deg,
            ..
        } => phi_max_deg.to_radians() * radius * (z_max - z_min),
        Geometry::Curves(c) => c.area_m2(),
        #[allow(unreachable_patterns)]
        _ => 0.0,
    }
}

/// Axis-aligned bounds (min, max) of a shape, m.
pub fn shape_bounds(g: &Geometry) -> ([f64; 3], [f64; 3]) {
    match g {
        Geometry::Triangles { positions, .. } => {
            let mut lo = [f64::INFINITY; 3];
            let mut hi = [f64::NEG_INFINITY; 3];
            for p in positions {
                for k in 0..3 {
                    lo[k] = lo[k].min(p[k]);
                    hi[k] = hi[k].max(p[k]);
                }
            }
            (lo, hi)
        }
        Geometry::Sphere { center, radius } | Geometry::PartialSphere { center, radius, .. } => (
            [center[0] - radius, center[1] - radius, center[2] - radius],
            [center[0] + radius, center[1] + radius, center[2] + radius],
        ),
        Geometry::Curves(c) => c.bounds_m(),
        #[allow(unreachable_patterns)]
        _ => ([0.0; 3], [0.0; 3]),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inverse_and_look_at() {
        let t = Transform::translate([1.0, 2.0, 3.0])
            .then_apply_to(&Transform::rotate(30.0, [1.0, 1.0, 0.0]));
        let i = inverse(&t).unwrap();
        let p = i.apply_point(t.apply_point([0.3, -0.7, 2.0]));
        assert!(
            (p[0] - 0.3).abs() < 1e-12 && (p[1] + 0.7).abs() < 1e-12 && (p[2] - 2.0).abs() < 1e-12
        );
        let cam = look_at([0.0, 0.0, -5.0], [0.0, 0.0, 0.0], [0.0, 1.0, 0.0]).unwrap();
        let c = cam.apply_point([0.0, 0.0, 0.0]);
        assert!((c[2] - 5.0).abs() < 1e-12 && c[0].abs() < 1e-12);
        assert!(look_at([0.0; 3], [0.0, 1.0, 0.0], [0.0, 1.0, 0.0]).is_err());
    }
}
