//! The peer case of seed 000 / AVSim: one Ozaki leaflet sutured into a
//! cylinder of radius [`R`], closed under 80 mmHg. `coapt bench close`
//! builds it from the leaflet stage's template mesher; the mechanics' own
//! tests read the same meshes from `tests/data/` (written and kept equal to
//! what the benchmark builds by the root package's
//! `tests/it/peer_fixture.rs`), so the mechanics needs no stage to test,
//! and the report stage's test of seed 001's zone needs no benchmark.

use super::element::V3;
use super::model::{self, Axis, Leaflets};

/// The cylinder's radius (mm).
pub const R: f64 = 12.0;
/// The suture line's straight part below each commissure and the belly's
/// depth below that (mm): the nadir lies H_C + H_B below the commissures.
pub const HC: f64 = 1.5;
pub const HB: f64 = 9.0;

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

/// The peer leaflet kept at `path` (see [`fixture_path`]) and its axis
/// (through the commissure height along +z).
pub fn read_leaflet(path: &std::path::Path) -> Result<(Leaflets, Axis), String> {
    let mesh = coapt_io::vtp::read_mesh(path).map_err(|e| e.to_string())?;
    let l = model::leaflets_from_mesh(&mesh)?;
    let axis = Axis {
        origin: V3::zeros(),
        dir: V3::z(),
    };
    Ok((l, axis))
}

/// The peer leaflet at mesh size `h` (0.7, 1 or 2 mm) and its axis, from
/// this crate's kept meshes.
#[cfg(test)]
pub(crate) fn leaflet(h: f64) -> Result<(Leaflets, Axis), String> {
    read_leaflet(&fixture_path(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")),
        h,
    ))
}

/// Signed distances of `x` to the two planes through the +z axis that
/// bound the placed leaflet `l`'s 120° sector, positive on its side.
pub fn plane_distances(l: &Leaflets, x: &[V3]) -> Vec<[f64; 2]> {
    let c = model::corners(l);
    let rad = |p: &V3| V3::new(p.x, p.y, 0.0);
    let centroid = rad(&(l.x.iter().sum::<V3>() / l.x.len() as f64));
    // Split the corners by the side of the centroid's radial line.
    let side = |p: &V3| centroid.cross(&rad(p)).z >= 0.0;
    // The planes bound the leaflet's 120° sector, as `close` puts them for
    // a leaflet alone: 60° either side of the middle of its corners.
    let ends: Vec<V3> = [true, false]
        .map(|s| {
            let pts: Vec<V3> = c
                .iter()
                .map(|&i| l.x[i as usize])
                .filter(|p| side(p) == s)
                .collect();
            rad(&(pts.iter().sum::<V3>() / pts.len().max(1) as f64)).normalize()
        })
        .to_vec();
    let middle = (ends[0] + ends[1]).normalize();
    let mut normals = Vec::new();
    for e in &ends {
        let m = model::sector_edge(&V3::z(), &middle, e);
        let mut n = V3::z().cross(&m).normalize();
        if n.dot(&centroid) < 0.0 {
            n = -n;
        }
        normals.push(n);
    }
    x.iter()
        .map(|p| [normals[0].dot(&rad(p)), normals[1].dot(&rad(p))])
        .collect()
}
