//! BSDFs at a surface point, in the local shading frame (z = shading normal). The set is closed
//! (dispatch by `match`): a new BSDF is a new variant here, a new [`crate::scene::Material`]
//! variant and a new arm in the tracer's material compile step.
//!
//! Conventions (pbrt-v4's, 4th ed. ch. 9): `wo` and `wi` point away from the surface; `f` is
//! the BSDF value, `pdf` the density per steradian of sampling `wi` given `wo`. Delta (perfectly
//! specular) lobes are not part of `eval`/`pdf`: they are only produced by `sample`, flagged
//! [`BsdfSample::specular`]. Camera paths carry radiance (pbrt's `TransportMode::Radiance`):
//! transmission into a medium of relative index `eta` scales radiance by `1 / eta^2`.
//!
//! For dielectrics `eta` is the relative index of the side `wo` is *not* on, over the index of
//! `wo`'s side, seen from the +z side: `eta` applies for `wo.z > 0` and `1 / eta` for
//! `wo.z < 0` (the tracer orients the frame and passes the matching value).
//!
//! The coated BSDFs ([`Bsdf::CoatedDiffuse`], [`Bsdf::CoatedConductor`]) are pbrt-v4's layered
//! BSDFs: their `eval` and `pdf` are Monte Carlo estimates (deterministic for a given pair of
//! directions) and a sample's weight is the walk's own unbiased `f cos / pdf`, not the ratio of
//! the two estimates; see [`layered`].

pub mod fresnel;
pub mod gltf;
pub mod hair;
pub mod layered;
pub mod microfacet;

use crate::math::V3;
use crate::sampling::{cosine_hemisphere, cosine_hemisphere_pdf};
use fresnel::{fr_complex, fr_dielectric, reflect, refract};
pub use layered::Layer;
pub use microfacet::TrowbridgeReitz;
use std::f32::consts::FRAC_1_PI;

/// A BSDF evaluated at the path's `N` wavelengths.
#[derive(Debug, Clone, Copy)]
pub enum Bsdf<const N: usize> {
    /// Lambertian reflection, f = reflectance / pi (pbrt-v4 `DiffuseBxDF`), reflecting on both
    /// sides of the surface.
    Diffuse { reflectance: [f32; N] },
    /// A metal: Fresnel reflectance of the complex index `eta + i k` (relative to the outside),
    /// on a Trowbridge-Reitz microfacet surface without multiple scattering between microfacets
    /// (pbrt-v4 `ConductorBxDF`, §9.6); a mirror (delta BSDF) when effectively smooth.
    Conductor {
        eta: [f32; N],
        k: [f32; N],
        distrib: TrowbridgeReitz,
    },
    /// A dielectric interface with relative index `eta` (see the module docs for its side):
    /// Fresnel-weighted reflection and refraction, smooth (delta) or rough microfacet
    /// (pbrt-v4 `DielectricBxDF`, §9.5 and §9.7). One index for all wavelengths: a dispersive
    /// material is evaluated at the hero wavelength after the others were terminated.
    Dielectric { eta: f32, distrib: TrowbridgeReitz },
    /// A thin dielectric slab (pbrt-v4 `ThinDielectricBxDF`, §9.5.3): inter-reflections inside the
    /// slab summed in closed form, transmitted light leaves undeflected. Always a delta BSDF.
    ThinDielectric { eta: f32 },
    /// Lambertian reflection `r / pi` on `wo`'s side and Lambertian transmission `t / pi` to the
    /// other side (pbrt-v4 `DiffuseTransmissionBxDF`).
    DiffuseTransmission { r: [f32; N], t: [f32; N] },
    /// A dielectric coating (relative index `eta`, roughness `distrib`) over a Lambertian base of
    /// albedo `reflectance`, with the medium and walk parameters `layer` (pbrt-v4
    /// `CoatedDiffuseBxDF`, 4th ed. §14.3): evaluated, sampled and its density estimated by
    /// pbrt-v4's stochastic random walk between the interfaces, see [`layered`]. Two-sided.
    CoatedDiffuse {
        reflectance: [f32; N],
        eta: f32,
        distrib: TrowbridgeReitz,
        layer: Layer<N>,
    },
    /// A dielectric coating (relative index `eta`, roughness `coat`) over a conductor
    /// (`c_eta + i c_k` relative to the coating, roughness `base`), with the medium and walk
    /// parameters `layer` (pbrt-v4 `CoatedConductorBxDF`, §14.3), by the random walk of
    /// [`layered`]. Two-sided.
    CoatedConductor {
        eta: f32,
        coat: TrowbridgeReitz,
        c_eta: [f32; N],
        c_k: [f32; N],
        base: TrowbridgeReitz,
        layer: Layer<N>,
    },
    /// A hair fibre (Chiang et al. 2016, pbrt-v4 `HairBxDF`, see [`hair`]): the local frame's x
    /// axis runs along the fibre. Scatters to both sides of the (ray-facing) curve surface.
    Hair(hair::Hair<N>),
    /// The glTF 2.0 metallic-roughness BRDF (specification Appendix B, see [`gltf`]); reflection
    /// only, the same on both sides.
    GltfPbr(gltf::GltfBrdf<N>),
}

