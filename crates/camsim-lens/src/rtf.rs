//! Ray-transfer functions (RTF): a lens given as polynomials from rays on an input plane to rays
//! on an output plane, with an elliptical pass/no-pass (vignetting) region per input height
//! (Goossens, Lyu, Ko, Wan, Farrell, Wandell, "Ray-transfer functions for camera simulation of 3D
//! scenes with hidden lens design", Optics Express 30, 2022; ISET/isetrtf JSON files).
//!
//! Conventions of the JSON (as the authors' `traceRTFFilmToScene` uses it): rays travel from the
//! film side toward the scene; the input plane lies `planeoffsetinput` mm in front of the lens's
//! sensor-side vertex. A ray is first rotated about the axis so that its input-plane point lies on
//! the +y axis at distance r; the polynomials are in (r, dx, dy), the rotated direction's x and y
//! components, and give the output point and direction (then rotated back). The ray passes when,
//! continued from the input plane a distance `intersectPlaneDistance` along the axis, it lands
//! inside the ellipse (centre, radii interpolated linearly in r between `positions`; outside the
//! listed positions nothing passes).
//!
//! A point on the input plane at r = 0 leaves the shipped Pixel 4a RTF as a collimated beam (the
//! output direction does not depend on the input direction), i.e. the input plane is the film plane
//! of a lens focused at infinity; [`Rtf::relative_illumination`] integrates there.
//!
//! The shipped Pixel 4a RTF against the lens maker's Zemax relative illumination (555 nm): its pass
//! region on the axis is an f/3.44 cone (projected solid angle 0.0663 sr), 28 % of the f/1.83 one
//! Zemax integrates (0.234 sr from its "Effective F/#"); the ray data it was fitted to (isetrtf's
//! Zemax macro samples normalized pupil coordinates within the unit circle) held a smaller pupil
//! than the design's. Its relative illumination follows Zemax's within 1.8 % out to 2.65 mm and
//! 2.2-3.9 % beyond, where the two apertures' pupils differ most. The pass ellipses are not the
//! cause: a pupil clipped by a lens rim (cat's eye) would make the minimal enclosing ellipse
//! bulge (a disk cut by one chord keeps the full circle as its minimal ellipse until half of it is
//! cut; cut to the 0.74 radial/sagittal ratio the file reaches at 3.5 mm, the ellipse's area is
//! 1.35-1.4x the region's), while the file's sagittal radii shrink smoothly from the axis (pupil
//! aberration, not clipping), and the integral over the ellipses equals a render through
//! [`Rtf::trace`] within 0.02 % (tests/it/relative_illumination.rs).

use crate::error::{LensError, Result};
use serde::Deserialize;
use std::path::Path;

#[derive(Deserialize)]
struct JsonRtf {
    #[serde(default)]
    name: Option<String>,
    thickness: f64,
    planeoffsetinput: f64,
    planeoffsetoutput: f64,
    polynomials: Vec<JsonWave>,
}

#[derive(Deserialize)]
struct JsonWave {
    wavelength_nm: f64,
    passnopass: JsonPass,
    poly: Vec<JsonPoly>,
}

#[derive(Deserialize)]
#[serde(rename_all = "camelCase")]
struct JsonPass {
    method: String,
    positions: Vec<f64>,
    radii_x: Vec<f64>,
    radii_y: Vec<f64>,
    centers_x: Vec<f64>,
    centers_y: Vec<f64>,
    intersect_plane_distance: f64,
}

#[derive(Deserialize)]
#[serde(rename_all = "lowercase")]
struct JsonPoly {
    outputname: String,
    coeff: Vec<f64>,
    termr: Vec<u32>,
    termdx: Vec<u32>,
    termdy: Vec<u32>,
}

/// One polynomial: sum of c r^a dx^b dy^e.
#[derive(Debug, Clone, PartialEq)]
struct Poly {
    terms: Vec<(f64, i32, i32, i32)>,
}

impl Poly {
    fn eval(&self, r: f64, dx: f64, dy: f64) -> f64 {
        self.terms
            .iter()
            .map(|(c, a, b, e)| c * r.powi(*a) * dx.powi(*b) * dy.powi(*e))
            .sum()
    }
}

/// The elliptical pass region at one input height.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PassEllipse {
    /// Centre (x, y) on the pass plane, mm.
    pub center_mm: [f64; 2],
    /// Radii (x, y), mm.
    pub radii_mm: [f64; 2],
}

