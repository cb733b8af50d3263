//! ISETCam MATLAB v5 spectral files (placeholder, see the mat module).
