//! Triangle meshes: the aortic wall, leaflets, closed valves.

use super::{Attributes, DataArray, Frame, Point3, PolyData, Vector3};
use coapt_base::{Error, Result};

/// A triangle mesh with named point and cell data arrays.
///
/// Invariants checked by [`TriMesh::sanity_check`]: every index refers to a
/// vertex; no triangle repeats a vertex; no two triangles share the same
/// vertex set; coordinates are finite; every point/cell array has one tuple
/// per vertex/triangle; every edge borders at most two triangles, and an edge
/// shared by two triangles is traversed in opposite directions by them
/// (consistent orientation).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct TriMesh {
    pub vertices: Vec<Point3>,
    pub triangles: Vec<[u32; 3]>,
    pub point_data: Attributes,
    pub cell_data: Attributes,
    /// Dataset-level arrays other than the frame (provenance, units).
    pub field_data: Attributes,
    pub frame: Frame,
}

/// Edge and vertex incidence, built once by sorting (no hashing).
#[derive(Debug, Clone)]
pub struct Adjacency {
    /// Unique undirected edges, each as `[a, b]` with `a < b`, sorted.
    pub edges: Vec<[u32; 2]>,
    /// For each edge, the triangles that use it (1 on a boundary, 2 inside,
    /// more on a non-manifold edge), in CSR form.
    pub edge_tri_offsets: Vec<u32>,
    pub edge_tris: Vec<u32>,
    /// For each triangle, the edge index of side `k` = (v[k], v[(k+1)%3]).
    pub tri_edges: Vec<[u32; 3]>,
    /// For each vertex, the incident triangles, in CSR form.
    pub vertex_tri_offsets: Vec<u32>,
    pub vertex_tris: Vec<u32>,
}

impl Adjacency {
    pub fn triangles_of_edge(&self, e: usize) -> &[u32] {
        &self.edge_tris[self.edge_tri_offsets[e] as usize..self.edge_tri_offsets[e + 1] as usize]
    }

    pub fn triangles_of_vertex(&self, v: usize) -> &[u32] {
        &self.vertex_tris
            [self.vertex_tri_offsets[v] as usize..self.vertex_tri_offsets[v + 1] as usize]
    }

    /// Edges used by exactly one triangle.
    pub fn boundary_edges(&self) -> Vec<usize> {
        (0..self.edges.len())
            .filter(|&e| self.edge_tri_offsets[e + 1] - self.edge_tri_offsets[e] == 1)
            .collect()
    }

    /// Edges used by more than two triangles.
    pub fn nonmanifold_edges(&self) -> Vec<usize> {
        (0..self.edges.len())
            .filter(|&e| self.edge_tri_offsets[e + 1] - self.edge_tri_offsets[e] > 2)
            .collect()
    }
}

/// Per-triangle shape quality.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Quality {
    /// Smallest interior angle, radians.
    pub min_angle: f64,
    /// Largest interior angle, radians.
    pub max_angle: f64,
    /// 4√3·A / (l₁² + l₂² + l₃²): 1 for an equilateral triangle, 0 when degenerate.
    pub shape: f64,
    pub min_edge: f64,
    pub max_edge: f64,
}

/// Counts that describe a mesh's topology.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Topology {
    pub vertices: usize,
    pub used_vertices: usize,
    pub edges: usize,
    pub triangles: usize,
    pub boundary_edges: usize,
    pub nonmanifold_edges: usize,
    pub components: usize,
    /// V − E + F over the vertices in use.
    pub euler_characteristic: i64,
}

impl TriMesh {
    pub fn new(vertices: Vec<Point3>, triangles: Vec<[u32; 3]>) -> Self {
        Self {
            vertices,
            triangles,
            ..Default::default()
        }
    }

    /// The lumen wall without its caps: the triangles of region 0 when the
    /// surface labels its regions (cell data `region`, one per triangle),
    /// else all of them.
    pub fn wall_triangles(&self) -> Vec<[u32; 3]> {
        match self.cell_data.get("region").and_then(|a| a.values.to_f64()) {
            Some(r) if r.len() == self.triangles.len() => self
                .triangles
                .iter()
                .zip(&r)
                .filter(|(_, r)| **r == 0.0)
                .map(|(t, _)| *t)
                .collect(),
            _ => self.triangles.clone(),
        }
    }

