//! Bump and normal mapping (pbrt-v4 4th ed. sec. 10.5.1 `BumpMap`, `NormalMap`, and
//! `SurfaceInteraction::GetBSDF`): a material's `displacement` texture or `normalmap` image
//! perturbs the shading normal at a hit; the BSDF is then built around the perturbed normal.
//!
//! - Shading geometry as pbrt-v4's shapes compute it: triangles take `dp/du`, `dp/dv` from their
//!   uv (pbrt-v4 default uvs (0,0), (1,0), (1,1)), a uv-less or degenerate parameterisation gets
//!   a coordinate system around the face normal; with vertex normals the shading tangent is
//!   `dp/du` made orthogonal to the interpolated normal and the shading `dp/dv` is `n x dp/du`
//!   (pbrt-v4 `Triangle::InteractionFromIntersection`, whose shading `dp/dv` has the length of
//!   `dp/du`), `dn/du`, `dn/dv` from the vertex normals; spheres take pbrt-v4's `(phi, theta)`
//!   parameterisation with `dn/du = dp/du / r` (the Weingarten equations on a sphere).
//! - `BumpMap`: `dp/du' = dp/du + (D(u + du) - D(u)) / du n + D dn/du` (and the same in v), the
//!   shading normal `dp/du' x dp/dv'` turned to the geometric normal's side. pbrt-v4's shift:
//!   `du = (|du/dx| + |du/dy|) / 2` over the pixel footprint at the hit, `0.0005` where that is
//!   zero. camsim traces no ray differentials: the footprint is pbrt-v4's
//!   `Camera::Approximate_dp_dxy` (the camera's smallest one-pixel direction change, across the
//!   image along its rows and columns, met at the hit's distance on its tangent plane, times
//!   `max(1/8, 1/sqrt(spp))`) at every vertex; pbrt-v4 uses the camera ray's own differentials
//!   at the first hit and carries them through specular bounces. The three displacement
//!   lookups carry the hit's footprint, as pbrt-v4's shifted texture contexts copy it: a
//!   `trilinear` displacement is read at the MIP level the footprint picks (read at full
//!   resolution, a fine texture's finite differences straddle texels and tilt the normal far
//!   more than pbrt-v4's: the bathroom floor of issue 43).
//! - `NormalMap`: the image's RGB (linear, bilinear, repeat wrap, at `(u, 1 - v)`) as `2 rgb - 1`
//!   in the tangent frame `(dp/du, n x dp/du, n)`, normalised; on a mesh with tangents (glTF
//!   `TANGENT` or MikkTSpace's, `MeshShading::tangents`) the frame is `(t, w n x t, n)` with `t`
//!   the interpolated tangent made orthogonal to the shading normal (glTF 2.0 sec. 3.7.2.1),
//!   looked up at the second uv set where the map names it. pbrt-v4 rebuilds `dp/du`, `dp/dv`
//!   around it and takes their cross product: the same normal up to rounding, which camsim skips
//!   (so a flat map, `(0.5, 0.5, 1)`, leaves the shading normal bit for bit).
//!
//! The BSDF's frame around the perturbed normal is camsim's `Frame::from_normal` as everywhere
//! (pbrt-v4 aligns it with the shading `dp/du`; it matters only to anisotropic roughness).

use crate::math::{Frame, V3};
use crate::scene::{Camera, NormalMapImage};
use crate::texture::{FTex, TexCtx};
use std::sync::Arc;

/// pbrt-v4 `BumpMap`'s shift when the footprint gives none.
const DEFAULT_SHIFT: f32 = 0.0005;

