//! Participating media compiled for tracing (pbrt-v4 4th ed. ch. 11 and sec. 14.1): the
//! coefficients at a point (`SamplePoint`), the piecewise-constant majorants along a ray
//! (`SampleRay`: one segment for homogeneous and cloud media, a 16^3 grid of maxima walked by a
//! 3D DDA for grid media), and delta tracking against them ([`MediaSet::sample_t_maj`], pbrt-v4
//! `SampleT_maj`). The volumetric path tracer (`integrator/volpath.rs`) drives them.
//!
//! Spectral coefficients are evaluated at a path's wavelengths; distances are sampled with the
//! hero wavelength's majorant (index 0), the others carried by ratios (spectral MIS, Miller,
//! Georgiev & Jarosz 2019, as pbrt-v4).

use crate::error::RenderError;
use crate::geometry::Ray;
use crate::math::V3;
use crate::scene::{Material, SceneDescription};
use crate::spectral::{Lambdas, SpectrumTable, WavelengthSampler};
use crate::uplift::{rgb_to_coefficients, SigmoidPolynomial};
use camsim_core::rng::Rng;
use camsim_scene3d::media::{GridSize, Medium, MediumBox, MediumKind};
use rand::Rng as _;

/// No medium: vacuum.
pub(crate) const NO_MEDIUM: u32 = u32::MAX;

/// Majorant grid resolution per axis (pbrt-v4 uses 16^3 for grid media).
const MAJORANT_RES: usize = 16;

/// The scene's media, compiled.
pub(crate) struct MediaSet {
    pub media: Vec<CMedium>,
    /// The camera's medium, or [`NO_MEDIUM`].
    pub camera: u32,
    /// Per compiled material: the `[inside, outside]` media of a medium boundary (a
    /// `MediumInterface` wrapper, reached directly or through an alpha mask), or `None` for a
    /// surface that leaves a ray's medium unchanged.
    pub interfaces: Vec<Option<[u32; 2]>>,
}

/// One medium.
pub(crate) struct CMedium {
    /// Henyey-Greenstein asymmetry.
    pub g: f32,
    kind: Kind,
}

enum Kind {
    Homogeneous {
        sigma_a: SpectrumTable,
        sigma_s: SpectrumTable,
        le: Option<SpectrumTable>,
    },
    Grid(Box<DensityGrid>),
    Rgb(Box<RgbGrid>),
    Cloud(Box<Cloud>),
}

/// The coefficients at a point, at a path's wavelengths: 1/m, and the emitted radiance
/// W/(sr m^2 nm).
#[derive(Debug, Clone, Copy)]
pub(crate) struct MediumPoint<const N: usize> {
    pub sigma_a: [f32; N],
    pub sigma_s: [f32; N],
    pub le: [f32; N],
}

/// A box in a medium's frame, as the unit cube: `unit(p) = (M p - p0) / (p1 - p0)`.
struct UnitBox {
    /// `M`, world to medium frame (rows of an affine 3 x 4 matrix).
    m: [[f32; 4]; 3],
    p0: V3,
    inv_diag: V3,
}

