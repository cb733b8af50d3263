//! camsim stage 1 (3D): spectral path tracer and pbrt-v4 scene reader -> spectral radiance and depth
