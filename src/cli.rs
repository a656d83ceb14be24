//! The `coapt` command line: a thin layer over the library. Stage
//! subcommands are generated from the stages' declarations.

use std::ffi::OsString;
use std::path::PathBuf;

use clap::{Arg, ArgAction, ArgMatches, Command};

use crate::pipeline::execute::Invocation;
use crate::pipeline::{
    self, ArtifactKind, LogMode, Param, ParamKind, Params, StageIo, StageSpec, params, provenance,
    runner,
};
use crate::{Error, Result, bench, design, inspect, stages};

/// Run the CLI with the process's arguments; returns the exit code.
pub fn main() -> i32 {
    run_with(std::env::args_os().collect())
}

/// Run the CLI with explicit arguments; returns the exit code
/// (0 success, 1 a computation failed, 2 bad input or usage).
pub fn run_with(args: Vec<OsString>) -> i32 {
    let matches = match command().try_get_matches_from(&args) {
        Ok(m) => m,
        Err(e) => {
            let _ = e.print();
            return match e.kind() {
                clap::error::ErrorKind::DisplayHelp
                | clap::error::ErrorKind::DisplayVersion
                | clap::error::ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand => 0,
                _ => 2,
            };
        }
    };
    match dispatch(&matches, &args) {
        Ok(()) => 0,
        Err(e) => {
            eprintln!("error: {}", render(&e));
            e.exit_code()
        }
    }
}

/// The error and its causes on one line, without repeating a cause the
/// message already contains.
fn render(e: &Error) -> String {
    let mut text = e.to_string();
    let mut source = std::error::Error::source(e);
    while let Some(s) = source {
        let part = s.to_string();
        if !text.contains(&part) {
            text.push_str(": ");
            text.push_str(&part);
        }
        source = s.source();
    }
    text.replace('\n', " ")
}

