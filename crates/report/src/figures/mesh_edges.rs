//! The outline of a leaflet mesh split by what it is in surgery: the free
//! edge (boundary code 2) and the sutured edge (code 1).

/// Kind of a boundary edge, from its end nodes' boundary codes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EdgeKind {
    /// Both ends on the free edge.
    Free,
    /// Both ends on a boundary, at least one sutured (commissure corners
    /// are both free and sutured: the suture wins).
    Sutured,
    /// A mesh boundary with no code: the template's outline all the same.
    Other,
}

/// Edges used by exactly one triangle, each as (a, b) with a < b, sorted;
/// triangles with an index ≥ `nodes` or a repeated index are ignored.
pub fn boundary_edges(tris: &[[u32; 3]], nodes: usize) -> Vec<[u32; 2]> {
    let mut e: Vec<[u32; 2]> = Vec::with_capacity(3 * tris.len());
    for t in tris {
        if t.iter().any(|&i| i as usize >= nodes) || t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
            continue;
        }
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            e.push([a.min(b), a.max(b)]);
        }
    }
    e.sort_unstable();
    let mut out = Vec::new();
    let mut i = 0;
    while i < e.len() {
        let mut j = i + 1;
        while j < e.len() && e[j] == e[i] {
            j += 1;
        }
        if j - i == 1 {
            out.push(e[i]);
        }
        i = j;
    }
    out
}

pub fn edge_kind(edge: [u32; 2], boundary: &[u8]) -> EdgeKind {
    let code = |i: u32| boundary.get(i as usize).copied().unwrap_or(0);
    match (code(edge[0]), code(edge[1])) {
        (2, 2) => EdgeKind::Free,
        (a, b) if a >= 1 && b >= 1 => EdgeKind::Sutured,
        _ => EdgeKind::Other,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn square_outline_and_kinds() {
        // Square 0-1-2-3 split along 0-2: the diagonal is inner.
        let tris = [[0u32, 1, 2], [0, 2, 3], [0, 7, 1], [1, 1, 2]];
        let e = boundary_edges(&tris, 4);
        assert_eq!(e, vec![[0, 1], [0, 3], [1, 2], [2, 3]]);
        let codes = [1u8, 2, 2, 0];
        assert_eq!(edge_kind([1, 2], &codes), EdgeKind::Free);
        assert_eq!(edge_kind([0, 1], &codes), EdgeKind::Sutured);
        assert_eq!(edge_kind([2, 3], &codes), EdgeKind::Other);
        assert_eq!(edge_kind([2, 30], &codes), EdgeKind::Other);
    }
}