/// A sampled incident direction.
#[derive(Debug, Clone, Copy)]
pub struct BsdfSample<const N: usize> {
    /// Sampled direction in the local frame.
    pub wi_local: V3,
    /// `f |cos theta_i| / pdf` per wavelength.
    pub weight: [f32; N],
    /// Density of the sample, per steradian (for a delta lobe: the probability of choosing it).
    pub pdf: f32,
    /// The sample comes from a delta (perfectly specular) lobe: no MIS with light sampling.
    pub specular: bool,
    /// `wi` is on the other side of the surface than `wo`.
    pub transmission: bool,
    /// Relative index crossed by a transmission (1 for reflection): radiance was scaled by
    /// `1 / eta^2`, which Russian roulette undoes (pbrt-v4 `etaScale`).
    pub eta: f32,
}

#[inline(always)]
pub(crate) fn same_hemisphere(a: &V3, b: &V3) -> bool {
    a.z * b.z > 0.0
}

impl<const N: usize> BsdfSample<N> {
    #[inline(always)]
    pub(crate) fn new(
        wi_local: V3,
        weight: [f32; N],
        pdf: f32,
        specular: bool,
        transmission: bool,
        eta: f32,
    ) -> Option<Self> {
        if pdf.is_nan() || pdf <= 0.0 || !weight.iter().all(|w| w.is_finite()) {
            return None;
        }
        Some(BsdfSample {
            wi_local,
            weight,
            pdf,
            specular,
            transmission,
            eta,
        })
    }
}

impl<const N: usize> Bsdf<N> {
    /// True when the BSDF is only delta lobes: `eval` is zero everywhere, light sampling is
    /// useless and skipped.
    #[inline]
    pub fn is_delta(&self) -> bool {
        match self {
            Bsdf::Conductor { distrib, .. } => distrib.effectively_smooth(),
            Bsdf::Dielectric { eta, distrib } => *eta == 1.0 || distrib.effectively_smooth(),
            Bsdf::ThinDielectric { .. } => true,
            Bsdf::CoatedConductor { .. } => self.layered().is_some_and(|l| l.is_delta()),
            Bsdf::Diffuse { .. }
            | Bsdf::DiffuseTransmission { .. }
            | Bsdf::CoatedDiffuse { .. }
            | Bsdf::Hair(_)
            | Bsdf::GltfPbr(_) => false,
        }
    }