fn command() -> Command {
    let mut cmd = Command::new("coapt")
        .version(provenance::version_line())
        .about("From a contrast CT angiogram to the predicted closure of an Ozaki-reconstructed aortic valve")
        .subcommand_required(true)
        .arg_required_else_help(true)
        .arg(
            Arg::new("threads")
                .long("threads")
                .global(true)
                .value_name("N")
                .value_parser(clap::value_parser!(usize))
                .help("worker threads (default: all cores); outputs do not depend on it"),
        )
        .arg(
            Arg::new("series")
                .long("series")
                .global(true)
                .value_name("UID|NUMBER")
                .help("the DICOM series to read when a CT folder holds several (its SeriesInstanceUID or SeriesNumber; `coapt info DIR` lists them)"),
        )
        .arg(
            Arg::new("quiet")
                .long("quiet")
                .short('q')
                .global(true)
                .action(ArgAction::SetTrue)
                .help("only warnings and errors; no progress bars"),
        )
        .arg(
            Arg::new("log-json")
                .long("log-json")
                .global(true)
                .action(ArgAction::SetTrue)
                .help("log one JSON event per line on stderr (for schedulers)"),
        )
        .subcommand(
            Command::new("run")
                .about("Run the chain a run config describes, skipping stages whose inputs, parameters and version are unchanged")
                .arg(Arg::new("config").required(true).value_name("CONFIG.toml").value_parser(clap::value_parser!(PathBuf)))
                .arg(
                    Arg::new("out")
                        .long("out")
                        .value_name("DIR")
                        .value_parser(clap::value_parser!(PathBuf))
                        .help("run directory (default: the config's [run] dir)"),
                )
                .arg(Arg::new("from").long("from").value_name("STAGE").help("start at this stage, reusing upstream outputs"))
                .arg(Arg::new("until").long("until").value_name("STAGE").help("stop after this stage"))
                .arg(Arg::new("force").long("force").action(ArgAction::SetTrue).help("run every selected stage even if unchanged")),
        );
    cmd = cmd.subcommand(
        Command::new("design")
            .about("Leaflet sizing: close the patient's valve with each Ozaki sizer size on the same suture paths and recommend the smallest that meets every criterion")
            .arg(Arg::new("config").required(true).value_name("CONFIG.toml").value_parser(clap::value_parser!(PathBuf)))
            .arg(
                Arg::new("out")
                    .long("out")
                    .value_name("DIR")
                    .value_parser(clap::value_parser!(PathBuf))
                    .help("run directory (default: the config's [run] dir); the sweep goes to DIR/design"),
            )
            .arg(
                Arg::new("sizes")
                    .long("sizes")
                    .value_name("LIST")
                    .help("sizer sizes, e.g. 19,21,23 or 17-27 [default: the config's [design] sizes, else 13-35]"),
            )
            .arg(Arg::new("force").long("force").action(ArgAction::SetTrue).help("re-run every stage even if unchanged")),
    );
    for spec in stages::registry() {
        cmd = cmd.subcommand(stage_command(spec));
    }
    cmd.subcommand(
        Command::new("info")
            .about("Describe a coapt artifact: volume (NIfTI, NRRD, MetaImage; a DICOM folder: its series), .vtp mesh or polylines, landmarks")
            .arg(Arg::new("file").required(true).value_name("FILE").value_parser(clap::value_parser!(PathBuf)))
            .arg(Arg::new("json").long("json").action(ArgAction::SetTrue).help("print JSON instead of text")),
    )
    .subcommand(
        Command::new("cohort")
            .about("Cohort tables: `coapt cohort summary RUN… --out cohort.csv`, one row per run directory")
            .subcommand_required(true)
            .arg_required_else_help(true)
            .subcommand(
                Command::new("summary")
                    .about("One CSV row per run directory: verdict, criteria met and failed, key metrics, solver, templates, root, recommended size; a run without report.json is a row saying so")
                    .arg(Arg::new("runs").required(true).num_args(1..).value_name("RUN_DIR").value_parser(clap::value_parser!(PathBuf)))
                    .arg(Arg::new("out").long("out").required(true).value_name("FILE").value_parser(clap::value_parser!(PathBuf)).help("the CSV to write (atomically)")),
            ),
    )
    .subcommand(
        Command::new("check")
            .about("Check input files as `coapt run` would before starting: readable, valid, complete (landmarks need some of C1–C3, N1–N3; `coapt run` finds the rest)")
            .arg_required_else_help(true)
            .args(CHECKS.iter().map(|(flag, kind)| {
                Arg::new(*flag)
                    .long(*flag)
                    .value_name("PATH")
                    .action(ArgAction::Append)
                    .value_parser(clap::value_parser!(PathBuf))
                    .help(kind.describe())
            })),
    )
    .subcommand(
        Command::new("convert")
            .about("Convert between formats: volume (.nii/.nii.gz/.nrrd/.nhdr/.mha/.mhd, DICOM series folder) → .nii/.nii.gz/.nrrd; .vtp → .vtp/.stl/.ply; landmarks → .mrk.json/.fcsv/.json")
            .arg(Arg::new("input").required(true).value_name("IN").value_parser(clap::value_parser!(PathBuf)))
            .arg(Arg::new("output").required(true).value_name("OUT").value_parser(clap::value_parser!(PathBuf)))
            .arg(
                Arg::new("frame")
                    .long("frame")
                    .value_name("LPS|RAS")
                    .default_value("LPS")
                    .help("coordinate system written into landmark files"),
            ),
    )
    .subcommand(
        Command::new("bench")
            .about("Benchmarks: time and peak memory, measured in child processes")
            .subcommand_required(true)
            .subcommand(
                Command::new("phantom")
                    .about("Phantom generation time and peak memory per preset")
                    .arg(
                        Arg::new("presets")
                            .long("presets")
                            .value_name("LIST")
                            .default_value("sample,standard,full")
                            .help("comma-separated presets"),
                    )
                    .arg(
                        Arg::new("repeat")
                            .long("repeat")
                            .value_name("N")
                            .default_value("1")
                            .value_parser(clap::value_parser!(u32).range(1..=20)),
                    ),
            )
            .subcommand(bench::surface::command())
            .subcommand(bench::close::command())
            .subcommand(bench::pipeline::command())
            .subcommand(bench::seed001::command())
            .subcommand(bench::marom::command())
            .subcommand(
                Command::new("stress-close")
                    .about("The closure solver on randomised hostile variants of the peer case: counts converged / failed with a diagnosis / non-finite / hang")
                    .arg(Arg::new("cases").long("cases").value_name("N").default_value("500").value_parser(bench::bounded::count(1, 100_000)))
                    .arg(Arg::new("seed").long("seed").value_name("N").default_value("1").value_parser(clap::value_parser!(u64)))
                    .arg(Arg::new("h-min").long("h-min").value_name("MM").default_value("0.25").value_parser(bench::bounded::mesh_size()))
                    .arg(Arg::new("h-max").long("h-max").value_name("MM").default_value("3").value_parser(bench::bounded::mesh_size()))
                    .arg(Arg::new("time-limit").long("time-limit").value_name("S").default_value("600").value_parser(bench::bounded::time_limit()).help("the solver's own limit per case (the close stage's default); twice that plus 10 s counts as a hang"))
                    .arg(Arg::new("csv").long("csv").value_name("FILE").value_parser(clap::value_parser!(PathBuf)).help("one row per case"))
                    .arg(Arg::new("only").long("only").value_name("I,J,…").value_delimiter(',').value_parser(bench::bounded::count(0, 1_000_000)).help("replay these cases of the seed's sequence (0-based indices, as in the CSV) instead of 0..N"))
                    .arg(Arg::new("plausible").long("plausible").action(clap::ArgAction::SetTrue).help("draw only from the plausible range: E 0.3–10 MPa, 40–120 mmHg, 0.2–0.8 mm, jittered but unsqueezed meshes (use with --h-max 2)"))
                    .arg(Arg::new("explain").long("explain").action(clap::ArgAction::SetTrue).help("close each failed case again at fractions of its pressure (3–11 closures each) and say whether it lies beyond its limit load or the solver missed an equilibrium")),
            )
            .subcommand(
                Command::new("segment")
                    .about("Segmentation accuracy against the phantom truth and seconds per step")
                    .arg(
                        Arg::new("cases")
                            .long("cases")
                            .value_name("SET")
                            .default_value("quick")
                            .help("quick: sample variations; grid: plus spacings and the full preset; factorial: tilt × noise × spacing × calcium × coronaries on the sample, a fraction on the full preset"),
                    )
                    .arg(Arg::new("csv").long("csv").value_name("FILE").value_parser(clap::value_parser!(PathBuf)).help("one row per case"))
                    .arg(
                        Arg::new("baseline")
                            .long("baseline")
                            .value_name("CMD")
                            .help("run this SimpleITK baseline (tools/segment_baseline.py) on each case"),
                    ),
            ),
    )
}

