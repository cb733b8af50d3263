//! Camera set-up: pbrt-v4's `LookAt`, a camera from a lens focal length and sensor size, and the
//! `RealisticCamera` / ISET3d `raytransfer` lens set-ups (film extent, focus, equivalent field of
//! view). The ray generation for these cameras is the tracer's (`camsim_render`'s camera rig).

pub use crate::scene::film_half_extent_mm;
use crate::scene::{Camera, RayTransferLens, RealisticLens, Transform};
use camsim_lens::{Lens, LensCamera, Rtf};
use std::sync::Arc;

/// The pinhole camera with the same image scale as `camera`: the film's distance from the rear
/// principal point (paraxial, 550 nm; the nodal point in air), v = film distance - BFD + EFL
/// (Hecht, Optics, 5th ed., sec. 6.1); the film distance itself for a lens without a positive v.
pub fn pinhole_image_distance_mm(camera: &LensCamera) -> f64 {
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
        return Err(format!(
            "aperturediameter {aperture_diameter_mm} mm is not > 0"
        ));
    }
    if !(focus_distance_m > 0.0 && focus_distance_m.is_finite()) {
        return Err(format!("focusdistance {focus_distance_m} m is not > 0"));
    }
    if !(film_diagonal_mm > 0.0 && film_diagonal_mm.is_finite()) {
        return Err(format!("film diagonal {film_diagonal_mm} mm is not > 0"));
    }
    let stop_r_mm = lens.surfaces[lens.stop_index()].semi_aperture_mm;
    let lens = lens.with_stop_semi_aperture_mm((aperture_diameter_mm / 2.0).min(stop_r_mm));
    let camera = LensCamera::focused(lens, focus_distance_m * 1e3, film_diagonal_mm)
        .map_err(|e| e.to_string())?;
    let lens = realistic_lens_with_pinhole(camera, film_diagonal_mm);
    let fov_deg = lens.fov_deg(width, height);
    Ok((lens, fov_deg))
}

/// A realistic camera's lens with the pinhole that images as it does near the axis
/// ([`chief_ray_pinhole`]): the chief ray (through the centre of the exit-pupil bounds, 550 nm) of
/// a film point 1 % of the focal length off the axis. Falls back to the paraxial image distance
/// with the pinhole on the film ([`pinhole_image_distance_mm`]) if that ray is blocked.
pub fn realistic_lens_with_pinhole(camera: LensCamera, film_diagonal_mm: f64) -> RealisticLens {
    let h_mm = 0.01 * camera.lens.paraxial(550.0).efl_mm.abs();
    let b = camera.exit_pupil_bounds(h_mm);
    let dir = [
        0.5 * (b[0] + b[1]) - h_mm,
        0.5 * (b[2] + b[3]),
        -camera.film_distance_mm,
    ];
    // Lens coordinates (scene toward -z, the film point on +x) to the film frame of
    // `chief_ray_pinhole` (z from the film toward the scene, the film point on +y).
    let film_z_mm = camera.film_z_mm();
    let chief = camera.trace_ray([h_mm, 0.0], dir, 550.0).map(|r| {
        (
            [r.origin_mm[1], r.origin_mm[0], film_z_mm - r.origin_mm[2]],
            [r.direction[1], r.direction[0], -r.direction[2]],
        )
    });
    let (image_distance_mm, pupil_z_mm) =
        chief_ray_pinhole(h_mm, chief).unwrap_or_else(|| (pinhole_image_distance_mm(&camera), 0.0));
    RealisticLens {
        camera: Arc::new(camera),
        film_diagonal_mm,
        image_distance_mm,
        pupil_z_mm,
    }
}

/// Where a ray-transfer camera's film lies.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum RtfFilm {
    /// ISET3d's `filmdistance`: from the film to the lens's sensor-side vertex, mm.
    DistanceMm(f64),
    /// Focused (autofocus, [`Rtf::focus_offset_mm`]) on an object plane this far from the film, m
    /// (infinite allowed).
    FocusM(f64),
}