/// A ray-transfer function at one wavelength.
#[derive(Debug, Clone, PartialEq)]
pub struct Rtf {
    /// Name from the file.
    pub name: String,
    /// Wavelength of the fit, nm.
    pub wavelength_nm: f64,
    /// Lens thickness (vertex to vertex), mm.
    pub thickness_mm: f64,
    /// Input plane in front of the sensor-side vertex, mm.
    pub plane_offset_input_mm: f64,
    /// Output plane beyond the scene-side vertex, mm.
    pub plane_offset_output_mm: f64,
    /// Pass plane distance from the input plane, mm.
    pub pass_plane_distance_mm: f64,
    positions_mm: Vec<f64>,
    ellipses: Vec<PassEllipse>,
    /// outx, outy, outz, outdx, outdy, outdz.
    polys: [Poly; 6],
}

const OUTPUTS: [&str; 6] = ["outx", "outy", "outz", "outdx", "outdy", "outdz"];

impl Rtf {
    /// Read an RTF JSON file (the first wavelength it holds).
    pub fn from_file(path: &Path) -> Result<Rtf> {
        let text = std::fs::read_to_string(path).map_err(|e| LensError::File {
            path: path.to_path_buf(),
            message: e.to_string(),
        })?;
        Rtf::from_json(&text, &path.display().to_string())
    }

    /// Parse RTF JSON (`what` names the source in messages).
    pub fn from_json(text: &str, what: &str) -> Result<Rtf> {
        let bad = |m: String| LensError::Lens {
            what: what.to_string(),
            message: m,
        };
        let j: JsonRtf = serde_json::from_str(text).map_err(|e| LensError::Parse {
            what: what.to_string(),
            line: e.line(),
            message: e.to_string(),
        })?;
        let w = j
            .polynomials
            .first()
            .ok_or_else(|| bad("no polynomials".into()))?;
        let p = &w.passnopass;
        if p.method != "minimalellipse" {
            return Err(bad(format!(
                "passnopass.method '{}': only 'minimalellipse' is supported",
                p.method
            )));
        }
        let n = p.positions.len();
        if n < 2
            || [
                p.radii_x.len(),
                p.radii_y.len(),
                p.centers_x.len(),
                p.centers_y.len(),
            ]
            .iter()
            .any(|l| *l != n)
        {
            return Err(bad(format!(
                "passnopass: positions, radiiX, radiiY, centersX, centersY must have the same length >= 2 ({n} positions)"
            )));
        }
        if p.positions
            .windows(2)
            .any(|w| w[1].partial_cmp(&w[0]) != Some(std::cmp::Ordering::Greater))
            || p.positions.iter().any(|v| !v.is_finite())
        {
            return Err(bad(
                "passnopass.positions must be finite and increasing".into()
            ));
        }
        let all = [&p.radii_x, &p.radii_y, &p.centers_x, &p.centers_y];
        if all.iter().any(|v| v.iter().any(|x| !x.is_finite()))
            || p.radii_x.iter().chain(&p.radii_y).any(|r| *r <= 0.0)
        {
            return Err(bad(
                "passnopass: radii must be finite and > 0, centres finite".into(),
            ));
        }
        if !(p.intersect_plane_distance.is_finite() && p.intersect_plane_distance != 0.0) {
            return Err(bad(format!(
                "passnopass.intersectPlaneDistance {} must be finite and nonzero",
                p.intersect_plane_distance
            )));
        }
        let ellipses = (0..n)
            .map(|i| PassEllipse {
                center_mm: [p.centers_x[i], p.centers_y[i]],
                radii_mm: [p.radii_x[i], p.radii_y[i]],
            })
            .collect();
        let mut polys: Vec<Poly> = Vec::new();
        for name in OUTPUTS {
            let q = w
                .poly
                .iter()
                .find(|q| q.outputname == name)
                .ok_or_else(|| bad(format!("no polynomial for {name}")))?;
            let k = q.coeff.len();
            if [q.termr.len(), q.termdx.len(), q.termdy.len()]
                .iter()
                .any(|l| *l != k)
                || q.coeff.iter().any(|c| !c.is_finite())
            {
                return Err(bad(format!("polynomial {name}: coeff, termr, termdx, termdy must be finite and of one length")));
            }
            if q.termr
                .iter()
                .chain(&q.termdx)
                .chain(&q.termdy)
                .any(|e| *e > 16)
            {
                return Err(bad(format!("polynomial {name}: exponents above 16")));
            }
            let terms = (0..k)
                .map(|i| {
                    (
                        q.coeff[i],
                        q.termr[i] as i32,
                        q.termdx[i] as i32,
                        q.termdy[i] as i32,
                    )
                })
                .collect();
            polys.push(Poly { terms });
        }
        let polys: [Poly; 6] = polys
            .try_into()
            .map_err(|_| bad("six polynomials expected".into()))?;
        Ok(Rtf {
            name: j.name.unwrap_or_default(),
            wavelength_nm: w.wavelength_nm,
            thickness_mm: j.thickness,
            plane_offset_input_mm: j.planeoffsetinput,
            plane_offset_output_mm: j.planeoffsetoutput,
            pass_plane_distance_mm: p.intersect_plane_distance,
            positions_mm: p.positions.clone(),
            ellipses,
            polys,
        })
    }

