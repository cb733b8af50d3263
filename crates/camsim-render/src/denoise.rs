//! Optional denoising of the rendered spectral film with Intel Open Image Denoise (OIDN), a
//! C++ library loaded at run time (the build needs no C library; a user who asks for denoising
//! names the library, e.g. the one in PyPI's `oidn` wheel).
//!
//! OIDN's `RT` filter denoises three-channel HDR images guided by albedo and normal images. The
//! spectral film goes through it as one such image: its bands summed in three contiguous broad
//! bands (the grid's thirds: about 400-500, 500-600 and 600-700 nm), guided by the first
//! surface's albedo averaged over the same bands and its camera-frame normal (the render's label
//! maps). Each broad band's denoised value is then shared out over its bands as the film's
//! spectrum, summed over the 5 x 5 pixels around with weights from how alike their denoised
//! broad bands are ([`band_shape`]), shares it; so the spectrum stays non-negative, its three
//! broad-band integrals are the denoised ones, and its shape within each third is the film's,
//! averaged over about 25 times the samples. Why not band by band: a path carries 4 of the
//! grid's wavelengths, so one 10-nm band holds about 4/31 of the samples and is far noisier than
//! the colour image a denoiser is trained on. Relative error of the denoised luminance at 16
//! samples, Blender's `textured` / `room` scenes (BENCHMARKS.md, "camsim against Cycles and
//! Mitsuba 3"): 10.8 / 9.0 % denoised in groups of three neighbouring 10-nm bands, 6.1 / 9.7 %
//! in the three broad bands with each band keeping its own ratio of the film, and 5.4 / 7.5 %
//! shared out by the averaged shape as now.
//!
//! Determinism: OIDN's result depends on its thread count (in its last bits), so it runs on a
//! one-thread OIDN device: the bytes are the same for any `RAYON_NUM_THREADS` on one machine
//! (OIDN picks kernels by instruction set, so two CPUs may differ in the last bits). One thread
//! costs time on large images; BENCHMARKS.md gives the figures.
//!
//! What a denoiser does to a camera simulation is measured in docs/src/adaptive.md ("Denoised
//! radiance"): it is for training data, not for lens or sensor studies.

use crate::error::RenderError;
use camsim_core::SpectralImage;
use rayon::prelude::*;
use std::ffi::{c_char, c_void, CStr};
use std::path::{Path, PathBuf};

/// The environment variable naming the OIDN shared library (`libOpenImageDenoise.so.*`).
pub const LIBRARY_ENV: &str = "CAMSIM_OIDN_LIBRARY";

/// How to get the library, for messages.
const HOW_TO_GET: &str = "install it (e.g. `pip install oidn`, whose wheel ships \
    oidn/lib.linux.x64/libOpenImageDenoise.so.1.4.3) and set CAMSIM_OIDN_LIBRARY to the file";

// OIDN's C API (oidn.h, versions 1.x and 2.x): the few entry points used, as function pointers.
type NewDevice = unsafe extern "C" fn(i32) -> *mut c_void;
type SetDeviceInt = unsafe extern "C" fn(*mut c_void, *const c_char, i32);
type DeviceFn = unsafe extern "C" fn(*mut c_void);
type GetDeviceError = unsafe extern "C" fn(*mut c_void, *mut *const c_char) -> i32;
type NewFilter = unsafe extern "C" fn(*mut c_void, *const c_char) -> *mut c_void;
type SetSharedFilterImage = unsafe extern "C" fn(
    *mut c_void,
    *const c_char,
    *mut c_void,
    i32,
    usize,
    usize,
    usize,
    usize,
    usize,
);
type SetFilterBool = unsafe extern "C" fn(*mut c_void, *const c_char, bool);
type FilterFn = unsafe extern "C" fn(*mut c_void);

/// `OIDN_DEVICE_TYPE_CPU` and `OIDN_FORMAT_FLOAT3` (oidn.h).
const DEVICE_CPU: i32 = 1;
const FORMAT_FLOAT3: i32 = 3;

/// A loaded OIDN library.
pub struct Oidn {
    path: PathBuf,
    new_device: NewDevice,
    set_device_int: SetDeviceInt,
    commit_device: DeviceFn,
    release_device: DeviceFn,
    device_error: GetDeviceError,
    new_filter: NewFilter,
    set_image: SetSharedFilterImage,
    set_bool: SetFilterBool,
    commit_filter: FilterFn,
    execute_filter: FilterFn,
    release_filter: FilterFn,
    // Loaded for good: OIDN's worker threads outlive any one denoise, and unloading it (or the
    // TBB library it needs) under them would crash the process.
    _libraries: Vec<&'static libloading::Library>,
}

