//! (to be written: see the crate's documentation)