    /// Largest input height with a pass region, mm.
    pub fn max_height_mm(&self) -> f64 {
        self.positions_mm.last().copied().unwrap_or(0.0)
    }

    /// The pass ellipse at input height `r_mm` (linear interpolation; `None` outside the table).
    pub fn pass_ellipse(&self, r_mm: f64) -> Option<PassEllipse> {
        let x = &self.positions_mm;
        if !(r_mm >= x[0] && r_mm <= x[x.len() - 1]) {
            return None;
        }
        let i = x.partition_point(|v| *v < r_mm).clamp(1, x.len() - 1);
        let w = (r_mm - x[i - 1]) / (x[i] - x[i - 1]);
        let (a, b) = (self.ellipses[i - 1], self.ellipses[i]);
        let l = |p: f64, q: f64| p * (1.0 - w) + q * w;
        Some(PassEllipse {
            center_mm: [
                l(a.center_mm[0], b.center_mm[0]),
                l(a.center_mm[1], b.center_mm[1]),
            ],
            radii_mm: [
                l(a.radii_mm[0], b.radii_mm[0]),
                l(a.radii_mm[1], b.radii_mm[1]),
            ],
        })
    }

    /// The pass ellipse extrapolated linearly beyond the last position, at most one step.
    fn extrapolated_ellipse(&self, r_mm: f64) -> Option<PassEllipse> {
        let x = &self.positions_mm;
        let k = x.len();
        let step = x[k - 1] - x[k - 2];
        if !(r_mm > x[k - 1] && r_mm <= x[k - 1] + step) {
            return None;
        }
        let w = (r_mm - x[k - 1]) / step;
        let (a, b) = (self.ellipses[k - 2], self.ellipses[k - 1]);
        let l = |p: f64, q: f64| q + (q - p) * w;
        Some(PassEllipse {
            center_mm: [
                l(a.center_mm[0], b.center_mm[0]),
                l(a.center_mm[1], b.center_mm[1]),
            ],
            radii_mm: [
                l(a.radii_mm[0], b.radii_mm[0]),
                l(a.radii_mm[1], b.radii_mm[1]),
            ],
        })
    }

    /// The pass ellipse at input height `r_mm`, with [`Self::irradiance`]'s linear extrapolation up
    /// to one table step beyond the last position (`None` further out).
    pub fn pass_region(&self, r_mm: f64) -> Option<PassEllipse> {
        self.pass_ellipse(r_mm)
            .or_else(|| self.extrapolated_ellipse(r_mm))
    }

    /// Trace a ray given on the input plane (point (x, y) in mm, unit direction toward the lens,
    /// z > 0): `None` when vignetted; else the output point (x, y, z: z measured as the file does)
    /// and unit direction.
    pub fn trace(&self, point_mm: [f64; 2], direction: [f64; 3]) -> Option<([f64; 3], [f64; 3])> {
        let r = point_mm[0].hypot(point_mm[1]);
        if direction[2] <= 0.0 || !self.inside(&self.pass_ellipse(r)?, point_mm, direction) {
            return None;
        }
        Some(self.transfer(point_mm, direction))
    }

