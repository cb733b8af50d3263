//! Ray generation for the pinhole perspective camera (pbrt-v4 `PerspectiveCamera` with
//! `lensradius 0`), pbrt-v4's `RealisticCamera` (rays traced through a lens prescription) and the
//! ISET3d ray-transfer camera. Setting a camera up (look-at, focal length, lens focus) is
//! [`camsim_scene3d::camera`]'s.

use crate::geometry::Ray;
use crate::math::V3;
use camsim_lens::{LensCamera, Rtf};
use camsim_scene3d::camera::film_half_extent_mm;
use camsim_scene3d::scene::{Camera, CameraLens};
use std::sync::Arc;

/// A realistic or ray-transfer camera prepared for ray generation.
#[derive(Debug, Clone)]
struct LensRig {
    optics: RigOptics,
    /// Half the film's width and height, mm.
    film_half_mm: [f64; 2],
}

#[derive(Debug, Clone)]
enum RigOptics {
    Traced {
        camera: Arc<LensCamera>,
        /// z of the film plane and of the rear vertex in lens coordinates, mm.
        film_z_mm: f64,
        rear_z_mm: f64,
    },
    RayTransfer {
        rtf: Arc<Rtf>,
        /// Film distance behind the RTF's input plane, mm.
        film_offset_mm: f64,
    },
}

/// The camera prepared for ray generation.
#[derive(Debug, Clone)]
pub(crate) struct CameraRig {
    origin: V3,
    /// Origin of the pinhole rays ([`CameraRig::ray`]: depth map, object ids, perspective camera):
    /// the camera's origin, or a lens camera's entrance pupil (the centre of perspective).
    pinhole: V3,
    /// World images of the camera-space x, y and z axes.
    axes: [V3; 3],
    /// Unit world direction of the camera's +z axis (depth is measured along it).
    pub forward: V3,
    /// Half extents of the screen window times tan(fov/2) (pbrt: the shorter axis spans [-1, 1]).
    half_x: f32,
    half_y: f32,
    inv_w: f32,
    inv_h: f32,
    lens: Option<LensRig>,
}

impl CameraRig {
    /// Check and prepare `c`; the error names what is wrong.
    pub(crate) fn new(c: &Camera) -> Result<CameraRig, String> {
        if c.width == 0 || c.height == 0 {
            return Err(format!(
                "image size {} x {} has no pixels",
                c.width, c.height
            ));
        }
        if c.width > 1 << 20 || c.height > 1 << 20 {
            return Err(format!(
                "image size {} x {} is too large",
                c.width, c.height
            ));
        }
        if !(c.fov_deg > 0.0 && c.fov_deg < 180.0) {
            return Err(format!("fov {} degrees is not in (0, 180)", c.fov_deg));
        }
        let t = &c.camera_to_world;
        if t.m.iter().flatten().any(|v| !v.is_finite()) {
            return Err("camera_to_world has a non-finite entry".into());
        }
        let o = t.apply_point([0.0; 3]);
        let ax = t.apply_vector([1.0, 0.0, 0.0]);
        let ay = t.apply_vector([0.0, 1.0, 0.0]);
        let az = t.apply_vector([0.0, 0.0, 1.0]);
        let det = ax[0] * (ay[1] * az[2] - ay[2] * az[1]) - ax[1] * (ay[0] * az[2] - ay[2] * az[0])
            + ax[2] * (ay[0] * az[1] - ay[1] * az[0]);
        if det.abs() < 1e-12 || !det.is_finite() {
            return Err("camera_to_world is degenerate (its 3x3 part is singular): check LookAt's up vector".into());
        }
        let tan_half = (c.fov_deg.to_radians() / 2.0).tan();
        let aspect = c.width as f64 / c.height as f64;
        // pbrt-v4 CameraBase: screen window [-aspect, aspect] x [-1, 1] when aspect > 1, else
        // [-1, 1] x [-1/aspect, 1/aspect]; `fov` spans the shorter axis.
        let (sx, sy) = if aspect > 1.0 {
            (aspect, 1.0)
        } else {
            (1.0, 1.0 / aspect)
        };
        let azv = V3::from_f64(az);
        let (mut half_x, mut half_y) = ((sx * tan_half) as f32, (sy * tan_half) as f32);
        // Camera-space z of the pinhole rays' origin, m.
        let mut pinhole_z_m = 0.0;
        let lens = match &c.lens {
            None => None,
            Some(CameraLens::Realistic(l)) => {
                let film_half_mm = film_half_extent_mm(l.film_diagonal_mm, c.width, c.height);
                let d_mm = l.camera.film_distance_mm;
                if !(film_half_mm[0] > 0.0 && film_half_mm[1] > 0.0 && d_mm > 0.0) {
                    return Err(format!(
                        "realistic camera: film diagonal {} mm is not > 0",
                        l.film_diagonal_mm
                    ));
                }
                // The pinhole rays (depth map, ids) from the entrance pupil through the film
                // point's image.
                half_x = (film_half_mm[0] / l.image_distance_mm) as f32;
                half_y = (film_half_mm[1] / l.image_distance_mm) as f32;
                pinhole_z_m = l.pupil_z_mm * 1e-3;
                let film_z_mm = l.camera.film_z_mm();
                let optics = RigOptics::Traced {
                    camera: l.camera.clone(),
                    film_z_mm,
                    rear_z_mm: film_z_mm - d_mm,
                };
                Some(LensRig {
                    optics,
                    film_half_mm,
                })
            }
            Some(CameraLens::RayTransfer(l)) => {
                let film_half_mm = film_half_extent_mm(l.film_diagonal_mm, c.width, c.height);
                if !(film_half_mm[0] > 0.0 && film_half_mm[1] > 0.0 && l.image_distance_mm > 0.0) {
                    return Err(format!(
                        "ray-transfer camera: film diagonal {} mm is not > 0",
                        l.film_diagonal_mm
                    ));
                }
                half_x = (film_half_mm[0] / l.image_distance_mm) as f32;
                half_y = (film_half_mm[1] / l.image_distance_mm) as f32;
                pinhole_z_m = l.pupil_z_mm * 1e-3;
                let optics = RigOptics::RayTransfer {
                    rtf: l.rtf.clone(),
                    film_offset_mm: l.film_offset_mm,
                };
                Some(LensRig {
                    optics,
                    film_half_mm,
                })
            }
        };
        Ok(CameraRig {
            origin: V3::from_f64(o),
            pinhole: V3::from_f64(o) + azv * pinhole_z_m as f32,
            axes: [V3::from_f64(ax), V3::from_f64(ay), azv],
            forward: azv.normalize(),
            half_x,
            half_y,
            inv_w: 1.0 / c.width as f32,
            inv_h: 1.0 / c.height as f32,
            lens,
        })
    }

