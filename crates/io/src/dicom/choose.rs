//! Which series of a folder to read: the one `--series` names, the only
//! one, or — among several — the only one that can be the CT angiogram.
//! A study folder commonly holds the CTA beside a localiser, a dose report
//! or a few reformatted images; those are told apart from the header alone.
//! Two plausible CTA series (an arterial and a delayed phase, or two
//! reconstructions) are never guessed between.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use super::scan::Series;
use coapt_base::{Error, Result};

/// Fewer slices than this cannot cover an aortic root at CTA resolution
/// (20 slices of 1 mm is 2 cm, less than the root's height): reformats,
/// key images, a handful of slices from a bolus-tracking scan.
const MIN_CTA_SLICES: usize = 20;

/// How the series was chosen, for the log and the manifest.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Chosen {
    /// The folder (or file) holds one series.
    Only,
    /// `--series` (or the run config's `series`) named it.
    Picked(String),
    /// The only plausible CTA; the others, each with why it is not.
    OnlyPlausible(Vec<(String, String)>),
}

impl Chosen {
    pub fn describe(&self) -> String {
        match self {
            Chosen::Only => "the only series".into(),
            Chosen::Picked(p) => format!("chosen with series {p}"),
            Chosen::OnlyPlausible(others) => format!(
                "the only plausible CTA series; not read: {}",
                others
                    .iter()
                    .map(|(label, why)| format!("{label} ({why})"))
                    .collect::<Vec<_>>()
                    .join("; ")
            ),
        }
    }
}

/// Why `s` cannot be the CT angiogram, if it cannot.
pub fn implausible(s: &Series) -> Option<String> {
    let sop = s.sop_class.as_str();
    if s.localiser {
        Some("a localiser (scout)".into())
    } else if s.modality != "CT" {
        Some(format!("modality {:?}, not CT", s.modality))
    } else if sop.starts_with("1.2.840.10008.5.1.4.1.1.7") {
        Some("a secondary capture".into())
    } else if sop.starts_with("1.2.840.10008.5.1.4.1.1.88.") {
        Some("a structured report (dose report)".into())
    } else if s.without_pixels {
        Some("images without pixel data".into())
    } else if s.slices.len() < MIN_CTA_SLICES {
        Some(format!(
            "{} readable slice{}, fewer than {MIN_CTA_SLICES}",
            s.slices.len(),
            if s.slices.len() == 1 { "" } else { "s" }
        ))
    } else {
        None
    }
}

/// Number, UID, description, slices and spacing: what a user needs to pick.
fn listing(s: &Series) -> String {
    let spacing = match super::geometry::grid(&s.slices) {
        Ok((_, a)) => format!(
            "{:.3} × {:.3} × {:.3} mm",
            a.fixed_view::<3, 1>(0, 0).norm(),
            a.fixed_view::<3, 1>(0, 1).norm(),
            a.fixed_view::<3, 1>(0, 2).norm()
        ),
        Err(_) => "not one regular grid".into(),
    };
    format!(
        "number {}, UID {}, \"{}\", {} slices, spacing {spacing}",
        s.number.map_or("-".to_string(), |n| n.to_string()),
        s.uid,
        s.description,
        s.slices.len()
    )
}