/// Bilinear lookup of a normal map with repeat wrap at surface `(u, v)` (pbrt-v4 `NormalMap`:
/// `BilerpChannel((u, 1 - v), c, Repeat)`), as nested lerps, exact on a constant image.
fn lookup(map: &NormalMapImage, uv: [f32; 2]) -> [f32; 3] {
    let (idx, _) = crate::image_tex::bilinear_texels(
        map.width,
        map.height,
        uv[0],
        uv[1],
        crate::scene::WrapMode::Repeat,
    );
    let x = uv[0] * map.width as f32 - 0.5;
    let y = (1.0 - uv[1]) * map.height as f32 - 0.5;
    let (fx, fy) = (x - x.floor(), y - y.floor());
    let (fx, fy) = if fx.is_finite() && fy.is_finite() {
        (fx, fy)
    } else {
        (0.0, 0.0)
    };
    let lerp = |t: f32, a: f32, b: f32| a + t * (b - a);
    std::array::from_fn(|c| {
        let t = |k: usize| map.rgb[idx[k]][c];
        lerp(fy, lerp(fx, t(0), t(1)), lerp(fx, t(2), t(3)))
    })
}

/// What perturbs a material's shading normal (compiled).
#[derive(Debug, Clone)]
pub(crate) enum Perturb {
    /// pbrt-v4 `displacement`: a float texture, displacement along the shading normal.
    Displacement(FTex),
    /// pbrt-v4 `normalmap`.
    NormalMap(Arc<NormalMapImage>),
}

/// Compile a scene's normal perturbation for material `material_index` (its texture or image
/// checked: finite, the right size).
pub(crate) fn compile(
    p: &crate::scene::NormalPerturbation,
    material_index: usize,
) -> Result<Perturb, crate::error::RenderError> {
    use crate::scene::NormalPerturbation as P;
    Ok(match p {
        P::Displacement(t) => {
            Perturb::Displacement(crate::texture::compile_float_texture(t, material_index)?)
        }
        P::NormalMap(im) => {
            if im.width == 0 || im.height == 0 || im.rgb.len() != im.width * im.height {
                return Err(crate::error::RenderError::Material {
                    index: material_index,
                    message: format!(
                        "normal map of {} x {} pixels has {} texels",
                        im.width,
                        im.height,
                        im.rgb.len()
                    ),
                });
            }
            if im.rgb.iter().flatten().any(|v| !v.is_finite()) {
                return Err(crate::error::RenderError::Material {
                    index: material_index,
                    message: "normal map has a non-finite texel".into(),
                });
            }
            Perturb::NormalMap(im.clone())
        }
    })
}

/// pbrt-v4's shading geometry at a hit (render space): the point, uv, geometric normal
/// (oriented as pbrt-v4 orients it), the shading normal and its partial derivatives.
#[derive(Debug, Clone, Copy)]
pub(crate) struct ShadingGeometry {
    pub p: V3,
    pub uv: [f32; 2],
    /// Geometric normal, pbrt-v4's orientation (`n`).
    pub n: V3,
    /// Geometric `dp/du`, `dp/dv` (what pbrt-v4's `ComputeDifferentials` projects on).
    pub dpdu: V3,
    pub dpdv: V3,
    /// Shading normal and `dp/du`, `dp/dv`, `dn/du`, `dn/dv` (pbrt-v4 `shading.*`).
    pub ns: V3,
    pub ss: V3,
    pub ts: V3,
    pub dndu: V3,
    pub dndv: V3,
    /// A normal map's tangent from the mesh (glTF `TANGENT` or MikkTSpace, interpolated; zero
    /// where the shape has none: the frame is then `dp/du`'s) and its handedness `w` (+-1).
    pub tangent: V3,
    pub tangent_w: f32,
}

/// A coordinate system around the unit vector `n` (pbrt-v4 `CoordinateSystem`, Duff et al.
/// 2017: the same construction as `Frame::from_normal`).
pub(crate) fn coordinate_system(n: V3) -> (V3, V3) {
    let f = Frame::from_normal(n);
    (f.s, f.t)
}