impl UnitBox {
    fn new(b: &MediumBox) -> UnitBox {
        let t = &b.medium_from_world.m;
        let m = std::array::from_fn(|r| std::array::from_fn(|c| t[r][c] as f32));
        let (p0, p1) = (V3::from_f64(b.p0), V3::from_f64(b.p1));
        let d = p1 - p0;
        UnitBox {
            m,
            p0,
            inv_diag: V3::new(1.0 / d.x, 1.0 / d.y, 1.0 / d.z),
        }
    }
    /// A world point in the medium's frame.
    #[inline]
    fn frame_point(&self, p: V3) -> V3 {
        let m = &self.m;
        V3::new(
            m[0][0] * p.x + m[0][1] * p.y + m[0][2] * p.z + m[0][3],
            m[1][0] * p.x + m[1][1] * p.y + m[1][2] * p.z + m[1][3],
            m[2][0] * p.x + m[2][1] * p.y + m[2][2] * p.z + m[2][3],
        )
    }
    #[inline]
    fn unit_point(&self, p: V3) -> V3 {
        (self.frame_point(p) - self.p0).mul_elem(self.inv_diag)
    }
    #[inline]
    fn unit_vector(&self, d: V3) -> V3 {
        let m = &self.m;
        V3::new(
            m[0][0] * d.x + m[0][1] * d.y + m[0][2] * d.z,
            m[1][0] * d.x + m[1][1] * d.y + m[1][2] * d.z,
            m[2][0] * d.x + m[2][1] * d.y + m[2][2] * d.z,
        )
        .mul_elem(self.inv_diag)
    }
    /// The ray (world origin, world direction) in unit-cube coordinates (same parameter t)
    /// and its parameter interval inside the cube within `[0, t_max]` (slab test).
    #[inline]
    fn clip(&self, o: V3, d: V3, t_max: f32) -> Option<(V3, V3, f32, f32)> {
        let (ou, du) = (self.unit_point(o), self.unit_vector(d));
        let (mut t0, mut t1) = (0f32, t_max);
        for a in 0..3 {
            let inv = 1.0 / du[a];
            let (mut near, mut far) = ((0.0 - ou[a]) * inv, (1.0 - ou[a]) * inv);
            if near > far {
                std::mem::swap(&mut near, &mut far);
            }
            // A zero direction component gives NaN or +-inf: inside the slab keeps the interval.
            if near.is_nan() || far.is_nan() {
                if !(0.0..=1.0).contains(&ou[a]) {
                    return None;
                }
                continue;
            }
            t0 = t0.max(near);
            t1 = t1.min(far);
            if t0 > t1 {
                return None;
            }
        }
        Some((ou, du, t0, t1))
    }
}

/// Samples on a regular grid over the unit cube, x fastest (pbrt-v4 `SampledGrid`).
struct Grid3<T> {
    nx: usize,
    ny: usize,
    nz: usize,
    values: Vec<T>,
}

impl<T: Copy> Grid3<T> {
    fn new(size: &GridSize, values: Vec<T>) -> Grid3<T> {
        Grid3 {
            nx: size.nx,
            ny: size.ny,
            nz: size.nz,
            values,
        }
    }

    /// Trilinear interpolation of `convert(sample)` at the unit-cube point `p`: sample `(i, j,
    /// k)` at `((i + 1/2)/nx, ...)`, samples beyond the grid `zero` (pbrt-v4
    /// `SampledGrid::Lookup`).
    #[inline]
    fn lookup<R, const K: usize>(
        &self,
        p: V3,
        zero: [R; K],
        convert: impl Fn(T) -> [R; K],
    ) -> [R; K]
    where
        R: Copy + std::ops::Mul<f32, Output = R> + std::ops::Add<Output = R>,
    {
        let s = [
            p.x * self.nx as f32 - 0.5,
            p.y * self.ny as f32 - 0.5,
            p.z * self.nz as f32 - 0.5,
        ];
        let i = s.map(|v| v.floor());
        let f = [s[0] - i[0], s[1] - i[1], s[2] - i[2]];
        let (ix, iy, iz) = (i[0] as i64, i[1] as i64, i[2] as i64);
        let mut out = zero;
        for (dz, wz) in [(0, 1.0 - f[2]), (1, f[2])] {
            for (dy, wy) in [(0, 1.0 - f[1]), (1, f[1])] {
                for (dx, wx) in [(0, 1.0 - f[0]), (1, f[0])] {
                    let w = wx * wy * wz;
                    if w == 0.0 {
                        continue;
                    }
                    let (x, y, z) = (ix + dx, iy + dy, iz + dz);
                    if x < 0
                        || y < 0
                        || z < 0
                        || x >= self.nx as i64
                        || y >= self.ny as i64
                        || z >= self.nz as i64
                    {
                        continue;
                    }
                    let v = convert(
                        self.values[(z as usize * self.ny + y as usize) * self.nx + x as usize],
                    );
                    for k in 0..K {
                        out[k] = out[k] + v[k] * w;
                    }
                }
            }
        }
        out
    }

    /// Largest `value(sample)` among the samples whose interpolation reaches into the unit
    /// sub-box `[lo, hi]` (pbrt-v4 `SampledGrid::MaxValue`).
    fn max_in(&self, lo: [f32; 3], hi: [f32; 3], value: impl Fn(T) -> f32) -> f32 {
        let n = [self.nx, self.ny, self.nz];
        let mut a = [0usize; 3];
        let mut b = [0usize; 3];
        for k in 0..3 {
            a[k] = ((lo[k] * n[k] as f32 - 0.5).floor().max(0.0)) as usize;
            b[k] = (((hi[k] * n[k] as f32 - 0.5).floor() + 1.0).max(0.0) as usize).min(n[k] - 1);
        }
        let mut m = 0f32;
        for z in a[2]..=b[2] {
            for y in a[1]..=b[1] {
                for x in a[0]..=b[0] {
                    m = m.max(value(self.values[(z * self.ny + y) * self.nx + x]));
                }
            }
        }
        m
    }
}

