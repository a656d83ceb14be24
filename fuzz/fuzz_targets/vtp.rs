//! VTK XML PolyData (leaflets.vtp, closed.vtp, aorta.vtp, paths.vtp): the
//! parser and the triangle-mesh view every stage reads meshes through.
#![no_main]
use libfuzzer_sys::fuzz_target;

#[path = "scratch.rs"]
mod scratch;

fuzz_target!(|data: &[u8]| {
    let _ = coapt::io::vtp::parse(data);
    let p = scratch::file("mesh.vtp", data);
    let _ = coapt::io::vtp::read_mesh(&p);
});