    #[inline]
    pub fn corners(&self, t: usize) -> [Point3; 3] {
        let [a, b, c] = self.triangles[t];
        [
            self.vertices[a as usize],
            self.vertices[b as usize],
            self.vertices[c as usize],
        ]
    }

    /// (b − a) × (c − a): twice the area, along the right-handed normal.
    #[inline]
    pub fn area_vector(&self, t: usize) -> Vector3 {
        let [a, b, c] = self.corners(t);
        (b - a).cross(&(c - a))
    }

    pub fn area(&self, t: usize) -> f64 {
        0.5 * self.area_vector(t).norm()
    }

    pub fn areas(&self) -> Vec<f64> {
        (0..self.triangles.len()).map(|t| self.area(t)).collect()
    }

    pub fn total_area(&self) -> f64 {
        (0..self.triangles.len()).map(|t| self.area(t)).sum()
    }

    /// Unit normal of each triangle (zero for a degenerate one).
    pub fn face_normals(&self) -> Vec<Vector3> {
        (0..self.triangles.len())
            .map(|t| {
                self.area_vector(t)
                    .try_normalize(0.0)
                    .unwrap_or_else(Vector3::zeros)
            })
            .collect()
    }

    /// Area-weighted unit vertex normals (zero for an unused vertex).
    pub fn vertex_normals(&self) -> Vec<Vector3> {
        let mut n = vec![Vector3::zeros(); self.vertices.len()];
        for (t, tri) in self.triangles.iter().enumerate() {
            let av = self.area_vector(t);
            for &v in tri {
                n[v as usize] += av;
            }
        }
        n.into_iter()
            .map(|v| v.try_normalize(0.0).unwrap_or_else(Vector3::zeros))
            .collect()
    }

    /// Signed enclosed volume by the divergence theorem: positive for a closed
    /// surface whose triangles are ordered counter-clockwise seen from outside.
    pub fn signed_volume(&self) -> f64 {
        // Sum over triangles of a·(b×c)/6, relative to the centroid of the
        // vertices to limit cancellation far from the origin.
        let c = self.centroid();
        self.triangles
            .iter()
            .map(|&[a, b, d]| {
                let pa = self.vertices[a as usize] - c;
                let pb = self.vertices[b as usize] - c;
                let pd = self.vertices[d as usize] - c;
                pa.dot(&pb.cross(&pd))
            })
            .sum::<f64>()
            / 6.0
    }

    /// Mean of the vertex positions.
    pub fn centroid(&self) -> Point3 {
        if self.vertices.is_empty() {
            return Point3::origin();
        }
        let s: Vector3 = self.vertices.iter().map(|p| p.coords).sum();
        Point3::from(s / self.vertices.len() as f64)
    }

    pub fn quality(&self, t: usize) -> Quality {
        let [a, b, c] = self.corners(t);
        let (la, lb, lc) = ((c - b).norm(), (a - c).norm(), (b - a).norm());
        let angle = |u: Vector3, v: Vector3| {
            let d = u.norm() * v.norm();
            if d == 0.0 {
                0.0
            } else {
                (u.dot(&v) / d).clamp(-1.0, 1.0).acos()
            }
        };
        let angles = [
            angle(b - a, c - a),
            angle(a - b, c - b),
            angle(a - c, b - c),
        ];
        let sq = la * la + lb * lb + lc * lc;
        let area = self.area(t);
        Quality {
            min_angle: angles.iter().copied().fold(f64::INFINITY, f64::min),
            max_angle: angles.iter().copied().fold(0.0, f64::max),
            shape: if sq == 0.0 {
                0.0
            } else {
                4.0 * 3f64.sqrt() * area / sq
            },
            min_edge: la.min(lb).min(lc),
            max_edge: la.max(lb).max(lc),
        }
    }

