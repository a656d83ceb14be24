//! Keep the aorta: the largest connected piece of the isosurface.

use coapt_geom::TriMesh;

/// The connected component with the most triangles (ties: the first), with
/// unused vertices dropped. Returns the mesh and the kept old vertex ids.
pub fn largest_component(mesh: &TriMesh) -> (TriMesh, Vec<u32>) {
    let (label, count) = mesh.triangle_components();
    if count <= 1 {
        let ids = (0..mesh.vertices.len() as u32).collect();
        let mut m = TriMesh::new(mesh.vertices.clone(), mesh.triangles.clone());
        m.frame = mesh.frame;
        return (m, ids);
    }
    let mut size = vec![0usize; count];
    for &l in &label {
        size[l as usize] += 1;
    }
    let best = (0..count)
        .max_by_key(|&c| (size[c], usize::MAX - c))
        .unwrap() as u32;
    let mut new_id = vec![u32::MAX; mesh.vertices.len()];
    let mut kept = Vec::new();
    let mut tris = Vec::with_capacity(size[best as usize]);
    for (t, tri) in mesh.triangles.iter().enumerate() {
        if label[t] != best {
            continue;
        }
        tris.push(tri.map(|v| {
            if new_id[v as usize] == u32::MAX {
                new_id[v as usize] = kept.len() as u32;
                kept.push(v);
            }
            new_id[v as usize]
        }));
    }
    let verts = kept.iter().map(|&v| mesh.vertices[v as usize]).collect();
    let mut m = TriMesh::new(verts, tris);
    m.frame = mesh.frame;
    (m, kept)
}