/// The 16^3 maxima of a density over the unit cube (pbrt-v4 `MajorantGrid`).
struct MajorantGrid {
    values: Vec<f32>,
}

impl MajorantGrid {
    fn new(max_in: impl Fn([f32; 3], [f32; 3]) -> f32) -> MajorantGrid {
        let r = MAJORANT_RES;
        let mut values = Vec::with_capacity(r * r * r);
        for z in 0..r {
            for y in 0..r {
                for x in 0..r {
                    let lo = [
                        x as f32 / r as f32,
                        y as f32 / r as f32,
                        z as f32 / r as f32,
                    ];
                    let hi = [
                        (x + 1) as f32 / r as f32,
                        (y + 1) as f32 / r as f32,
                        (z + 1) as f32 / r as f32,
                    ];
                    values.push(max_in(lo, hi));
                }
            }
        }
        MajorantGrid { values }
    }
    #[inline]
    fn at(&self, v: [i32; 3]) -> f32 {
        let r = MAJORANT_RES;
        self.values[(v[2] as usize * r + v[1] as usize) * r + v[0] as usize]
    }
}

/// pbrt-v4 `uniformgrid`.
struct DensityGrid {
    space: UnitBox,
    sigma_a: SpectrumTable,
    sigma_s: SpectrumTable,
    density: Grid3<f32>,
    majorant: MajorantGrid,
    /// Emission per unit scale (the illuminant, W/(sr m^2 nm)), or none.
    le: Option<SpectrumTable>,
    le_scale: Grid3<f32>,
    /// Temperature grid, offset K and scale (blackbody emission).
    temperature: Option<(Grid3<f32>, f32, f32)>,
}

/// One RGB sample of an `rgbgrid`, uplifted: `scale * S(lambda)` (pbrt-v4
/// `RGBUnboundedSpectrum` / `RGBIlluminantSpectrum` without the illuminant).
#[derive(Clone, Copy)]
struct RgbSample {
    poly: SigmoidPolynomial,
    scale: f32,
}

impl RgbSample {
    fn new(rgb: [f32; 3]) -> RgbSample {
        let m = rgb[0].max(rgb[1]).max(rgb[2]);
        let scale = 2.0 * m;
        let poly = if scale > 0.0 {
            rgb_to_coefficients([rgb[0] / scale, rgb[1] / scale, rgb[2] / scale])
        } else {
            SigmoidPolynomial::constant(0.0)
        };
        RgbSample { poly, scale }
    }
    /// Largest value over `[lo_nm, hi_nm]`: the sigmoid is monotonic in the quadratic, whose
    /// extreme lies at an end or at its vertex.
    fn max_value(&self, lo_nm: f64, hi_nm: f64) -> f32 {
        let c = self.poly.c;
        let mut m = self.poly.eval(lo_nm).max(self.poly.eval(hi_nm));
        if c[0] != 0.0 {
            let t = -c[1] / (2.0 * c[0]);
            let l = crate::uplift::LAMBDA_MIN_NM
                + t * (crate::uplift::LAMBDA_MAX_NM - crate::uplift::LAMBDA_MIN_NM);
            if l > lo_nm && l < hi_nm {
                m = m.max(self.poly.eval(l));
            }
        }
        self.scale * m as f32
    }
}

/// pbrt-v4 `rgbgrid`.
struct RgbGrid {
    space: UnitBox,
    sigma_a: Option<Grid3<RgbSample>>,
    sigma_s: Option<Grid3<RgbSample>>,
    sigma_scale: f32,
    majorant: MajorantGrid,
    le: Option<(Grid3<RgbSample>, SpectrumTable)>,
}

/// pbrt-v4 `cloud`.
struct Cloud {
    space: UnitBox,
    sigma_a: SpectrumTable,
    sigma_s: SpectrumTable,
    density: f64,
    wispiness: f64,
    frequency: f64,
}