    /// Whether the ray (input-plane point, direction with z > 0), continued to the pass plane,
    /// lands inside the pass ellipse `e` (given in the frame where the point lies on +y).
    pub fn inside(&self, e: &PassEllipse, point_mm: [f64; 2], direction: [f64; 3]) -> bool {
        let r = point_mm[0].hypot(point_mm[1]);
        let (c, s) = if r > 0.0 {
            (point_mm[1] / r, point_mm[0] / r)
        } else {
            (1.0, 0.0)
        };
        let d = [
            direction[0] * c - direction[1] * s,
            direction[0] * s + direction[1] * c,
        ];
        let t = self.pass_plane_distance_mm / direction[2];
        let (px, py) = (d[0] * t, r + d[1] * t);
        let (u, v) = (
            (px - e.center_mm[0]) / e.radii_mm[0],
            (py - e.center_mm[1]) / e.radii_mm[1],
        );
        u * u + v * v <= 1.0
    }

    /// The polynomial transfer of a ray given on the input plane, without the pass test (the
    /// caller checks [`Self::inside`]): output point (x, y, z) and direction.
    pub fn transfer(&self, point_mm: [f64; 2], direction: [f64; 3]) -> ([f64; 3], [f64; 3]) {
        let r = point_mm[0].hypot(point_mm[1]);
        // Rotation taking the point to the +y axis: (x, y) -> (x c - y s, x s + y c) with the angle
        // that maps (px, py) to (0, r): c = py / r, s = px / r.
        let (c, s) = if r > 0.0 {
            (point_mm[1] / r, point_mm[0] / r)
        } else {
            (1.0, 0.0)
        };
        let d = [
            direction[0] * c - direction[1] * s,
            direction[0] * s + direction[1] * c,
        ];
        let mut o = [0.0; 6];
        o.iter_mut()
            .zip(&self.polys)
            .for_each(|(v, p)| *v = p.eval(r, d[0], d[1]));
        // Rotate back: inverse rotation (x, y) -> (x c + y s, -x s + y c).
        let back = |v: [f64; 2]| [v[0] * c + v[1] * s, -v[0] * s + v[1] * c];
        let pos = back([o[0], o[1]]);
        let dir = back([o[3], o[4]]);
        ([pos[0], pos[1], o[2]], [dir[0], dir[1], o[5]])
    }

    /// Relative illumination at film heights `heights_mm` (film on the input plane, lens focused
    /// at infinity), normalized to the axis: the irradiance of a uniform Lambertian scene is
    /// E = L integral of cos(theta) d(omega) over the directions that pass (radiance is conserved
    /// along a ray through a lossless lens, so L is the same for every passing ray). With the pass
    /// region an ellipse on a plane at distance D from the film point (0, h):
    /// cos(theta) d(omega) = D^2 dA / rho^4, rho^2 = x^2 + (y - h)^2 + D^2 (the projected solid
    /// angle of a plane patch). Integrated by the midpoint rule on an `n` x `n` grid over the
    /// ellipse's bounding box in ellipse coordinates (area element rx ry du dv).
    pub fn relative_illumination(&self, heights_mm: &[f64], n: usize) -> Vec<Option<f64>> {
        let e0 = self.irradiance(0.0, n);
        heights_mm
            .iter()
            .map(|h| self.irradiance(*h, n).zip(e0).map(|(e, z)| e / z))
            .collect()
    }

    /// Film offset behind the input plane (mm) that focuses an object plane `focus_distance_mm`
    /// in front of the film (infinite allowed): the offset at which the rays from the axial film
    /// point, over the whole pass region, spread least in object space (RMS angular spread about
    /// their mean, weighted by projected solid angle; golden-section search over -0.2..0.8 mm, to
    /// 0.05 um). ISET3d's `filmdistance` (film to the lens's sensor-side vertex) is
    /// `plane_offset_input_mm` plus this offset. `None` when no ray passes.
    ///
    /// The input plane of an RTF need not be a focal plane: the shipped Pixel 4a file's rays from
    /// the axial point of its input plane leave with an RMS spread of 3.5e-4 rad (1.5 um at
    /// f = 4.38 mm); 16.6 um further back they leave parallel (spread 6e-5 rad).
    pub fn focus_offset_mm(&self, focus_distance_mm: f64) -> Option<f64> {
        if focus_distance_mm.is_nan() || focus_distance_mm <= 0.0 {
            return None;
        }
        let spread = |dz: f64| {
            self.axial_spread(dz, focus_distance_mm)
                .unwrap_or(f64::INFINITY)
        };
        self.axial_spread(0.0, focus_distance_mm)?;
        Some(golden_section_min(spread, -0.2, 0.8, 5e-5))
    }