    /// The layered BSDF of a coated material (the base relative to the coating).
    #[inline]
    fn layered(&self) -> Option<layered::Layered<N>> {
        match self {
            Bsdf::CoatedDiffuse {
                reflectance,
                eta,
                distrib,
                layer,
            } => Some(layered::Layered::new(
                *eta,
                *distrib,
                Bsdf::Diffuse {
                    reflectance: *reflectance,
                },
                layer,
            )),
            Bsdf::CoatedConductor {
                eta,
                coat,
                c_eta,
                c_k,
                base,
                layer,
            } => Some(layered::Layered::new(
                *eta,
                *coat,
                Bsdf::Conductor {
                    eta: *c_eta,
                    k: *c_k,
                    distrib: *base,
                },
                layer,
            )),
            _ => None,
        }
    }

    /// `(f, pdf)` estimates of a layered BSDF: two-sided (both directions mirrored through the
    /// origin when `wo` is below, as pbrt-v4's `twoSided` layers), reflection only.
    #[inline]
    fn layered_eval(&self, wo: &V3, wi: &V3) -> ([f32; N], f32) {
        let Some(l) = self.layered() else {
            return ([0.0; N], 0.0);
        };
        if !same_hemisphere(wo, wi) {
            return ([0.0; N], 0.0);
        }
        let (wo, wi) = if wo.z < 0.0 { (-*wo, -*wi) } else { (*wo, *wi) };
        (l.f(wo, wi), l.pdf(wo, wi))
    }

    /// True when the BSDF can send light to the other side of the surface.
    #[inline]
    pub fn has_transmission(&self) -> bool {
        matches!(
            self,
            Bsdf::Dielectric { .. }
                | Bsdf::ThinDielectric { .. }
                | Bsdf::DiffuseTransmission { .. }
                | Bsdf::Hair(_)
        )
    }

    /// `(f(wo, wi), pdf(wi | wo))` for local directions (delta lobes excluded).
    #[inline]
    pub fn eval(&self, wo: &V3, wi: &V3) -> ([f32; N], f32) {
        const ZERO: f32 = 0.0;
        match self {
            Bsdf::CoatedConductor { .. } | Bsdf::CoatedDiffuse { .. } => self.layered_eval(wo, wi),
            Bsdf::Hair(h) => (h.f(wo, wi), h.pdf(wo, wi)),
            Bsdf::GltfPbr(b) => b.eval(wo, wi),
            Bsdf::Diffuse { reflectance } => {
                if !same_hemisphere(wo, wi) {
                    return ([ZERO; N], 0.0);
                }
                let mut f = [0f32; N];
                for i in 0..N {
                    f[i] = reflectance[i] * FRAC_1_PI;
                }
                (f, cosine_hemisphere_pdf(wi.z.abs()))
            }
            Bsdf::Conductor { eta, k, distrib } => {
                if distrib.effectively_smooth() || !same_hemisphere(wo, wi) {
                    return ([ZERO; N], 0.0);
                }
                let (cos_o, cos_i) = (wo.z.abs(), wi.z.abs());
                let wm = *wo + *wi;
                if cos_o == 0.0 || cos_i == 0.0 || wm.length_squared() == 0.0 {
                    return ([ZERO; N], 0.0);
                }
                let wm = wm.normalize().face_forward(V3::new(0.0, 0.0, 1.0));
                let dot = wo.dot(wm).abs();
                // pbrt-v4 eq. 9.33: f = D(wm) F(wo . wm) G(wo, wi) / (4 cos_o cos_i).
                let common = distrib.d(wm) * distrib.g(*wo, *wi) / (4.0 * cos_o * cos_i);
                let f = std::array::from_fn(|i| common * fr_complex(dot, eta[i], k[i]));
                // pbrt-v4 eq. 9.28: p(wi) = D_wo(wm) / (4 |wo . wm|).
                (f, distrib.pdf(*wo, wm) / (4.0 * dot))
            }
            Bsdf::Dielectric { eta, distrib } => {
                if *eta == 1.0 || distrib.effectively_smooth() {
                    return ([ZERO; N], 0.0);
                }
                match rough_dielectric(*eta, distrib, wo, wi) {
                    Some((f, pdf)) => ([f; N], pdf),
                    None => ([ZERO; N], 0.0),
                }
            }
            Bsdf::ThinDielectric { .. } => ([ZERO; N], 0.0),
            Bsdf::DiffuseTransmission { r, t } => {
                let (pr, pt) = (max_of(r), max_of(t));
                if pr + pt <= 0.0 || wi.z == 0.0 {
                    return ([ZERO; N], 0.0);
                }
                let c = cosine_hemisphere_pdf(wi.z.abs());
                if same_hemisphere(wo, wi) {
                    (
                        std::array::from_fn(|i| r[i] * FRAC_1_PI),
                        c * pr / (pr + pt),
                    )
                } else {
                    (
                        std::array::from_fn(|i| t[i] * FRAC_1_PI),
                        c * pt / (pr + pt),
                    )
                }
            }
        }
    }

