//! How the closure solver converged: residual and largest nodal force per
//! iteration on a log axis, against the tolerance.

use super::xy_chart::{Series, XyChart, xy_chart};
use crate::Figure;

/// `history`: (iteration, residual N); `max_force`: (iteration, largest
/// nodal force N). Values ≤ 0 or not finite cannot sit on a log axis and
/// are left out; with nothing left the figure says so. `solver`: the
/// solver's own final residual (N) and verdict, when it recorded them: the
/// history's last entry is the residual before the last step, and the
/// solver's test may be relative to the initial residual, so only the
/// solver can say whether it converged. `reason`: the solver's stop
/// reason, whose last phase says which test was met when a converged
/// residual still lies above the drawn tolerance (the relative or the step
/// test).
pub fn convergence(
    history: &[(usize, f64)],
    max_force: &[(usize, f64)],
    tolerance_n: Option<f64>,
    solver: Option<(f64, bool)>,
    reason: Option<&str>,
) -> Figure {
    let mut c = XyChart::new(
        "convergence",
        "Closure solver convergence",
        "iteration (all solver phases)",
        "force (N, log scale)",
    );
    c.log_y = true;
    let pts = running;
    if !history.is_empty() {
        c.series.push(Series::new("residual ‖R‖₂", pts(history)));
    }
    if !max_force.is_empty() {
        c.series
            .push(Series::new("largest nodal force", pts(max_force)));
    }
    let tol = tolerance_n.filter(|t| t.is_finite() && *t > 0.0);
    if let Some(t) = tol {
        c.hlines.push((format!("tolerance {t:.3e} N"), t, None));
    }
    let all = running(history);
    let last = all
        .iter()
        .rev()
        .find(|(_, r)| r.is_finite())
        .map(|&(i, r)| (i as usize, r));
    const WHAT: &str = "Residual ‖R‖₂ (N, all free-node forces) and largest nodal force of the closure solver per iteration, log scale";
    c.caption = match (last, tol) {
        (Some((i, _)), Some(t)) if solver.is_some() => {
            let (r, ok) = solver.unwrap();
            let verdict = match (ok, r <= t) {
                (true, true) => "converged (below the tolerance)".to_string(),
                // The plot shows the residual ending above the line: say
                // which of the solver's other tests stopped it.
                (true, false) => format!(
                    "converged by another of the solver's tests than the dashed line{}",
                    reason
                        .and_then(last_phase)
                        .map_or(String::new(), |p| format!(": {p}"))
                ),
                (false, _) => "not converged".to_string(),
            };
            format!(
                "{WHAT}; dashed red line: the absolute tolerance ({t:.3e} N). Final residual {r:.3e} N after {i} iterations: {verdict}."
            )
        }
        (Some((i, r)), Some(t)) => format!(
            "{WHAT}; dashed red line: the absolute tolerance ({t:.3e} N). Last residual {r:.3e} N after {i} iterations: {}.",
            if r <= t {
                "below the tolerance"
            } else {
                "above the tolerance"
            }
        ),
        (Some((i, r)), None) => {
            format!("{WHAT}. Last residual {r:.3e} N after {i} iterations.")
        }
        _ => format!("{WHAT}."),
    };
    let mut fig = xy_chart(&c);
    if history.is_empty() && max_force.is_empty() {
        fig.caption = "Not drawn: the solver recorded no iterations.".to_string();
    }
    fig
}

/// The last solver phase of a stop reason ("round 1: continuation: …;
/// Newton: Newton's correction … (the step criterion …)" → "Newton's
/// correction … (the step criterion …)").
fn last_phase(reason: &str) -> Option<&str> {
    let last = reason.rsplit("; ").next()?.trim();
    let body = last
        .split_once(": ")
        .map_or(
            last,
            |(phase, rest)| {
                if phase.len() < 16 { rest } else { last }
            },
        )
        .trim_end_matches('.');
    (!body.is_empty()).then_some(body)
}