impl std::fmt::Debug for Oidn {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Oidn").field("path", &self.path).finish()
    }
}

fn denoise_error(message: String) -> RenderError {
    RenderError::Settings(format!("denoise: {message}"))
}

impl Oidn {
    /// Load the library at `path`, or at `$CAMSIM_OIDN_LIBRARY`, or `libOpenImageDenoise.so.2`
    /// / `.so.1` from the system's library path. A `libtbb.so.*` beside the file (as the `oidn`
    /// wheel ships it, without its soname link) is loaded first.
    pub fn load(path: Option<&Path>) -> Result<Oidn, RenderError> {
        let from_env = std::env::var_os(LIBRARY_ENV).map(PathBuf::from);
        let candidates: Vec<PathBuf> = match path.map(Path::to_path_buf).or(from_env) {
            Some(p) => {
                if !p.is_file() {
                    return Err(denoise_error(format!(
                        "the OIDN library {} does not exist: {HOW_TO_GET}",
                        p.display()
                    )));
                }
                vec![p]
            }
            None => ["libOpenImageDenoise.so.2", "libOpenImageDenoise.so.1"]
                .iter()
                .map(PathBuf::from)
                .collect(),
        };
        let mut reasons = Vec::new();
        for p in candidates {
            match Self::open(&p) {
                Ok(o) => return Ok(o),
                Err(e) => reasons.push(format!("{}: {e}", p.display())),
            }
        }
        Err(denoise_error(format!(
            "no OIDN library could be loaded ({}); {HOW_TO_GET}",
            reasons.join("; ")
        )))
    }

