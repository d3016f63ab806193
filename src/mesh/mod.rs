//! 2D meshes: nodes, `Tri3`/`Quad4` cells and named node, edge and cell sets (tags).
//!
//! Conventions: cells are stored counter-clockwise; boundary edges in an edge set are oriented
//! so that their cell lies on the left, hence the outward normal of edge `a -> b` is
//! `(t_y, -t_x) / |t|` with `t = x_b - x_a`. Generators and the Gmsh reader both produce
//! oriented edges (see [`Mesh2::orient_edge_sets`]).

pub mod generate;
pub mod gmsh;
pub mod relocate;

use nalgebra::{Point2, Vector2};
use std::collections::{BTreeMap, HashMap};

/// Cell types supported by the engine (linear elements only).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub enum CellKind {
    Tri3,
    Quad4,
}

impl CellKind {
    pub fn num_nodes(self) -> usize {
        match self {
            CellKind::Tri3 => 3,
            CellKind::Quad4 => 4,
        }
    }
}

/// One cell: its kind and node indices (a `Tri3` uses the first three entries).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Cell {
    pub kind: CellKind,
    conn: [usize; 4],
}

impl Cell {
    pub fn tri3(a: usize, b: usize, c: usize) -> Self {
        Cell { kind: CellKind::Tri3, conn: [a, b, c, usize::MAX] }
    }
    pub fn quad4(a: usize, b: usize, c: usize, d: usize) -> Self {
        Cell { kind: CellKind::Quad4, conn: [a, b, c, d] }
    }
    /// Node indices of the cell, counter-clockwise.
    pub fn nodes(&self) -> &[usize] {
        &self.conn[..self.kind.num_nodes()]
    }
    /// The edges of the cell as ordered node pairs (counter-clockwise).
    pub fn edges(&self) -> impl Iterator<Item = [usize; 2]> + '_ {
        let n = self.nodes();
        (0..n.len()).map(move |i| [n[i], n[(i + 1) % n.len()]])
    }
}

#[derive(Debug, thiserror::Error, PartialEq)]
pub enum MeshError {
    #[error("cell {cell} references node {node}, but the mesh has only {num_nodes} nodes")]
    NodeOutOfRange { cell: usize, node: usize, num_nodes: usize },
    #[error("cell {cell} ({kind:?}) is inverted or degenerate: Jacobian determinant {det_j:.3e} at corner {corner} (nodes {nodes:?})")]
    InvertedCell { cell: usize, kind: CellKind, corner: usize, det_j: f64, nodes: Vec<usize> },
    #[error("edge ({a}, {b}) of edge set '{set}' is not an edge of any cell")]
    EdgeNotOnCell { set: String, a: usize, b: usize },
    #[error("set '{set}' references node {node}, but the mesh has only {num_nodes} nodes")]
    SetNodeOutOfRange { set: String, node: usize, num_nodes: usize },
    #[error("mesh has no cells")]
    Empty,
    #[error("invalid mesh generator parameter: {0}")]
    BadParameter(String),
}

/// A 2D mesh with named sets.
#[derive(Debug, Clone, Default)]
pub struct Mesh2 {
    pub nodes: Vec<Point2<f64>>,
    pub cells: Vec<Cell>,
    pub node_sets: BTreeMap<String, Vec<usize>>,
    pub edge_sets: BTreeMap<String, Vec<[usize; 2]>>,
    pub cell_sets: BTreeMap<String, Vec<usize>>,
}

impl Mesh2 {
    pub fn num_nodes(&self) -> usize {
        self.nodes.len()
    }
    pub fn num_cells(&self) -> usize {
        self.cells.len()
    }

    /// Corner coordinates of a cell (unused slots of a `Tri3` are zero).
    pub fn cell_coords(&self, c: usize) -> [Point2<f64>; 4] {
        let mut x = [Point2::origin(); 4];
        for (k, &n) in self.cells[c].nodes().iter().enumerate() {
            x[k] = self.nodes[n];
        }
        x
    }