/// pbrt-v4 `Triangle::InteractionFromIntersection`'s differential geometry: vertices `p`,
/// uvs `uv`, optional unit vertex normals `vn`, barycentrics `(b1, b2)` of vertices 1 and 2, and
/// `n` the oriented geometric normal, `ns` the shading normal at the hit.
pub(crate) fn triangle_geometry(
    p: [V3; 3],
    uv: [[f32; 2]; 3],
    vn: Option<[V3; 3]>,
    hit_p: V3,
    hit_uv: [f32; 2],
    n: V3,
    ns: V3,
) -> ShadingGeometry {
    let duv02 = [uv[0][0] - uv[2][0], uv[0][1] - uv[2][1]];
    let duv12 = [uv[1][0] - uv[2][0], uv[1][1] - uv[2][1]];
    let (dp02, dp12) = (p[0] - p[2], p[1] - p[2]);
    let det = duv02[0] * duv12[1] - duv02[1] * duv12[0];
    let degenerate = det.abs() < 1e-9;
    let (mut dpdu, mut dpdv) = (V3::splat(0.0), V3::splat(0.0));
    if !degenerate {
        let inv = 1.0 / det;
        dpdu = (dp02 * duv12[1] - dp12 * duv02[1]) * inv;
        dpdv = (dp12 * duv02[0] - dp02 * duv12[0]) * inv;
    }
    if degenerate || dpdu.cross(dpdv).length_squared() == 0.0 {
        let ng = (p[2] - p[0]).cross(p[1] - p[0]);
        (dpdu, dpdv) = coordinate_system(ng.normalize());
    }
    let (mut ss, mut ts, mut dndu, mut dndv) = (dpdu, dpdv, V3::splat(0.0), V3::splat(0.0));
    if let Some(vn) = vn {
        // Shading tangent: dp/du made orthogonal to ns; bitangent ns x ss.
        ts = ns.cross(dpdu);
        if ts.length_squared() > 0.0 {
            ss = ts.cross(ns);
        } else {
            (ss, ts) = coordinate_system(ns);
        }
        let (dn1, dn2) = (vn[0] - vn[2], vn[1] - vn[2]);
        if degenerate {
            let dn = (vn[2] - vn[0]).cross(vn[1] - vn[0]);
            if dn.length_squared() > 0.0 {
                (dndu, dndv) = coordinate_system(dn.normalize());
            }
        } else {
            let inv = 1.0 / det;
            dndu = (dn1 * duv12[1] - dn2 * duv02[1]) * inv;
            dndv = (dn2 * duv02[0] - dn1 * duv12[0]) * inv;
        }
    }
    ShadingGeometry {
        p: hit_p,
        uv: hit_uv,
        n,
        dpdu,
        dpdv,
        ns,
        ss,
        ts,
        dndu,
        dndv,
        tangent: V3::splat(0.0),
        tangent_w: 1.0,
    }
}

/// pbrt-v4 `Sphere::InteractionFromIntersection`'s differential geometry at object-frame point
/// `l` (offset from the centre, radius `r`), the frame's axes `axes` in render space, the
/// sphere's `z` range and `phi_max`; `n` the oriented normal, `p` and `uv` the hit's.
#[allow(clippy::too_many_arguments)]
pub(crate) fn sphere_geometry(
    l: V3,
    r: f32,
    axes: [V3; 3],
    z_min: f32,
    z_max: f32,
    phi_max: f32,
    p: V3,
    uv: [f32; 2],
    n: V3,
) -> ShadingGeometry {
    let world = |v: V3| axes[0] * v.x + axes[1] * v.y + axes[2] * v.z;
    let th0 = (z_min / r).clamp(-1.0, 1.0).acos();
    let th1 = (z_max / r).clamp(-1.0, 1.0).acos();
    let z_radius = (l.x * l.x + l.y * l.y).sqrt();
    let (cos_phi, sin_phi) = if z_radius > 0.0 {
        (l.x / z_radius, l.y / z_radius)
    } else {
        (1.0, 0.0)
    };
    let sin_theta = (1.0 - (l.z / r).powi(2)).max(0.0).sqrt();
    let dpdu = world(V3::new(-phi_max * l.y, phi_max * l.x, 0.0));
    let dpdv = world(V3::new(l.z * cos_phi, l.z * sin_phi, -r * sin_theta) * (th1 - th0));
    // Weingarten equations on a sphere: dn/du = dp/du / r, dn/dv = dp/dv / r.
    let (dndu, dndv) = (dpdu * (1.0 / r), dpdv * (1.0 / r));
    ShadingGeometry {
        p,
        uv,
        n,
        dpdu,
        dpdv,
        ns: n,
        ss: dpdu,
        ts: dpdv,
        dndu,
        dndv,
        tangent: V3::splat(0.0),
        tangent_w: 1.0,
    }
}

