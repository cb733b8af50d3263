//! Built-in spectral tables (filled in by the tables module files).