impl Cloud {
    /// pbrt-v4 `CloudMedium::Density` at a point of the medium's frame: the point is displaced
    /// by two octaves of the noise's gradient (wisps), then `d` = 5 octaves of fractional
    /// Brownian motion, `clamp((1 - y) 4.5 density d, 0, 1) + 2 max(0, 1/2 - y)`, clamped to
    /// [0, 1].
    fn density_at(&self, p: V3) -> f32 {
        use crate::noise::noise;
        let p = [p.x as f64, p.y as f64, p.z as f64];
        let mut pp = p.map(|v| v * self.frequency);
        if self.wispiness > 0.0 {
            let (mut vomega, mut vlambda) = (0.05 * self.wispiness, 10.0);
            for _ in 0..2 {
                // pbrt-v4 DNoise: forward differences of the noise, step 0.01.
                let q = pp.map(|v| v * vlambda);
                let n0 = noise(q);
                let delta = 0.01;
                let g = [
                    (noise([q[0] + delta, q[1], q[2]]) - n0) / delta,
                    (noise([q[0], q[1] + delta, q[2]]) - n0) / delta,
                    (noise([q[0], q[1], q[2] + delta]) - n0) / delta,
                ];
                for k in 0..3 {
                    pp[k] += vomega * g[k];
                }
                vomega *= 0.5;
                vlambda *= 1.99;
            }
        }
        let (mut d, mut omega, mut lambda) = (0.0, 0.5, 1.0);
        for _ in 0..5 {
            d += omega * noise(pp.map(|v| v * lambda));
            omega *= 0.5;
            lambda *= 1.99;
        }
        let d = ((1.0 - p[1]) * 4.5 * self.density * d).clamp(0.0, 1.0);
        (d + 2.0 * (0.5 - p[1]).max(0.0)).clamp(0.0, 1.0) as f32
    }
}

/// A 3D DDA over the majorant grid (pbrt-v4 `DDAMajorantIterator`), in unit-cube coordinates.
struct Dda {
    t_min: f32,
    t_max: f32,
    next_t: [f32; 3],
    delta_t: [f32; 3],
    step: [i32; 3],
    limit: [i32; 3],
    voxel: [i32; 3],
}

impl Dda {
    fn new(o: V3, d: V3, t_min: f32, t_max: f32) -> Dda {
        let r = MAJORANT_RES as f32;
        let p = o + d * t_min;
        let mut dda = Dda {
            t_min,
            t_max,
            next_t: [0.0; 3],
            delta_t: [0.0; 3],
            step: [0; 3],
            limit: [0; 3],
            voxel: [0; 3],
        };
        for a in 0..3 {
            let v = ((p[a] * r) as i32).clamp(0, MAJORANT_RES as i32 - 1);
            dda.voxel[a] = v;
            let da = d[a];
            if da == 0.0 {
                dda.next_t[a] = f32::INFINITY;
                dda.delta_t[a] = f32::INFINITY;
                dda.step[a] = 1;
                dda.limit[a] = MAJORANT_RES as i32;
                continue;
            }
            dda.delta_t[a] = 1.0 / (da.abs() * r);
            if da > 0.0 {
                dda.next_t[a] = t_min + ((v + 1) as f32 / r - p[a]) / da;
                dda.step[a] = 1;
                dda.limit[a] = MAJORANT_RES as i32;
            } else {
                dda.next_t[a] = t_min + (v as f32 / r - p[a]) / da;
                dda.step[a] = -1;
                dda.limit[a] = -1;
            }
        }
        dda
    }

    /// The next voxel's interval and voxel.
    #[inline]
    fn next(&mut self) -> Option<(f32, f32, [i32; 3])> {
        if self.t_min >= self.t_max {
            return None;
        }
        let n = &self.next_t;
        let ax = if n[0] < n[1] {
            if n[0] < n[2] {
                0
            } else {
                2
            }
        } else if n[1] < n[2] {
            1
        } else {
            2
        };
        let t_exit = self.t_max.min(n[ax]);
        let seg = (self.t_min, t_exit, self.voxel);
        self.t_min = t_exit;
        if self.next_t[ax] > self.t_max {
            self.t_min = self.t_max;
        }
        self.voxel[ax] += self.step[ax];
        if self.voxel[ax] == self.limit[ax] {
            self.t_min = self.t_max;
        }
        self.next_t[ax] += self.delta_t[ax];
        Some(seg)
    }
}

