//! The tracer at a path's time: surfaces of moving primitives, the moving camera's rays, and
//! light samples and hits of moving lights, each through the poses of [`crate::motion`].

use super::Tracer;
use crate::bump::ShadingGeometry;
use crate::bvh::Hit;
use crate::geometry::{PrimInfo, Ray, SurfaceHit};
use crate::lights::LightSample;
use crate::math::V3;
use crate::motion::{to_ref, PathTime, Pose, NO_MOVER};
use crate::spectral::Lambdas;

impl Tracer {
    /// The surface of a hit on a moving primitive: computed in its group's reference pose and
    /// moved to the world at `pt`.
    pub(crate) fn moving_surface(&self, r: &Ray, h: &Hit, pt: &PathTime) -> SurfaceHit {
        let m = self.motion.as_deref().expect("a moving slot has motion");
        let gi = m.group_of(h.slot);
        let g = &m.groups[gi];
        let pose = pt.pose(m, gi);
        let (rr, len) = to_ref(&pose, r);
        let local = (h.slot - g.slot0) as usize;
        let hr = Hit { t: h.t * len, ..*h };
        let s = self.surface_of(&g.bvh.prims[local], g.tri_normals[local], &g.bvh, &rr, &hr);
        SurfaceHit {
            p: pose.to_world.point(s.p),
            ng: pose.to_ref.normal_from_inverse(s.ng),
            ns: pose.to_ref.normal_from_inverse(s.ns),
            uv: s.uv,
            uv1: s.uv1,
            color: s.color,
            dpdu: pose.to_world.vector(s.dpdu),
            err: pose.to_world.point_error(s.p, s.err),
        }
    }

    /// The shading geometry (bump and normal maps) of a hit on a moving primitive: `sh` (world,
    /// at `pt`) moved into its group's reference pose, the geometry computed there and moved
    /// back (normals by the inverse transpose, `dn/du` and `dn/dv` as the normal's rotation).
    pub(crate) fn moving_shading_geometry(
        &self,
        h: &Hit,
        pi: &PrimInfo,
        sh: &SurfaceHit,
        pt: &PathTime,
    ) -> ShadingGeometry {
        let m = self.motion.as_deref().expect("a moving slot has motion");
        let gi = m.group_of(h.slot);
        let g = &m.groups[gi];
        let pose = pt.pose(m, gi);
        let (w, r) = (&pose.to_world, &pose.to_ref);
        let local = SurfaceHit {
            p: r.point(sh.p),
            ng: w.normal_from_inverse(sh.ng),
            ns: w.normal_from_inverse(sh.ns),
            uv: sh.uv,
            uv1: sh.uv1,
            color: sh.color,
            dpdu: r.vector(sh.dpdu),
            err: sh.err,
        };
        let s = self.shading_geometry_of(
            &g.bvh.prims[(h.slot - g.slot0) as usize],
            &g.bvh,
            pi,
            &local,
        );
        let k = 1.0 / pose.scale;
        ShadingGeometry {
            p: w.point(s.p),
            uv: s.uv,
            n: r.normal_from_inverse(s.n),
            dpdu: w.vector(s.dpdu),
            dpdv: w.vector(s.dpdv),
            ns: r.normal_from_inverse(s.ns),
            ss: w.vector(s.ss).normalize(),
            ts: w.vector(s.ts).normalize(),
            dndu: w.vector(s.dndu) * k,
            dndv: w.vector(s.dndv) * k,
            tangent: w.vector(s.tangent),
            tangent_w: s.tangent_w,
        }
    }

    /// A camera ray of the camera's stored pose moved to its pose at `pt`.
    #[inline]
    pub(crate) fn camera_ray(&self, r: Ray, pt: &PathTime) -> Ray {
        match self.motion.as_deref().and_then(|m| m.camera_pose(pt)) {
            None => r,
            Some(p) => Ray {
                o: p.to_world.point(r.o),
                d: p.to_world.vector(r.d).normalize(),
            },
        }
    }

