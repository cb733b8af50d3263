//! Pinhole perspective camera (pbrt-v4 `PerspectiveCamera` with `lensradius 0`), pbrt-v4's
//! `RealisticCamera` (rays traced through a lens prescription) and helpers to set one up from a
//! look-at triple or from a lens focal length and sensor size.

use crate::geometry::Ray;
use crate::math::V3;
use crate::scene::{Camera, CameraLens, RayTransferLens, RealisticLens, Transform};
use camsim_lens::{Lens, LensCamera, Rtf};
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
    RayTransfer(Arc<Rtf>),
}

/// The camera prepared for ray generation.
#[derive(Debug, Clone)]
pub(crate) struct CameraRig {
    origin: V3,
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
            return Err(format!("image size {} x {} has no pixels", c.width, c.height));
        }
        if c.width > 1 << 20 || c.height > 1 << 20 {
            return Err(format!("image size {} x {} is too large", c.width, c.height));
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
        let (sx, sy) = if aspect > 1.0 { (aspect, 1.0) } else { (1.0, 1.0 / aspect) };
        let azv = V3::from_f64(az);
        let (mut half_x, mut half_y) = ((sx * tan_half) as f32, (sy * tan_half) as f32);
        let lens = match &c.lens {
            None => None,
            Some(CameraLens::Realistic(l)) => {
                let film_half_mm = film_half_extent_mm(l.film_diagonal_mm, c.width, c.height);
                let d_mm = l.camera.film_distance_mm;
                if !(film_half_mm[0] > 0.0 && film_half_mm[1] > 0.0 && d_mm > 0.0) {
                    return Err(format!("realistic camera: film diagonal {} mm is not > 0", l.film_diagonal_mm));
                }
                // The pinhole ray (depth map) through the film point's image.
                let v_mm = pinhole_image_distance_mm(&l.camera);
                half_x = (film_half_mm[0] / v_mm) as f32;
                half_y = (film_half_mm[1] / v_mm) as f32;
                let film_z_mm = l.camera.film_z_mm();
                let optics = RigOptics::Traced { camera: l.camera.clone(), film_z_mm, rear_z_mm: film_z_mm - d_mm };
                Some(LensRig { optics, film_half_mm })
            }
            Some(CameraLens::RayTransfer(l)) => {
                let film_half_mm = film_half_extent_mm(l.film_diagonal_mm, c.width, c.height);
                if !(film_half_mm[0] > 0.0 && film_half_mm[1] > 0.0 && l.focal_length_mm > 0.0) {
                    return Err(format!("ray-transfer camera: film diagonal {} mm is not > 0", l.film_diagonal_mm));
                }
                half_x = (film_half_mm[0] / l.focal_length_mm) as f32;
                half_y = (film_half_mm[1] / l.focal_length_mm) as f32;
                Some(LensRig { optics: RigOptics::RayTransfer(l.rtf.clone()), film_half_mm })
            }
        };
        Ok(CameraRig {
            origin: V3::from_f64(o),
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
    pub(crate) fn lens_ray(&self, x: f32, y: f32, u_pupil: [f32; 2], wavelength_nm: f32) -> Option<(Ray, f32)> {
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
            RigOptics::Traced { camera, film_z_mm, rear_z_mm } => (camera, *film_z_mm, *rear_z_mm),
            RigOptics::RayTransfer(rtf) => return self.rtf_ray(rtf, p, u_pupil),
        };
        let b = camera.exit_pupil_bounds(r_mm);
        let area_mm2 = (b[1] - b[0]) * (b[3] - b[2]);
        if area_mm2 <= 0.0 {
            return None;
        }
        let qx = b[0] + (b[1] - b[0]) * u_pupil[0] as f64;
        let qy = b[2] + (b[3] - b[2]) * u_pupil[1] as f64;
        // Rotate from the frame where the film point lies on +x to its azimuth.
        let (cos_phi, sin_phi) = if r_mm > 0.0 { (p[0] / r_mm, p[1] / r_mm) } else { (1.0, 0.0) };
        let rear = [qx * cos_phi - qy * sin_phi, qx * sin_phi + qy * cos_phi];
        let d_mm = film_z_mm - rear_z_mm;
        let dir = [rear[0] - p[0], rear[1] - p[1], -d_mm];
        let out = camera.trace_ray(p, dir, wavelength_nm as f64)?;
        let len = (dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]).sqrt();
        let cos_theta = d_mm / len;
        let weight = cos_theta.powi(4) * area_mm2 / (d_mm * d_mm);
        // Lens coordinates (mm, scene toward -z) to camera space (m, scene toward +z, film at
        // the origin): pbrt's CameraFromLens = Scale(1, 1, -1).
        let o = [out.origin_mm[0] * 1e-3, out.origin_mm[1] * 1e-3, (film_z_mm - out.origin_mm[2]) * 1e-3];
        let d = [out.direction[0], out.direction[1], -out.direction[2]];
        Some((self.camera_ray_to_world(o, d), weight as f32))
    }

    /// A ray-transfer camera's ray from film point `p` (mm, on the RTF's input plane): a point
    /// drawn uniformly (concentric map of `u_pupil`) in the pass ellipse for the film height, on
    /// the pass plane a distance D in front, gives the direction; the RTF maps the ray to its
    /// output. The weight is the projected solid angle per unit pdf, D^2 A / rho^4 (A the
    /// ellipse's area, rho the distance to the drawn point): the same measure as the realistic
    /// camera's cos^4(theta) A / D^2 and as [`Rtf::relative_illumination`]. The RTF is fitted at
    /// one wavelength: no dispersion. Outside the RTF's table of heights nothing passes.
    fn rtf_ray(&self, rtf: &Rtf, p: [f64; 2], u_pupil: [f32; 2]) -> Option<(Ray, f32)> {
        let r_mm = p[0].hypot(p[1]);
        let e = rtf.pass_ellipse(r_mm)?;
        let (du, dv) = crate::sampling::concentric_disk(u_pupil[0], u_pupil[1]);
        // The ellipse is given in the frame where the film point lies on +y at height r.
        let q = [e.center_mm[0] + e.radii_mm[0] * du as f64, e.center_mm[1] + e.radii_mm[1] * dv as f64];
        let d_mm = rtf.pass_plane_distance_mm;
        let local = [q[0], q[1] - r_mm, d_mm];
        let rho2 = local[0] * local[0] + local[1] * local[1] + d_mm * d_mm;
        let weight = d_mm * d_mm * std::f64::consts::PI * e.radii_mm[0] * e.radii_mm[1] / (rho2 * rho2);
        // Back from that frame: (x, y) -> (x c + y s, -x s + y c) with c = py / r, s = px / r.
        let (c, s) = if r_mm > 0.0 { (p[1] / r_mm, p[0] / r_mm) } else { (1.0, 0.0) };
        let rho = rho2.sqrt();
        let dir = [(local[0] * c + local[1] * s) / rho, (-local[0] * s + local[1] * c) / rho, d_mm / rho];
        let (out_p, out_d) = rtf.trace(p, dir)?;
        // RTF coordinates (mm, toward the scene along +z from the input plane = the film) are
        // camera space's (m, film at the origin, scene toward +z).
        let o = [out_p[0] * 1e-3, out_p[1] * 1e-3, out_p[2] * 1e-3];
        Some((self.camera_ray_to_world(o, out_d), weight as f32))
    }

    /// A camera-space ray (origin in m, direction) in world space.
    fn camera_ray_to_world(&self, o: [f64; 3], d: [f64; 3]) -> Ray {
        let world_o = self.origin + self.axes[0] * o[0] as f32 + self.axes[1] * o[1] as f32 + self.axes[2] * o[2] as f32;
        let world_d = self.axes[0] * d[0] as f32 + self.axes[1] * d[1] as f32 + self.axes[2] * d[2] as f32;
        Ray { o: world_o, d: world_d.normalize() }
    }

    /// Ray through continuous raster position (`x`, `y`) (pixel (i, j) covers [i, i+1) x [j, j+1),
    /// raster y grows downwards, (0, 0) is the top-left corner).
    #[inline(always)]
    pub(crate) fn ray(&self, x: f32, y: f32) -> Ray {
        let cx = (2.0 * x * self.inv_w - 1.0) * self.half_x;
        let cy = (1.0 - 2.0 * y * self.inv_h) * self.half_y;
        let d = self.axes[0] * cx + self.axes[1] * cy + self.axes[2];
        Ray { o: self.origin, d: d.normalize() }
    }
}