/// The majorant segments of a ray in one medium (pbrt-v4 `RayMajorantIterator`).
enum Segments<'a, const N: usize> {
    One(Option<(f32, f32, [f32; N])>),
    Dda {
        dda: Dda,
        grid: &'a MajorantGrid,
        sigma_t: [f32; N],
    },
}

impl<const N: usize> Segments<'_, N> {
    #[inline]
    fn next(&mut self) -> Option<(f32, f32, [f32; N])> {
        match self {
            Segments::One(s) => s.take(),
            Segments::Dda { dda, grid, sigma_t } => {
                let (t0, t1, v) = dda.next()?;
                let m = grid.at(v);
                Some((t0, t1, sigma_t.map(|s| s * m)))
            }
        }
    }
}

/// Element-wise sum of two spectral samples.
#[inline(always)]
fn add<const N: usize>(a: [f32; N], b: [f32; N]) -> [f32; N] {
    std::array::from_fn(|i| a[i] + b[i])
}

/// pbrt-v4 `BlackbodySpectrum(T)` at `lambda_nm`: Planck's law over its value at the peak
/// (Wien's displacement law), dimensionless.
fn blackbody_normalized(lambda_nm: f32, t_k: f32) -> f32 {
    let peak_nm = 2.897_772e-3 / t_k as f64 * 1e9;
    let b = camsim_core::units::planck_radiance_w_per_sr_m2_nm;
    let v = b(lambda_nm as f64, t_k as f64) / b(peak_nm, t_k as f64);
    if v.is_finite() {
        v as f32
    } else {
        0.0
    }
}

impl CMedium {
    /// The coefficients at world point `p` (pbrt-v4 `Medium::SamplePoint`).
    #[inline]
    pub(crate) fn point<const N: usize>(&self, p: V3, lambdas: &Lambdas<N>) -> MediumPoint<N> {
        match &self.kind {
            Kind::Homogeneous {
                sigma_a,
                sigma_s,
                le,
            } => MediumPoint {
                sigma_a: sigma_a.eval_path(lambdas),
                sigma_s: sigma_s.eval_path(lambdas),
                le: le.as_ref().map_or([0.0; N], |t| t.eval_path(lambdas)),
            },
            Kind::Grid(g) => {
                let u = g.space.unit_point(p);
                let [d] = g.density.lookup(u, [0f32], |v| [v]);
                let (a, s) = (g.sigma_a.eval_path(lambdas), g.sigma_s.eval_path(lambdas));
                let mut le = [0f32; N];
                if let Some(l) = &g.le {
                    let [k] = g.le_scale.lookup(u, [0f32], |v| [v]);
                    if k > 0.0 {
                        le = l.eval_path(lambdas).map(|v| v * k);
                    }
                } else if let Some((t, offset, scale)) = &g.temperature {
                    let [k] = g.le_scale.lookup(u, [0f32], |v| [v]);
                    let [temp] = t.lookup(u, [0f32], |v| [v]);
                    let temp = (temp - offset) * scale;
                    // pbrt-v4 GridMedium: no emission at or below 100 K; camsim's unit / 683.
                    if k > 0.0 && temp > 100.0 {
                        let w = k / camsim_core::units::LUMINOUS_EFFICACY_LM_PER_W as f32;
                        le = std::array::from_fn(|i| w * blackbody_normalized(lambdas.nm[i], temp));
                    }
                }
                MediumPoint {
                    sigma_a: a.map(|v| v * d),
                    sigma_s: s.map(|v| v * d),
                    le,
                }
            }
            Kind::Rgb(g) => {
                let u = g.space.unit_point(p);
                let spec = |s: RgbSample| -> [f32; N] {
                    std::array::from_fn(|i| s.scale * s.poly.eval(lambdas.nm[i] as f64) as f32)
                };
                let one = |grid: &Option<Grid3<RgbSample>>| match grid {
                    Some(gr) => gr.lookup(u, [0f32; N], spec),
                    None => [1.0; N],
                };
                let (a, s) = (one(&g.sigma_a), one(&g.sigma_s));
                let le = match &g.le {
                    Some((gr, ill)) => {
                        let e = gr.lookup(u, [0f32; N], spec);
                        let i = ill.eval_path(lambdas);
                        std::array::from_fn(|k| e[k] * i[k])
                    }
                    None => [0.0; N],
                };
                MediumPoint {
                    sigma_a: a.map(|v| v * g.sigma_scale),
                    sigma_s: s.map(|v| v * g.sigma_scale),
                    le,
                }
            }
            Kind::Cloud(c) => {
                let d = c.density_at(c.space.frame_point(p));
                MediumPoint {
                    sigma_a: c.sigma_a.eval_path(lambdas).map(|v| v * d),
                    sigma_s: c.sigma_s.eval_path(lambdas).map(|v| v * d),
                    le: [0.0; N],
                }
            }
        }
    }

