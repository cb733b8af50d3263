//! `camsim analyze emva`: EMVA 1288 characterization from a series CSV (wired when the analysis
//! API is complete).
use anyhow::Result;

pub fn run(_a: super::analyze::EmvaArgs) -> Result<()> {
    anyhow::bail!("not wired yet")
}