    fn open(path: &Path) -> Result<Oidn, String> {
        let mut libraries = Vec::new();
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            let mut tbb: Vec<PathBuf> = std::fs::read_dir(dir)
                .map(|rd| {
                    rd.filter_map(|e| e.ok().map(|e| e.path()))
                        .filter(|p| {
                            p.file_name()
                                .and_then(|n| n.to_str())
                                .is_some_and(|n| n.starts_with("libtbb.so"))
                        })
                        .collect()
                })
                .unwrap_or_default();
            tbb.sort();
            if let Some(t) = tbb.last() {
                // SAFETY: loading a shared library runs its initialisers; TBB's are benign.
                let tbb = unsafe { libloading::Library::new(t) }.map_err(|e| e.to_string())?;
                libraries.push(&*Box::leak(Box::new(tbb)));
            }
        }
        // SAFETY: as above; the symbols are then looked up with their oidn.h signatures.
        let lib: &'static libloading::Library = Box::leak(Box::new(
            unsafe { libloading::Library::new(path) }.map_err(|e| e.to_string())?,
        ));
        unsafe fn sym<T: Copy>(lib: &libloading::Library, names: &[&str]) -> Result<T, String> {
            for n in names {
                if let Ok(s) = lib.get::<T>(n.as_bytes()) {
                    return Ok(*s);
                }
            }
            Err(format!("it has no {} (not an OIDN library?)", names[0]))
        }
        // SAFETY: each type above is the C signature oidn.h declares for that name (the 2.x
        // names first, then the 1.x ones they replaced).
        let o = unsafe {
            Oidn {
                path: path.to_path_buf(),
                new_device: sym(lib, &["oidnNewDevice"])?,
                set_device_int: sym(lib, &["oidnSetDeviceInt", "oidnSetDevice1i"])?,
                commit_device: sym(lib, &["oidnCommitDevice"])?,
                release_device: sym(lib, &["oidnReleaseDevice"])?,
                device_error: sym(lib, &["oidnGetDeviceError"])?,
                new_filter: sym(lib, &["oidnNewFilter"])?,
                set_image: sym(lib, &["oidnSetSharedFilterImage"])?,
                set_bool: sym(lib, &["oidnSetFilterBool", "oidnSetFilter1b"])?,
                commit_filter: sym(lib, &["oidnCommitFilter"])?,
                execute_filter: sym(lib, &["oidnExecuteFilter"])?,
                release_filter: sym(lib, &["oidnReleaseFilter"])?,
                _libraries: Vec::new(),
            }
        };
        libraries.push(lib);
        Ok(Oidn {
            _libraries: libraries,
            ..o
        })
    }

    /// The library's file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Denoise one HDR image of `width x height` pixels of three interleaved channels, guided
    /// by `albedo` and `normal` (the same layout; normal needs albedo), on a one-thread device
    /// (OIDN meters each HDR image itself: its default `inputScale`).
    fn filter3(
        &self,
        color: &[f32],
        albedo: Option<&[f32]>,
        normal: Option<&[f32]>,
        width: usize,
        height: usize,
    ) -> Result<Vec<f32>, RenderError> {
        let n = width * height * 3;
        assert!(color.len() == n && albedo.is_none_or(|a| a.len() == n));
        assert!(normal.is_none_or(|a| a.len() == n) && (normal.is_none() || albedo.is_some()));
        let mut out = vec![0f32; n];
        // SAFETY: the device and filter are created, used and released here; every image
        // pointer is valid for `width * height` FLOAT3 pixels (checked above) until the filter
        // has run, and OIDN only reads the inputs.
        unsafe {
            let dev = (self.new_device)(DEVICE_CPU);
            if dev.is_null() {
                return Err(denoise_error("OIDN could not create a CPU device".into()));
            }
            (self.set_device_int)(dev, c"numThreads".as_ptr(), 1);
            (self.commit_device)(dev);
            let filter = (self.new_filter)(dev, c"RT".as_ptr());
            let set = |name: &CStr, ptr: *mut c_void| {
                (self.set_image)(
                    filter,
                    name.as_ptr(),
                    ptr,
                    FORMAT_FLOAT3,
                    width,
                    height,
                    0,
                    0,
                    0,
                )
            };
            set(c"color", color.as_ptr() as *mut c_void);
            if let Some(a) = albedo {
                set(c"albedo", a.as_ptr() as *mut c_void);
            }
            if let Some(nrm) = normal {
                set(c"normal", nrm.as_ptr() as *mut c_void);
            }
            set(c"output", out.as_mut_ptr() as *mut c_void);
            (self.set_bool)(filter, c"hdr".as_ptr(), true);
            (self.commit_filter)(filter);
            (self.execute_filter)(filter);
            let mut msg: *const c_char = std::ptr::null();
            let code = (self.device_error)(dev, &mut msg);
            (self.release_filter)(filter);
            let text = if code != 0 && !msg.is_null() {
                CStr::from_ptr(msg).to_string_lossy().into_owned()
            } else {
                String::new()
            };
            (self.release_device)(dev);
            if code != 0 {
                return Err(denoise_error(format!("OIDN error {code}: {text}")));
            }
        }
        Ok(out)
    }
}

/// The guides of a denoise: the render's label maps of its first surfaces.
#[derive(Debug, Clone, Copy, Default)]
pub struct Guides<'a> {
    /// Spectral albedo, band-sequential on the radiance's grid (`crate::labels::Labels::albedo`).
    pub albedo: Option<&'a [f32]>,
    /// Unit normals per pixel, any fixed frame (`crate::labels::Labels::normal_camera`); used
    /// only with an albedo.
    pub normal: Option<&'a [[f32; 3]]>,
    /// Pixels whose centre sees an emitter or nothing (the background) first. The light there
    /// is what the emitter sends, not light transport's Monte Carlo noise, so they and their 8
    /// neighbours (whose footprints may hold part of the emitter) keep the film's value, and the
    /// filter sees them black in colour and albedo: a lamp hundreds of times brighter than the
    /// ceiling around it, and its partly covered edge pixels, would otherwise be spread into a
    /// halo.
    pub direct: Option<&'a [bool]>,
}

/// Zero the FLOAT3 pixels of `v` that `direct` marks.
fn blacken(v: &mut [f32], direct: Option<&[bool]>) {
    if let Some(d) = direct {
        for (px, _) in v.chunks_exact_mut(3).zip(d).filter(|(_, d)| **d) {
            px.fill(0.0);
        }
    }
}

/// The three broad bands the film is denoised in (module docs): contiguous runs of bands, the
/// grid split in thirds (sizes differ by one at most; with fewer than three bands, each channel
/// is one band, the last repeated).
pub fn broad_bands(bands: usize) -> [std::ops::Range<usize>; 3] {
    if bands < 3 {
        return std::array::from_fn(|c| {
            let b = c.min(bands.saturating_sub(1));
            b..b + 1
        });
    }
    let edge = |c: usize| (c * bands + 1) / 3;
    std::array::from_fn(|c| edge(c)..edge(c + 1))
}