    /// The majorant segments of the ray `o + t d` (`d` unit), `0 <= t <= t_max` (pbrt-v4
    /// `Medium::SampleRay`).
    #[inline]
    fn segments<const N: usize>(
        &self,
        o: V3,
        d: V3,
        t_max: f32,
        lambdas: &Lambdas<N>,
    ) -> Segments<'_, N> {
        match &self.kind {
            Kind::Homogeneous {
                sigma_a, sigma_s, ..
            } => Segments::One(Some((
                0.0,
                t_max,
                add(sigma_a.eval_path(lambdas), sigma_s.eval_path(lambdas)),
            ))),
            Kind::Grid(g) => match g.space.clip(o, d, t_max) {
                None => Segments::One(None),
                Some((ou, du, t0, t1)) => Segments::Dda {
                    dda: Dda::new(ou, du, t0, t1),
                    grid: &g.majorant,
                    sigma_t: add(g.sigma_a.eval_path(lambdas), g.sigma_s.eval_path(lambdas)),
                },
            },
            Kind::Rgb(g) => match g.space.clip(o, d, t_max) {
                None => Segments::One(None),
                Some((ou, du, t0, t1)) => Segments::Dda {
                    dda: Dda::new(ou, du, t0, t1),
                    grid: &g.majorant,
                    sigma_t: [1.0; N],
                },
            },
            Kind::Cloud(c) => match c.space.clip(o, d, t_max) {
                None => Segments::One(None),
                Some((_, _, t0, t1)) => Segments::One(Some((
                    t0,
                    t1,
                    add(c.sigma_a.eval_path(lambdas), c.sigma_s.eval_path(lambdas)),
                ))),
            },
        }
    }
}

