//! `design.json` (`coapt-design/1`), written by `coapt design` and read by
//! the report stage and `coapt cohort summary`: its schema name and where
//! each size's run lives, so that neither reader needs the design module.

/// The `schema` field of design.json.
pub const SCHEMA: &str = "coapt-design/1";

/// Where one size's run lives, relative to the design directory.
pub fn size_dir(size: u32) -> String {
    format!("size-{size}")
}
