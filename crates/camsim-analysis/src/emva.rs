//! emva (in progress)
