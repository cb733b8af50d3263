//! How camsim signs the files it writes, so a later run can tell its own output from a user's
//! file ([`crate::claim`]).

/// The signature: `camsim <version>`. Written as the `software` attribute of every OpenEXR file,
/// the `Software` text chunk of every PNG, and the `written_by` of an output folder's marker.
pub const SOFTWARE: &str = concat!("camsim ", env!("CARGO_PKG_VERSION"));

/// The first line of a text file camsim writes as a single output (a TOML fit) starts with this.
pub const TEXT_SIGNATURE: &str = "# camsim";