/// Iterations counted on across solver phases: a phase whose numbering
/// starts again (continuation steps, then Newton) continues the x axis
/// instead of folding back over the previous one.
fn running(s: &[(usize, f64)]) -> Vec<(f64, f64)> {
    let mut offset = 0usize;
    let mut prev: Option<usize> = None;
    s.iter()
        .map(|&(i, v)| {
            if let Some(p) = prev
                && i <= p
            {
                offset += p;
            }
            prev = Some(i);
            ((offset + i) as f64, v)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::super::test_valve::{count, decode};
    use super::*;

    #[test]
    fn residual_and_tolerance_are_drawn_and_captioned() {
        let h: Vec<(usize, f64)> = (0..30).map(|i| (i, 10f64.powf(-0.2 * i as f64))).collect();
        let m: Vec<(usize, f64)> = h.iter().map(|&(i, r)| (i, 0.3 * r)).collect();
        let f = convergence(&h, &m, Some(1e-7), None, None);
        assert!(f.caption.contains("above the tolerance"), "{}", f.caption);
        // The solver's own verdict wins over the history's last entry
        // (recorded before the last step).
        let f3 = convergence(&h, &m, Some(1e-7), Some((3.4e-9, true)), None);
        assert!(
            f3.caption.contains("3.400e-9 N")
                && f3.caption.contains(": converged (below the tolerance)."),
            "{}",
            f3.caption
        );
        let img = decode(&f.png);
        assert!(count(&img, [0, 114, 178]) > 200);
        assert!(count(&img, [213, 94, 0]) > 200);
        assert!(count(&img, [200, 30, 40]) > 100);
        let f2 = convergence(&h[..25], &[], Some(1e-4), None, None);
        assert!(f2.caption.contains("below the tolerance"));
    }

    /// A closure converged by the step test ends above the drawn
    /// tolerance: the caption says so and names the test, so the plot, the
    /// caption and the solver table agree.
    #[test]
    fn a_converged_residual_above_the_line_names_its_test() {
        let h: Vec<(usize, f64)> = (0..20).map(|i| (i, 10f64.powf(-0.25 * i as f64))).collect();
        let reason = "round 1: continuation: residual 7.952e-4 N ≤ max(1.0e-7 N, 1.0e-2 × initial); Newton: Newton's correction 8.3e-8 mm ≤ 1.0e-4 mm at residual 6.170e-6 N (the step criterion: the line search could no longer lower the residual)";
        let f = convergence(&h, &[], Some(1e-7), Some((6.17e-6, true)), Some(reason));
        assert!(
            f.caption.ends_with(
                "converged by another of the solver's tests than the dashed line: Newton's correction 8.3e-8 mm ≤ 1.0e-4 mm at residual 6.170e-6 N (the step criterion: the line search could no longer lower the residual)."
            ),
            "{}",
            f.caption
        );
        assert_eq!(last_phase("Newton: converged"), Some("converged"));
        assert_eq!(last_phase(""), None);
    }

    #[test]
    fn restarted_numbering_continues_the_axis() {
        let x: Vec<f64> = running(&[(1, 1.0), (2, 1.0), (3, 1.0), (1, 1.0), (2, 1.0)])
            .iter()
            .map(|p| p.0)
            .collect();
        assert_eq!(x, vec![1.0, 2.0, 3.0, 4.0, 5.0]);
    }

    #[test]
    fn empty_and_non_positive_histories_do_not_panic() {
        assert!(
            convergence(&[], &[], None, None, None)
                .caption
                .starts_with("Not drawn")
        );
        let f = convergence(
            &[(0, 0.0), (1, -1.0), (2, f64::NAN)],
            &[],
            Some(f64::NAN),
            None,
            None,
        );
        assert!(f.caption.starts_with("Not drawn"));
        let f = convergence(&[(0, 1.0)], &[], Some(0.0), None, None);
        assert!(!f.caption.starts_with("Not drawn"));
    }
}
