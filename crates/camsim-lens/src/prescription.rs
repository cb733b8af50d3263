//! Lens prescriptions: a sequence of refracting surfaces and one aperture stop along the optical
//! axis, read from ISET3d lens JSON or pbrt-v4 `realistic` lens files.
//!
//! Conventions (both formats, ISET3d `lensC` and pbrt-v4 `RealisticCamera`): surfaces are listed
//! from the object side to the image side; each surface's `thickness` is the axial distance to
//! the next surface; its index (`ior`, pbrt's `eta`) is that of the medium *after* it (toward the
//! image), 0 meaning air; a radius of 0 is the aperture stop (a flat opening). All lengths in mm.
//! The first surface's vertex is at z = 0 and light travels toward +z; a radius > 0 has its centre
//! of curvature on the image side (+z).
//!
//! Surface shape (sag along z at radial height r; ISO 10110-12 / Zemax "even asphere"):
//!
//! ```text
//! z(r) = c r^2 / (1 + sqrt(1 - (1 + k) c^2 r^2)) + a_1 r^2 + a_2 r^4 + a_3 r^6 + ...
//! ```
//!
//! with c = 1 / radius and k the conic constant. The aspheric series starts at r^2 as Zemax's even
//! asphere does: with that reading the shipped `mobile.76deg.4.4mm` lens has a paraxial focal
//! length of 4.418 mm (its name says 4.4 mm), while a series starting at r^4 would give 11.7 mm.

use crate::error::{LensError, Result};
use crate::glass::Medium;
use serde::Deserialize;
use std::path::Path;

/// How far consecutive surfaces may cross inside their common aperture before [`Lens::check`]
/// refuses the lens, mm: the classic designs that ISET3d scales down to 4.38 mm have knife-edge
/// elements whose faces meet just inside the rim (dogmar's first element: by 8.3 um at its 0.69 mm
/// semi-aperture).
pub const CROSSING_TOLERANCE_MM: f64 = 0.01;

/// One surface of a prescription.
#[derive(Debug, Clone, PartialEq)]
pub struct Surface {
    /// Radius of curvature at the vertex, mm (0: flat; the stop is flat).
    pub radius_mm: f64,
    /// Axial distance to the next surface (or the image plane after the last), mm.
    pub thickness_mm: f64,
    /// Medium after the surface (toward the image).
    pub medium: Medium,
    /// Clear semi-aperture (radius), mm: rays farther from the axis are blocked.
    pub semi_aperture_mm: f64,
    /// Conic constant k (0 sphere, -1 paraboloid).
    pub conic: f64,
    /// Even-asphere coefficients of r^2, r^4, r^6, ... (mm^-1, mm^-3, ...).
    pub aspheric: Vec<f64>,
    /// True for the aperture stop.
    pub is_stop: bool,
}

impl Surface {
    /// Vertex curvature 1 / radius, 1/mm (0 for flat).
    pub fn curvature_per_mm(&self) -> f64 {
        if self.radius_mm == 0.0 {
            0.0
        } else {
            1.0 / self.radius_mm
        }
    }

    /// Paraxial curvature, 1/mm: the vertex curvature plus twice the r^2 aspheric coefficient (the
    /// conic and higher terms do not change the paraxial power).
    pub fn paraxial_curvature_per_mm(&self) -> f64 {
        self.curvature_per_mm() + 2.0 * self.aspheric.first().copied().unwrap_or(0.0)
    }

    /// Sag z(r) relative to the vertex, mm; `None` where the conic is undefined
    /// ((1 + k) c^2 r^2 > 1).
    pub fn sag_mm(&self, r_mm: f64) -> Option<f64> {
        let c = self.curvature_per_mm();
        let r2 = r_mm * r_mm;
        let q = 1.0 - (1.0 + self.conic) * c * c * r2;
        if q < 0.0 {
            return None;
        }
        let mut z = c * r2 / (1.0 + q.sqrt());
        let mut p = r2;
        for a in &self.aspheric {
            z += a * p;
            p *= r2;
        }
        Some(z)
    }