    /// Edge and vertex incidence. Indices must be valid (see `sanity_check`).
    pub fn adjacency(&self) -> Adjacency {
        let nt = self.triangles.len();
        let mut half: Vec<(u32, u32, u32, u8)> = Vec::with_capacity(3 * nt);
        for (t, tri) in self.triangles.iter().enumerate() {
            for k in 0..3 {
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                half.push((a.min(b), a.max(b), t as u32, k as u8));
            }
        }
        half.sort_unstable();
        let mut edges = Vec::new();
        let mut edge_tri_offsets = vec![0u32];
        let mut edge_tris = Vec::with_capacity(half.len());
        let mut tri_edges = vec![[0u32; 3]; nt];
        for (i, &(a, b, t, k)) in half.iter().enumerate() {
            if i == 0 || (half[i - 1].0, half[i - 1].1) != (a, b) {
                if i > 0 {
                    edge_tri_offsets.push(edge_tris.len() as u32);
                }
                edges.push([a, b]);
            }
            tri_edges[t as usize][k as usize] = (edges.len() - 1) as u32;
            edge_tris.push(t);
        }
        if !half.is_empty() {
            edge_tri_offsets.push(edge_tris.len() as u32);
        }
        // Vertex → triangles by counting sort.
        let nv = self.vertices.len();
        let mut vertex_tri_offsets = vec![0u32; nv + 1];
        for tri in &self.triangles {
            for &v in tri {
                vertex_tri_offsets[v as usize + 1] += 1;
            }
        }
        for v in 0..nv {
            vertex_tri_offsets[v + 1] += vertex_tri_offsets[v];
        }
        let mut fill = vertex_tri_offsets.clone();
        let mut vertex_tris = vec![0u32; 3 * nt];
        for (t, tri) in self.triangles.iter().enumerate() {
            for &v in tri {
                vertex_tris[fill[v as usize] as usize] = t as u32;
                fill[v as usize] += 1;
            }
        }
        Adjacency {
            edges,
            edge_tri_offsets,
            edge_tris,
            tri_edges,
            vertex_tri_offsets,
            vertex_tris,
        }
    }

    /// Connected components of triangles (sharing a vertex): a label per triangle
    /// and the number of components. Labels follow first appearance.
    pub fn triangle_components(&self) -> (Vec<u32>, usize) {
        let nv = self.vertices.len();
        let mut parent: Vec<u32> = (0..nv as u32).collect();
        fn find(p: &mut [u32], mut x: u32) -> u32 {
            while p[x as usize] != x {
                p[x as usize] = p[p[x as usize] as usize];
                x = p[x as usize];
            }
            x
        }
        for tri in &self.triangles {
            let r0 = find(&mut parent, tri[0]);
            for &v in &tri[1..] {
                let r = find(&mut parent, v);
                if r != r0 {
                    parent[r as usize] = r0;
                }
            }
        }
        let mut label = vec![u32::MAX; nv];
        let mut next = 0u32;
        let out = self
            .triangles
            .iter()
            .map(|tri| {
                let r = find(&mut parent, tri[0]) as usize;
                if label[r] == u32::MAX {
                    label[r] = next;
                    next += 1;
                }
                label[r]
            })
            .collect();
        (out, next as usize)
    }

    pub fn topology(&self) -> Topology {
        let adj = self.adjacency();
        let mut used = vec![false; self.vertices.len()];
        for tri in &self.triangles {
            for &v in tri {
                used[v as usize] = true;
            }
        }
        let used_vertices = used.iter().filter(|&&u| u).count();
        let (_, components) = self.triangle_components();
        Topology {
            vertices: self.vertices.len(),
            used_vertices,
            edges: adj.edges.len(),
            triangles: self.triangles.len(),
            boundary_edges: adj.boundary_edges().len(),
            nonmanifold_edges: adj.nonmanifold_edges().len(),
            components,
            euler_characteristic: used_vertices as i64 - adj.edges.len() as i64
                + self.triangles.len() as i64,
        }
    }

