//! Shading geometry at a hit and the shading normal that bump and normal maps perturb
//! (pbrt-v4 `SurfaceInteraction::GetBSDF`; the maps themselves are in [`crate::bump`]).

use super::Tracer;
use crate::bump::{
    bump_normal, coordinate_system, mapped_normal, sphere_geometry, triangle_geometry, Perturb,
    ShadingGeometry,
};
use crate::bvh::{Bvh, Hit};
use crate::geometry::{Prim, PrimInfo, SurfaceHit};
use crate::materials::Mat;
use crate::math::V3;
use crate::motion::PathTime;
use crate::texture::eval_float;

impl Tracer {
    /// pbrt-v4's shading geometry at hit `h` (`sh` its surface data) of primitive `pi`, at the
    /// path's time `pt` (a moving primitive's in its group's reference pose, moved to the world).
    pub(super) fn shading_geometry(
        &self,
        h: &Hit,
        pi: &PrimInfo,
        sh: &SurfaceHit,
        pt: &PathTime,
    ) -> ShadingGeometry {
        match self.bvh.prims.get(h.slot as usize) {
            Some(prim) => self.shading_geometry_of(prim, &self.bvh, pi, sh),
            None => self.moving_shading_geometry(h, pi, sh, pt),
        }
    }

    /// The shading geometry at `sh` on `prim` (partial-sphere clips from `side`, the BVH that
    /// holds it), in the frame `prim` and `sh` are given in.
    pub(crate) fn shading_geometry_of(
        &self,
        prim: &Prim,
        side: &Bvh,
        pi: &PrimInfo,
        sh: &SurfaceHit,
    ) -> ShadingGeometry {
        let n = self.oriented_normal(pi, sh);
        match *prim {
            Prim::Tri { p0, e1, e2 } => {
                let mesh = self.meshes[pi.shape as usize].as_ref();
                let tri = mesh.map(|m| m.indices[pi.tri as usize]);
                let uv = match (mesh.and_then(|m| m.uvs.as_ref()), tri) {
                    (Some(t), Some(i)) => [t[i[0] as usize], t[i[1] as usize], t[i[2] as usize]],
                    _ => [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]],
                };
                let vn = match (mesh.and_then(|m| m.normals.as_ref()), tri) {
                    (Some(nv), Some(i)) => {
                        Some([nv[i[0] as usize], nv[i[1] as usize], nv[i[2] as usize]])
                    }
                    _ => None,
                };
                let ns = if vn.is_some() { sh.ns } else { n };
                let mut g = triangle_geometry([p0, p0 + e1, p0 + e2], uv, vn, sh.p, sh.uv, n, ns);
                // The mesh's tangents interpolated at the hit (glTF 2.0 sec. 3.7.2.1: vertex
                // attributes interpolate linearly); the handedness of the nearest vertex.
                if let (Some(ts), Some(i)) = (mesh.and_then(|m| m.tangents.as_ref()), tri) {
                    let [a, b, c] = [ts[i[0] as usize], ts[i[1] as usize], ts[i[2] as usize]];
                    let (b1, b2) = barycentrics(p0, e1, e2, sh.p);
                    let b0 = 1.0 - b1 - b2;
                    g.tangent = a.0 * b0 + b.0 * b1 + c.0 * b2;
                    g.tangent_w = if b0 >= b1 && b0 >= b2 {
                        a.1
                    } else if b1 >= b2 {
                        b.1
                    } else {
                        c.1
                    };
                }
                g
            }
            Prim::Sphere { center, radius } => sphere_geometry(
                sh.p - center,
                radius,
                [
                    V3::new(1.0, 0.0, 0.0),
                    V3::new(0.0, 1.0, 0.0),
                    V3::new(0.0, 0.0, 1.0),
                ],
                -radius,
                radius,
                2.0 * std::f32::consts::PI,
                sh.p,
                sh.uv,
                n,
            ),
            Prim::PartialSphere {
                center,
                radius,
                clip,
            } => {
                let c = &side.clips[clip as usize];
                sphere_geometry(
                    c.local(sh.p - center),
                    radius,
                    [c.ex, c.ey, c.ez],
                    c.z_min,
                    c.z_max,
                    c.phi_max,
                    sh.p,
                    sh.uv,
                    n,
                )
            }
            // A curve's surface at the hit: dp/du along the fibre, dp/dv across it (pbrt-v4
            // `Curve::InteractionFromIntersection` takes dn/du = dn/dv = 0 as well).
            Prim::Curve { .. } => {
                let (dpdu, dpdv) = if sh.dpdu.length_squared() > 0.0 {
                    (sh.dpdu, n.cross(sh.dpdu))
                } else {
                    coordinate_system(n)
                };
                ShadingGeometry {
                    p: sh.p,
                    uv: sh.uv,
                    n,
                    dpdu,
                    dpdv,
                    ns: n,
                    ss: dpdu.normalize(),
                    ts: dpdv.normalize(),
                    dndu: V3::new(0.0, 0.0, 0.0),
                    dndv: V3::new(0.0, 0.0, 0.0),
                    tangent: V3::splat(0.0),
                    tangent_w: 1.0,
                }
            }
        }
    }

    /// The material that scatters at a hit and its shading normal: material `m` (mixes already
    /// chosen) unwrapped from its bump or normal map, which perturbs the hit's shading normal
    /// `sh.ns` (pbrt-v4 `SurfaceInteraction::GetBSDF`); other materials keep `sh.ns`.
    #[inline]
    pub(crate) fn shading_normal(
        &self,
        m: u32,
        h: &Hit,
        pi: &PrimInfo,
        sh: &SurfaceHit,
        pt: &PathTime,
    ) -> (u32, V3) {
        let Mat::Bumped { base, perturb } = &self.materials[m as usize] else {
            return (m, sh.ns);
        };
        let g = self.shading_geometry(h, pi, sh, pt);
        let ns = match perturb {
            Perturb::NormalMap(map) => {
                let uv = if map.uv1 { sh.uv1 } else { g.uv };
                mapped_normal(&g, map, uv)
            }
            Perturb::Displacement(tex) => {
                let duv = self.footprint.uv_derivatives(&g);
                let (du, dv) = crate::bump::shifts_of(duv);
                bump_normal(&g, du, dv, duv, |ctx| eval_float(tex, ctx))
            }
        };
        (*base, ns)
    }
}

/// The barycentrics `(b1, b2)` of point `p` on the triangle `p0`, `p0 + e1`, `p0 + e2` (the
/// least-squares solution of `p - p0 = b1 e1 + b2 e2`).
fn barycentrics(p0: V3, e1: V3, e2: V3, p: V3) -> (f32, f32) {
    let d = p - p0;
    let (a11, a12, a22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
    let (r1, r2) = (d.dot(e1), d.dot(e2));
    let det = a11 * a22 - a12 * a12;
    if !(det.abs() > 0.0) {
        return (0.0, 0.0);
    }
    ((a22 * r1 - a12 * r2) / det, (a11 * r2 - a12 * r1) / det)
}