    /// RMS object-space angular spread (about the mean) of the rays from the axial film point `dz`
    /// mm behind the input plane toward an object plane `focus_distance_mm` from the film; `None`
    /// when none passes. Rays on a 24 x 24 grid over the axial pass ellipse (enlarged to cover
    /// the pass regions of the input-plane points they cross), each with the exact pass test.
    fn axial_spread(&self, dz: f64, focus_distance_mm: f64) -> Option<f64> {
        let m = 24usize;
        let e = self.pass_region(0.0)?;
        let d = self.pass_plane_distance_mm;
        let grow = 1.05 + dz.abs() / d;
        let (mut sw, mut s1, mut s2) = (0.0, [0.0f64; 2], 0.0);
        for i in 0..m {
            for j in 0..m {
                let u = -1.0 + (2 * i + 1) as f64 / m as f64;
                let v = -1.0 + (2 * j + 1) as f64 / m as f64;
                let q = [
                    e.center_mm[0] + grow * e.radii_mm[0] * u,
                    e.center_mm[1] + grow * e.radii_mm[1] * v,
                ];
                let Some((pin, dir, w)) = self.film_ray([0.0, 0.0], dz, q) else {
                    continue;
                };
                let Some((o, od)) = self.trace(pin, dir) else {
                    continue;
                };
                let t = if focus_distance_mm.is_finite() {
                    // Land on the object plane (z from the input plane), as an angle from the film.
                    let z_obj = focus_distance_mm - dz;
                    let s = (z_obj - o[2]) / od[2];
                    [
                        (o[0] + od[0] * s) / focus_distance_mm,
                        (o[1] + od[1] * s) / focus_distance_mm,
                    ]
                } else {
                    [od[0] / od[2], od[1] / od[2]]
                };
                sw += w;
                s1[0] += w * t[0];
                s1[1] += w * t[1];
                s2 += w * (t[0] * t[0] + t[1] * t[1]);
            }
        }
        (sw > 0.0).then(|| {
            (s2 / sw - (s1[0] / sw).powi(2) - (s1[1] / sw).powi(2))
                .max(0.0)
                .sqrt()
        })
    }

    /// The ray from film point `p` (mm), the film `dz` mm behind the input plane, toward point `q`
    /// (mm) of the pass plane: its input-plane point, unit direction, and the projected solid
    /// angle per unit pass-plane area seen from the film point, D'^2 / rho^4 (D' = D + dz the
    /// film-to-pass-plane distance, rho the ray's length to q). `None` when the film lies at or
    /// beyond the pass plane.
    pub fn film_ray(&self, p: [f64; 2], dz: f64, q: [f64; 2]) -> Option<([f64; 2], [f64; 3], f64)> {
        let dd = self.pass_plane_distance_mm + dz;
        if dd.is_nan() || dd <= 0.0 {
            return None;
        }
        let v = [q[0] - p[0], q[1] - p[1], dd];
        let rho2 = v[0] * v[0] + v[1] * v[1] + dd * dd;
        let rho = rho2.sqrt();
        let t = dz / dd;
        Some((
            [p[0] + v[0] * t, p[1] + v[1] * t],
            [v[0] / rho, v[1] / rho, v[2] / rho],
            dd * dd / (rho2 * rho2),
        ))
    }

    /// The pass ellipse that governs the rays from film point (0, `r_mm`), the film `dz` mm behind
    /// the input plane: the one at the input height where the ray toward the ellipse's own centre
    /// crosses the input plane (two fixed-point steps; on the input plane, the ellipse at r).
    pub fn film_pass_ellipse(&self, r_mm: f64, dz: f64) -> Option<PassEllipse> {
        let mut e = self.pass_ellipse(r_mm)?;
        if dz != 0.0 {
            for _ in 0..2 {
                let (pin, _, _) = self.film_ray([0.0, r_mm], dz, e.center_mm)?;
                e = self.pass_region(pin[0].hypot(pin[1]))?;
            }
        }
        Some(e)
    }