    /// Sample `wi` given `wo` from three uniform numbers (`uc` picks a lobe, `u0`, `u1` the
    /// direction).
    #[inline]
    pub fn sample(&self, wo: &V3, uc: f32, u0: f32, u1: f32) -> Option<BsdfSample<N>> {
        match self {
            Bsdf::CoatedConductor { .. } | Bsdf::CoatedDiffuse { .. } => {
                let l = self.layered()?;
                let flip = wo.z < 0.0;
                let wo_up = if flip { -*wo } else { *wo };
                let x = l.sample(wo_up, uc, u0, u1)?;
                let wi = if flip { -x.wi } else { x.wi };
                BsdfSample::new(wi, x.weight, x.pdf, x.specular, false, 1.0)
            }
            Bsdf::GltfPbr(b) => b.sample(wo, uc, u0, u1),
            Bsdf::Hair(h) => {
                let (wi, f, pdf) = h.sample(wo, uc, u0, u1)?;
                let c = wi.z.abs();
                BsdfSample::new(
                    wi,
                    f.map(|v| v * c / pdf),
                    pdf,
                    false,
                    wi.z * wo.z < 0.0,
                    1.0,
                )
            }
            Bsdf::Diffuse { reflectance } => {
                // Cosine-weighted on wo's side (pbrt-v4 DiffuseBxDF::Sample_f).
                let mut wi = cosine_hemisphere(u0, u1);
                if wo.z < 0.0 {
                    wi.z = -wi.z;
                }
                let pdf = cosine_hemisphere_pdf(wi.z.abs());
                // f cos / pdf = (rho / pi) cos / (cos / pi) = rho.
                BsdfSample::new(wi, *reflectance, pdf, false, false, 1.0)
            }
            Bsdf::Conductor { eta, k, distrib } => {
                if distrib.effectively_smooth() {
                    // Mirror: f = F(cos) / |cos| delta, weight = F (pbrt-v4 §9.6.2).
                    let wi = V3::new(-wo.x, -wo.y, wo.z);
                    let c = wi.z.abs();
                    return BsdfSample::new(
                        wi,
                        std::array::from_fn(|i| fr_complex(c, eta[i], k[i])),
                        1.0,
                        true,
                        false,
                        1.0,
                    );
                }
                if wo.z == 0.0 {
                    return None;
                }
                let wm = distrib.sample_wm(*wo, u0, u1);
                let wi = reflect(*wo, wm);
                if !same_hemisphere(wo, &wi) {
                    return None;
                }
                let dot = wo.dot(wm).abs();
                let pdf = distrib.pdf(*wo, wm) / (4.0 * dot);
                let (cos_o, cos_i) = (wo.z.abs(), wi.z.abs());
                if cos_i == 0.0 || pdf <= 0.0 {
                    return None;
                }
                let common =
                    distrib.d(wm) * distrib.g(*wo, wi) / (4.0 * cos_o * cos_i) * cos_i / pdf;
                BsdfSample::new(
                    wi,
                    std::array::from_fn(|i| common * fr_complex(dot, eta[i], k[i])),
                    pdf,
                    false,
                    false,
                    1.0,
                )
            }
            Bsdf::Dielectric { eta, distrib } => {
                let eta = *eta;
                if eta == 1.0 || distrib.effectively_smooth() {
                    // pbrt-v4 §9.5.2: reflect with probability R, else refract; weights R / pr
                    // and T / (pt eta'^2) with pr = R, pt = T.
                    let r = fr_dielectric(wo.z, eta);
                    let t = 1.0 - r;
                    if uc < r / (r + t) {
                        let wi = V3::new(-wo.x, -wo.y, wo.z);
                        return BsdfSample::new(wi, [1.0; N], r / (r + t), true, false, 1.0);
                    }
                    // `refract` flips the normal and the index when wo is below.
                    let (wi, etap) = refract(*wo, V3::new(0.0, 0.0, 1.0), eta)?;
                    let w = 1.0 / (etap * etap);
                    return BsdfSample::new(wi, [w; N], t / (r + t), true, true, etap);
                }
                rough_dielectric_sample(eta, distrib, wo, uc, u0, u1)
            }
            Bsdf::ThinDielectric { eta } => {
                let mut r = fr_dielectric(wo.z.abs(), *eta);
                let mut t = 1.0 - r;
                // Sum of the inter-reflections inside the slab (pbrt-v4 eq. 9.9, 9.10).
                if r < 1.0 {
                    r += t * t * r / (1.0 - r * r);
                    t = 1.0 - r;
                }
                // Both lobes have weight f cos / p = 1 (R + T = 1).
                if uc < r / (r + t) {
                    BsdfSample::new(
                        V3::new(-wo.x, -wo.y, wo.z),
                        [1.0; N],
                        r / (r + t),
                        true,
                        false,
                        1.0,
                    )
                } else {
                    BsdfSample::new(-*wo, [1.0; N], t / (r + t), true, true, 1.0)
                }
            }
            Bsdf::DiffuseTransmission { r, t } => {
                let (pr, pt) = (max_of(r), max_of(t));
                if pr + pt <= 0.0 {
                    return None;
                }
                let mut wi = cosine_hemisphere(u0, u1);
                let reflect = uc < pr / (pr + pt);
                // Reflection on wo's side, transmission on the other.
                if (wo.z < 0.0) == reflect {
                    wi.z = -wi.z;
                }
                let c = cosine_hemisphere_pdf(wi.z.abs());
                if reflect {
                    BsdfSample::new(
                        wi,
                        std::array::from_fn(|i| r[i] * (pr + pt) / pr),
                        c * pr / (pr + pt),
                        false,
                        false,
                        1.0,
                    )
                } else {
                    BsdfSample::new(
                        wi,
                        std::array::from_fn(|i| t[i] * (pr + pt) / pt),
                        c * pt / (pr + pt),
                        false,
                        true,
                        1.0,
                    )
                }
            }
        }
    }

