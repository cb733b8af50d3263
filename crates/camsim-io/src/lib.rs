//! camsim io: spectral OpenEXR, DNG read/write, PNG/TIFF, plots, atomic file writes