/// `coapt check` flags and the kind of file each expects.
const CHECKS: [(&str, ArtifactKind); 5] = [
    ("ct", ArtifactKind::Volume),
    ("mask", ArtifactKind::Mask),
    ("landmarks", ArtifactKind::Landmarks),
    ("surface", ArtifactKind::Mesh),
    ("paths", ArtifactKind::Polylines),
];

/// The flag of a parameter: `noise` → `--noise`; booleans become switches
/// that flip their default (`--no-contrast`, `--calcium`).
fn param_flag(p: &Param) -> String {
    let base = p.name.replace('_', "-");
    match (p.kind, p.default) {
        (ParamKind::Bool, Some("true")) => format!("no-{base}"),
        _ => base,
    }
}

fn stage_command(spec: &'static StageSpec) -> Command {
    let mut cmd = Command::new(spec.name).about(spec.about);
    for port in spec.inputs {
        cmd = cmd.arg(
            Arg::new(port.name)
                .long(port.flag)
                .value_name("PATH")
                .required(port.required)
                .value_parser(clap::value_parser!(PathBuf))
                .help(format!("{} [{}]", port.help, port.kind.describe())),
        );
    }
    match spec.out_dir {
        Some(flag) => {
            let files: Vec<&str> = spec.outputs.iter().map(|p| p.file).collect();
            cmd = cmd.arg(
                Arg::new("__out_dir")
                    .long(flag)
                    .value_name("DIR")
                    .required(true)
                    .value_parser(clap::value_parser!(PathBuf))
                    .help(format!(
                        "output directory; writes {} and manifest.json",
                        files.join(", ")
                    )),
            );
        }
        None => {
            for port in spec.outputs {
                cmd = cmd.arg(
                    Arg::new(port.name)
                        .long(port.flag)
                        .value_name("PATH")
                        .required(port.flag == "out")
                        .value_parser(clap::value_parser!(PathBuf))
                        .help(format!(
                            "{} [default: {} beside --out]",
                            port.help, port.file
                        )),
                );
            }
        }
    }
    for p in spec.params {
        let flag = param_flag(p);
        let arg = match p.kind {
            // A switch that turns a default-on setting off says so, or its
            // help reads as the opposite of what it does.
            ParamKind::Bool => Arg::new(p.name)
                .long(flag)
                .action(ArgAction::SetTrue)
                .help(match p.default {
                    Some("true") => format!("turn off (on by default): {}", p.help),
                    _ => p.help.to_string(),
                }),
            kind => {
                let default = p
                    .default
                    .map(|d| format!(" [default: {d}]"))
                    .unwrap_or_default();
                // `--omega "-40 deg"`, as docs/commands.md writes it: a negative
                // quantity is a value, not a flag.
                Arg::new(p.name)
                    .long(flag)
                    .value_name(value_name(kind))
                    .allow_hyphen_values(!matches!(kind, ParamKind::Path | ParamKind::Choice(_)))
                    .help(format!("{}{default}", p.help))
            }
        };
        cmd = cmd.arg(arg);
    }
    cmd
}