/// `radiance` denoised by `oidn` (module docs), on the same grid and geometry.
pub fn denoise(
    oidn: &Oidn,
    radiance: &SpectralImage,
    guides: Guides<'_>,
) -> Result<SpectralImage, RenderError> {
    let (w, h, bands) = (radiance.cols, radiance.rows, radiance.bands());
    let n = w * h;
    if let Some(a) = guides.albedo {
        if a.len() != n * bands {
            return Err(denoise_error(format!(
                "the albedo guide has {} values, the radiance {} x {} x {bands}",
                a.len(),
                h,
                w
            )));
        }
    }
    if let Some(d) = guides.direct {
        if d.len() != n {
            return Err(denoise_error(format!(
                "the emitter mask has {} pixels, the radiance {n}",
                d.len()
            )));
        }
    }
    if let Some(nrm) = guides.normal {
        if nrm.len() != n {
            return Err(denoise_error(format!(
                "the normal guide has {} pixels, the radiance {n}",
                nrm.len()
            )));
        }
    }
    // The direct pixels and their 8 neighbours.
    let kept: Option<Vec<bool>> = guides.direct.map(|d| {
        let mut k = d.to_vec();
        for y in 0..h {
            for x in 0..w {
                if d[y * w + x] {
                    for yy in y.saturating_sub(1)..(y + 2).min(h) {
                        for xx in x.saturating_sub(1)..(x + 2).min(w) {
                            k[yy * w + xx] = true;
                        }
                    }
                }
            }
        }
        k
    });
    let kept = kept.as_deref();
    let normal: Option<Vec<f32>> = guides
        .albedo
        .and(guides.normal)
        .map(|nrm| nrm.iter().flatten().copied().collect());
    let ranges = broad_bands(bands);
    // Per broad band: the sum of the film's bands and the mean of the albedo's, per pixel.
    let broad = |data: &[f32], mean: bool| -> Vec<f32> {
        let mut v = vec![0f32; 3 * n];
        for (c, r) in ranges.iter().enumerate() {
            let k = if mean { 1.0 / r.len() as f32 } else { 1.0 };
            for b in r.clone() {
                for (p, x) in data[b * n..(b + 1) * n].iter().enumerate() {
                    v[3 * p + c] += x * k;
                }
            }
        }
        v
    };
    let mut color = broad(&radiance.data, false);
    blacken(&mut color, kept);
    let albedo = guides.albedo.map(|a| {
        let mut v = broad(a, true);
        blacken(&mut v, kept);
        v
    });
    let result = oidn.filter3(&color, albedo.as_deref(), normal.as_deref(), w, h)?;
    let shape = band_shape(&radiance.data, (w, h, bands), &result, kept);
    let mut out = radiance.clone();
    rescale_bands(&mut out.data, n, &ranges, &shape, &result, kept);
    Ok(out)
}

/// Half-width of the window the within-band shape is averaged over, pixels (5 x 5).
const SHAPE_RADIUS_PX: usize = 2;
/// Width of the shape's weights in the denoised broad bands' natural log (about 10 %).
const SHAPE_SIGMA_LOG: f32 = 0.1;