/// `BumpMap`: the shading normal of `g` displaced by `disp` along it, with shifts `du`, `dv`
/// (`disp` evaluates the displacement texture at a texture context), turned to `g.n`'s side.
/// Every lookup carries the hit's footprint `duv` (`du/dx`, `du/dy`, `dv/dx`, `dv/dy`), as
/// pbrt-v4's shifted contexts copy the hit's: a MIP-mapped displacement is read at the level the
/// footprint picks at all three points, not at full resolution.
pub(crate) fn bump_normal(
    g: &ShadingGeometry,
    du: f32,
    dv: f32,
    duv: [f32; 4],
    disp: impl Fn(&TexCtx) -> f32,
) -> V3 {
    let ctx = |p: V3, uv: [f32; 2]| TexCtx {
        duv,
        ..TexCtx::at_uv(uv, g.n, p)
    };
    let d_u = disp(&ctx(g.p + g.ss * du, [g.uv[0] + du, g.uv[1]]));
    let d_v = disp(&ctx(g.p + g.ts * dv, [g.uv[0], g.uv[1] + dv]));
    let d = disp(&ctx(g.p, g.uv));
    let dpdu = g.ss + g.ns * ((d_u - d) / du) + g.dndu * d;
    let dpdv = g.ts + g.ns * ((d_v - d) / dv) + g.dndv * d;
    let ns = dpdu.cross(dpdv).normalize();
    if ns.is_finite() && ns.length_squared() > 0.0 {
        // pbrt-v4 SetShadingGeometry(..., false): the shading normal faces n.
        ns.face_forward(g.n)
    } else {
        g.ns
    }
}

/// `NormalMap`: the map's tangent-space normal at `g.uv` in the frame `(dp/du, n x dp/du, n)`
/// of the shading geometry.
pub(crate) fn mapped_normal(g: &ShadingGeometry, map: &NormalMapImage, uv: [f32; 2]) -> V3 {
    let c = lookup(map, uv);
    let local = V3::new(2.0 * c[0] - 1.0, 2.0 * c[1] - 1.0, 2.0 * c[2] - 1.0);
    let len = local.length();
    // The mesh's tangent where it has one (glTF 2.0 sec. 3.7.2.1 and 3.9.3: the normal texture
    // is in the frame (t, w n x t, n)), made orthogonal to the shading normal (Gram-Schmidt).
    let t = g.tangent - g.ns * g.ns.dot(g.tangent);
    let tl = t.length();
    let (x, w) = if tl > 0.0 && tl.is_finite() {
        (t / tl, g.tangent_w)
    } else {
        (g.ss.normalize(), 1.0)
    };
    if !(len > 0.0 && len.is_finite() && x.is_finite()) {
        return g.ns;
    }
    let local = if len == 1.0 { local } else { local / len };
    // pbrt-v4 Frame::FromXZ(normalize(dpdu), n): y = z x x (times glTF's handedness w).
    let y = g.ns.cross(x) * w;
    x * local.x + y * local.y + g.ns * local.z
}

/// The pixel footprint pbrt-v4's `Camera::Approximate_dp_dxy` gives at a point (for bump
/// mapping's shifts and the filtered textures, `crate::image_tex`): the camera's
/// position and axes, the smallest one-pixel direction change over the image (pbrt-v4
/// `FindMinimumDifferentials`, rows and columns), and `max(1/8, 1/sqrt(spp))`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Footprint {
    origin: V3,
    axes: [V3; 3],
    min_dir: [f32; 2],
    spp_scale: f32,
}