fn value_name(kind: ParamKind) -> &'static str {
    match kind {
        ParamKind::Quantity(k) => match k {
            crate::units::Kind::Length => "LENGTH",
            crate::units::Kind::Pressure => "PRESSURE",
            crate::units::Kind::Angle => "ANGLE",
            crate::units::Kind::Intensity => "HU",
            crate::units::Kind::Force => "FORCE",
            crate::units::Kind::Time => "TIME",
            crate::units::Kind::LineForce => "FORCE/LENGTH",
            crate::units::Kind::Area => "AREA",
        },
        ParamKind::Lengths3 => "\"X, Y, Z mm\"",
        ParamKind::Int { .. } => "N",
        ParamKind::Float { .. } => "X",
        ParamKind::Bool => "",
        ParamKind::Choice(_) => "NAME",
        ParamKind::Path => "PATH",
    }
}

fn dispatch(m: &ArgMatches, args: &[OsString]) -> Result<()> {
    let log = LogMode {
        quiet: m.get_flag("quiet"),
        json: m.get_flag("log-json"),
    };
    pipeline::progress::init_logging(log);
    if let Some(pick) = m.get_one::<String>("series") {
        // The first choice in this process: cannot disagree.
        let _ = crate::io::volume_file::set_series(pick);
    }
    let threads = threads(m)?;
    // The global pool may already exist when the CLI runs inside a test process.
    let _ = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build_global();
    let inv = Invocation {
        command_line: args
            .iter()
            .map(|a| a.to_string_lossy().into_owned())
            .collect(),
        threads,
        log,
    };
    let (name, sub) = m.subcommand().expect("a subcommand is required");
    match name {
        "run" => run(sub, &inv),
        "design" => design(sub, &inv),
        "cohort" => cohort(sub, log),
        "info" => {
            let file = sub.get_one::<PathBuf>("file").expect("required");
            let out = inspect::describe(file, sub.get_flag("json"))?;
            println!("{out}");
            Ok(())
        }
        "check" => {
            for (flag, kind) in CHECKS {
                for path in sub.get_many::<PathBuf>(flag).into_iter().flatten() {
                    // As `coapt run` judges it: landmarks given in part are
                    // completed by the landmarks stage.
                    if pipeline::validate::is_partial(kind, path) {
                        pipeline::validate::input(ArtifactKind::SomeLandmarks, path)?;
                        println!(
                            "ok: {} (landmarks holding some of C1–C3, N1–N3: `coapt run` finds the others; `coapt valve` alone needs C1–C3)",
                            path.display()
                        );
                        continue;
                    }
                    pipeline::validate::input(kind, path)?;
                    println!("ok: {} ({})", path.display(), kind.describe());
                }
            }
            Ok(())
        }
        "convert" => {
            let frame = sub.get_one::<String>("frame").expect("has default");
            let frame = crate::geom::Frame::parse(frame)
                .ok_or_else(|| Error::usage(format!("--frame {frame}: expected LPS or RAS")))?;
            inspect::convert(
                sub.get_one::<PathBuf>("input").expect("required"),
                sub.get_one::<PathBuf>("output").expect("required"),
                frame,
            )
        }
        "bench" => bench_command(sub, threads, log),
        stage => {
            let spec = stages::registry()
                .iter()
                .find(|s| s.name == stage)
                .expect("clap only accepts registered stages");
            run_stage(spec, sub, &inv)
        }
    }
}