    /// Whether camera rays need [`CameraRig::lens_ray`] (a realistic camera).
    #[inline(always)]
    pub(crate) fn has_lens(&self) -> bool {
        self.lens.is_some()
    }

    /// A camera ray of a realistic camera at continuous raster position (`x`, `y`) through the
    /// exit-pupil point chosen by `u_pupil`, traced through the lens at `wavelength_nm`, with its
    /// weight; `None` when the lens blocks it (a zero-weight sample). pbrt-v4 4th ed. sec. 5.3.5
    /// (`RealisticCamera::GenerateRay`): the film point, a point drawn uniformly in the exit-pupil
    /// bounds for the film radius (rotated to the film point's azimuth), and the weight
    /// cos^4(theta) * A / D^2 (A the bounds' area, D the film-to-rear-vertex distance), which
    /// turns the scene radiance into film irradiance over radiance (sr): E = L integral of
    /// cos(theta) d(omega) = L integral over the rear plane of cos^4(theta) / D^2 dA.
    /// A perspective camera returns `rig.ray(x, y)` with weight 1.
    pub(crate) fn lens_ray(
        &self,
        x: f32,
        y: f32,
        u_pupil: [f32; 2],
        wavelength_nm: f32,
    ) -> Option<(Ray, f32)> {
        let Some(l) = &self.lens else {
            return Some((self.ray(x, y), 1.0));
        };
        // The lens inverts the image: the scene point seen at screen (u, v) (right, up) forms
        // its image at film (-u, -v).
        let u = (2.0 * x * self.inv_w - 1.0) as f64;
        let v = (1.0 - 2.0 * y * self.inv_h) as f64;
        let p = [-u * l.film_half_mm[0], -v * l.film_half_mm[1]];
        let r_mm = p[0].hypot(p[1]);
        let (camera, film_z_mm, rear_z_mm) = match &l.optics {
            RigOptics::Traced {
                camera,
                film_z_mm,
                rear_z_mm,
            } => (camera, *film_z_mm, *rear_z_mm),
            RigOptics::RayTransfer {
                rtf,
                film_offset_mm,
            } => return self.rtf_ray(rtf, *film_offset_mm, p, u_pupil),
        };
        let b = camera.exit_pupil_bounds(r_mm);
        let area_mm2 = (b[1] - b[0]) * (b[3] - b[2]);
        if area_mm2 <= 0.0 {
            return None;
        }
        let qx = b[0] + (b[1] - b[0]) * u_pupil[0] as f64;
        let qy = b[2] + (b[3] - b[2]) * u_pupil[1] as f64;
        // Rotate from the frame where the film point lies on +x to its azimuth.
        let (cos_phi, sin_phi) = if r_mm > 0.0 {
            (p[0] / r_mm, p[1] / r_mm)
        } else {
            (1.0, 0.0)
        };
        let rear = [qx * cos_phi - qy * sin_phi, qx * sin_phi + qy * cos_phi];
        let d_mm = film_z_mm - rear_z_mm;
        let dir = [rear[0] - p[0], rear[1] - p[1], -d_mm];
        let out = camera.trace_ray(p, dir, wavelength_nm as f64)?;
        let len = (dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]).sqrt();
        let cos_theta = d_mm / len;
        let weight = cos_theta.powi(4) * area_mm2 / (d_mm * d_mm);
        // Lens coordinates (mm, scene toward -z) to camera space (m, scene toward +z, film at
        // the origin): pbrt's CameraFromLens = Scale(1, 1, -1).
        let o = [
            out.origin_mm[0] * 1e-3,
            out.origin_mm[1] * 1e-3,
            (film_z_mm - out.origin_mm[2]) * 1e-3,
        ];
        let d = [out.direction[0], out.direction[1], -out.direction[2]];
        Some((self.camera_ray_to_world(o, d), weight as f32))
    }

    /// A ray-transfer camera's ray from film point `p` (mm), the film `dz` mm behind the RTF's
    /// input plane: a point drawn uniformly (concentric map of `u_pupil`) in the pass ellipse of
    /// the input height where the ray toward the ellipse's centre crosses the input plane (on the
    /// pass plane, D + dz in front of the film) gives the direction; the RTF maps the ray to its
    /// output after its own pass test at the ray's input-plane point. Off the input plane
    /// (dz != 0) the rays of one film point cross the input plane at different heights, so the
    /// drawn ellipse is enlarged (by 5 % and 0.25 |dz|: the ellipses' centres move by at most
    /// 0.6 mm per mm of input height, and the pupil spreads the crossings over 0.15 |dz|) to hold
    /// every ray that can pass. The weight is the projected solid angle per unit pdf,
    /// D'^2 A / rho^4 (A the drawn ellipse's area, rho the distance to the drawn point, D' = D +
    /// dz): the same measure as the realistic camera's cos^4(theta) A / D^2 and as
    /// [`Rtf::relative_illumination`]. The RTF is fitted at one wavelength: no dispersion.
    /// Outside the RTF's table of heights nothing passes.
    fn rtf_ray(&self, rtf: &Rtf, dz: f64, p: [f64; 2], u_pupil: [f32; 2]) -> Option<(Ray, f32)> {
        let r_mm = p[0].hypot(p[1]);
        // The frame where the film point lies on +y at height r (the file's ellipse frame).
        let (c, s) = if r_mm > 0.0 {
            (p[1] / r_mm, p[0] / r_mm)
        } else {
            (1.0, 0.0)
        };
        let e = rtf.film_pass_ellipse(r_mm, dz)?;
        let grow = if dz == 0.0 {
            [1.0, 1.0]
        } else {
            [
                1.05 + 0.25 * dz.abs() / e.radii_mm[0],
                1.05 + 0.25 * dz.abs() / e.radii_mm[1],
            ]
        };
        let (du, dv) = crate::sampling::concentric_disk(u_pupil[0], u_pupil[1]);
        let (rx, ry) = (e.radii_mm[0] * grow[0], e.radii_mm[1] * grow[1]);
        let q = [
            e.center_mm[0] + rx * du as f64,
            e.center_mm[1] + ry * dv as f64,
        ];
        let (pin, local, w) = rtf.film_ray([0.0, r_mm], dz, q)?;
        let weight = w * std::f64::consts::PI * rx * ry;
        // Back from that frame: (x, y) -> (x c + y s, -x s + y c).
        let back = |v: [f64; 2]| [v[0] * c + v[1] * s, -v[0] * s + v[1] * c];
        let (pin, dxy) = (back(pin), back([local[0], local[1]]));
        let (out_p, out_d) = rtf.trace(pin, [dxy[0], dxy[1], local[2]])?;
        // RTF coordinates (mm, z toward the scene from the input plane) to camera space (m, film
        // at the origin, scene toward +z).
        let o = [out_p[0] * 1e-3, out_p[1] * 1e-3, (out_p[2] + dz) * 1e-3];
        Some((self.camera_ray_to_world(o, out_d), weight as f32))
    }

    /// A camera-space ray (origin in m, direction) in world space.
    fn camera_ray_to_world(&self, o: [f64; 3], d: [f64; 3]) -> Ray {
        let world_o = self.origin
            + self.axes[0] * o[0] as f32
            + self.axes[1] * o[1] as f32
            + self.axes[2] * o[2] as f32;
        let world_d =
            self.axes[0] * d[0] as f32 + self.axes[1] * d[1] as f32 + self.axes[2] * d[2] as f32;
        Ray {
            o: world_o,
            d: world_d.normalize(),
        }
    }

    /// The pinhole rays' ([`CameraRig::ray`]) intrinsics for a `width` x `height` image in
    /// OpenCV's convention (pixel centres at integer coordinates, u right, v down): `[fx, fy, cx,
    /// cy]`, pixels. `ray(x, y)` has the camera-space direction `((2x/W - 1) hx, (1 - 2y/H) hy,
    /// 1)`, so a camera point (X, Y, Z) (y up) lands at raster x = (X / (Z hx) + 1) W / 2 and
    /// y = (1 - Y / (Z hy)) H / 2, and u = x - 1/2, v = y - 1/2.
    pub(crate) fn pinhole_intrinsics(&self, width: usize, height: usize) -> [f64; 4] {
        let (w, h) = (width as f64, height as f64);
        [
            w / (2.0 * self.half_x as f64),
            h / (2.0 * self.half_y as f64),
            w / 2.0 - 0.5,
            h / 2.0 - 0.5,
        ]
    }

    /// World position of the pinhole rays' origin (the camera, or a lens camera's entrance
    /// pupil).
    pub(crate) fn pinhole_origin(&self) -> V3 {
        self.pinhole
    }

    /// The continuous raster position where the pinhole rays ([`CameraRig::ray`]) see the
    /// world point `p` (`Some` only in front of the camera): the inverse of [`CameraRig::ray`].
    pub(crate) fn raster_of_point(&self, p: V3) -> Option<[f32; 2]> {
        self.raster_of_direction(p - self.pinhole)
    }

    /// The continuous raster position of the world direction `d` (a point at infinity).
    pub(crate) fn raster_of_direction(&self, d: V3) -> Option<[f32; 2]> {
        // Solve d = cx ax + cy ay + cz az (Cramer's rule), then invert `ray`'s screen mapping.
        let [a, b, c] = self.axes;
        let det = a.dot(b.cross(c));
        let cz = a.dot(b.cross(d)) / det;
        if !(cz > 0.0) {
            return None;
        }
        let cx = d.dot(b.cross(c)) / det;
        let cy = a.dot(d.cross(c)) / det;
        let x = ((cx / cz) / self.half_x + 1.0) * 0.5 / self.inv_w;
        let y = (1.0 - (cy / cz) / self.half_y) * 0.5 / self.inv_h;
        Some([x, y])
    }

    /// Ray through continuous raster position (`x`, `y`) (pixel (i, j) covers [i, i+1) x [j, j+1),
    /// raster y grows downwards, (0, 0) is the top-left corner).
    #[inline(always)]
    pub(crate) fn ray(&self, x: f32, y: f32) -> Ray {
        let cx = (2.0 * x * self.inv_w - 1.0) * self.half_x;
        let cy = (1.0 - 2.0 * y * self.inv_h) * self.half_y;
        let d = self.axes[0] * cx + self.axes[1] * cy + self.axes[2];
        Ray {
            o: self.pinhole,
            d: d.normalize(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use camsim_scene3d::scene::Transform;

    #[test]
    fn rays_follow_pbrt_screen_window() {
        let c = Camera {
            camera_to_world: Transform::identity(),
            fov_deg: 90.0,
            width: 200,
            height: 100,
            lens: None,
        };
        let rig = CameraRig::new(&c).unwrap();
        // Centre ray looks down +z.
        let r = rig.ray(100.0, 50.0);
        assert!((r.d.z - 1.0).abs() < 1e-6);
        // Top edge at the centre column: y = tan(45 deg) = 1 (the shorter axis spans the fov).
        let r = rig.ray(100.0, 0.0);
        assert!((r.d.y / r.d.z - 1.0).abs() < 1e-5);
        // Left edge: x = -aspect = -2 (raster x grows with camera +x).
        let r = rig.ray(0.0, 50.0);
        assert!((r.d.x / r.d.z + 2.0).abs() < 1e-5);
        // The raster position of a point on a ray is where the ray started.
        let r = rig.ray(37.25, 81.5);
        let [x, y] = rig.raster_of_point(r.o + r.d * 3.0).unwrap();
        assert!((x - 37.25).abs() < 1e-3 && (y - 81.5).abs() < 1e-3);
        assert!(rig.raster_of_direction(-r.d).is_none());
    }
}
