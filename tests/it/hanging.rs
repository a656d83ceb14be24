//! `placement = "hanging"` on the committed sample: the free edge hangs
//! taut from commissure to centre to commissure, so a longer free edge
//! (a larger sizer size) meets the others lower, and the closure keeps the
//! coaptation below the commissures, where the extruded placement left it
//! 5–9 mm above them at every size.

use crate::common::*;
use crate::design::config_with;

#[test]
fn hanging_leaflets_meet_below_the_commissures_and_lower_for_a_longer_free_edge() {
    let d = tmpdir("hanging-design");
    let cfg = config_with(&d, "1 mm", "[19, 23]", "placement = \"hanging\"\n");
    let o = coapt(&["design", cfg.to_str().unwrap(), "--quiet"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let run = d.join("run");
    let h_comm = json(&run.join("valve.json"))["h_comm_mm"].as_f64().unwrap();
    let mut eff = Vec::new();
    for size in [19, 23] {
        let dir = run.join(format!("design/size-{size}"));
        let closure = json(&dir.join("closure.json"));
        assert_eq!(closure["solver"]["converged"], true, "size {size}");
        assert_eq!(closure["intersecting_triangle_pairs"], 0, "size {size}");
        assert!(
            closure["suturing"]
                .as_str()
                .is_some_and(|s| s.contains("sutured")),
            "a hanging leaflet is placed as sewn: {}",
            closure["suturing"]
        );
        let leaflets = json(&dir.join("leaflets.json"));
        let report = json(&dir.join("report.json"));
        let e = report["metrics"]["effective_height_mm"].as_f64().unwrap();
        for l in leaflets["leaflets"].as_array().unwrap() {
            let drop = l["hanging"]["free_edge"]["drop_mm"].as_f64().unwrap();
            // The closure settles the hanging state, it does not undo it:
            // the leaflets meet about where their free edges hang.
            assert!(
                (e - (h_comm - drop)).abs() < 2.0,
                "size {size}: effective height {e:.2} mm, free edge hung {drop:.2} mm below commissures at {h_comm:.2} mm"
            );
        }
        assert!(
            e < h_comm - 3.0,
            "size {size}: effective height {e:.2} mm, commissures {h_comm:.2} mm"
        );
        eff.push(e);
    }
    // Four more millimetres of free edge (2 × 15.8 against 2 × 13.8 mm)
    // hang the centre lower: √(15.8² − R²) − √(13.8² − R²) ≈ 4 mm at R 12.9.
    assert!(eff[0] - eff[1] > 2.5, "effective heights {eff:?}");
}