/// Each pixel's spectral shape within the broad bands, pixel-interleaved (`bands` values a
/// pixel): the film's bands summed over the 5 x 5 window around it, each neighbour weighted by
/// how alike its denoised broad bands are to the pixel's, `exp(-|ln D(q) - ln D(p)|^2 / (2
/// sigma^2))` (a cross-bilateral filter guided by the denoised image: Eisemann and Durand 2004,
/// Petschnigg et al. 2004), the `kept` pixels left out of every window. Only the shape is taken
/// from it: the level is the denoiser's. Against each pixel's own film as the shape, it takes the
/// denoised luminance error at 16 spp from 9.7 to 7.5 % on Blender's `room` and from 6.1 to
/// 5.4 % on `textured` (module docs).
fn band_shape(
    film: &[f32],
    (w, h, bands): (usize, usize, usize),
    denoised: &[f32],
    kept: Option<&[bool]>,
) -> Vec<f32> {
    let n = w * h;
    let mean =
        denoised.iter().map(|&v| v.max(0.0) as f64).sum::<f64>() / denoised.len().max(1) as f64;
    let floor = (1e-6 * mean).max(f64::MIN_POSITIVE) as f32;
    let log: Vec<f32> = denoised.iter().map(|&v| v.max(floor).ln()).collect();
    let inv = 1.0 / (2.0 * SHAPE_SIGMA_LOG * SHAPE_SIGMA_LOG);
    let r = SHAPE_RADIUS_PX;
    let mut shape = vec![0f32; n * bands];
    shape.par_chunks_mut(w * bands).enumerate().for_each_init(
        || vec![0f32; w],
        |weights, (y, row)| {
            for yy in y.saturating_sub(r)..(y + r + 1).min(h) {
                for dx in -(r as isize)..=r as isize {
                    for (x, wt) in weights.iter_mut().enumerate() {
                        let xx = x as isize + dx;
                        *wt = if xx < 0 || xx >= w as isize {
                            0.0
                        } else {
                            let (p, q) = (y * w + x, yy * w + xx as usize);
                            if kept.is_some_and(|k| k[q]) {
                                0.0
                            } else {
                                let d2: f32 = (0..3)
                                    .map(|c| (log[3 * q + c] - log[3 * p + c]).powi(2))
                                    .sum();
                                (-d2 * inv).exp()
                            }
                        };
                    }
                    for b in 0..bands {
                        let src = &film[b * n + yy * w..b * n + (yy + 1) * w];
                        for (x, &wt) in weights.iter().enumerate() {
                            if wt > 0.0 {
                                row[x * bands + b] += wt * src[(x as isize + dx) as usize];
                            }
                        }
                    }
                }
            }
        },
    );
    shape
}

