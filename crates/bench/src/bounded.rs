//! Bounded command-line numbers for the benchmarks: a mesh size, a time
//! limit or a case count sets the work a run does, so each is checked
//! against a stated range when the command line is read (`--cases 1e12`
//! asked for 8 TB, `--h 1e-6` for as many nodes as memory holds).

use clap::builder::ValueParser;

/// A number within `lo..=hi` (in `unit`, named in the refusal).
pub fn number(lo: f64, hi: f64, unit: &'static str) -> ValueParser {
    ValueParser::new(move |s: &str| -> Result<f64, String> {
        let v: f64 = s.trim().parse().map_err(|e| format!("{e}"))?;
        if v >= lo && v <= hi {
            Ok(v)
        } else {
            Err(format!(
                "{} lies outside {} to {}{unit}: it sets the work the run does",
                coapt_base::units::short(v),
                coapt_base::units::short(lo),
                coapt_base::units::short(hi)
            ))
        }
    })
}

/// A count within `lo..=hi`.
pub fn count(lo: usize, hi: usize) -> ValueParser {
    ValueParser::new(move |s: &str| -> Result<usize, String> {
        let v: usize = s.trim().parse().map_err(|e| format!("{e}"))?;
        if (lo..=hi).contains(&v) {
            Ok(v)
        } else {
            Err(format!(
                "{v} lies outside {lo} to {hi}: it sets the work the run does"
            ))
        }
    })
}

/// Mesh sizes a benchmark may ask for (mm): the finest the closure-trust
/// measurements use is 0.125 mm (27 355 nodes on the peer case).
pub fn mesh_size() -> ValueParser {
    number(0.05, 10.0, " mm")
}

/// A solver time limit (s): a day at most.
pub fn time_limit() -> ValueParser {
    number(0.001, 86_400.0, " s")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(p: &ValueParser, text: &str) -> Result<(), String> {
        clap::Command::new("t")
            .arg(clap::Arg::new("x").long("x").value_parser(p.clone()))
            .try_get_matches_from(["t", "--x", text])
            .map(|_| ())
            .map_err(|e| e.to_string())
    }

    #[test]
    fn bounds_hold_at_both_ends_and_name_the_range() {
        let h = mesh_size();
        assert!(parse(&h, "0.05").is_ok() && parse(&h, "10").is_ok());
        let e = parse(&h, "1e-6").unwrap_err();
        assert!(e.contains("1e-6") && e.contains("0.05 to 10 mm"), "{e}");
        assert!(parse(&h, "nan").is_err() && parse(&h, "inf").is_err());
        let n = count(1, 100_000);
        assert!(parse(&n, "500").is_ok());
        let e = parse(&n, "1000000000000").unwrap_err();
        assert!(e.contains("1 to 100000"), "{e}");
        assert!(parse(&n, "0").is_err());
    }
}
