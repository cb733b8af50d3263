//! camsim stage 2: radiance -> sensor irradiance (f-number, cos4, OTF/PSF, wavefront, defocus, shading)