    /// dz/dr of the sag at r, or `None` where undefined (or where the surface turns vertical).
    pub fn sag_slope(&self, r_mm: f64) -> Option<f64> {
        let c = self.curvature_per_mm();
        let q = 1.0 - (1.0 + self.conic) * c * c * r_mm * r_mm;
        if q <= 0.0 && c != 0.0 {
            return None;
        }
        // d/dr [c r^2 / (1 + sqrt(q))] = c r / sqrt(q).
        let mut s = if c == 0.0 { 0.0 } else { c * r_mm / q.sqrt() };
        let mut p = r_mm;
        for (i, a) in self.aspheric.iter().enumerate() {
            s += 2.0 * (i + 1) as f64 * a * p;
            p *= r_mm * r_mm;
        }
        Some(s)
    }

    /// True for a sphere (or plane) without conic or aspheric terms.
    pub fn is_spherical(&self) -> bool {
        self.conic == 0.0 && self.aspheric.iter().all(|a| *a == 0.0)
    }
}

/// A lens: its surfaces, object side first.
#[derive(Debug, Clone, PartialEq)]
pub struct Lens {
    /// Name (from the file, or the file name).
    pub name: String,
    /// Surfaces, object side first.
    pub surfaces: Vec<Surface>,
}

/// ISET3d lens JSON (`lensC` `fileWrite`): name, description, type, surfaces.
#[derive(Deserialize)]
struct JsonLens {
    #[serde(default)]
    name: Option<String>,
    surfaces: Vec<JsonSurface>,
}

#[derive(Deserialize)]
struct JsonSurface {
    radius: f64,
    thickness: f64,
    ior: f64,
    semi_aperture: f64,
    #[serde(default)]
    conic_constant: Option<NumberOrList>,
    #[serde(default)]
    aspheric_coefficients: Vec<f64>,
    /// camsim extension: Abbe number V_d of the medium after the surface (dispersion).
    #[serde(default)]
    abbe_number: Option<f64>,
}

#[derive(Deserialize)]
#[serde(untagged)]
enum NumberOrList {
    Number(f64),
    List(Vec<f64>),
}

impl Lens {
    /// Read a lens file: `.json` as ISET3d lens JSON, anything else as a pbrt-v4 `realistic` lens
    /// file. The lens is checked ([`Lens::check`]).
    pub fn from_file(path: &Path) -> Result<Lens> {
        let lens = Lens::from_file_unchecked(path)?;
        lens.check(&path.display().to_string())?;
        Ok(lens)
    }