/// ISET3d `raytransfer` camera set-up: the RTF with a film of `film_diagonal_mm` placed as `film`
/// says. Its focal length comes from the RTF itself by the Abbe sine condition (a point on the
/// input plane's axis leaves as a parallel beam of height f sin(theta) for a ray at angle theta);
/// also returns the pinhole-equivalent field of view across the shorter image axis (degrees), at
/// the image distance of the film's focus.
pub fn ray_transfer_lens(
    rtf: Rtf,
    film: RtfFilm,
    film_diagonal_mm: f64,
    width: usize,
    height: usize,
) -> Result<(RayTransferLens, f64), String> {
    if !(film_diagonal_mm > 0.0 && film_diagonal_mm.is_finite()) {
        return Err(format!("film diagonal {film_diagonal_mm} mm is not > 0"));
    }
    let sin_theta = 0.02f64;
    let h = |s: f64| {
        rtf.trace([0.0, 0.0], [0.0, s, (1.0 - s * s).sqrt()])
            .map(|(p, _)| p[1])
    };
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
    let pass_mm = rtf.pass_plane_distance_mm;
    let film_offset_mm = match film {
        RtfFilm::DistanceMm(d) => {
            let dz = d - rtf.plane_offset_input_mm;
            if !(d > 0.0 && d.is_finite() && pass_mm + dz > 0.0) {
                return Err(format!(
                    "filmdistance {d} mm must be > 0 and put the film in front of the pass plane ({:.4} mm beyond the lens's sensor-side vertex)",
                    pass_mm - rtf.plane_offset_input_mm
                ));
            }
            dz
        }
        RtfFilm::FocusM(m) => {
            if m.is_nan() || m <= 0.0 {
                return Err(format!("focusdistance {m} m must be > 0"));
            }
            let lens_mm = rtf.plane_offset_input_mm + rtf.thickness_mm + rtf.plane_offset_output_mm;
            if m * 1e3 <= lens_mm {
                return Err(format!(
                    "focusdistance {m} m lies inside the lens (its RTF spans {lens_mm:.3} mm from the film's side to its output plane)"
                ));
            }
            let dz = rtf
                .focus_offset_mm(m * 1e3)
                .ok_or("the ray-transfer function passes no ray from the film centre: no focus")?;
            // The search runs over -0.2..0.8 mm: an optimum on its edge is no focus.
            if !(-0.199..=0.799).contains(&dz) {
                return Err(format!(
                    "the lens does not focus at focusdistance {m} m: the sharpest film lies {dz:.3} mm from the input plane, at the end of the 1 mm focus range (set filmdistance instead)"
                ));
            }
            dz
        }
    };
    // The pinhole that images as the lens does near the axis (0.1 mm: clear of the RTF's kink at
    // r = 0, see camsim-optics' rtf_psf).
    let h_mm = 0.1;
    let (image_distance_mm, pupil_z_mm) =
        chief_ray_pinhole(h_mm, rtf.chief_ray(h_mm, film_offset_mm)).ok_or(
            "the ray-transfer function passes no chief ray 0.1 mm off the axis: no image scale",
        )?;
    let fov_deg = 2.0
        * (half[0].min(half[1]) / image_distance_mm)
            .atan()
            .to_degrees();
    let lens = RayTransferLens {
        rtf: Arc::new(rtf),
        film_offset_mm,
        film_diagonal_mm,
        focal_length_mm: f_mm,
        image_distance_mm,
        pupil_z_mm,
    };
    Ok((lens, fov_deg))
}

/// The pinhole camera equivalent to a lens near its axis, from the chief ray of a film point `h_mm`
/// up the +y axis as it leaves the lens (`chief`: point, mm with z from the film toward the
/// scene, and unit direction): the image distance v = h / tan(theta) (theta its angle in object
/// space; the image is inverted, so the ray heads down) and the entrance pupil's z, where the
/// ray continued backwards crosses the axis (the centre of perspective: a point at any distance
/// images where the ray from the pupil at that angle meets it). `None` for a ray that does not
/// head down toward the scene.
pub fn chief_ray_pinhole(h_mm: f64, chief: Option<([f64; 3], [f64; 3])>) -> Option<(f64, f64)> {
    let (o, d) = chief?;
    if !(d[2] > 0.0 && d[1] < 0.0) {
        return None;
    }
    let v_mm = h_mm * d[2] / -d[1];
    let pupil_z_mm = o[2] - o[1] * d[2] / d[1];
    (v_mm > 0.0 && v_mm.is_finite() && pupil_z_mm.is_finite()).then_some((v_mm, pupil_z_mm))
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
pub fn look_at_camera_to_world(
    from: [f64; 3],
    to: [f64; 3],
    up: [f64; 3],
    right_handed_view: bool,
) -> Option<Transform> {
    let sub = |a: [f64; 3], b: [f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    let cross = |a: [f64; 3], b: [f64; 3]| {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    };
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
/// yields a camera that `camsim_render::render()` rejects with `RenderError::Camera`.
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
    let short_side_m = if width >= height {
        sensor_height_m
    } else {
        sensor_width_m
    };
    let fov_deg = 2.0 * (short_side_m / (2.0 * focal_length_m)).atan().to_degrees();
    let fov_deg = if fov_deg.is_finite() && focal_length_m > 0.0 && short_side_m > 0.0 {
        fov_deg
    } else {
        f64::NAN
    };
    let camera_to_world =
        look_at_camera_to_world(from, to, up, true).unwrap_or(Transform { m: [[0.0; 4]; 4] });
    Camera {
        camera_to_world,
        fov_deg,
        width,
        height,
        lens: None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pixel4a_field_of_view() {
        let c = camera_from_focal_length(
            4.38e-3,
            4032.0 * 1.4e-6,
            3024.0 * 1.4e-6,
            [0.0; 3],
            [0.0, 0.0, 1.0],
            [0.0, 1.0, 0.0],
            4032,
            3024,
        );
        assert!((c.fov_deg - 51.60).abs() < 0.02, "{}", c.fov_deg);
        // Horizontal: 2 atan(5.6448 / 8.76) = 65.594 degrees.
        assert!(
            (c.horizontal_fov_deg() - 65.594).abs() < 0.002,
            "{}",
            c.horizontal_fov_deg()
        );
    }

    #[test]
    fn look_at_right_handed_view_is_not_mirrored() {
        // Looking down -z with +y up, the image's right is world +x.
        let t = look_at_camera_to_world([0.0; 3], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0], true).unwrap();
        let x = t.apply_vector([1.0, 0.0, 0.0]);
        assert!((x[0] - 1.0).abs() < 1e-12);
        // pbrt's LookAt maps camera +x to world -x here, and pbrt_look_at is its inverse.
        let t2 = look_at_camera_to_world([1.0, 2.0, 3.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0], false)
            .unwrap();
        let w2c = pbrt_look_at([1.0, 2.0, 3.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]).unwrap();
        let id = w2c.then_apply_to(&t2);
        for r in 0..4 {
            for c in 0..4 {
                assert!((id.m[r][c] - if r == c { 1.0 } else { 0.0 }).abs() < 1e-12);
            }
        }
        assert!(
            look_at_camera_to_world([0.0; 3], [0.0, 1.0, 0.0], [0.0, 1.0, 0.0], false).is_none()
        );
    }
}