    /// Density of sampling `wi` given `wo` (per steradian; delta lobes excluded).
    #[inline]
    pub fn pdf(&self, wo: &V3, wi: &V3) -> f32 {
        match self {
            Bsdf::Diffuse { .. } => {
                if same_hemisphere(wo, wi) {
                    cosine_hemisphere_pdf(wi.z.abs())
                } else {
                    0.0
                }
            }
            Bsdf::CoatedConductor { .. } | Bsdf::CoatedDiffuse { .. } => match self.layered() {
                Some(l) if same_hemisphere(wo, wi) => {
                    let (wo, wi) = if wo.z < 0.0 { (-*wo, -*wi) } else { (*wo, *wi) };
                    l.pdf(wo, wi)
                }
                _ => 0.0,
            },
            Bsdf::Hair(h) => h.pdf(wo, wi),
            Bsdf::GltfPbr(b) => b.pdf(wo, wi),
            _ => self.eval(wo, wi).1,
        }
    }
}

#[inline(always)]
fn max_of<const N: usize>(v: &[f32; N]) -> f32 {
    v.iter().fold(0.0, |a, &b| a.max(b))
}

/// Generalized half vector of a rough dielectric pair, facing +z, with the microfacet
/// back-facing test (pbrt-v4 §9.7.2 eq. 9.34 and `DielectricBxDF::f`): `(wm, etap, reflect)`.
#[inline]
fn dielectric_half_vector(eta: f32, wo: &V3, wi: &V3) -> Option<(V3, f32, bool)> {
    let (cos_o, cos_i) = (wo.z, wi.z);
    if cos_o == 0.0 || cos_i == 0.0 {
        return None;
    }
    let reflect = cos_o * cos_i > 0.0;
    let etap = if reflect {
        1.0
    } else if cos_o > 0.0 {
        eta
    } else {
        1.0 / eta
    };
    let wm = *wi * etap + *wo;
    if wm.length_squared() == 0.0 {
        return None;
    }
    let wm = wm.normalize().face_forward(V3::new(0.0, 0.0, 1.0));
    // Discard back-facing microfacets.
    if wm.dot(*wi) * cos_i < 0.0 || wm.dot(*wo) * cos_o < 0.0 {
        return None;
    }
    Some((wm, etap, reflect))
}

