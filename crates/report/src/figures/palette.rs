//! Contact classes and their colours, shared by the 3-D views and the
//! flat coaptation maps so that one legend reads for both.

use crate::raster::Rgb8;

/// What a point of a leaflet touches.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum ContactClass {
    /// No other leaflet.
    Free = 0,
    /// Exactly one other leaflet: the coaptation zone.
    Pair = 1,
    /// Two or more other leaflets: the central (triple) zone.
    Triple = 2,
}

/// Pale, distinguishable tints for leaflets out of contact; contact colours
/// stay saturated so that they stand out against all of them.
const TINTS: [Rgb8; 6] = [
    [236, 226, 178],
    [190, 226, 200],
    [214, 204, 236],
    [236, 200, 184],
    [190, 214, 236],
    [214, 214, 214],
];

/// Blue for two-leaflet contact and red for the central zone: apart in hue
/// and lightness, so also for colour-blind readers.
pub const PAIR: Rgb8 = [0, 104, 178];
pub const TRIPLE: Rgb8 = [214, 28, 36];

/// Edges and text.
pub const INK: Rgb8 = [30, 30, 30];
pub const FREE_EDGE: Rgb8 = [40, 40, 40];
pub const SUTURE: Rgb8 = [150, 75, 20];
pub const BACKGROUND: Rgb8 = [255, 255, 255];

pub fn leaflet_tint(j: usize) -> Rgb8 {
    TINTS[j % TINTS.len()]
}

pub fn class_colour(class: ContactClass, leaflet: usize) -> Rgb8 {
    match class {
        ContactClass::Free => leaflet_tint(leaflet),
        ContactClass::Pair => PAIR,
        ContactClass::Triple => TRIPLE,
    }
}

/// Bit 7 of closed.vtp's `contact` marks a node touching the aortic wall
/// (`wall_contact = true`), not another leaflet: no colour of its own.
const WALL_BIT: u8 = 1 << 7;

/// Class of a node from its contact bitmask (bit j: touches leaflet j),
/// ignoring the bit of its own leaflet.
pub fn classify(mask: u8, own: Option<usize>) -> ContactClass {
    let own_bit = own.filter(|&j| j < 8).map_or(0, |j| 1u8 << j);
    match (mask & !own_bit & !WALL_BIT).count_ones() {
        0 => ContactClass::Free,
        1 => ContactClass::Pair,
        _ => ContactClass::Triple,
    }
}

/// Leaflet of each node: that of the first triangle using it (a node is on
/// one leaflet only); `None` for unused nodes or bad indices.
pub fn node_leaflets(nodes: usize, tris: &[[u32; 3]], tri_leaflet: &[u8]) -> Vec<Option<usize>> {
    let mut out = vec![None; nodes];
    for (t, tri) in tris.iter().enumerate() {
        let Some(&l) = tri_leaflet.get(t) else {
            continue;
        };
        for &i in tri {
            if let Some(slot) = out.get_mut(i as usize)
                && slot.is_none()
            {
                *slot = Some(l as usize);
            }
        }
    }
    out
}

/// Class of every node; nodes beyond `contact` count as touching nothing.
pub fn node_classes(contact: &[u8], leaflet: &[Option<usize>]) -> Vec<ContactClass> {
    leaflet
        .iter()
        .enumerate()
        .map(|(i, &l)| classify(contact.get(i).copied().unwrap_or(0), l))
        .collect()
}

/// One-hot weights of a class, for interpolation across a triangle.
pub fn one_hot(c: ContactClass) -> [f32; 3] {
    let mut v = [0.0; 3];
    v[c as usize] = 1.0;
    v
}

/// The class whose interpolated weight is largest; ties go to the stronger
/// contact so that a zone's border is drawn halfway along each edge.
pub fn dominant(w: [f32; 3]) -> ContactClass {
    let mut best = ContactClass::Free;
    let mut bw = w[0];
    for (c, k) in [(ContactClass::Pair, 1), (ContactClass::Triple, 2)] {
        if w[k] >= bw {
            best = c;
            bw = w[k];
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn own_bit_is_ignored_and_counts_give_classes() {
        assert_eq!(classify(0b001, Some(0)), ContactClass::Free);
        assert_eq!(classify(0b011, Some(0)), ContactClass::Pair);
        assert_eq!(classify(0b010, Some(0)), ContactClass::Pair);
        assert_eq!(classify(0b110, Some(0)), ContactClass::Triple);
        assert_eq!(classify(0b111, Some(1)), ContactClass::Triple);
        assert_eq!(classify(0b100, None), ContactClass::Pair);
        assert_eq!(classify(0xFF, Some(200)), ContactClass::Triple);
        // The wall bit is not a leaflet.
        assert_eq!(classify(0b1000_0000, Some(0)), ContactClass::Free);
        assert_eq!(classify(0b1000_0010, Some(0)), ContactClass::Pair);
    }

    #[test]
    fn node_leaflets_and_classes_tolerate_short_inputs() {
        let tris = [[0u32, 1, 2], [2, 3, 9]];
        let l = node_leaflets(5, &tris, &[1]);
        assert_eq!(l, vec![Some(1), Some(1), Some(1), None, None]);
        let c = node_classes(&[0b001], &l);
        assert_eq!(c[0], ContactClass::Pair);
        assert_eq!(c[4], ContactClass::Free);
    }

    #[test]
    fn dominant_breaks_ties_towards_contact() {
        assert_eq!(dominant([0.5, 0.5, 0.0]), ContactClass::Pair);
        assert_eq!(dominant([0.6, 0.4, 0.0]), ContactClass::Free);
        assert_eq!(dominant([0.2, 0.4, 0.4]), ContactClass::Triple);
        assert_eq!(dominant([f32::NAN, 0.0, 0.0]), ContactClass::Free);
    }

    #[test]
    fn contact_colours_differ_from_every_tint() {
        for j in 0..6 {
            assert_ne!(leaflet_tint(j), PAIR);
            assert_ne!(leaflet_tint(j), TRIPLE);
        }
    }
}
