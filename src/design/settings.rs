//! The `[design]` section of a run config (and `coapt design --sizes`):
//! which Ozaki sizer sizes to sweep.
//!
//! ```toml
//! [design]
//! sizes = [19, 21, 23, 25]     # or "13-35": every sizer size in the range
//! ```

use std::path::Path;

use crate::template::OZAKI_SIZES;
use crate::{Error, Result};

/// What a design sweep tries.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Settings {
    /// Ozaki sizer sizes, ascending, no repeats.
    pub sizes: Vec<u32>,
}

impl Default for Settings {
    /// Every size of the sizer table.
    fn default() -> Self {
        Settings {
            sizes: OZAKI_SIZES.iter().map(|s| s.0).collect(),
        }
    }
}

fn table_sizes() -> String {
    OZAKI_SIZES
        .iter()
        .map(|s| s.0.to_string())
        .collect::<Vec<_>>()
        .join(", ")
}

fn checked(mut sizes: Vec<u32>) -> std::result::Result<Vec<u32>, String> {
    if let Some(bad) = sizes
        .iter()
        .find(|s| !OZAKI_SIZES.iter().any(|t| t.0 == **s))
    {
        return Err(format!(
            "size {bad} is not in the Ozaki sizer table ({})",
            table_sizes()
        ));
    }
    sizes.sort_unstable();
    sizes.dedup();
    if sizes.is_empty() {
        return Err("no sizes to try".into());
    }
    Ok(sizes)
}

/// "19,21,23" or "13-35" (every table size in the range, ends included).
pub fn parse_sizes(text: &str) -> std::result::Result<Vec<u32>, String> {
    let t = text.trim();
    if let Some((a, b)) = t.split_once('-') {
        let num = |s: &str| {
            s.trim()
                .parse::<u32>()
                .map_err(|_| format!("'{t}': expected a range like 13-35"))
        };
        let (lo, hi) = (num(a)?, num(b)?);
        if lo > hi {
            return Err(format!("'{t}': the range is empty ({lo} > {hi})"));
        }
        let sizes: Vec<u32> = OZAKI_SIZES
            .iter()
            .map(|s| s.0)
            .filter(|s| (lo..=hi).contains(s))
            .collect();
        if sizes.is_empty() {
            return Err(format!(
                "'{t}': no sizer size in this range (sizes: {})",
                table_sizes()
            ));
        }
        return Ok(sizes);
    }
    let sizes = t
        .split(',')
        .map(|s| {
            s.trim().parse::<u32>().map_err(|_| {
                format!(
                    "'{}' is not a size (write e.g. 19,21,23 or 13-35)",
                    s.trim()
                )
            })
        })
        .collect::<std::result::Result<Vec<_>, _>>()?;
    checked(sizes)
}

impl Settings {
    /// Read a `[design]` table; errors name the file and the key.
    pub fn from_toml(path: &Path, table: &toml::Table) -> Result<Settings> {
        let mut s = Settings::default();
        for (k, v) in table {
            match k.as_str() {
                "sizes" => {
                    let sizes = match v {
                        toml::Value::String(t) => parse_sizes(t),
                        toml::Value::Array(a) => a
                            .iter()
                            .map(|x| match x.as_integer() {
                                Some(i) if i > 0 && i < 1000 => Ok(i as u32),
                                _ => Err(format!("{x} is not a sizer size")),
                            })
                            .collect::<std::result::Result<Vec<_>, _>>()
                            .and_then(checked),
                        other => Err(format!(
                            "{other} is not a list of sizes (write sizes = [19, 21] or \"13-35\")"
                        )),
                    };
                    s.sizes = sizes.map_err(|e| Error::config(path, "design.sizes", e))?;
                }
                _ => {
                    return Err(Error::config(
                        path,
                        format!("design.{k}"),
                        "unknown key (the [design] section takes: sizes)",
                    ));
                }
            }
        }
        Ok(s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_from_lists_and_ranges() {
        assert_eq!(parse_sizes("23, 19,21,19").unwrap(), vec![19, 21, 23]);
        assert_eq!(parse_sizes("18-24").unwrap(), vec![19, 21, 23]);
        assert_eq!(parse_sizes("13-35").unwrap(), Settings::default().sizes);
        assert!(parse_sizes("20").unwrap_err().contains("not in the Ozaki"));
        assert!(parse_sizes("36-40").unwrap_err().contains("no sizer size"));
        assert!(parse_sizes("25-19").unwrap_err().contains("empty"));
        assert!(parse_sizes("x").unwrap_err().contains("not a size"));
    }

    #[test]
    fn toml_section() {
        let p = Path::new("run.toml");
        let t: toml::Table = "sizes = [21, 19]".parse().unwrap();
        assert_eq!(Settings::from_toml(p, &t).unwrap().sizes, vec![19, 21]);
        let t: toml::Table = "sizes = \"30-35\"".parse().unwrap();
        assert_eq!(Settings::from_toml(p, &t).unwrap().sizes, vec![31, 33, 35]);
        let t: toml::Table = "sizes = [20]".parse().unwrap();
        let e = Settings::from_toml(p, &t).unwrap_err().to_string();
        assert!(e.contains("run.toml") && e.contains("design.sizes"), "{e}");
        let t: toml::Table = "size = [21]".parse().unwrap();
        let e = Settings::from_toml(p, &t).unwrap_err().to_string();
        assert!(
            e.contains("design.size") && e.contains("takes: sizes"),
            "{e}"
        );
    }
}
