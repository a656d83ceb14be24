//! Where point labels go so that none covers another: the landmarks of a
//! root lie close in some views (N1 and N3 side by side in the long axis
//! through C1, C2 and C3 a few pixels apart), and labels all put up and to
//! the right of their markers printed over each other ("N1N3").

/// Gap (px) between a marker and its label.
const GAP: f64 = 7.0;

/// A label's box: left, top, right, bottom (px).
type Rect = [f64; 4];

fn overlaps(a: &Rect, b: &Rect) -> bool {
    a[0] < b[2] && b[0] < a[2] && a[1] < b[3] && b[1] < a[3]
}

/// Left-aligned, vertically centred text origins for labels of the given
/// widths at the given markers, in order: each takes the first of
/// up-right, up-left, down-right, down-left (then further out along the
/// same four) whose box covers no label placed before it and no marker.
/// `height`: the labels' line height (px).
pub fn place(anchors: &[[f64; 2]], widths: &[f64], height: f64) -> Vec<[f64; 2]> {
    let half = 0.5 * height;
    let marker = |p: &[f64; 2]| [p[0] - 5.0, p[1] - 5.0, p[0] + 5.0, p[1] + 5.0];
    let mut placed: Vec<Rect> = Vec::with_capacity(anchors.len());
    let mut out = Vec::with_capacity(anchors.len());
    for (p, &w) in anchors.iter().zip(widths) {
        let candidate = |k: usize| -> ([f64; 2], Rect) {
            let reach = GAP * (1 + k / 4) as f64;
            let (right, up) = (k % 4 == 0 || k % 4 == 2, k % 4 < 2);
            let x = if right {
                p[0] + reach
            } else {
                p[0] - reach - w
            };
            let y = if up { p[1] - reach } else { p[1] + reach };
            ([x, y], [x, y - half, x + w, y + half])
        };
        let free = |r: &Rect| {
            !placed.iter().any(|q| overlaps(r, q))
                && !anchors.iter().any(|a| overlaps(r, &marker(a)))
        };
        let (origin, rect) = (0..12)
            .map(candidate)
            .find(|(_, r)| free(r))
            .unwrap_or_else(|| candidate(0));
        placed.push(rect);
        out.push(origin);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rect(o: &[f64; 2], w: f64, h: f64) -> Rect {
        [o[0], o[1] - h / 2.0, o[0] + w, o[1] + h / 2.0]
    }

    #[test]
    fn a_lone_label_sits_up_and_right_of_its_marker() {
        assert_eq!(place(&[[100.0, 100.0]], &[20.0], 13.0), vec![[107.0, 93.0]]);
    }

    #[test]
    fn labels_of_neighbouring_markers_do_not_cover_each_other_or_a_marker() {
        // N1 and N3 of the sample's long-axis view: 8 px apart on one row;
        // C2 and C3: 18 px apart.
        for anchors in [
            vec![[100.0, 200.0], [108.0, 200.0]],
            vec![[200.0, 80.0], [218.0, 80.0]],
            vec![[50.0, 50.0], [54.0, 52.0], [58.0, 50.0], [52.0, 56.0]],
        ] {
            let w = vec![22.0; anchors.len()];
            let o = place(&anchors, &w, 13.0);
            let r: Vec<Rect> = o.iter().map(|p| rect(p, 22.0, 13.0)).collect();
            for i in 0..r.len() {
                for j in 0..i {
                    assert!(!overlaps(&r[i], &r[j]), "{anchors:?}: {i} and {j}");
                }
                for a in &anchors {
                    assert!(!overlaps(
                        &r[i],
                        &[a[0] - 5.0, a[1] - 5.0, a[0] + 5.0, a[1] + 5.0]
                    ));
                }
            }
        }
    }
}