impl MediaSet {
    /// Compile the scene's media, or `None` when no ray can ever be in a medium (no camera
    /// medium and no medium boundary): such a scene is rendered by the path tracer.
    pub(crate) fn compile(
        scene: &SceneDescription,
        ws: &WavelengthSampler,
    ) -> Result<Option<Box<MediaSet>>, RenderError> {
        let n = scene.media.list.len();
        let medium_index = |i: Option<usize>, what: &str| -> Result<u32, RenderError> {
            match i {
                None => Ok(NO_MEDIUM),
                Some(i) if i < n => Ok(i as u32),
                Some(i) => Err(RenderError::Settings(format!(
                    "{what} refers to medium {i} but the scene has {n} media"
                ))),
            }
        };
        let camera = medium_index(scene.media.camera, "the camera's medium")?;
        // Each material's boundary, through an alpha mask's wrapper (the reader's nesting).
        let mut interfaces = Vec::with_capacity(scene.materials.len());
        for (mi, m) in scene.materials.iter().enumerate() {
            let mut m = m;
            if let Material::AlphaMasked { material, .. } = m {
                m = scene
                    .materials
                    .get(*material)
                    .ok_or_else(|| RenderError::Material {
                        index: mi,
                        message: format!("alpha mask refers to material {material}"),
                    })?;
            }
            interfaces.push(match m {
                Material::MediumInterface {
                    inside, outside, ..
                } => Some([
                    medium_index(*inside, &format!("material {mi}'s inside"))?,
                    medium_index(*outside, &format!("material {mi}'s outside"))?,
                ]),
                _ => None,
            });
        }
        if camera == NO_MEDIUM && interfaces.iter().all(Option::is_none) {
            return Ok(None);
        }
        let media = scene
            .media
            .list
            .iter()
            .map(|m| compile_medium(m, ws))
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Some(Box::new(MediaSet {
            media,
            camera,
            interfaces,
        })))
    }

    /// Some medium emits (it lights the scene without any light source).
    pub(crate) fn emissive(&self) -> bool {
        self.media.iter().any(|m| match &m.kind {
            Kind::Homogeneous { le, .. } => le.is_some(),
            Kind::Grid(g) => g.le.is_some() || g.temperature.is_some(),
            Kind::Rgb(g) => g.le.is_some(),
            Kind::Cloud(_) => false,
        })
    }

    /// The medium a ray leaving a surface of compiled material `material` along `w` travels in
    /// (pbrt-v4 `Interaction::GetMedium(w)`): a boundary's outside when `w` points to the side
    /// of the oriented geometric normal `n`, its inside otherwise; `current` at surfaces that
    /// are not boundaries.
    #[inline]
    pub(crate) fn after(&self, material: u32, n: V3, w: V3, current: u32) -> u32 {
        match self.interfaces[material as usize] {
            Some([inside, outside]) => {
                if w.dot(n) > 0.0 {
                    outside
                } else {
                    inside
                }
            }
            None => current,
        }
    }

    /// Delta tracking along `ray` (unit direction) in `medium` up to `t_max` (pbrt-v4
    /// `SampleT_maj`): collision distances are sampled from the hero wavelength's majorant,
    /// the first with the uniform `u`, the rest with `rng`; at each collision `callback(rng,
    /// p, coefficients, sigma_maj, T_maj)` gets the majorant transmittance since the previous
    /// one and returns whether to go on. Returns the majorant transmittance from the last
    /// collision to `t_max` (all ones when the callback stopped the walk).
    // pbrt-v4's `SampleT_maj` arguments (medium, ray, extent, the first sample, the RNG for the
    // rest, wavelengths, callback): bundling them would only rename them.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    pub(crate) fn sample_t_maj<const N: usize>(
        &self,
        medium: u32,
        ray: &Ray,
        t_max: f32,
        mut u: f32,
        rng: &mut Rng,
        lambdas: &Lambdas<N>,
        mut callback: impl FnMut(&mut Rng, V3, &MediumPoint<N>, [f32; N], [f32; N]) -> bool,
    ) -> [f32; N] {
        let m = &self.media[medium as usize];
        let mut segs = m.segments(ray.o, ray.d, t_max, lambdas);
        let mut t_maj = [1f32; N];
        while let Some((t0, t1, sigma_maj)) = segs.next() {
            if sigma_maj[0] == 0.0 {
                // The hero sees nothing here: no collision to sample, only the others' decay.
                let dt = (t1 - t0).min(f32::MAX);
                for i in 0..N {
                    t_maj[i] *= (-dt * sigma_maj[i]).exp();
                }
                continue;
            }
            let mut t_min = t0;
            loop {
                // Exponential distance, density sigma exp(-sigma t) (4th ed. eq. 11.18 / A.19).
                let t = t_min - (1.0 - u).ln() / sigma_maj[0];
                u = rng.gen::<f32>();
                if t < t1 {
                    for i in 0..N {
                        t_maj[i] *= (-(t - t_min) * sigma_maj[i]).exp();
                    }
                    let p = ray.o + ray.d * t;
                    let mp = m.point(p, lambdas);
                    if !callback(rng, p, &mp, sigma_maj, t_maj) {
                        return [1.0; N];
                    }
                    t_maj = [1.0; N];
                    t_min = t;
                } else {
                    let dt = (t1 - t_min).min(f32::MAX);
                    for i in 0..N {
                        t_maj[i] *= (-dt * sigma_maj[i]).exp();
                    }
                    break;
                }
            }
        }
        t_maj
    }
}

