//! `Shape "curve"` (pbrt-v4 `Curve::Create`, 4th ed. sec. 6.7): control points `P` in a
//! `basis` (`bezier`, default, or `bspline`) of `degree` 2 or 3 (default 3), `type` `flat`
//! (default), `cylinder` or `ribbon`, `width` (default 1) or `width0`/`width1` at the two ends,
//! ribbon normals `N` (one per segment end), `splitdepth` (default 3). Turned into cubic Bezier
//! segments in object space ([`camsim_scene3d::curves`]); the caller moves them to world space.

use super::super::params::ParamList;
use super::super::{Loc, PbrtError};
use super::SceneBuilder;
use crate::scene::Geometry;
use camsim_scene3d::curves::{
    bezier_control_points, CurveBasis, CurveType, Curves, MAX_SPLIT_DEPTH,
};

impl SceneBuilder {
    /// The curve of a `Shape "curve"` directive, in object space.
    pub(super) fn curve(&mut self, params: &ParamList, loc: &Loc) -> Result<Geometry, PbrtError> {
        let what = "Shape \"curve\"";
        let p = params
            .get("P", &["point3"])?
            .ok_or_else(|| loc.err(format!("{what}: no \"point3 P\"")))?;
        let (p_loc, nums) = (p.loc.clone(), p.nums()?);
        if nums.len() % 3 != 0 {
            return Err(p_loc.err(format!(
                "{what}: \"P\" has {} values, not a multiple of 3",
                nums.len()
            )));
        }
        let cp: Vec<[f64; 3]> = nums.chunks(3).map(|c| [c[0], c[1], c[2]]).collect();
        drop(nums);
        let basis = match params.string("basis")?.as_deref() {
            None | Some("bezier") => CurveBasis::Bezier,
            Some("bspline") => CurveBasis::BSpline,
            Some(b) => {
                return Err(loc.err(format!(
                    "{what}: basis \"{b}\" is not supported (bezier, bspline)"
                )))
            }
        };
        let degree = params.int("degree", 3)?;
        if degree != 2 && degree != 3 {
            return Err(loc.err(format!(
                "{what}: degree {degree}: only degree 2 and 3 curves are supported"
            )));
        }
        let points = bezier_control_points(&cp, basis, degree as u32)
            .map_err(|e| p_loc.err(format!("{what}: {e}")))?;
        drop(cp);
        let n_segments = (points.len() - 1) / 3;
        let ty = params.string("type")?;
        let kind = match ty.as_deref() {
            None => CurveType::Flat,
            Some(t) => CurveType::from_name(t).ok_or_else(|| {
                loc.err(format!(
                    "{what}: type \"{t}\" is not a curve type (flat, cylinder, ribbon)"
                ))
            })?,
        };
        let width = params.float("width", 1.0)?;
        let width0 = params.float("width0", width)?;
        let width1 = params.float("width1", width)?;
        if !(width0 > 0.0 && width1 > 0.0 && width0.is_finite() && width1.is_finite()) {
            return Err(loc.err(format!(
                "{what}: widths {width0} and {width1} must be positive"
            )));
        }
        let mut normals = Vec::new();
        if let Some(n) = params.get("N", &["normal3"])? {
            let v = n.nums()?;
            if kind != CurveType::Ribbon {
                // pbrt-v4 warns and drops them.
                self.note(
                    &n.loc,
                    format!("{what}: \"N\" is only used by ribbon curves: ignored"),
                );
            } else if v.len() != 3 * (n_segments + 1) {
                return Err(n.loc.err(format!(
                    "{what}: {} normals for {n_segments} segments; ribbons need one per segment end ({})",
                    v.len() / 3,
                    n_segments + 1
                )));
            } else {
                for c in v.chunks(3) {
                    let l = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
                    if !(l > 0.0 && l.is_finite()) {
                        return Err(n.loc.err(format!(
                            "{what}: normal ({}, {}, {}) has no direction",
                            c[0], c[1], c[2]
                        )));
                    }
                    normals.push([(c[0] / l) as f32, (c[1] / l) as f32, (c[2] / l) as f32]);
                }
            }
        }
        if kind == CurveType::Ribbon && normals.is_empty() {
            return Err(loc.err(format!(
                "{what}: ribbon curves need normals \"N\" at the segment ends"
            )));
        }
        let split_depth = params.int("splitdepth", 3)?;
        if !(0..=MAX_SPLIT_DEPTH as i64).contains(&split_depth) {
            return Err(loc.err(format!(
                "{what}: splitdepth {split_depth} must lie in 0..={MAX_SPLIT_DEPTH}"
            )));
        }
        // The width becomes world-space by the transform's mean scale (see
        // `xform::transform_shape`): say so when the transform scales unevenly.
        let m = &self.gs.ctm.m;
        let col = |j: usize| (0..3).map(|i| m[i][j] * m[i][j]).sum::<f64>().sqrt();
        let (a, b, c) = (col(0), col(1), col(2));
        let (lo, hi) = (a.min(b).min(c), a.max(b).max(c));
        if hi > lo * (1.0 + 1e-6) {
            self.note(
                loc,
                format!("{what}: the transform scales unevenly ({a:.4}, {b:.4}, {c:.4}); the width is scaled by |det|^(1/3) = {:.4}", crate::xform::det3(&self.gs.ctm).abs().cbrt()),
            );
        }
        Ok(Geometry::Curves(Curves {
            kind,
            points: points
                .iter()
                .map(|p| [p[0] as f32, p[1] as f32, p[2] as f32])
                .collect(),
            width_m: [width0 as f32, width1 as f32],
            normals,
            split_depth: split_depth as u32,
        }))
    }
}