impl Footprint {
    pub(crate) fn new(camera: &Camera, spp: u32) -> Footprint {
        let m = &camera.camera_to_world.m;
        let col = |j: usize| V3::new(m[0][j] as f32, m[1][j] as f32, m[2][j] as f32).normalize();
        let origin = V3::new(m[0][3] as f32, m[1][3] as f32, m[2][3] as f32);
        // A pinhole of `fov_deg` across the shorter side: pixel size at z = 1.
        let (w, h) = (camera.width.max(1) as f64, camera.height.max(1) as f64);
        let s = 2.0 * (camera.fov_deg.to_radians() / 2.0).tan() / w.min(h);
        let (hx, hy) = (w / 2.0 * s, h / 2.0 * s);
        // pbrt-v4 FindMinimumDifferentials: 512 film points along the diagonal.
        let mut min_dir = [f64::INFINITY; 2];
        let n = 512;
        for i in 0..n {
            let t = i as f64 / (n - 1) as f64;
            let p = [-hx + 2.0 * hx * t, hy - 2.0 * hy * t, 1.0];
            let unit = |q: [f64; 3]| {
                let l = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2]).sqrt();
                q.map(|c| c / l)
            };
            let d = unit(p);
            for (k, off) in [[s, 0.0, 0.0], [0.0, -s, 0.0]].iter().enumerate() {
                let e = unit([p[0] + off[0], p[1] + off[1], p[2] + off[2]]);
                let len =
                    ((e[0] - d[0]).powi(2) + (e[1] - d[1]).powi(2) + (e[2] - d[2]).powi(2)).sqrt();
                min_dir[k] = min_dir[k].min(len);
            }
        }
        Footprint {
            origin,
            axes: [col(0), col(1), col(2)],
            min_dir: min_dir.map(|v| if v.is_finite() { v as f32 } else { 0.0 }),
            spp_scale: (1.0 / (spp.max(1) as f32).sqrt()).max(0.125),
        }
    }

    /// The footprint's `du/dx`, `du/dy`, `dv/dx`, `dv/dy` at shading geometry `g` (pbrt-v4
    /// `SurfaceInteraction::ComputeDifferentials`: the one-pixel steps of `Approximate_dp_dxy`
    /// solved by least squares on the geometric `dp/du`, `dp/dv`; each clamped to +-1e8, zero
    /// where undefined).
    pub(crate) fn uv_derivatives(&self, g: &ShadingGeometry) -> [f32; 4] {
        let q = g.p - self.origin;
        let dist = q.length();
        let mut out = [0f32; 4];
        if !(dist > 0.0 && dist.is_finite()) {
            return out;
        }
        let d = q / dist;
        let (a00, a01, a11) = (g.dpdu.dot(g.dpdu), g.dpdu.dot(g.dpdv), g.dpdv.dot(g.dpdv));
        let inv = 1.0 / (a00 * a11 - a01 * a01);
        let inv = if inv.is_finite() { inv } else { 0.0 };
        let clamp = |v: f32| {
            if v.is_finite() {
                v.clamp(-1e8, 1e8)
            } else {
                0.0
            }
        };
        for k in 0..2 {
            // The differential ray: the view direction turned by the smallest pixel step
            // along the image's rows (k = 0) or columns (k = 1), met on the tangent plane.
            let side = self.axes[k] - d * self.axes[k].dot(d);
            let side = side.normalize();
            let dir = d + side * self.min_dir[k];
            let denom = g.n.dot(dir);
            let t = g.n.dot(q) / denom;
            let dp = (dir * t - q) * self.spp_scale;
            if !(t.is_finite() && dp.is_finite()) {
                continue;
            }
            let (b0, b1) = (g.dpdu.dot(dp), g.dpdv.dot(dp));
            out[k] = clamp((a11 * b0 - a01 * b1) * inv);
            out[2 + k] = clamp((a00 * b1 - a01 * b0) * inv);
        }
        out
    }
}