/// Half the width and height (mm) of a film of diagonal `diagonal_mm` with `width` x `height`
/// square pixels (pbrt-v4 `PixelSensor`/`Film` physical extent).
pub fn film_half_extent_mm(diagonal_mm: f64, width: usize, height: usize) -> [f64; 2] {
    let (w, h) = (width as f64, height as f64);
    let k = diagonal_mm / 2.0 / w.hypot(h);
    [w * k, h * k]
}

/// The pinhole camera with the same image scale as `camera`: the film's distance from the rear
/// principal point (paraxial, 550 nm; the nodal point in air), v = film distance - BFD + EFL
/// (Hecht, Optics, 5th ed., sec. 6.1); the film distance itself for a lens without a positive v.
fn pinhole_image_distance_mm(camera: &LensCamera) -> f64 {
    let p = camera.lens.paraxial(550.0);
    let v_mm = camera.film_distance_mm - p.bfd_mm + p.efl_mm;
    if v_mm > 0.0 && v_mm.is_finite() {
        v_mm
    } else {
        camera.film_distance_mm
    }
}

/// pbrt-v4 `RealisticCamera` set-up: `lens` with its stop opened to `aperture_diameter_mm`
/// (clamped to the stop's own diameter, as pbrt does), focused on `focus_distance_m` in front of
/// its first vertex, with a film of `film_diagonal_mm`. Also returns the pinhole-equivalent field
/// of view across the shorter image axis (degrees). The error names what fails (a lens that
/// cannot form an image of that distance).
pub fn realistic_lens(
    lens: Lens,
    aperture_diameter_mm: f64,
    focus_distance_m: f64,
    film_diagonal_mm: f64,
    width: usize,
    height: usize,
) -> Result<(RealisticLens, f64), String> {
    if !(aperture_diameter_mm > 0.0 && aperture_diameter_mm.is_finite()) {
        return Err(format!("aperturediameter {aperture_diameter_mm} mm is not > 0"));
    }
    if !(focus_distance_m > 0.0 && focus_distance_m.is_finite()) {
        return Err(format!("focusdistance {focus_distance_m} m is not > 0"));
    }
    if !(film_diagonal_mm > 0.0 && film_diagonal_mm.is_finite()) {
        return Err(format!("film diagonal {film_diagonal_mm} mm is not > 0"));
    }
    let stop_r_mm = lens.surfaces[lens.stop_index()].semi_aperture_mm;
    let lens = lens.with_stop_semi_aperture_mm((aperture_diameter_mm / 2.0).min(stop_r_mm));
    let camera = LensCamera::focused(lens, focus_distance_m * 1e3, film_diagonal_mm).map_err(|e| e.to_string())?;
    let half = film_half_extent_mm(film_diagonal_mm, width, height);
    let fov_deg = 2.0 * (half[0].min(half[1]) / pinhole_image_distance_mm(&camera)).atan().to_degrees();
    Ok((RealisticLens { camera: Arc::new(camera), film_diagonal_mm }, fov_deg))
}