/// The series `pick` names (its UID or its SeriesNumber), the only one, or
/// the only plausible CTA among several; and how it was chosen.
pub fn choose<'a>(
    dir: &Path,
    series: &'a [Series],
    pick: Option<&str>,
) -> Result<(&'a Series, Chosen)> {
    let list = || {
        series
            .iter()
            .map(|s| s.label())
            .collect::<Vec<_>>()
            .join("; ")
    };
    let Some(p) = pick else {
        if series.len() == 1 {
            return Ok((&series[0], Chosen::Only));
        }
        let (plausible, not): (Vec<&Series>, Vec<&Series>) =
            series.iter().partition(|s| implausible(s).is_none());
        return match plausible.as_slice() {
            [one] => {
                let others = not
                    .iter()
                    .map(|s| (s.label(), implausible(s).unwrap_or_default()))
                    .collect();
                let chosen = Chosen::OnlyPlausible(others);
                // Every reader of the folder (check, hashing, the stage)
                // comes here: say it once per folder.
                static SAID: Mutex<BTreeSet<PathBuf>> = Mutex::new(BTreeSet::new());
                let first = SAID
                    .lock()
                    .map(|mut said| said.insert(dir.to_path_buf()))
                    .unwrap_or(true);
                if first {
                    tracing::info!(
                        event = "dicom_series_chosen",
                        uid = one.uid.as_str(),
                        "{}: reading series {} — {}",
                        dir.display(),
                        one.label(),
                        chosen.describe()
                    );
                }
                Ok((one, chosen))
            }
            [] => Err(Error::bad_input(
                dir,
                format!(
                    "holds {} series; choose one with --series UID|NUMBER ({})",
                    series.len(),
                    list()
                ),
            )),
            several => Err(Error::bad_input(
                dir,
                format!(
                    "holds {} series that could each be the CT angiogram, and coapt does not \
                     guess between them: {}; choose one with --series UID|NUMBER (in a run \
                     config: series = \"NUMBER\" under [run])",
                    several.len(),
                    several
                        .iter()
                        .map(|s| listing(s))
                        .collect::<Vec<_>>()
                        .join("; ")
                ),
            )),
        };
    };
    let hits: Vec<&Series> = series
        .iter()
        .filter(|s| s.uid == p || s.number.is_some_and(|n| p.parse() == Ok(n)))
        .collect();
    match hits.as_slice() {
        [one] => Ok((one, Chosen::Picked(p.to_string()))),
        [] => Err(Error::bad_input(
            dir,
            format!("has no series {p}; it holds: {}", list()),
        )),
        _ => Err(Error::bad_input(
            dir,
            format!(
                "several series have the number {p}; choose by UID ({})",
                list()
            ),
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dicom::Slice;

    /// A series of `n` axial 1 mm slices.
    fn series(uid: &str, number: i64, n: usize) -> Series {
        Series {
            uid: uid.into(),
            number: Some(number),
            description: format!("series {number}"),
            modality: "CT".into(),
            localiser: false,
            sop_class: "1.2.840.10008.5.1.4.1.1.2".into(),
            without_pixels: false,
            files: n,
            transfer_syntax: "1.2.840.10008.1.2.1".into(),
            slices: (0..n)
                .map(|k| Slice {
                    path: PathBuf::from(format!("{uid}-{k}")),
                    frame: None,
                    position: [0.0, 0.0, k as f64],
                    orientation: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0],
                    pixel_spacing: [0.5, 0.5],
                    rows: 4,
                    columns: 4,
                    slope: 1.0,
                    intercept: 0.0,
                })
                .collect(),
            problems: Vec::new(),
        }
    }

    #[test]
    fn what_cannot_be_the_cta_is_set_aside_and_two_ctas_are_not_guessed_between() {
        let cta = series("1.1", 3, 40);
        assert_eq!(implausible(&cta), None);
        let mut scout = series("1.2", 1, 40);
        scout.localiser = true;
        let mut mr = series("1.3", 2, 40);
        mr.modality = "MR".into();
        let mut sc = series("1.4", 4, 40);
        sc.sop_class = "1.2.840.10008.5.1.4.1.1.7".into();
        let mut sr = series("1.5", 5, 40);
        sr.sop_class = "1.2.840.10008.5.1.4.1.1.88.67".into();
        let mut empty = series("1.6", 6, 40);
        empty.without_pixels = true;
        let few = series("1.7", 7, 19);
        for (s, why) in [
            (&scout, "localiser"),
            (&mr, "not CT"),
            (&sc, "secondary capture"),
            (&sr, "dose report"),
            (&empty, "without pixel data"),
            (&few, "19 readable slices"),
        ] {
            let got = implausible(s).unwrap_or_default();
            assert!(got.contains(why), "{}: {got}", s.uid);
        }
        let dir = Path::new("study");
        let all = vec![scout.clone(), mr, cta.clone(), sc, sr, empty, few.clone()];
        let (s, how) = choose(dir, &all, None).unwrap();
        assert_eq!(s.uid, "1.1");
        let Chosen::OnlyPlausible(others) = &how else {
            panic!("{how:?}");
        };
        assert_eq!(others.len(), 6);
        // Two plausible: refused, both listed with slices and spacing.
        let late = series("1.8", 8, 40);
        let e = choose(dir, &[cta.clone(), late, few], None)
            .err()
            .unwrap()
            .to_string();
        for w in [
            "1.1",
            "1.8",
            "40 slices",
            "0.500 × 0.500 × 1.000 mm",
            "--series",
        ] {
            assert!(e.contains(w), "{w}: {e}");
        }
        assert!(!e.contains("1.7"), "{e}");
        // None plausible: the old refusal, listing every series.
        let e = choose(dir, &[scout, series("1.9", 9, 3)], None)
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains("holds 2 series") && e.contains("1.9"), "{e}");
        // A pick wins over plausibility.
        let (s, how) = choose(dir, &all, Some("7")).unwrap();
        assert_eq!((s.uid.as_str(), how), ("1.7", Chosen::Picked("7".into())));
    }
}
