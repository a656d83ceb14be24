//! The peer case of seed 000 / AVSim: one Ozaki leaflet sutured into a
//! cylinder of radius [`R`], closed under 80 mmHg. `coapt bench close`
//! builds it from the leaflet stage's template mesher; the mechanics' own
//! tests read the same meshes from `tests/data/` (written and kept equal to
//! what the benchmark builds by the root package's
//! `tests/it/peer_fixture.rs`), so the mechanics needs no stage to test.

/// The cylinder's radius (mm).
pub const R: f64 = 12.0;

/// The close stage's settings for the peer case: `model` "svk",
/// "neo-hookean" or else seed 001's stiffer GOH set (circumferential
/// fibres), planes contact, 0.5 mm thick, 80 mmHg.
pub fn config_text_with(model: &str, solver: &str, time_limit_s: f64, bending: bool) -> String {
    let material = match model {
        "svk" => "model = \"svk\"\nyoung = \"1 MPa\"\npoisson = 0\n",
        "neo-hookean" => "model = \"neo-hookean\"\nyoung = \"1 MPa\"\n",
        // Seed 001's stiffer GOH set with circumferential fibres.
        _ => "model = \"goh\"\nyoung = \"1 MPa\"\nk1 = \"1100 kPa\"\nk2 = 1000\nkappa = 0.2\n",
    };
    format!(
        "{material}thickness = \"0.5 mm\"\npressure = \"80 mmHg\"\ncontact = \"planes\"\nsolver = \"{solver}\"\ntime_limit = \"{time_limit_s} s\"\nbending = {bending}\n"
    )
}

/// The file holding the peer leaflet meshed at `h` mm (0.7, 1 and 2 are
/// kept).
pub fn fixture_path(crate_dir: &std::path::Path, h: f64) -> std::path::PathBuf {
    crate_dir.join("tests/data").join(format!("peer_h{h}.vtp"))
}

/// The peer leaflet at mesh size `h` (0.7, 1 or 2 mm) and its axis (through
/// the commissure height along +z), from the kept mesh.
#[cfg(test)]
pub(crate) fn leaflet(h: f64) -> Result<(super::model::Leaflets, super::model::Axis), String> {
    use super::element::V3;
    let path = fixture_path(std::path::Path::new(env!("CARGO_MANIFEST_DIR")), h);
    let mesh = coapt_io::vtp::read_mesh(&path).map_err(|e| e.to_string())?;
    let l = super::model::leaflets_from_mesh(&mesh)?;
    let axis = super::model::Axis {
        origin: V3::zeros(),
        dir: V3::z(),
    };
    Ok((l, axis))
}