/// pbrt-v4 `BumpMap`'s `du`, `dv` from a footprint's `[du/dx, du/dy, dv/dx, dv/dy]`
/// ([`Footprint::uv_derivatives`]): half the sum of the absolute derivatives, `0.0005` where that
/// is zero.
pub(crate) fn shifts_of(duv: [f32; 4]) -> (f32, f32) {
    let [dudx, dudy, dvdx, dvdy] = duv;
    // Summed as halves, in this order (the renders' bits depend on it).
    let du = 0.5 * dudx.abs() + 0.5 * dudy.abs();
    let dv = 0.5 * dvdx.abs() + 0.5 * dvdy.abs();
    (
        if du == 0.0 { DEFAULT_SHIFT } else { du },
        if dv == 0.0 { DEFAULT_SHIFT } else { dv },
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plane(dpdu: V3, dpdv: V3) -> ShadingGeometry {
        let n = dpdu.cross(dpdv).normalize();
        ShadingGeometry {
            p: V3::new(0.3, -0.2, 0.0),
            uv: [0.4, 0.7],
            n,
            dpdu,
            dpdv,
            ns: n,
            ss: dpdu,
            ts: dpdv,
            dndu: V3::splat(0.0),
            dndv: V3::splat(0.0),
            tangent: V3::splat(0.0),
            tangent_w: 1.0,
        }
    }

    /// A displacement linear in u, `D = a u`, on a plane with `|dp/du| = L`: the displaced
    /// surface's tangent is `dp/du + a n`, so the shading normal tilts away from `dp/du` by
    /// `atan(a / L)` exactly, for any shift `du` (a finite difference of a linear function is
    /// exact); with `D = a u + b v` on orthogonal `dp/du`, `dp/dv` it is `(-a/L_u, -b/L_v, 1)`
    /// normalised in the frame `(dp/du, dp/dv, n)`.
    #[test]
    fn a_linear_bump_tilts_the_normal_by_the_closed_form_angle() {
        let g = plane(V3::new(2.0, 0.0, 0.0), V3::new(0.0, 3.0, 0.0));
        for (a, du) in [(0.5f32, 0.0005f32), (2.0, 0.01), (-1.0, 0.1)] {
            let ns = bump_normal(&g, du, du, [0.0; 4], |c| a * c.uv[0]);
            let tilt = ns.dot(g.n).clamp(-1.0, 1.0).acos();
            let want = (a / 2.0).abs().atan();
            assert!((tilt - want).abs() < 2e-4, "a {a}: tilt {tilt} vs {want}");
            // Tilted against the direction the surface rises in.
            assert!(ns.x * a < 0.0 && ns.y.abs() < 1e-5, "{ns:?}");
        }
        let (a, b) = (0.8f32, -0.6f32);
        let ns = bump_normal(&g, 0.001, 0.001, [0.0; 4], |c| a * c.uv[0] + b * c.uv[1]);
        let want = V3::new(-a / 2.0, -b / 3.0, 1.0).normalize();
        assert!((ns - want).length() < 1e-4, "{ns:?} vs {want:?}");
        // A constant displacement on a plane changes nothing.
        let flat = bump_normal(&g, 0.0005, 0.0005, [0.0; 4], |_| 0.3);
        assert!((flat - g.n).length() < 1e-6);
    }

    /// On a sphere of radius r, `D = a u` gives `dp/du' = dp/du (1 + D / r) + a n`: the tilt is
    /// `atan(a / (|dp/du| (1 + D / r)))` (the `D dn/du` term of pbrt-v4's `BumpMap`).
    #[test]
    fn a_bump_on_a_sphere_includes_the_normal_derivative_term() {
        let r = 2.0f32;
        let (theta, phi) = (1.1f32, 0.7f32);
        let l = V3::new(
            r * theta.sin() * phi.cos(),
            r * theta.sin() * phi.sin(),
            r * theta.cos(),
        );
        let two_pi = 2.0 * std::f32::consts::PI;
        let uv = [phi / two_pi, 1.0 - theta / std::f32::consts::PI];
        let axes = [
            V3::new(1.0, 0.0, 0.0),
            V3::new(0.0, 1.0, 0.0),
            V3::new(0.0, 0.0, 1.0),
        ];
        let n = l / r;
        let g = sphere_geometry(l, r, axes, -r, r, two_pi, l, uv, n);
        let a = 0.9f32;
        let disp = |c: &TexCtx| a * c.uv[0];
        let ns = bump_normal(&g, 1e-3, 1e-3, [0.0; 4], disp);
        let d = a * uv[0];
        let lu = g.dpdu.length() * (1.0 + d / r);
        let want = (a / lu).atan();
        let tilt = ns.dot(n).acos();
        assert!((tilt - want).abs() < 1e-3, "tilt {tilt} vs {want}");
        // dp/du is r sin(theta) 2 pi long (pbrt-v4's phi_max times the ring radius).
        assert!((g.dpdu.length() - r * theta.sin() * two_pi).abs() < 1e-4);
    }

    /// pbrt-v4's triangle dp/du, dp/dv solve `p_i - p_2 = (u_i - u_2) dp/du + (v_i - v_2) dp/dv`.
    #[test]
    fn triangle_partials_reproduce_the_vertices() {
        let p = [
            V3::new(0.0, 0.0, 0.0),
            V3::new(2.0, 0.5, 0.1),
            V3::new(0.3, 1.5, -0.2),
        ];
        let uv = [[0.1, 0.2], [0.9, 0.3], [0.2, 0.8]];
        let n = (p[1] - p[0]).cross(p[2] - p[0]).normalize();
        let g = triangle_geometry(p, uv, None, p[0], uv[0], n, n);
        for i in 0..2 {
            let rebuilt = g.dpdu * (uv[i][0] - uv[2][0]) + g.dpdv * (uv[i][1] - uv[2][1]) + p[2];
            assert!((rebuilt - p[i]).length() < 1e-5, "{i}: {rebuilt:?}");
        }
    }

    #[test]
    fn a_flat_normal_map_returns_the_shading_normal_bit_for_bit() {
        let g = plane(V3::new(0.6, 0.8, 0.0), V3::new(-0.8, 0.6, 0.3));
        let map = NormalMapImage {
            width: 3,
            height: 2,
            rgb: vec![[0.5, 0.5, 1.0]; 6],
            uv1: false,
        };
        for uv in [[0.0, 0.0], [0.37, 0.91], [1.7, -0.3]] {
            let g = ShadingGeometry { uv, ..g };
            assert_eq!(mapped_normal(&g, &map, g.uv), g.ns);
        }
        // A tilted map: (1, 0.5, 1) is the normal (1, 0, 1) / sqrt 2 in (dp/du, ., n).
        let tilted = NormalMapImage {
            width: 1,
            height: 1,
            rgb: vec![[1.0, 0.5, 1.0]],
            uv1: false,
        };
        let ns = mapped_normal(&g, &tilted, g.uv);
        let want = (g.ss.normalize() + g.ns) * std::f32::consts::FRAC_1_SQRT_2;
        assert!((ns - want).length() < 1e-6, "{ns:?} vs {want:?}");
    }

    /// With a mesh tangent the frame is (t', w n x t', n), t' the tangent made orthogonal to
    /// n (glTF 2.0 sec. 3.7.2.1): a map tilted toward +y turns the normal toward w n x t'.
    #[test]
    fn a_mesh_tangent_and_its_handedness_set_the_normal_map_frame() {
        let h = std::f32::consts::FRAC_1_SQRT_2;
        // n = +z; dp/du along +x, the mesh tangent (0, 1, 0.5): t' = +y.
        let g = ShadingGeometry {
            tangent: V3::new(0.0, 1.0, 0.5),
            ..plane(V3::new(1.0, 0.0, 0.0), V3::new(0.0, 1.0, 0.0))
        };
        let toward_y = NormalMapImage {
            width: 1,
            height: 1,
            rgb: vec![[0.5, (h + 1.0) / 2.0, (h + 1.0) / 2.0]],
            uv1: false,
        };
        // n x t' = z x y = -x.
        for (w, want) in [(1.0, V3::new(-h, 0.0, h)), (-1.0, V3::new(h, 0.0, h))] {
            let g = ShadingGeometry { tangent_w: w, ..g };
            let ns = mapped_normal(&g, &toward_y, g.uv);
            assert!((ns - want).length() < 1e-6, "w = {w}: {ns:?} vs {want:?}");
        }
    }
}