    /// Checks node indices and that every cell has a positive Jacobian at its corners
    /// (for `Quad4` the corners bound the bilinear Jacobian: positive there means positive everywhere).
    pub fn validate(&self) -> Result<(), MeshError> {
        if self.cells.is_empty() {
            return Err(MeshError::Empty);
        }
        let nn = self.nodes.len();
        for (c, cell) in self.cells.iter().enumerate() {
            for &n in cell.nodes() {
                if n >= nn {
                    return Err(MeshError::NodeOutOfRange { cell: c, node: n, num_nodes: nn });
                }
            }
            let x: Vec<Point2<f64>> = cell.nodes().iter().map(|&n| self.nodes[n]).collect();
            let k = x.len();
            // Scale for the degeneracy tolerance: squared longest edge.
            let mut h2: f64 = 0.0;
            for i in 0..k {
                h2 = h2.max((x[(i + 1) % k] - x[i]).norm_squared());
            }
            for i in 0..k {
                let e1 = x[(i + 1) % k] - x[i];
                let e0 = x[(i + k - 1) % k] - x[i];
                let det = e1.x * e0.y - e1.y * e0.x;
                // Relative tolerance 1e-12: below it the corner angle is numerically zero.
                if det <= 1e-12 * h2 || !det.is_finite() {
                    return Err(MeshError::InvertedCell {
                        cell: c,
                        kind: cell.kind,
                        corner: i,
                        det_j: det,
                        nodes: cell.nodes().to_vec(),
                    });
                }
            }
        }
        for (name, set) in &self.node_sets {
            if let Some(&n) = set.iter().find(|&&n| n >= nn) {
                return Err(MeshError::SetNodeOutOfRange { set: name.clone(), node: n, num_nodes: nn });
            }
        }
        Ok(())
    }

    /// Orients every edge of every edge set so that its cell lies on its left, and adds a node set
    /// of the same name (unless one exists) holding the edge set's nodes.
    pub fn orient_edge_sets(&mut self) -> Result<(), MeshError> {
        let mut owner: HashMap<(usize, usize), [usize; 2]> = HashMap::new();
        for cell in &self.cells {
            for [a, b] in cell.edges() {
                owner.insert((a.min(b), a.max(b)), [a, b]);
            }
        }
        for (name, edges) in self.edge_sets.iter_mut() {
            for e in edges.iter_mut() {
                let key = (e[0].min(e[1]), e[0].max(e[1]));
                match owner.get(&key) {
                    Some(&oriented) => *e = oriented,
                    None => return Err(MeshError::EdgeNotOnCell { set: name.clone(), a: e[0], b: e[1] }),
                }
            }
        }
        let derived: Vec<(String, Vec<usize>)> = self
            .edge_sets
            .iter()
            .filter(|(name, _)| !self.node_sets.contains_key(*name))
            .map(|(name, edges)| {
                let mut v: Vec<usize> = edges.iter().flat_map(|e| e.iter().copied()).collect();
                v.sort_unstable();
                v.dedup();
                (name.clone(), v)
            })
            .collect();
        self.node_sets.extend(derived);
        Ok(())
    }

    /// Outward unit normal and length of an oriented boundary edge.
    pub fn edge_normal(&self, e: [usize; 2]) -> (Vector2<f64>, f64) {
        let t = self.nodes[e[1]] - self.nodes[e[0]];
        let len = t.norm();
        (Vector2::new(t.y, -t.x) / len, len)
    }

    /// Sum of cell areas (exact for straight-sided cells).
    pub fn area(&self) -> f64 {
        self.cells
            .iter()
            .map(|cell| {
                let n = cell.nodes();
                let mut a = 0.0;
                for i in 0..n.len() {
                    let p = self.nodes[n[i]];
                    let q = self.nodes[n[(i + 1) % n.len()]];
                    a += p.x * q.y - q.x * p.y;
                }
                0.5 * a
            })
            .sum()
    }

    /// Names of all sets, for error messages.
    pub fn set_names(&self) -> Vec<String> {
        let mut v: Vec<String> =
            self.node_sets.keys().chain(self.edge_sets.keys()).chain(self.cell_sets.keys()).cloned().collect();
        v.sort();
        v.dedup();
        v
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inverted_quad_is_reported_with_its_index() {
        let mut m = generate::rectangle(0.0, 0.0, 1.0, 1.0, 2, 1, 1.0, 1.0, CellKind::Quad4).expect("valid rectangle");
        let c = m.cells[1];
        let n = c.nodes();
        m.cells[1] = Cell::quad4(n[0], n[3], n[2], n[1]); // clockwise
        match m.validate() {
            Err(MeshError::InvertedCell { cell, .. }) => assert_eq!(cell, 1),
            other => panic!("expected InvertedCell, got {other:?}"),
        }
    }

    #[test]
    fn edge_normals_point_outward() {
        let m = generate::rectangle(0.0, 0.0, 2.0, 1.0, 3, 2, 1.0, 1.0, CellKind::Tri3).expect("valid rectangle");
        for (name, expect) in
            [("left", [-1.0, 0.0]), ("right", [1.0, 0.0]), ("bottom", [0.0, -1.0]), ("top", [0.0, 1.0])]
        {
            for &e in &m.edge_sets[name] {
                let (n, _) = m.edge_normal(e);
                assert!((n.x - expect[0]).abs() < 1e-14 && (n.y - expect[1]).abs() < 1e-14, "{name}");
            }
        }
        // Area exact to round-off: rectangle 2 x 1.
        assert!((m.area() - 2.0).abs() < 1e-14);
    }
}