/// ISET3d `raytransfer` camera set-up: the RTF with a film of `film_diagonal_mm` on its input
/// plane. Its focal length comes from the RTF itself by the Abbe sine condition (a film point on
/// the axis leaves as a parallel beam of height f sin(theta) for a ray at angle theta); also
/// returns the pinhole-equivalent field of view across the shorter image axis (degrees).
pub fn ray_transfer_lens(rtf: Rtf, film_diagonal_mm: f64, width: usize, height: usize) -> Result<(RayTransferLens, f64), String> {
    if !(film_diagonal_mm > 0.0 && film_diagonal_mm.is_finite()) {
        return Err(format!("film diagonal {film_diagonal_mm} mm is not > 0"));
    }
    let sin_theta = 0.02f64;
    let h = |s: f64| rtf.trace([0.0, 0.0], [0.0, s, (1.0 - s * s).sqrt()]).map(|(p, _)| p[1]);
    let f_mm = match (h(0.0), h(sin_theta)) {
        (Some(a), Some(b)) if ((b - a) / sin_theta) > 0.0 => (b - a) / sin_theta,
        _ => return Err("the ray-transfer function passes no ray from the film centre near the axis: no focal length".into()),
    };
    let half = film_half_extent_mm(film_diagonal_mm, width, height);
    let corner_mm = half[0].hypot(half[1]);
    if corner_mm > rtf.max_height_mm() {
        return Err(format!(
            "the film's corner is {corner_mm:.3} mm off the axis, beyond the ray-transfer function's last field height {:.3} mm: use a smaller Film \"diagonal\"",
            rtf.max_height_mm()
        ));
    }
    let fov_deg = 2.0 * (half[0].min(half[1]) / f_mm).atan().to_degrees();
    Ok((RayTransferLens { rtf: Arc::new(rtf), film_diagonal_mm, focal_length_mm: f_mm }, fov_deg))
}

