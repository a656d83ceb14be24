//! `coapt bench stress-close`: a few coarse cases, their CSV, and the
//! running count on stderr that a run stopped part-way leaves behind.

use crate::common::*;

/// Coarse cases of seed 7 on one thread, with `which` (`--cases` or
/// `--only`) and a CSV.
fn stress(which: &[&str], csv: &std::path::Path) -> std::process::Output {
    let mut a = vec!["bench", "stress-close", "--seed", "7", "--h-min", "2.5"];
    a.extend(["--h-max", "3", "--time-limit", "30", "--threads", "1"]);
    a.extend(which);
    let csv = s(csv);
    a.extend(["--csv", csv.as_str()]);
    coapt(&a)
}

#[test]
fn stress_close_reports_each_case_as_it_finishes_and_counts_them() {
    let dir = tmpdir("stress-close");
    let csv = dir.join("stress.csv");
    let o = stress(&["--cases", "3"], &csv);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let err = stderr(&o);
    let progress: Vec<&str> = err.lines().filter(|l| l.starts_with("case ")).collect();
    assert_eq!(progress.len(), 3, "{err}");
    // The running total counts up to the whole run, one case per line.
    for (k, l) in progress.iter().enumerate() {
        assert!(l.contains(&format!("| {}/3 done:", k + 1)), "{l}");
    }
    let text = std::fs::read_to_string(&csv).unwrap();
    let rows: Vec<&str> = text.lines().skip(1).collect();
    assert_eq!(rows.len(), 3);
    for (i, r) in rows.iter().enumerate() {
        assert!(r.starts_with(&format!("{i},")), "{r}");
    }
    // The last progress line and the summary agree with the CSV's verdicts.
    let converged = rows.iter().filter(|r| r.contains(",converged,")).count();
    let failed = rows.iter().filter(|r| r.contains(",failed,")).count();
    assert_eq!(converged + failed, 3, "{text}");
    assert!(
        progress[2].ends_with(&format!(
            "{converged} converged, {failed} failed, 0 non-finite, 0 hang"
        )),
        "{}",
        progress[2]
    );
    // `--only` replays one case of the sequence: the same row but the time.
    let one = dir.join("one.csv");
    let o2 = stress(&["--only", "2", "--quiet"], &one);
    assert_eq!(o2.status.code(), Some(0), "{}", stderr(&o2));
    // --quiet keeps the running count off stderr.
    assert!(!stderr(&o2).contains("done:"), "{}", stderr(&o2));
    let replayed = std::fs::read_to_string(&one).unwrap();
    let without_time = |r: &str| {
        let c: Vec<&str> = r.split(',').collect();
        [&c[..14], &c[15..]].concat().join(",")
    };
    assert_eq!(
        without_time(replayed.lines().nth(1).unwrap()),
        without_time(rows[2])
    );
    let table = String::from_utf8_lossy(&o.stdout);
    assert!(
        table.starts_with(&format!("3 cases: {converged} converged, {failed} failed")),
        "{table}"
    );
}

/// `--explain` closes a failed case again at fractions of its pressure.
/// Plausible case 25 of seed 1 (linear springs, E 0.32 MPa, t 0.29 mm,
/// h 1.45 mm) fails at 100.5 mmHg: its path from rest softens towards a
/// limit load below that, which the ladder must find between the highest
/// pressure that converged and the case's own.
#[test]
fn explain_finds_the_limit_load_of_a_ballooning_case() {
    let o = coapt(&[
        "bench",
        "stress-close",
        "--plausible",
        "--h-max",
        "2",
        "--only",
        "25",
        "--explain",
        "--threads",
        "1",
        "--quiet",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    let line = out
        .lines()
        .find(|l| l.trim_start().starts_with("case   25 at 100.5 mmHg"))
        .unwrap_or_else(|| panic!("{out}"));
    let number_after = |key: &str| -> f64 {
        let rest = &line[line.find(key).unwrap_or_else(|| panic!("{line}")) + key.len()..];
        rest.split_whitespace().next().unwrap().parse().unwrap()
    };
    let top = number_after("up to ");
    let limit = number_after("limit load of about ");
    assert!(line.contains("no equilibrium"), "{line}");
    assert!(top > 60.0 && top < limit && limit < 100.5, "{line}");
    assert!(
        out.contains("1 failed case(s) lie beyond their limit load"),
        "{out}"
    );
}