/// `--threads`, or every core.
fn threads(m: &ArgMatches) -> Result<usize> {
    Ok(match m.get_one::<usize>("threads") {
        Some(0) => return Err(Error::usage("--threads must be at least 1")),
        // Each thread is a stack and a worker: a million of them was a hang.
        Some(&n) if n > MAX_THREADS => {
            return Err(Error::usage(format!(
                "--threads {n}: at most {MAX_THREADS} (this machine has {})",
                std::thread::available_parallelism().map_or(1, |n| n.get())
            )));
        }
        Some(&n) => n,
        None => std::thread::available_parallelism()
            .map(|n| n.get())
            .unwrap_or(1),
    })
}

/// `coapt run`: the chain, then the verdict on stdout when it reached the
/// report.
fn run(sub: &ArgMatches, inv: &Invocation) -> Result<()> {
    let log = inv.log;
    let opts = runner::RunOptions {
        config: sub.get_one::<PathBuf>("config").expect("required").clone(),
        out: sub.get_one::<PathBuf>("out").cloned(),
        from: sub.get_one::<String>("from").cloned(),
        until: sub.get_one::<String>("until").cloned(),
        force: sub.get_flag("force"),
    };
    let report = runner::run(&opts, stages::registry(), inv)?;
    if !log.quiet && !log.json && !report.stages.is_empty() {
        eprintln!("run directory: {}", report.run_dir.display());
    }
    for (stage, missing) in &report.left_out {
        let after = report
            .stages
            .last()
            .map_or("nothing ran".to_string(), |(s, ..)| {
                format!("the chain stops after {s}")
            });
        tracing::warn!(
            event = "stage_left_out",
            stage = stage.as_str(),
            "{}: {after}: stage {stage} needs {} (give {} under [inputs])",
            opts.config.display(),
            missing.join(", "),
            missing
                .iter()
                .map(|m| format!("`{m} = \"…\"`"))
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    // The run's answer, when it reached the report: the same words
    // as report.json, on stdout like `design`'s table.
    if report.stages.iter().any(|(s, ..)| s == "report") {
        let doc = crate::io::report_json::Report::read(&report.run_dir.join("report.json"))?;
        print!(
            "{}",
            crate::report::terminal::summary(&doc, &report.run_dir.join("report.html"))
        );
    }
    Ok(())
}

/// `coapt design`: the size sweep, its table on stdout.
fn design(sub: &ArgMatches, inv: &Invocation) -> Result<()> {
    let log = inv.log;
    let sizes = match sub.get_one::<String>("sizes") {
        Some(t) => Some(
            design::settings::parse_sizes(t)
                .map_err(|e| Error::usage(format!("--sizes {t}: {e}")))?,
        ),
        None => None,
    };
    let opts = design::Options {
        config: sub.get_one::<PathBuf>("config").expect("required").clone(),
        out: sub.get_one::<PathBuf>("out").cloned(),
        sizes,
        force: sub.get_flag("force"),
    };
    let summary = design::run(&opts, stages::registry(), inv)?;
    print!("{}", design::table(&summary));
    if !log.quiet && !log.json {
        eprintln!(
            "design report: {}",
            summary.design_dir.join("report.html").display()
        );
    }
    Ok(())
}

/// `coapt cohort summary`: one CSV row per run directory.
fn cohort(sub: &ArgMatches, log: LogMode) -> Result<()> {
    let (_, sub) = sub.subcommand().expect("a cohort subcommand is required");
    let runs: Vec<PathBuf> = sub
        .get_many::<PathBuf>("runs")
        .expect("required")
        .cloned()
        .collect();
    let out = sub.get_one::<PathBuf>("out").expect("required");
    if runs.iter().any(|r| r == out) {
        return Err(Error::usage(format!(
            "--out {} is one of the run directories",
            out.display()
        )));
    }
    let n = crate::report::cohort_summary::write(&runs, out)?;
    if !log.quiet && !log.json {
        eprintln!("cohort summary: {n} runs → {}", out.display());
    }
    Ok(())
}

/// `coapt bench …`: each benchmark reads its own options.
fn bench_command(sub: &ArgMatches, threads: usize, log: LogMode) -> Result<()> {
    match sub.subcommand() {
        Some(("phantom", b)) => {
            let presets: Vec<String> = b
                .get_one::<String>("presets")
                .expect("has default")
                .split(',')
                .map(|s| s.trim().to_string())
                .collect();
            let repeat = *b.get_one::<u32>("repeat").expect("has default");
            let table = bench::phantom::run(&presets, repeat, threads)?;
            println!("{table}");
            Ok(())
        }
        Some(("surface", b)) => bench::surface::dispatch(b, threads),
        Some(("close", b)) => bench::close::dispatch(b, threads),
        Some(("stress-close", b)) => bench::stress_close::dispatch(b, log.quiet),
        Some(("pipeline", b)) => bench::pipeline::dispatch(b, threads),
        Some(("seed001", b)) => bench::seed001::dispatch(b),
        Some(("marom", b)) => bench::marom::dispatch(b),
        Some(("segment", b)) => {
            let set = b.get_one::<String>("cases").expect("has default");
            let baseline = b.get_one::<String>("baseline").map(String::as_str);
            let csv = b.get_one::<PathBuf>("csv").map(PathBuf::as_path);
            println!("{}", bench::segment::run(set, baseline, csv)?);
            Ok(())
        }
        _ => Err(Error::usage(
            "coapt bench: name a benchmark (phantom, segment, surface, close, seed001, marom, stress-close, pipeline)",
        )),
    }
}

/// More worker threads than any machine coapt runs on has cores.
const MAX_THREADS: usize = 1024;

fn run_stage(spec: &'static StageSpec, m: &ArgMatches, inv: &Invocation) -> Result<()> {
    let mut given = std::collections::BTreeMap::new();
    for p in spec.params {
        match p.kind {
            ParamKind::Bool => {
                if m.get_flag(p.name) {
                    let flipped = p.default != Some("true");
                    given.insert(p.name.to_string(), params::Value::Bool(flipped));
                }
            }
            _ => {
                if let Some(text) = m.get_one::<String>(p.name) {
                    let v = params::parse_text(p, text)
                        .map_err(|e| Error::usage(format!("--{} {text}: {e}", param_flag(p))))?;
                    given.insert(p.name.to_string(), v);
                }
            }
        }
    }
    let params = Params::resolve(spec, given)?;
    let mut io = StageIo::default();
    for port in spec.inputs {
        if let Some(path) = m.get_one::<PathBuf>(port.name) {
            io.inputs.push((port.name, path.clone()));
        }
    }
    let out_dir = match spec.out_dir {
        Some(_) => {
            let dir = m.get_one::<PathBuf>("__out_dir").expect("required").clone();
            for port in spec.outputs {
                io.outputs.push((port.name, dir.join(port.file)));
            }
            Some(dir)
        }
        None => {
            let main = spec
                .outputs
                .iter()
                .find(|p| p.flag == "out")
                .and_then(|p| m.get_one::<PathBuf>(p.name))
                .cloned();
            let beside = main
                .as_ref()
                .and_then(|p| p.parent().map(PathBuf::from))
                .unwrap_or_default();
            for port in spec.outputs {
                let path = m
                    .get_one::<PathBuf>(port.name)
                    .cloned()
                    .unwrap_or_else(|| beside.join(port.file));
                io.outputs.push((port.name, path));
            }
            None
        }
    };
    runner::run_single(spec, &io, &params, out_dir.as_deref(), inv)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn command_is_well_formed() {
        command().debug_assert();
    }

    #[test]
    fn render_does_not_repeat_causes() {
        let e = Error::read(
            "x.nii",
            std::io::Error::new(std::io::ErrorKind::NotFound, "gone"),
        );
        assert_eq!(render(&e), "x.nii: cannot read: gone");
    }
}