    /// Verify the invariants listed on the type.
    pub fn sanity_check(&self) -> Result<()> {
        let n = self.vertices.len();
        if let Some(p) = self
            .vertices
            .iter()
            .position(|p| !p.iter().all(|c| c.is_finite()))
        {
            return Err(Error::value(format!(
                "vertex {p} has a NaN or infinite coordinate"
            )));
        }
        for (t, tri) in self.triangles.iter().enumerate() {
            if let Some(&i) = tri.iter().find(|&&i| i as usize >= n) {
                return Err(Error::value(format!(
                    "triangle {t} refers to vertex {i}, but there are only {n} vertices"
                )));
            }
            if tri[0] == tri[1] || tri[1] == tri[2] || tri[0] == tri[2] {
                return Err(Error::value(format!(
                    "triangle {t} repeats a vertex: {tri:?}"
                )));
            }
        }
        self.point_data.check(Some(n), "point data")?;
        self.cell_data
            .check(Some(self.triangles.len()), "cell data")?;
        self.field_data.check(None, "field data")?;

        let mut keys: Vec<([u32; 3], usize)> = self
            .triangles
            .iter()
            .enumerate()
            .map(|(t, tri)| {
                let mut s = *tri;
                s.sort_unstable();
                (s, t)
            })
            .collect();
        keys.sort_unstable();
        if let Some(w) = keys.windows(2).find(|w| w[0].0 == w[1].0) {
            return Err(Error::value(format!(
                "triangles {} and {} use the same vertices {:?}",
                w[0].1, w[1].1, w[0].0
            )));
        }

        let mut directed: Vec<(u32, u32, usize)> = Vec::with_capacity(3 * self.triangles.len());
        for (t, tri) in self.triangles.iter().enumerate() {
            for k in 0..3 {
                directed.push((tri[k], tri[(k + 1) % 3], t));
            }
        }
        directed.sort_unstable();
        if let Some(w) = directed
            .windows(2)
            .find(|w| (w[0].0, w[0].1) == (w[1].0, w[1].1))
        {
            return Err(Error::value(format!(
                "edge {}→{} is traversed in the same direction by triangles {} and {}: \
                 inconsistent orientation or a non-manifold edge",
                w[0].0, w[0].1, w[0].2, w[1].2
            )));
        }
        let adj = self.adjacency();
        if let Some(&e) = adj.nonmanifold_edges().first() {
            return Err(Error::value(format!(
                "edge {:?} borders {} triangles (non-manifold)",
                adj.edges[e],
                adj.triangles_of_edge(e).len()
            )));
        }
        Ok(())
    }

    /// As a `.vtp` dataset; the frame goes to field data `frame`.
    pub fn to_polydata(&self) -> PolyData {
        let mut field_data = self.field_data.clone();
        field_data.insert(DataArray::string("frame", self.frame.name()));
        PolyData {
            points: self.vertices.clone(),
            lines: Vec::new(),
            triangles: self.triangles.clone(),
            point_data: self.point_data.clone(),
            cell_data: self.cell_data.clone(),
            field_data,
        }
    }

    /// From a `.vtp` dataset holding triangles only (polylines are refused,
    /// since cell data would no longer line up).
    pub fn from_polydata(pd: PolyData) -> Result<TriMesh> {
        if !pd.lines.is_empty() {
            return Err(Error::value(format!(
                "expected a triangle mesh, found {} polylines",
                pd.lines.len()
            )));
        }
        let frame = pd.frame()?;
        let mut field_data = pd.field_data;
        field_data.remove("frame");
        let mesh = TriMesh {
            vertices: pd.points,
            triangles: pd.triangles,
            point_data: pd.point_data,
            cell_data: pd.cell_data,
            field_data,
            frame,
        };
        Ok(mesh)
    }
}