/// pbrt-v4 `LookAt`: the world-to-camera transform for an eye at `from` looking at `to` with
/// `up` (camera +z toward `to`, +x = normalize(up x dir), +y = dir x right). As in pbrt, in a
/// right-handed world this shows the scene mirrored left-right unless preceded by `Scale -1 1 1`.
/// Returns `None` when `up` is parallel to the viewing direction or `from == to`.
pub fn pbrt_look_at(from: [f64; 3], to: [f64; 3], up: [f64; 3]) -> Option<Transform> {
    let c2w = look_at_camera_to_world(from, to, up, false)?;
    invert_rigid(&c2w)
}

/// Camera-to-world transform for an eye at `from` looking at `to` with `up`.
/// `right_handed_view == false`: pbrt-v4 `LookAt` exactly (inverse of [`pbrt_look_at`]).
/// `right_handed_view == true`: the image shows a right-handed world as a viewer at `from` sees it
/// (camera +x maps to `dir x up`, i.e. pbrt's `Scale -1 1 1` followed by `LookAt`).
pub fn look_at_camera_to_world(from: [f64; 3], to: [f64; 3], up: [f64; 3], right_handed_view: bool) -> Option<Transform> {
    let sub = |a: [f64; 3], b: [f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    let cross = |a: [f64; 3], b: [f64; 3]| [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
    let norm = |a: [f64; 3]| {
        let l = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
        if l > 0.0 && l.is_finite() {
            Some([a[0] / l, a[1] / l, a[2] / l])
        } else {
            None
        }
    };
    let dir = norm(sub(to, from))?;
    let upn = norm(up)?;
    let mut right = norm(cross(upn, dir))?;
    let new_up = cross(dir, right);
    if right_handed_view {
        right = [-right[0], -right[1], -right[2]];
    }
    let mut t = Transform::identity();
    for r in 0..3 {
        t.m[r][0] = right[r];
        t.m[r][1] = new_up[r];
        t.m[r][2] = dir[r];
        t.m[r][3] = from[r];
    }
    Some(t)
}

/// Inverse of a transform whose 3x3 part is orthogonal (rotation, possibly with a mirror).
fn invert_rigid(t: &Transform) -> Option<Transform> {
    let mut inv = Transform::identity();
    for r in 0..3 {
        for c in 0..3 {
            inv.m[r][c] = t.m[c][r];
        }
    }
    for r in 0..3 {
        inv.m[r][3] = -(0..3).map(|k| inv.m[r][k] * t.m[k][3]).sum::<f64>();
    }
    if inv.m.iter().flatten().all(|v| v.is_finite()) {
        Some(inv)
    } else {
        None
    }
}

/// A camera whose field of view matches a lens of `focal_length_m` in front of a sensor of
/// `sensor_width_m` x `sensor_height_m` (pinhole model: fov = 2 atan(d / (2 f)) across the image's
/// shorter pixel axis, using the sensor dimension along that axis), at `from` looking at `to` with
/// `up`, rendering `width` x `height` pixels. The view is right-handed (not mirrored; see
/// [`look_at_camera_to_world`]). Degenerate input (zero focal length, `up` parallel to the view)
/// yields a camera that [`crate::render()`] rejects with a [`crate::RenderError::Camera`].
///
/// Example: the Pixel 4a preset (f = 4.38 mm, 4032 x 3024 pixels of 1.4 um, i.e. 5.645 x 4.234
/// mm) gives a vertical fov of 51.59 degrees and a horizontal fov of 65.59 degrees.
#[allow(clippy::too_many_arguments)]
pub fn camera_from_focal_length(
    focal_length_m: f64,
    sensor_width_m: f64,
    sensor_height_m: f64,
    from: [f64; 3],
    to: [f64; 3],
    up: [f64; 3],
    width: usize,
    height: usize,
) -> Camera {
    let short_side_m = if width >= height { sensor_height_m } else { sensor_width_m };
    let fov_deg = 2.0 * (short_side_m / (2.0 * focal_length_m)).atan().to_degrees();
    let fov_deg = if fov_deg.is_finite() && focal_length_m > 0.0 && short_side_m > 0.0 { fov_deg } else { f64::NAN };
    let camera_to_world = look_at_camera_to_world(from, to, up, true).unwrap_or(Transform { m: [[0.0; 4]; 4] });
    Camera { camera_to_world, fov_deg, width, height, lens: None }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pixel4a_field_of_view() {
        let c = camera_from_focal_length(4.38e-3, 4032.0 * 1.4e-6, 3024.0 * 1.4e-6, [0.0; 3], [0.0, 0.0, 1.0], [0.0, 1.0, 0.0], 4032, 3024);
        assert!((c.fov_deg - 51.60).abs() < 0.02, "{}", c.fov_deg);
        // Horizontal: 2 atan(5.6448 / 8.76) = 65.594 degrees.
        assert!((c.horizontal_fov_deg() - 65.594).abs() < 0.002, "{}", c.horizontal_fov_deg());
    }

    #[test]
    fn rays_follow_pbrt_screen_window() {
        let c = Camera { camera_to_world: Transform::identity(), fov_deg: 90.0, width: 200, height: 100, lens: None };
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
    }

    #[test]
    fn look_at_right_handed_view_is_not_mirrored() {
        // Looking down -z with +y up, the image's right is world +x.
        let t = look_at_camera_to_world([0.0; 3], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0], true).unwrap();
        let x = t.apply_vector([1.0, 0.0, 0.0]);
        assert!((x[0] - 1.0).abs() < 1e-12);
        // pbrt's LookAt maps camera +x to world -x here, and pbrt_look_at is its inverse.
        let t2 = look_at_camera_to_world([1.0, 2.0, 3.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0], false).unwrap();
        let w2c = pbrt_look_at([1.0, 2.0, 3.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]).unwrap();
        let id = w2c.then_apply_to(&t2);
        for r in 0..4 {
            for c in 0..4 {
                assert!((id.m[r][c] - if r == c { 1.0 } else { 0.0 }).abs() < 1e-12);
            }
        }
        assert!(look_at_camera_to_world([0.0; 3], [0.0, 1.0, 0.0], [0.0, 1.0, 0.0], false).is_none());
    }
}