/// Give each band of `data` (band-sequential, `n` pixels a band) its broad band's denoised
/// value (`denoised`, three channels a pixel) shared out as `shape` (pixel-interleaved,
/// `shape.len() / n` values a pixel) shares its broad band, leaving the `kept` pixels as they
/// are; where the shape's broad band is 0, evenly over its bands. A range repeated (fewer than
/// three bands) is shared out once.
fn rescale_bands(
    data: &mut [f32],
    n: usize,
    ranges: &[std::ops::Range<usize>; 3],
    shape: &[f32],
    denoised: &[f32],
    kept: Option<&[bool]>,
) {
    let bands = shape.len() / n.max(1);
    for (c, r) in ranges.iter().enumerate() {
        if ranges[..c].contains(r) {
            continue;
        }
        let width = r.len() as f32;
        for p in 0..n {
            if kept.is_some_and(|m| m[p]) {
                continue;
            }
            let here = &shape[p * bands + r.start..p * bands + r.end];
            let total: f32 = here.iter().sum();
            let after = denoised[3 * p + c].max(0.0);
            for (b, &sh) in r.clone().zip(here) {
                data[b * n + p] = if total > 0.0 {
                    after * (sh / total)
                } else {
                    after / width
                };
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rescaled_bands_share_the_denoised_broad_bands_as_the_shape_does() {
        // Two pixels, 4 bands split [0..1, 1..3, 3..4]; pixel 1 kept as it was.
        let n = 2;
        let ranges = broad_bands(4);
        assert_eq!(ranges, [0..1, 1..3, 3..4]);
        let mut data = vec![1.0, 5.0, 2.0, 6.0, 3.0, 7.0, 1.0, 8.0];
        let shape = [1.0, 2.0, 3.0, 7.0, 9.0, 9.0, 9.0, 9.0];
        let denoised = [2.0, 2.5, 0.5, 0.0, 0.0, 0.0];
        rescale_bands(
            &mut data,
            n,
            &ranges,
            &shape,
            &denoised,
            Some(&[false, true]),
        );
        // Pixel 0: band 0 takes 2; bands 1-2 share 2.5 as 2 : 3; band 3 takes 0.5.
        assert_eq!([data[0], data[2], data[4], data[6]], [2.0, 1.0, 1.5, 0.5]);
        assert_eq!([data[1], data[3], data[5], data[7]], [5.0, 6.0, 7.0, 8.0]);
        // A shape of zero shares the denoised value evenly.
        let mut z = vec![0.0; 4];
        rescale_bands(
            &mut z,
            1,
            &ranges,
            &[1.0, 0.0, 0.0, 1.0],
            &[1.0, 3.0, 1.0],
            None,
        );
        assert_eq!(z[1..3], [1.5, 1.5]);
        // One band takes its denoised value.
        let mut one = vec![4.0];
        rescale_bands(&mut one, 1, &broad_bands(1), &[4.0], &[2.0; 3], None);
        assert_eq!(one, [2.0]);
    }

    #[test]
    fn band_shape_sums_the_window_of_alike_pixels_only() {
        // 8 x 6 pixels, 2 bands: band 0 = 1 + x, band 1 = 10 y. Denoised: 1 left of x = 4, 5 right.
        let (w, h, bands) = (8, 6, 2);
        let n = w * h;
        let mut film = vec![0f32; n * bands];
        for y in 0..h {
            for x in 0..w {
                film[y * w + x] = 1.0 + x as f32;
                film[n + y * w + x] = 10.0 * y as f32;
            }
        }
        let denoised: Vec<f32> = (0..n)
            .flat_map(|p| [if p % w < 4 { 1.0 } else { 5.0 }; 3])
            .collect();
        let shape = band_shape(&film, (w, h, bands), &denoised, None);
        // (x 1, y 2): the 5 x 5 window clipped at x = 0 and not crossing x = 4: x 0..=3, y 0..=4.
        let p = 2 * w + 1;
        let want0: f32 = 5.0 * (1.0 + 2.0 + 3.0 + 4.0);
        let want1: f32 = 4.0 * 10.0 * (0.0 + 1.0 + 2.0 + 3.0 + 4.0);
        assert!(
            (shape[p * bands] - want0).abs() < 1e-3,
            "{}",
            shape[p * bands]
        );
        assert!(
            (shape[p * bands + 1] - want1).abs() < 1e-3,
            "{}",
            shape[p * bands + 1]
        );
        // (x 3, y 2): the window x 1..=5 crosses the edge at x = 4; the pixels beyond it
        // (denoised 5 against 1: weight exp(-3 ln(5)^2 / (2 0.1^2)) = 0) are left out.
        let q = 2 * w + 3;
        let edge0: f32 = 5.0 * (2.0 + 3.0 + 4.0);
        let edge1: f32 = 3.0 * 10.0 * (0.0 + 1.0 + 2.0 + 3.0 + 4.0);
        assert!(
            (shape[q * bands] - edge0).abs() < 1e-3 && (shape[q * bands + 1] - edge1).abs() < 1e-3,
            "{} {}",
            shape[q * bands],
            shape[q * bands + 1]
        );
        // A kept pixel is left out of its neighbours' windows.
        let mut kept = vec![false; n];
        kept[2 * w] = true;
        let shape = band_shape(&film, (w, h, bands), &denoised, Some(&kept));
        assert!((shape[p * bands] - (want0 - 1.0)).abs() < 1e-3);
        assert!((shape[p * bands + 1] - (want1 - 20.0)).abs() < 1e-3);
    }

    #[test]
    fn broad_bands_cover_every_band_once_in_thirds() {
        assert_eq!(broad_bands(31), [0..10, 10..21, 21..31]);
        assert_eq!(broad_bands(30), [0..10, 10..20, 20..30]);
        assert_eq!(broad_bands(3), [0..1, 1..2, 2..3]);
        assert_eq!(broad_bands(1), [0..1, 0..1, 0..1]);
        assert_eq!(broad_bands(2), [0..1, 1..2, 1..2]);
        for bands in [3, 4, 5, 7, 31, 61] {
            let r = broad_bands(bands);
            assert_eq!((r[0].start, r[2].end), (0, bands));
            assert!(r[0].end == r[1].start && r[1].end == r[2].start);
            let (lo, hi) = (
                r.iter().map(|r| r.len()).min(),
                r.iter().map(|r| r.len()).max(),
            );
            assert!(hi.unwrap() - lo.unwrap() <= 1, "{bands}: {r:?}");
        }
    }

    #[test]
    fn a_missing_library_is_named_with_how_to_get_one() {
        let e = Oidn::load(Some(Path::new("/nonexistent/libOpenImageDenoise.so.1"))).unwrap_err();
        let m = e.to_string();
        assert!(
            m.contains("/nonexistent/libOpenImageDenoise.so.1") && m.contains("pip install oidn"),
            "{m}"
        );
        let dir = tempfile::tempdir().unwrap();
        let fake = dir.path().join("libOpenImageDenoise.so.1");
        std::fs::write(&fake, b"not a library").unwrap();
        let m = Oidn::load(Some(&fake)).unwrap_err().to_string();
        assert!(
            m.contains("libOpenImageDenoise.so.1") && m.contains("CAMSIM_OIDN_LIBRARY"),
            "{m}"
        );
    }
}
