//! valve.json as the leaflets, close and report stages read it.
#![no_main]
use libfuzzer_sys::fuzz_target;

#[path = "scratch.rs"]
mod scratch;

fuzz_target!(|data: &[u8]| {
    let p = scratch::file("valve.json", data);
    if let Ok(f) = coapt::io::valve_json::read_frame(&p) {
        let _ = coapt::io::valve_json::read_stj_height(&p, &f);
    }
});