    /// The chief ray of film point (0, `h_mm`), the film `dz` mm behind the input plane: the ray
    /// toward the centre of its pass ellipse, as it leaves the lens: output point (mm, z from the
    /// film) and unit direction; `None` when it does not pass.
    pub fn chief_ray(&self, h_mm: f64, dz: f64) -> Option<([f64; 3], [f64; 3])> {
        let e = self.film_pass_ellipse(h_mm, dz)?;
        let (pin, dir, _) = self.film_ray([0.0, h_mm], dz, e.center_mm)?;
        let (o, d) = self.trace(pin, dir)?;
        Some(([o[0], o[1], o[2] + dz], d))
    }

    /// The integral of [`Self::relative_illumination`] (projected solid angle, sr) at height h.
    /// Heights up to one table step beyond the last position use the ellipse extrapolated
    /// linearly from the last two (the shipped Pixel 4a table ends at 3.5 mm; the sensor's
    /// half-diagonal and Zemax's last field are 3.528 mm).
    pub fn irradiance(&self, h_mm: f64, n: usize) -> Option<f64> {
        let e = self.pass_region(h_mm)?;
        let d = self.pass_plane_distance_mm;
        let n = n.max(8);
        let mut s = 0.0;
        for i in 0..n {
            let u = -1.0 + (2 * i + 1) as f64 / n as f64;
            for j in 0..n {
                let v = -1.0 + (2 * j + 1) as f64 / n as f64;
                if u * u + v * v > 1.0 {
                    continue;
                }
                let x = e.center_mm[0] + e.radii_mm[0] * u;
                let y = e.center_mm[1] + e.radii_mm[1] * v;
                let rho2 = x * x + (y - h_mm) * (y - h_mm) + d * d;
                s += d * d / (rho2 * rho2);
            }
        }
        Some(s * e.radii_mm[0] * e.radii_mm[1] * (2.0 / n as f64).powi(2))
    }
}

/// One row of a Zemax relative-illumination table.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RelativeIlluminationRow {
    /// Image height (Zemax "Y Field"), mm.
    pub height_mm: f64,
    /// Relative illumination (fraction).
    pub ri: f64,
    /// Effective F/#.
    pub effective_f_number: f64,
}

/// Read a Zemax "Relative Illumination Data" text export: header lines, then rows of three
/// numbers (field in mm, relative illumination, effective F/#). The file may be Latin-1 (Zemax
/// writes "µm"); non-numeric lines are header text.
pub fn read_zemax_relative_illumination(path: &Path) -> Result<Vec<RelativeIlluminationRow>> {
    let bytes = std::fs::read(path).map_err(|e| LensError::File {
        path: path.to_path_buf(),
        message: e.to_string(),
    })?;
    let text = String::from_utf8_lossy(&bytes);
    let mut rows = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let nums: Vec<f64> = line
            .split_whitespace()
            .map_while(|t| t.parse::<f64>().ok())
            .collect();
        let words = line.split_whitespace().count();
        if words == 3 && nums.len() == 3 && nums.iter().all(|v| v.is_finite()) {
            rows.push(RelativeIlluminationRow {
                height_mm: nums[0],
                ri: nums[1],
                effective_f_number: nums[2],
            });
        } else if !rows.is_empty() && words > 0 {
            return Err(LensError::Parse {
                what: path.display().to_string(),
                line: n + 1,
                message: format!(
                    "'{}' is not three numbers (field mm, relative illumination, effective F/#)",
                    line.trim()
                ),
            });
        }
    }
    if rows.is_empty() {
        return Err(LensError::Lens {
            what: path.display().to_string(),
            message: "no relative illumination rows".into(),
        });
    }
    Ok(rows)
}

/// The minimum of a unimodal function on [a, b] by golden-section search (Kiefer 1953; Press et
/// al., Numerical Recipes, 3rd ed., sec. 10.2), to an interval of `tol`.
pub fn golden_section_min(mut f: impl FnMut(f64) -> f64, a: f64, b: f64, tol: f64) -> f64 {
    let g = 0.5 * (5f64.sqrt() - 1.0);
    let (mut a, mut b) = (a, b);
    let (mut x1, mut x2) = (b - g * (b - a), a + g * (b - a));
    let (mut f1, mut f2) = (f(x1), f(x2));
    while b - a > tol {
        if f1 < f2 {
            (b, x2, f2) = (x2, x1, f1);
            x1 = b - g * (b - a);
            f1 = f(x1);
        } else {
            (a, x1, f1) = (x1, x2, f2);
            x2 = a + g * (b - a);
            f2 = f(x2);
        }
    }
    0.5 * (a + b)
}
