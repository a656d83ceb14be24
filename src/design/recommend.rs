//! Which size to recommend: the smallest that meets every criterion
//! (seed 001: neo-leaflets as small as sufficiently possible — larger ones
//! risk covering the coronaries and thrombosis), and why.

/// What the closure of one size gave.
#[derive(Debug, Clone, PartialEq)]
pub struct Measured {
    pub closed: bool,
    pub meets_all: bool,
    /// The closure can be judged (no gate of the verdict stops it).
    pub assessable: bool,
    /// Criteria passed, and how many were judged.
    pub passed: usize,
    pub judged: usize,
    /// The failed criteria in words ("Central coaptation height 3.20 mm, needs > 4 mm").
    pub failures: Vec<String>,
    /// How far the failed criteria measured in millimetres miss their
    /// thresholds, summed (mm): between sizes that fail as many criteria,
    /// the one nearer to passing them.
    pub shortfall_mm: f64,
    pub coaptation_height_mm: Option<f64>,
    pub central_coaptation_height_mm: Option<f64>,
    pub effective_height_mm: Option<f64>,
    /// Largest coaptation area of the three leaflets.
    pub coaptation_area_mm2: Option<f64>,
    /// Mean flat (template) area of the three leaflets.
    pub leaflet_area_mm2: Option<f64>,
    /// Mean free-edge length.
    pub free_edge_length_mm: Option<f64>,
}

/// One size of the sweep: measured, or why it could not be.
#[derive(Debug, Clone, PartialEq)]
pub struct Outcome {
    pub size: u32,
    pub result: Result<Measured, String>,
}

/// The answer of a sweep.
#[derive(Debug, Clone, PartialEq)]
pub struct Recommendation {
    /// The smallest size meeting every criterion, if any.
    pub size: Option<u32>,
    /// The size whose valve the design report shows: the recommended one,
    /// else the one closest to meeting the criteria.
    pub shown: Option<u32>,
    pub reason: String,
}

/// What became of one size, in words ("meets every criterion", "fails …").
pub fn fails(result: &Result<Measured, String>) -> String {
    match result {
        Ok(m) if m.failures.is_empty() => "meets every criterion".to_string(),
        Ok(m) => format!("fails {}", m.failures.join("; ")),
        Err(e) => format!("could not be computed ({e})"),
    }
}

