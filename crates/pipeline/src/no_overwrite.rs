//! No stage writes over one of its own inputs, nor two of its outputs over
//! each other: `segment --out ct.nii.gz --ct ct.nii.gz` used to replace the
//! CT with its mask, exit 0. A file is the same file when its device and
//! inode are (so a hard link or a symlink to an input is caught as well as
//! the same path spelt another way); an output that does not exist yet
//! cannot be an input.

use std::path::Path;

use super::spec::{StageIo, StageSpec};
use coapt_base::{Error, Result};

#[cfg(unix)]
fn identity(p: &Path) -> Option<(u64, u64)> {
    use std::os::unix::fs::MetadataExt;
    std::fs::metadata(p).ok().map(|m| (m.dev(), m.ino()))
}

#[cfg(not(unix))]
fn identity(p: &Path) -> Option<std::path::PathBuf> {
    std::fs::canonicalize(p).ok()
}

/// Refuses (exit 2) before any work when an output is an input, or two
/// outputs are one file, naming both options and the path.
pub fn check(spec: &StageSpec, io: &StageIo) -> Result<()> {
    let flag_in = |name: &'static str| spec.input(name).map_or(name, |p| p.flag);
    let flag_out = |name: &'static str| spec.output(name).map_or(name, |p| p.flag);
    let same_outputs = |a: &'static str, b: &'static str, path: &Path| {
        Error::usage(format!(
            "{}: --{} and --{} are the same file {}: give each output its own path",
            spec.name,
            flag_out(a),
            flag_out(b),
            path.display()
        ))
    };
    for (k, (out, path)) in io.outputs.iter().enumerate() {
        let Some(id) = identity(path) else {
            // Two outputs that do not exist yet can still be one path.
            if let Some((other, _)) = io.outputs[..k].iter().find(|(_, q)| q == path) {
                return Err(same_outputs(other, out, path));
            }
            continue;
        };
        for (input, q) in &io.inputs {
            if identity(q).as_ref() == Some(&id) {
                return Err(Error::usage(format!(
                    "{}: --{} {} is the input --{} ({}): coapt never writes over an input; choose another output path",
                    spec.name,
                    flag_out(out),
                    path.display(),
                    flag_in(input),
                    q.display()
                )));
            }
        }
        if let Some((other, _)) = io.outputs[..k]
            .iter()
            .find(|(_, q)| identity(q).as_ref() == Some(&id))
        {
            return Err(same_outputs(other, out, path));
        }
    }
    Ok(())
}
