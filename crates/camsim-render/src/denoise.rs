//! Optional denoising of the rendered spectral film with Intel Open Image Denoise (OIDN), a
//! C++ library loaded at run time (the build needs no C library; a user who asks for denoising
//! names the library, e.g. the one in PyPI's `oidn` wheel).
//!
//! OIDN's `RT` filter denoises three-channel HDR images guided by albedo and normal images. The
//! spectral film is denoised in groups of three neighbouring bands (31 bands: eleven groups, the
//! last overlapping the one before), each group guided by the first surface's spectral albedo in
//! the same bands and its camera-frame normal (the render's label maps). Neighbouring bands of
//! one path carry almost the same noise (every band is traced along the same paths), so a group
//! looks to the filter like the near-grey noise of an RGB render, and each band keeps its own
//! level: the spectrum stays a spectrum, non-negative (outputs are clamped at 0).
//!
//! Determinism: OIDN's result depends on its thread count (in its last bits), so every group
//! runs on its own one-thread OIDN device, the groups in parallel: the bytes are the same for any
//! `RAYON_NUM_THREADS` on one machine (OIDN picks kernels by instruction set, so two CPUs may
//! differ in the last bits).
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

/// The first band of each group of three the film is denoised in (module docs).
pub fn band_groups(bands: usize) -> Vec<usize> {
    if bands <= 3 {
        return vec![0];
    }
    let mut g: Vec<usize> = (0..bands / 3).map(|k| 3 * k).collect();
    if !bands.is_multiple_of(3) {
        g.push(bands - 3);
    }
    g
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
    // Interleave three planes (a band group or its albedo) into FLOAT3 pixels.
    let interleave = |planes: [&[f32]; 3]| -> Vec<f32> {
        let mut v = vec![0f32; 3 * n];
        for (p, px) in v.chunks_exact_mut(3).enumerate() {
            for c in 0..3 {
                px[c] = planes[c][p];
            }
        }
        v
    };
    fn plane(data: &[f32], b: usize, bands: usize, n: usize) -> &[f32] {
        let b = b.min(bands - 1);
        &data[b * n..(b + 1) * n]
    }
    let groups = band_groups(bands);
    let results: Vec<Vec<f32>> = groups
        .par_iter()
        .map(|&b0| {
            let mut color = interleave([0, 1, 2].map(|k| plane(&radiance.data, b0 + k, bands, n)));
            blacken(&mut color, kept);
            let albedo = guides.albedo.map(|a| {
                let mut v = interleave([0, 1, 2].map(|k| plane(a, b0 + k, bands, n)));
                blacken(&mut v, kept);
                v
            });
            oidn.filter3(&color, albedo.as_deref(), normal.as_deref(), w, h)
        })
        .collect::<Result<_, _>>()?;
    let mut out = radiance.clone();
    // Each band from the last group that holds it (groups overlap only at the end).
    for (g, &b0) in groups.iter().enumerate() {
        for k in 0..3 {
            let b = b0 + k;
            if b >= bands {
                continue;
            }
            let dst = out.band_mut(b);
            for (p, d) in dst.iter_mut().enumerate() {
                if !kept.is_some_and(|m| m[p]) {
                    *d = results[g][3 * p + k].max(0.0);
                }
            }
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn band_groups_cover_every_band_once_but_at_the_end() {
        assert_eq!(band_groups(31).len(), 11);
        assert_eq!(band_groups(31)[10], 28);
        assert_eq!(band_groups(30), (0..10).map(|k| 3 * k).collect::<Vec<_>>());
        assert_eq!(band_groups(3), vec![0]);
        assert_eq!(band_groups(1), vec![0]);
        for bands in [4, 7, 31, 61] {
            let g = band_groups(bands);
            for b in 0..bands {
                assert!(g.iter().any(|&s| (s..s + 3).contains(&b)), "{bands}: {b}");
            }
            assert!(g.iter().all(|&s| s + 3 <= bands));
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