/// Tabulate a medium for the sampler, refusing what cannot be rendered.
fn compile_medium(m: &Medium, ws: &WavelengthSampler) -> Result<CMedium, RenderError> {
    let err = |message: String| RenderError::Settings(format!("medium \"{}\": {message}", m.name));
    if !(m.g > -1.0 && m.g < 1.0) {
        return Err(err(format!("g {} must lie in (-1, 1)", m.g)));
    }
    let table = |s: &camsim_core::Spectrum, what: &str| -> Result<SpectrumTable, RenderError> {
        s.require_non_negative(what)
            .map_err(|e| err(e.to_string()))?;
        Ok(SpectrumTable::new(s, 1.0, ws))
    };
    let grid_check = |size: &GridSize, len: usize, what: &str| -> Result<(), RenderError> {
        if size.count() == 0 || size.count() != len {
            return Err(err(format!(
                "{what} has {len} values for a {} x {} x {} grid",
                size.nx, size.ny, size.nz
            )));
        }
        camsim_core::mem::check_alloc(len as u64 * 16, &format!("medium \"{}\"", m.name))
            .map_err(RenderError::from)
    };
    let finite_non_negative = |v: &[f32], what: &str| -> Result<(), RenderError> {
        if v.iter().any(|x| !(x.is_finite() && *x >= 0.0)) {
            return Err(err(format!("{what} has a negative or non-finite value")));
        }
        Ok(())
    };
    let kind = match &m.kind {
        MediumKind::Homogeneous(c) => Kind::Homogeneous {
            sigma_a: table(&c.sigma_a_per_m, "sigma_a")?,
            sigma_s: table(&c.sigma_s_per_m, "sigma_s")?,
            le: c.le.as_ref().map(|l| table(l, "Le")).transpose()?,
        },
        MediumKind::UniformGrid(g) => {
            grid_check(&g.size, g.density.len(), "density")?;
            finite_non_negative(&g.density, "density")?;
            finite_non_negative(&g.le_scale, "Lescale")?;
            let density = Grid3::new(&g.size, g.density.clone());
            let le_scale = if g.le_scale.len() == 1 {
                Grid3::new(
                    &GridSize {
                        nx: 1,
                        ny: 1,
                        nz: 1,
                    },
                    g.le_scale.clone(),
                )
            } else {
                grid_check(&g.size, g.le_scale.len(), "Lescale")?;
                Grid3::new(&g.size, g.le_scale.clone())
            };
            let temperature = match &g.temperature {
                Some(t) => {
                    grid_check(&g.size, t.values.len(), "temperature")?;
                    Some((
                        Grid3::new(&g.size, t.values.clone()),
                        t.offset_k as f32,
                        t.scale as f32,
                    ))
                }
                None => None,
            };
            let majorant = MajorantGrid::new(|lo, hi| density.max_in(lo, hi, |v| v));
            Kind::Grid(Box::new(DensityGrid {
                space: UnitBox::new(&g.bounds),
                sigma_a: table(&g.coefficients.sigma_a_per_m, "sigma_a")?,
                sigma_s: table(&g.coefficients.sigma_s_per_m, "sigma_s")?,
                density,
                majorant,
                le: g
                    .coefficients
                    .le
                    .as_ref()
                    .map(|l| table(l, "Le"))
                    .transpose()?,
                le_scale,
                temperature,
            }))
        }
        MediumKind::RgbGrid(g) => {
            let grid = |v: &Option<Vec<[f32; 3]>>,
                        what: &str|
             -> Result<Option<Grid3<RgbSample>>, RenderError> {
                match v {
                    None => Ok(None),
                    Some(v) => {
                        grid_check(&g.size, v.len(), what)?;
                        finite_non_negative(v.as_flattened(), what)?;
                        Ok(Some(Grid3::new(
                            &g.size,
                            v.iter().map(|c| RgbSample::new(*c)).collect(),
                        )))
                    }
                }
            };
            let (sigma_a, sigma_s) = (grid(&g.sigma_a, "sigma_a")?, grid(&g.sigma_s, "sigma_s")?);
            if !(g.sigma_scale_per_m >= 0.0 && g.sigma_scale_per_m.is_finite()) {
                return Err(err(format!("scale {} must be >= 0", g.sigma_scale_per_m)));
            }
            let sigma_scale = g.sigma_scale_per_m as f32;
            let (lo, hi) = (ws.lo_nm as f64, ws.hi_nm as f64);
            let majorant = MajorantGrid::new(|a, b| {
                let max = |gr: &Option<Grid3<RgbSample>>| match gr {
                    Some(gr) => gr.max_in(a, b, |s| s.max_value(lo, hi)),
                    None => 1.0,
                };
                sigma_scale * (max(&sigma_a) + max(&sigma_s))
            });
            let le = match grid(&g.le, "Le")? {
                Some(gr) => Some((gr, table(&g.illuminant, "Le illuminant")?)),
                None => None,
            };
            Kind::Rgb(Box::new(RgbGrid {
                space: UnitBox::new(&g.bounds),
                sigma_a,
                sigma_s,
                sigma_scale,
                majorant,
                le,
            }))
        }
        MediumKind::Cloud(c) => Kind::Cloud(Box::new(Cloud {
            space: UnitBox::new(&c.bounds),
            sigma_a: table(&c.sigma_a_per_m, "sigma_a")?,
            sigma_s: table(&c.sigma_s_per_m, "sigma_s")?,
            density: c.density,
            wispiness: c.wispiness,
            frequency: c.frequency,
        })),
    };
    Ok(CMedium {
        g: m.g as f32,
        kind,
    })
}