    /// [`Lens::from_file`] without [`Lens::check`]'s geometric checks (the file must still parse):
    /// for inspecting a prescription that is physically inconsistent somewhere, e.g. its paraxial
    /// properties near the axis.
    pub fn from_file_unchecked(path: &Path) -> Result<Lens> {
        let text = std::fs::read_to_string(path).map_err(|e| LensError::File {
            path: path.to_path_buf(),
            message: e.to_string(),
        })?;
        let what = path.display().to_string();
        let is_json = path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("json"));
        if is_json {
            Lens::parse_iset3d_json(&text, &what)
        } else {
            let name = path
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_default();
            Lens::parse_pbrt(&text, &what, &name)
        }
    }

    /// Parse ISET3d lens JSON (`what` names the source in messages). Per surface: `radius`,
    /// `thickness`, `ior` (0: air), `semi_aperture` (mm), optional `conic_constant` (a number; a
    /// list of one number; a list equal to `aspheric_coefficients`, which some ISET3d exports
    /// write by mistake, is read as 0), optional `aspheric_coefficients` (r^2, r^4, ...), and the
    /// camsim extension `abbe_number` (V_d) for a dispersive medium after the surface.
    pub fn from_iset3d_json(text: &str, what: &str) -> Result<Lens> {
        let lens = Lens::parse_iset3d_json(text, what)?;
        lens.check(what)?;
        Ok(lens)
    }

    fn parse_iset3d_json(text: &str, what: &str) -> Result<Lens> {
        let j: JsonLens = serde_json::from_str(text).map_err(|e| LensError::Parse {
            what: what.to_string(),
            line: e.line(),
            message: e.to_string(),
        })?;
        let mut surfaces = Vec::with_capacity(j.surfaces.len());
        for (i, s) in j.surfaces.iter().enumerate() {
            let bad = |m: String| LensError::Surface {
                what: what.to_string(),
                surface: i + 1,
                message: m,
            };
            let conic = match &s.conic_constant {
                None => 0.0,
                Some(NumberOrList::Number(k)) => *k,
                Some(NumberOrList::List(v)) if v.is_empty() => 0.0,
                Some(NumberOrList::List(v)) if v.len() == 1 => v[0],
                Some(NumberOrList::List(v)) if *v == s.aspheric_coefficients => 0.0,
                Some(NumberOrList::List(v)) => {
                    return Err(bad(format!(
                        "conic_constant is a list of {} numbers; give one number",
                        v.len()
                    )))
                }
            };
            let medium = match s.abbe_number {
                None => Medium::constant(s.ior),
                Some(vd) => Medium::from_abbe(s.ior, vd).map_err(bad)?,
            };
            surfaces.push(Surface {
                radius_mm: s.radius,
                thickness_mm: s.thickness,
                medium,
                semi_aperture_mm: s.semi_aperture,
                conic,
                aspheric: s.aspheric_coefficients.clone(),
                is_stop: s.radius == 0.0,
            });
        }
        Ok(Lens {
            name: j
                .name
                .unwrap_or_else(|| what.to_string())
                .trim()
                .to_string(),
            surfaces,
        })
    }

    /// Parse a pbrt-v4 `realistic` lens file: one surface per line, object side first, four
    /// numbers in mm: curvature radius, thickness, index of refraction (0: air) and aperture
    /// *diameter*; a radius of 0 is the stop; `#` starts a comment (pbrt-v4 book 4th ed. sec.
    /// 5.3, "Realistic cameras"; the files of pbrt-v4's `lenses/` folder).
    pub fn from_pbrt(text: &str, what: &str, name: &str) -> Result<Lens> {
        let lens = Lens::parse_pbrt(text, what, name)?;
        lens.check(what)?;
        Ok(lens)
    }

    fn parse_pbrt(text: &str, what: &str, name: &str) -> Result<Lens> {
        let mut surfaces = Vec::new();
        for (n, raw) in text.lines().enumerate() {
            let line = raw.split('#').next().unwrap_or("").trim();
            if line.is_empty() {
                continue;
            }
            let err = |m: String| LensError::Parse {
                what: what.to_string(),
                line: n + 1,
                message: m,
            };
            let v: Vec<f64> = line
                .split(|c: char| c.is_whitespace() || c == ',')
                .filter(|t| !t.is_empty())
                .map(|t| {
                    t.parse::<f64>()
                        .map_err(|_| err(format!("'{t}' is not a number")))
                })
                .collect::<Result<_>>()?;
            if v.len() != 4 {
                return Err(err(format!(
                    "{} numbers; expected radius thickness eta aperture-diameter (mm)",
                    v.len()
                )));
            }
            surfaces.push(Surface {
                radius_mm: v[0],
                thickness_mm: v[1],
                medium: Medium::constant(v[2]),
                semi_aperture_mm: v[3] / 2.0,
                conic: 0.0,
                aspheric: Vec::new(),
                is_stop: v[0] == 0.0,
            });
        }
        if surfaces.is_empty() {
            return Err(LensError::Lens {
                what: what.to_string(),
                message: "no surfaces".into(),
            });
        }
        Ok(Lens {
            name: name.to_string(),
            surfaces,
        })
    }

    /// Check the prescription (`what` names it in messages): at least one refracting surface and
    /// exactly one stop; finite numbers; positive semi-apertures; thicknesses >= 0; indices of 1
    /// or more (0: air); each surface's sag defined over its semi-aperture; and consecutive
    /// surfaces do not
    /// cross inside their common clear aperture (surface i + 1 lies behind surface i, up to
    /// [`CROSSING_TOLERANCE_MM`]).
    pub fn check(&self, what: &str) -> Result<()> {
        let bad = |i: usize, m: String| LensError::Surface {
            what: what.to_string(),
            surface: i + 1,
            message: m,
        };
        if self.surfaces.is_empty() {
            return Err(LensError::Lens {
                what: what.to_string(),
                message: "no surfaces".into(),
            });
        }
        for (i, s) in self.surfaces.iter().enumerate() {
            let nums = [
                ("radius", s.radius_mm),
                ("thickness", s.thickness_mm),
                ("semi_aperture", s.semi_aperture_mm),
                ("conic_constant", s.conic),
            ];
            if let Some((k, v)) = nums.iter().find(|(_, v)| !v.is_finite()) {
                return Err(bad(i, format!("{k} is {v}, not a finite number")));
            }
            if let Some(a) = s.aspheric.iter().find(|a| !a.is_finite()) {
                return Err(bad(
                    i,
                    format!("aspheric coefficient {a} is not a finite number"),
                ));
            }
            s.medium.check().map_err(|m| bad(i, m))?;
            if s.semi_aperture_mm <= 0.0 {
                return Err(bad(
                    i,
                    format!("semi-aperture {} mm is not > 0", s.semi_aperture_mm),
                ));
            }
            if s.thickness_mm < 0.0 {
                return Err(bad(
                    i,
                    format!("thickness {} mm is negative", s.thickness_mm),
                ));
            }
            if s.is_stop && !s.aspheric.is_empty() && s.aspheric.iter().any(|a| *a != 0.0) {
                return Err(bad(i, "the stop (radius 0) has aspheric terms".into()));
            }
            if s.sag_mm(s.semi_aperture_mm).is_none() {
                return Err(bad(
                    i,
                    format!(
                        "the surface is undefined at its semi-aperture {} mm (radius {} mm, conic {})",
                        s.semi_aperture_mm, s.radius_mm, s.conic
                    ),
                ));
            }
        }
        let stops = self.surfaces.iter().filter(|s| s.is_stop).count();
        if stops == 0 {
            return Err(LensError::Lens {
                what: what.to_string(),
                message: "no aperture stop (a surface with radius 0)".into(),
            });
        }
        if stops > 1 {
            let list: Vec<String> = self
                .surfaces
                .iter()
                .enumerate()
                .filter(|(_, s)| s.is_stop)
                .map(|(i, _)| (i + 1).to_string())
                .collect();
            return Err(LensError::Lens {
                what: what.to_string(),
                message: format!(
                    "{stops} surfaces with radius 0 ({}); one stop expected",
                    list.join(", ")
                ),
            });
        }
        if self.surfaces.iter().all(|s| s.is_stop) {
            return Err(LensError::Lens {
                what: what.to_string(),
                message: "no refracting surface".into(),
            });
        }
        // Consecutive surfaces must not cross inside their common aperture.
        let z = self.vertex_z_mm();
        for i in 0..self.surfaces.len() - 1 {
            let (a, b) = (&self.surfaces[i], &self.surfaces[i + 1]);
            let h_max = a.semi_aperture_mm.min(b.semi_aperture_mm);
            for k in 0..=64 {
                let h = h_max * k as f64 / 64.0;
                let (Some(za), Some(zb)) = (a.sag_mm(h), b.sag_mm(h)) else {
                    continue;
                };
                if z[i] + za > z[i + 1] + zb + CROSSING_TOLERANCE_MM {
                    return Err(bad(
                        i + 1,
                        format!(
                            "it crosses surface {} at height {h:.4} mm (surface {} at z = {:.4} mm lies in front of surface {} at z = {:.4} mm)",
                            i + 1,
                            i + 2,
                            z[i + 1] + zb,
                            i + 1,
                            z[i] + za
                        ),
                    ));
                }
            }
        }
        Ok(())
    }

    /// Axial position of each vertex, mm (the first at 0).
    pub fn vertex_z_mm(&self) -> Vec<f64> {
        let mut z = Vec::with_capacity(self.surfaces.len());
        let mut acc = 0.0;
        for s in &self.surfaces {
            z.push(acc);
            acc += s.thickness_mm;
        }
        z
    }

    /// Axial length from the first to the last vertex, mm.
    pub fn track_length_mm(&self) -> f64 {
        let n = self.surfaces.len();
        self.surfaces[..n - 1].iter().map(|s| s.thickness_mm).sum()
    }

    /// Index of the stop surface.
    pub fn stop_index(&self) -> usize {
        self.surfaces.iter().position(|s| s.is_stop).unwrap_or(0)
    }

    /// Index of the medium in front of surface `i` at `wavelength_nm` (air before the first).
    pub fn index_before(&self, i: usize, wavelength_nm: f64) -> f64 {
        if i == 0 {
            1.0
        } else {
            self.surfaces[i - 1].medium.index(wavelength_nm)
        }
    }

    /// Set the stop's semi-aperture, mm (e.g. to reach an f-number).
    pub fn with_stop_semi_aperture_mm(mut self, r_mm: f64) -> Self {
        let i = self.stop_index();
        self.surfaces[i].semi_aperture_mm = r_mm;
        self
    }
}
