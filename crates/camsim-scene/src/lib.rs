//! camsim stage 1 (2D): test charts -> spectral radiance
