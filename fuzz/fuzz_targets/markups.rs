//! Landmark files: 3D Slicer markups (.mrk.json), .fcsv and plain JSON.
#![no_main]
use libfuzzer_sys::fuzz_target;

#[path = "scratch.rs"]
mod scratch;

fuzz_target!(|data: &[u8]| {
    let Some((&pick, bytes)) = data.split_first() else {
        return;
    };
    let name = match pick % 3 {
        0 => "landmarks.mrk.json",
        1 => "landmarks.fcsv",
        _ => "landmarks.json",
    };
    let p = scratch::file(name, bytes);
    let _ = coapt::io::markups::read(&p);
});