/// Outcomes in ascending size.
pub fn recommend(outcomes: &[Outcome]) -> Recommendation {
    let ok = |o: &Outcome| matches!(&o.result, Ok(m) if m.meets_all);
    if let Some(i) = outcomes.iter().position(ok) {
        let best = &outcomes[i];
        let judged = match &best.result {
            Ok(m) => m.judged,
            Err(_) => 0,
        };
        let mut reason = format!(
            "Size {} is the smallest size tried that meets all {judged} criteria",
            best.size
        );
        match i.checked_sub(1).map(|j| &outcomes[j]) {
            Some(below) => reason.push_str(&format!(
                "; size {} {}.",
                below.size,
                fails(&below.result)
            )),
            None => reason.push_str(
                " — it is the smallest size tried, so a smaller one may do as well: widen the sweep downwards.",
            ),
        }
        // Larger leaflets that fail again (prolapse, no closure) are worth
        // knowing: the margin above the recommendation is not unlimited.
        let above: Vec<String> = outcomes[i + 1..]
            .iter()
            .filter(|o| !ok(o))
            .map(|o| format!("size {} {}", o.size, fails(&o.result)))
            .collect();
        if !above.is_empty() {
            reason.push_str(&format!(
                " Larger sizes are not all safe: {}.",
                above.join("; ")
            ));
        }
        return Recommendation {
            size: Some(best.size),
            shown: Some(best.size),
            reason,
        };
    }
    // Nothing passes: show the closest (most criteria met; then the least
    // shortfall; then the taller central coaptation; then the smaller
    // size). The shortfall decides before the central coaptation: on the
    // real CT every size 19–29 failed the same three criteria, and the
    // tallest central coaptation (29, 3.48 mm) came with its leaflets
    // 10.65 mm above the STJ against 4.36 mm at 19.
    let closest = outcomes
        .iter()
        .filter_map(|o| o.result.as_ref().ok().map(|m| (o, m)))
        .max_by(|(a, ma), (b, mb)| {
            // A size that cannot be judged is never closer than one that can.
            (ma.assessable, ma.passed)
                .cmp(&(mb.assessable, mb.passed))
                .then(mb.shortfall_mm.total_cmp(&ma.shortfall_mm))
                .then(
                    ma.central_coaptation_height_mm
                        .unwrap_or(f64::NEG_INFINITY)
                        .total_cmp(&mb.central_coaptation_height_mm.unwrap_or(f64::NEG_INFINITY)),
                )
                .then(b.size.cmp(&a.size))
        });
    match closest {
        Some((o, m)) => Recommendation {
            size: None,
            shown: Some(o.size),
            reason: format!(
                "No size tried meets every criterion. Closest: size {} ({} of {} criteria; {}).",
                o.size,
                m.passed,
                m.judged,
                fails(&o.result)
            ),
        },
        None => Recommendation {
            size: None,
            shown: None,
            reason: format!(
                "No size could be closed and measured: {}.",
                outcomes
                    .iter()
                    .map(|o| format!("size {} {}", o.size, fails(&o.result)))
                    .collect::<Vec<_>>()
                    .join("; ")
            ),
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn m(passed: usize, central: f64) -> Measured {
        Measured {
            closed: central > 0.0,
            meets_all: passed == 5,
            assessable: true,
            passed,
            judged: 5,
            failures: (passed..5).map(|i| format!("criterion {i}")).collect(),
            shortfall_mm: 0.0,
            coaptation_height_mm: Some(central + 2.0),
            central_coaptation_height_mm: Some(central),
            effective_height_mm: Some(10.0),
            coaptation_area_mm2: Some(50.0),
            leaflet_area_mm2: Some(300.0),
            free_edge_length_mm: Some(30.0),
        }
    }

    fn o(size: u32, r: Result<Measured, String>) -> Outcome {
        Outcome { size, result: r }
    }

    #[test]
    fn smallest_passing_size_with_the_failure_below_it() {
        let r = recommend(&[
            o(17, Ok(m(3, 1.0))),
            o(19, Ok(m(4, 3.0))),
            o(21, Ok(m(5, 5.0))),
            o(23, Ok(m(5, 6.0))),
            o(25, Err("did not converge".into())),
        ]);
        assert_eq!((r.size, r.shown), (Some(21), Some(21)));
        assert!(
            r.reason.contains("size 19 fails criterion 4"),
            "{}",
            r.reason
        );
        assert!(
            r.reason
                .contains("size 25 could not be computed (did not converge)"),
            "{}",
            r.reason
        );
    }

    #[test]
    fn passing_at_the_bottom_of_the_sweep_says_to_look_lower() {
        let r = recommend(&[o(19, Ok(m(5, 5.0))), o(21, Ok(m(5, 6.0)))]);
        assert_eq!(r.size, Some(19));
        assert!(
            r.reason.contains("widen the sweep downwards"),
            "{}",
            r.reason
        );
        assert!(!r.reason.contains("Larger sizes"), "{}", r.reason);
    }

    #[test]
    fn none_passing_shows_the_closest() {
        let r = recommend(&[
            o(19, Ok(m(3, 2.0))),
            o(21, Ok(m(4, 3.0))),
            o(23, Ok(m(4, 3.5))),
            o(25, Ok(m(2, 0.0))),
        ]);
        assert_eq!((r.size, r.shown), (None, Some(23)));
        assert!(r.reason.starts_with("No size tried meets"), "{}", r.reason);
        // A size that cannot be judged (its free edges too short to meet,
        // say) is not the closest, however many criteria it would pass.
        let mut short = m(4, 5.0);
        short.assessable = false;
        let r = recommend(&[o(17, Ok(short)), o(19, Ok(m(3, 2.0)))]);
        assert_eq!(r.shown, Some(19), "{}", r.reason);
        // As many failed, the size nearer to passing them is closer, even
        // with the shorter central coaptation (the real CT's sweep: 19
        // missed by 10.1 mm in all, 29 by 17.8 mm).
        let near = Measured {
            shortfall_mm: 10.1,
            ..m(3, 0.4)
        };
        let far = Measured {
            shortfall_mm: 17.8,
            ..m(3, 3.5)
        };
        let r = recommend(&[o(19, Ok(near)), o(29, Ok(far))]);
        assert_eq!(r.shown, Some(19), "{}", r.reason);
        let r = recommend(&[o(19, Err("a".into())), o(21, Err("b".into()))]);
        assert_eq!((r.size, r.shown), (None, None));
        assert!(
            r.reason.contains("size 21 could not be computed (b)"),
            "{}",
            r.reason
        );
    }
}