/// The unit octahedron (vertices ±1 on the axes) with outward
/// counter-clockwise triangles: a closed genus-0 mesh for tests of every
/// layer (Euler characteristic 2, volume 4/3).
pub fn octahedron() -> TriMesh {
    let v = vec![
        Point3::new(1.0, 0.0, 0.0),
        Point3::new(-1.0, 0.0, 0.0),
        Point3::new(0.0, 1.0, 0.0),
        Point3::new(0.0, -1.0, 0.0),
        Point3::new(0.0, 0.0, 1.0),
        Point3::new(0.0, 0.0, -1.0),
    ];
    let t = vec![
        [0, 2, 4],
        [2, 1, 4],
        [1, 3, 4],
        [3, 0, 4],
        [2, 0, 5],
        [1, 2, 5],
        [3, 1, 5],
        [0, 3, 5],
    ];
    TriMesh::new(v, t)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn octahedron_invariants() {
        let m = octahedron();
        m.sanity_check().unwrap();
        let topo = m.topology();
        assert_eq!(topo.euler_characteristic, 2);
        assert_eq!(topo.edges, 12);
        assert_eq!(topo.boundary_edges, 0);
        assert_eq!(topo.components, 1);
        // Volume of the unit octahedron is 4/3; area 8 · (√3/2).
        assert!((m.signed_volume() - 4.0 / 3.0).abs() < 1e-12);
        assert!((m.total_area() - 4.0 * 3f64.sqrt()).abs() < 1e-12);
        let q = m.quality(0);
        assert!((q.shape - 1.0).abs() < 1e-12);
        assert!((q.min_angle - std::f64::consts::FRAC_PI_3).abs() < 1e-12);
        for (n, p) in m.vertex_normals().iter().zip(&m.vertices) {
            assert!((n - p.coords).norm() < 1e-12);
        }
    }

    #[test]
    fn adjacency_consistent() {
        let m = octahedron();
        let adj = m.adjacency();
        for (t, te) in adj.tri_edges.iter().enumerate() {
            for k in 0..3 {
                let [a, b] = adj.edges[te[k] as usize];
                let (u, v) = (m.triangles[t][k], m.triangles[t][(k + 1) % 3]);
                assert_eq!([a, b], [u.min(v), u.max(v)]);
                assert!(adj.triangles_of_edge(te[k] as usize).contains(&(t as u32)));
            }
        }
        for v in 0..6 {
            assert_eq!(adj.triangles_of_vertex(v).len(), 4);
        }
    }

    #[test]
    fn sanity_check_catches_defects() {
        let mut m = octahedron();
        m.triangles[0] = [0, 4, 2]; // flipped
        assert!(m.sanity_check().is_err());
        let mut m = octahedron();
        m.triangles.push([0, 2, 4]);
        assert!(m.sanity_check().is_err());
        let mut m = octahedron();
        m.triangles[1] = [2, 2, 4];
        assert!(m.sanity_check().is_err());
        let mut m = octahedron();
        m.triangles[1] = [2, 1, 9];
        assert!(m.sanity_check().is_err());
        let mut m = octahedron();
        m.point_data
            .insert(DataArray::scalars_f64("x", vec![0.0; 5]));
        assert!(m.sanity_check().is_err());
        let mut m = octahedron();
        m.vertices[3].x = f64::NAN;
        assert!(m.sanity_check().is_err());
    }

    #[test]
    fn open_mesh_and_components() {
        let mut m = octahedron();
        m.triangles.truncate(4); // upper pyramid: open, a disc
        m.sanity_check().unwrap();
        let topo = m.topology();
        assert_eq!(topo.boundary_edges, 4);
        assert_eq!(topo.euler_characteristic, 1);
        let mut two = octahedron();
        let off = two.vertices.len() as u32;
        let shifted: Vec<Point3> = two
            .vertices
            .iter()
            .map(|p| p + Vector3::new(5.0, 0.0, 0.0))
            .collect();
        let tris: Vec<[u32; 3]> = two
            .triangles
            .iter()
            .map(|t| [t[0] + off, t[1] + off, t[2] + off])
            .collect();
        two.vertices.extend(shifted);
        two.triangles.extend(tris);
        assert_eq!(two.triangle_components().1, 2);
        assert_eq!(two.topology().euler_characteristic, 4);
    }
}