    /// A camera-space direction of the stored pose (e.g. the forward axis) at `pt`.
    #[inline]
    pub(crate) fn camera_vector(&self, v: V3, pt: &PathTime) -> V3 {
        match self.motion.as_deref().and_then(|m| m.camera_pose(pt)) {
            None => v,
            Some(p) => p.to_world.vector(v).normalize(),
        }
    }

    /// The pose of light entry `light` at `pt`, if it moves.
    #[inline]
    fn light_pose(&self, light: usize, pt: &PathTime) -> Option<Pose> {
        let m = self.motion.as_deref()?;
        let i = *m.light_mover.get(light)?;
        (i != NO_MOVER).then(|| pt.pose(m, i as usize))
    }

    /// [`crate::lights::Lights::sample`] at the path's time: a moving light is sampled in its
    /// reference pose from the reference point moved there, and the sample moved back.
    #[inline]
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn sample_light<const N: usize>(
        &self,
        p: V3,
        n: V3,
        u_sel: f32,
        u0: f32,
        u1: f32,
        lambdas: &Lambdas<N>,
        pt: &PathTime,
    ) -> Option<LightSample<N>> {
        // Moving lights turn the spatial sampler off (`Tracer::new`): power selection then
        // does not depend on the point, so the light is known before the pose.
        let pose = match &self.motion {
            Some(_) if !self.lights.spatial() => self.light_pose(self.lights.pick(u_sel), pt),
            _ => None,
        };
        let Some(pose) = pose else {
            return self
                .lights
                .sample::<N>(&self.tables, p, n, u_sel, u0, u1, lambdas);
        };
        // The receiver's normal turned with it (the triangle sampler's cosine warp).
        let n_ref = if n == V3::splat(0.0) {
            n
        } else {
            pose.to_ref.vector(n).normalize()
        };
        let mut s = self.lights.sample::<N>(
            &self.tables,
            pose.to_ref.point(p),
            n_ref,
            u_sel,
            u0,
            u1,
            lambdas,
        )?;
        s.wi = pose.to_world.vector(s.wi).normalize();
        s.p_err = pose.to_world.point_error(s.p_light, s.p_err);
        s.p_light = pose.to_world.point(s.p_light);
        if s.n_light != V3::splat(0.0) {
            s.n_light = pose.to_ref.normal_from_inverse(s.n_light);
        }
        if s.dist.is_finite() {
            s.dist *= pose.scale;
            if s.delta {
                // I / r^2 with r scaled (solid-angle densities are unchanged by a similarity).
                let k = 1.0 / (pose.scale * pose.scale);
                s.le = s.le.map(|v| v * k);
            }
        }
        Some(s)
    }

    /// [`crate::lights::Lights::emits_toward`] and [`crate::lights::Lights::pdf_hit`] for a hit
    /// at `q` (normal `ng`) on emitter `light`, seen along `w` from `p_ref` (shading normal
    /// `n_ref`, zero in a medium), at the path's time: (emits, density; 0 unless `need_pdf`).
    #[inline]
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn light_hit(
        &self,
        light: usize,
        p_ref: V3,
        n_ref: V3,
        q: V3,
        ng: V3,
        w: V3,
        pt: &PathTime,
        need_pdf: bool,
    ) -> (bool, f32) {
        let entry = &self.lights.list[light];
        let (p_ref, n_ref, q, ng, w) = match self.light_pose(light, pt) {
            None => (p_ref, n_ref, q, ng, w),
            Some(pose) => (
                pose.to_ref.point(p_ref),
                if n_ref == V3::splat(0.0) {
                    n_ref
                } else {
                    pose.to_ref.vector(n_ref).normalize()
                },
                pose.to_ref.point(q),
                pose.to_world.normal_from_inverse(ng),
                pose.to_ref.vector(w),
            ),
        };
        if !self.lights.emits_toward(entry, q, ng, w) {
            return (false, 0.0);
        }
        if !need_pdf {
            return (true, 0.0);
        }
        (true, self.lights.pdf_hit(light, p_ref, n_ref, q, ng))
    }
}
