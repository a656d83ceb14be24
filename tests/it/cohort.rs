//! `coapt cohort summary`: one CSV row per run directory, its numbers those
//! of the run's own artifacts; runs that stopped early are rows that say so;
//! bad runs are refused before anything is written.

use crate::common::*;

fn csv_rows(text: &str) -> Vec<Vec<String>> {
    // Minimal RFC 4180 reader: quoted fields may hold commas and "".
    let mut rows = Vec::new();
    for line in text.lines() {
        let (mut row, mut cur, mut quoted, mut chars) =
            (Vec::new(), String::new(), false, line.chars().peekable());
        while let Some(c) = chars.next() {
            match (c, quoted) {
                ('"', true) if chars.peek() == Some(&'"') => {
                    cur.push('"');
                    chars.next();
                }
                ('"', _) => quoted = !quoted,
                (',', false) => row.push(std::mem::take(&mut cur)),
                _ => cur.push(c),
            }
        }
        row.push(cur);
        rows.push(row);
    }
    rows
}

#[test]
fn one_row_per_run_with_the_runs_own_numbers() {
    let d = tmpdir("cohort");
    let data = repo().join("sample_data");
    std::fs::create_dir_all(d.join("sample")).unwrap();
    let run = run_default_chain(
        &d.join("sample"),
        &[
            ("ct", &data.join("ct.nii.gz")),
            ("landmarks", &data.join("landmarks.mrk.json")),
        ],
        "",
    );
    let stopped = d.join("stopped");
    std::fs::create_dir_all(&stopped).unwrap();
    let out = d.join("cohort.csv");
    let o = coapt(&[
        "cohort",
        "summary",
        &s(&run),
        &s(&stopped),
        "--out",
        &s(&out),
        "--quiet",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let rows = csv_rows(&std::fs::read_to_string(&out).unwrap());
    assert_eq!(rows.len(), 3);
    assert_eq!(rows[0], coapt::report::cohort_summary::COLUMNS);
    let col =
        |r: &Vec<String>, name: &str| r[rows[0].iter().position(|c| c == name).unwrap()].clone();
    let rep = json(&run.join("report.json"));
    let log = json(&run.join("closure.json"));
    let r = &rows[1];
    assert_eq!(col(r, "case"), "sample/run");
    assert_eq!(col(r, "status"), rep["verdict"]["status"].as_str().unwrap());
    assert_eq!(
        col(r, "summary"),
        rep["verdict"]["summary"].as_str().unwrap()
    );
    let crit = rep["criteria"].as_array().unwrap();
    let met = crit.iter().filter(|c| c["pass"] == true).count();
    assert_eq!(col(r, "criteria_met"), format!("{met}/{}", crit.len()));
    let eh: f64 = col(r, "effective_height_mm").parse().unwrap();
    assert!((eh - rep["metrics"]["effective_height_mm"].as_f64().unwrap()).abs() <= 5e-4);
    assert_eq!(
        col(r, "crossing_pairs"),
        log["intersecting_triangle_pairs"]
            .as_u64()
            .unwrap()
            .to_string()
    );
    assert_eq!(col(r, "templates").split(';').count(), 3);
    assert_eq!(col(r, "intercommissural_mm").split(';').count(), 3);
    assert_eq!(col(&rows[2], "case"), "stopped");
    assert_eq!(col(&rows[2], "status"), "no_report");

    // A directory that is not there, or a report.json that is not JSON: exit
    // 2 naming it, and the old table stays as it was.
    let before = std::fs::read(&out).unwrap();
    let o = coapt(&["cohort", "summary", &s(&d.join("nope")), "--out", &s(&out)]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("nope") && stderr(&o).contains("not a run directory"));
    std::fs::write(stopped.join("report.json"), b"{ not json").unwrap();
    let o = coapt(&[
        "cohort",
        "summary",
        &s(&run),
        &s(&stopped),
        "--out",
        &s(&out),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("report.json") && stderr(&o).contains("not valid JSON"));
    assert_eq!(std::fs::read(&out).unwrap(), before);
}