/// `(f, pdf)` of the rough dielectric (pbrt-v4 `DielectricBxDF::f` and `PDF`, radiance mode).
#[inline]
fn rough_dielectric(eta: f32, distrib: &TrowbridgeReitz, wo: &V3, wi: &V3) -> Option<(f32, f32)> {
    let (wm, etap, reflect) = dielectric_half_vector(eta, wo, wi)?;
    let r = fr_dielectric(wo.dot(wm), eta);
    let t = 1.0 - r;
    if reflect {
        let f = distrib.d(wm) * distrib.g(*wo, *wi) * r / (4.0 * wo.z * wi.z).abs();
        let pdf = distrib.pdf(*wo, wm) / (4.0 * wo.dot(wm).abs()) * r / (r + t);
        Some((f, pdf))
    } else {
        // pbrt-v4 eq. 9.40 (BTDF) and 9.37 (Jacobian dwm/dwi), times 1/etap^2 for radiance.
        let denom = wi.dot(wm) + wo.dot(wm) / etap;
        let denom2 = denom * denom;
        let f = distrib.d(wm)
            * t
            * distrib.g(*wo, *wi)
            * (wi.dot(wm) * wo.dot(wm) / (wi.z * wo.z * denom2)).abs()
            / (etap * etap);
        let dwm_dwi = wi.dot(wm).abs() / denom2;
        let pdf = distrib.pdf(*wo, wm) * dwm_dwi * t / (r + t);
        Some((f, pdf))
    }
}

/// Sample the rough dielectric (pbrt-v4 `DielectricBxDF::Sample_f`, radiance mode).
#[inline]
fn rough_dielectric_sample<const N: usize>(
    eta: f32,
    distrib: &TrowbridgeReitz,
    wo: &V3,
    uc: f32,
    u0: f32,
    u1: f32,
) -> Option<BsdfSample<N>> {
    if wo.z == 0.0 {
        return None;
    }
    let wm = distrib.sample_wm(*wo, u0, u1);
    let r = fr_dielectric(wo.dot(wm), eta);
    let t = 1.0 - r;
    if uc < r / (r + t) {
        let wi = reflect(*wo, wm);
        if !same_hemisphere(wo, &wi) {
            return None;
        }
        let (f, pdf) = rough_dielectric(eta, distrib, wo, &wi)?;
        BsdfSample::new(wi, [f * wi.z.abs() / pdf; N], pdf, false, false, 1.0)
    } else {
        let (wi, etap) = refract(*wo, wm, eta)?;
        if same_hemisphere(wo, &wi) || wi.z == 0.0 {
            return None;
        }
        let (f, pdf) = rough_dielectric(eta, distrib, wo, &wi)?;
        BsdfSample::new(wi, [f * wi.z.abs() / pdf; N], pdf, false, true, etap)
    }
}
