//! The leaflet-size sweep of `coapt design`: heights and areas against the
//! Ozaki sizer size, with the criteria's thresholds.

use super::xy_chart::{Series, XyChart, xy_chart};
use crate::Figure;
use coapt_io::design_json::{Closure, Design};

/// A number of one closure of the sweep.
type Reading = fn(&Closure) -> Option<f64>;

fn series(design: &Design, value: Reading) -> Vec<(f64, f64)> {
    design
        .sizes
        .iter()
        .filter_map(|s| Some((s.size? as f64, value(s).unwrap_or(f64::NAN))))
        .collect()
}

fn recommended(design: &Design) -> String {
    let answer = match design.recommended_size {
        Some(s) => format!("Recommended: size {s}, the smallest meeting every criterion."),
        None => "No size of the sweep meets every criterion.".to_string(),
    };
    // Ozaki's rule cuts a size per leaflet, so it is no point of these
    // uniform-size charts; its closure is stated under the table.
    match &design.ozaki_rule_sizes {
        Some(r) if r.len() == 3 => {
            let sizes: Vec<String> = r
                .iter()
                .map(|x| x.map_or("—".to_string(), |v| v.to_string()))
                .collect();
            format!("{answer} Ozaki's rule cuts {}.", sizes.join(" / "))
        }
        _ => answer,
    }
}

/// Two charts from `design.json`: heights (mm) and areas (mm²) per size.
/// `thresholds`: (central coaptation, effective height) in mm.
pub fn sizing(design: &Design, thresholds: (f64, f64)) -> Vec<Figure> {
    let mut h = XyChart::new(
        "sizing-heights",
        "Coaptation and effective height against leaflet size",
        "Ozaki sizer size",
        "height (mm)",
    );
    h.x_integer = true;
    let heights: [(&str, Reading); 3] = [
        ("coaptation height", |c| c.coaptation_height_mm),
        ("central coaptation height", |c| {
            c.central_coaptation_height_mm
        }),
        ("effective height", |c| c.effective_height_mm),
    ];
    for (name, key) in heights {
        h.series
            .push(Series::new(name, series(design, key)).with_markers());
    }
    // Each threshold in the colour of the height it judges (series 1, 2).
    h.hlines.push((
        format!("central coaptation > {} mm", thresholds.0),
        thresholds.0,
        Some(1),
    ));
    h.hlines.push((
        format!("effective height > {} mm", thresholds.1),
        thresholds.1,
        Some(2),
    ));
    h.caption = format!(
        "Each point is one closure of the patient's root with three leaflets of that sizer size, sutured on the same paths. \
         Dashed lines: the criteria's thresholds, each in the colour of the height it judges. A size without a point could not be closed or has no such zone. {}",
        recommended(design)
    );
    let mut a = XyChart::new(
        "sizing-areas",
        "Leaflet and coaptation area against leaflet size",
        "Ozaki sizer size",
        "area (mm²)",
    );
    a.x_integer = true;
    a.series.push(
        Series::new(
            "leaflet area (flat template)",
            series(design, |c| c.leaflet_area_mm2),
        )
        .with_markers(),
    );
    a.series.push(
        Series::new(
            "coaptation area (largest leaflet)",
            series(design, |c| c.coaptation_area_mm2),
        )
        .with_markers(),
    );
    a.caption = format!(
        "Pericardium cut per leaflet (template area) and the largest leaflet's coaptation area, per size. {}",
        recommended(design)
    );
    vec![xy_chart(&h), xy_chart(&a)]
}

#[cfg(test)]
mod tests {
    use super::super::test_valve::{count, decode};
    use super::*;
    use coapt_io::design_json::ClosureStatus;

    #[test]
    fn sweep_is_drawn_with_thresholds_and_gaps() {
        let size = |size: u32, v: Option<[f64; 5]>| Closure {
            status: ClosureStatus::Measured,
            closed: Some(true),
            coaptation_height_mm: v.map(|v| v[0]),
            central_coaptation_height_mm: v.map(|v| v[1]),
            effective_height_mm: v.map(|v| v[2]),
            leaflet_area_mm2: v.map(|v| v[3]),
            coaptation_area_mm2: v.map(|v| v[4]),
            size: Some(size),
            ..Closure::unmeasured(&format!("size-{size}"), &[Some(size); 3])
        };
        let d = Design {
            recommended_size: Some(21),
            ozaki_rule_sizes: Some(vec![Some(21), Some(23), None]),
            sizes: vec![
                size(19, Some([6.0, 3.0, 8.0, 300.0, 40.0])),
                size(21, Some([8.0, 5.0, 10.0, 350.0, 60.0])),
                size(23, None),
            ],
            ..Design::default()
        };
        let f = sizing(&d, (4.0, 9.0));
        assert_eq!(f.len(), 2);
        assert!(
            f[0].caption.contains("Recommended: size 21"),
            "{}",
            f[0].caption
        );
        assert!(
            f[1].caption.ends_with("Ozaki's rule cuts 21 / 23 / —."),
            "{}",
            f[1].caption
        );
        let img = decode(&f[0].png);
        // Three series colours; the thresholds are dashed in their
        // heights' colours, none in the old shared red.
        for c in [[0, 114, 178], [213, 94, 0], [0, 158, 115]] {
            assert!(count(&img, c) > 50, "colour {c:?}");
        }
        assert_eq!(count(&img, [200, 30, 40]), 0);
        let none = sizing(&Design::default(), (4.0, 9.0));
        assert!(
            none[0].caption.contains("no finite data"),
            "{}",
            none[0].caption
        );
        assert!(
            none[1].caption.contains("no finite data"),
            "{}",
            none[1].caption
        );
    }
}
