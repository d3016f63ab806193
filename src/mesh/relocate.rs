//! Node relocation: the mesh motion of a worn boundary, as commercial wear codes do it (the
//! ALE practice of Abaqus `UMESHMOTION`: move the boundary nodes by the wear depth, smooth the
//! interior).
//!
//! The boundary nodes of the worn surface get their displacement `d_B`; every other boundary
//! node is held; the interior nodes take the discrete harmonic extension of `d_B` on the node
//! graph (each interior node at the mean displacement of its edge neighbours, the uniform
//! "Laplacian" smoothing of mesh-motion schemes, Donea & Huerta, *Finite Element Methods for
//! Flow Problems*, sec. 7.3; solved exactly here by conjugate gradients rather than by a few
//! smoothing sweeps per update). A field that is linear in the coordinates on a uniform
//! structured grid is discrete-harmonic, so it is reproduced exactly. The moved nodes may invert
//! cells where the boundary moves by more than the cells next to it can absorb: [`quality`]
//! measures that.

use super::Mesh2;
use nalgebra::{Point2, Vector2};

/// The node graph of a mesh: the neighbours of each node along cell edges.
fn neighbours(mesh: &Mesh2) -> Vec<Vec<usize>> {
    let mut nb: Vec<Vec<usize>> = vec![vec![]; mesh.num_nodes()];
    for cell in &mesh.cells {
        for [a, b] in cell.edges() {
            nb[a].push(b);
            nb[b].push(a);
        }
    }
    for v in nb.iter_mut() {
        v.sort_unstable();
        v.dedup();
    }
    nb
}

/// Nodes on the mesh boundary (on an edge that only one cell has).
pub fn boundary_nodes(mesh: &Mesh2) -> Vec<bool> {
    let mut count: std::collections::HashMap<(usize, usize), u32> = std::collections::HashMap::new();
    for cell in &mesh.cells {
        for [a, b] in cell.edges() {
            *count.entry((a.min(b), a.max(b))).or_default() += 1;
        }
    }
    let mut on = vec![false; mesh.num_nodes()];
    for ((a, b), n) in count {
        if n == 1 {
            on[a] = true;
            on[b] = true;
        }
    }
    on
}

/// Displacement of every node: `moved` nodes by their given displacement, the other boundary
/// nodes held, the interior by the discrete harmonic extension (see the module documentation),
/// to a relative residual of 1e-13. With `layers`, only the nodes fewer than `layers` edge steps
/// from a moved node move (an ALE domain of that many cell layers under the surface; 1: the
/// surface nodes alone).
pub fn harmonic_extension(mesh: &Mesh2, moved: &[(usize, Vector2<f64>)], layers: Option<usize>) -> Vec<Vector2<f64>> {
    let n = mesh.num_nodes();
    let nb = neighbours(mesh);
    let mut d = vec![Vector2::zeros(); n];
    let mut free = boundary_nodes(mesh).into_iter().map(|b| !b).collect::<Vec<bool>>();
    for &(i, v) in moved {
        d[i] = v;
        free[i] = false;
    }
    if let Some(layers) = layers {
        // Breadth-first distance (in edges) from the moved nodes.
        let mut dist = vec![usize::MAX; n];
        let mut front: Vec<usize> = moved.iter().map(|m| m.0).collect();
        front.iter().for_each(|&i| dist[i] = 0);
        for step in 1..=layers {
            let mut next = vec![];
            for &i in &front {
                for &j in &nb[i] {
                    if dist[j] == usize::MAX {
                        dist[j] = step;
                        next.push(j);
                    }
                }
            }
            front = next;
        }
        // The domain: `layers` cell layers under the surface; nodes `layers` edges away and
        // beyond bound it (held).
        for i in 0..n {
            if dist[i] >= layers {
                free[i] = false;
            }
        }
    }
    // Solve `L_II d_I = -L_IB d_B` (L: degree on the diagonal, -1 per neighbour) per
    // component by conjugate gradients, Jacobi-preconditioned.
    let idx: Vec<usize> = (0..n).filter(|&i| free[i]).collect();
    if idx.is_empty() {
        return d;
    }
    let mut local = vec![usize::MAX; n];
    idx.iter().enumerate().for_each(|(k, &i)| local[i] = k);
    let m = idx.len();
    let apply = |x: &[f64], y: &mut [f64]| {
        for (k, &i) in idx.iter().enumerate() {
            let mut s = nb[i].len() as f64 * x[k];
            for &j in &nb[i] {
                if local[j] != usize::MAX {
                    s -= x[local[j]];
                }
            }
            y[k] = s;
        }
    };
    let diag: Vec<f64> = idx.iter().map(|&i| nb[i].len() as f64).collect();
    for comp in 0..2 {
        let b: Vec<f64> = idx.iter().map(|&i| nb[i].iter().filter(|&&j| !free[j]).map(|&j| d[j][comp]).sum()).collect();
        let bnorm = b.iter().map(|v| v * v).sum::<f64>().sqrt();
        if bnorm == 0.0 {
            continue;
        }
        let mut x = vec![0.0; m];
        let mut r = b.clone();
        let mut z: Vec<f64> = r.iter().zip(&diag).map(|(r, d)| r / d).collect();
        let mut p = z.clone();
        let mut rz: f64 = r.iter().zip(&z).map(|(a, b)| a * b).sum();
        let mut q = vec![0.0; m];
        for _ in 0..10 * m + 100 {
            apply(&p, &mut q);
            let alpha = rz / p.iter().zip(&q).map(|(a, b)| a * b).sum::<f64>();
            x.iter_mut().zip(&p).for_each(|(x, p)| *x += alpha * p);
            r.iter_mut().zip(&q).for_each(|(r, q)| *r -= alpha * q);
            if r.iter().map(|v| v * v).sum::<f64>().sqrt() <= 1e-13 * bnorm {
                break;
            }
            z.iter_mut().zip(r.iter().zip(&diag)).for_each(|(z, (r, d))| *z = r / d);
            let rz_new: f64 = r.iter().zip(&z).map(|(a, b)| a * b).sum();
            let beta = rz_new / rz;
            rz = rz_new;
            p.iter_mut().zip(&z).for_each(|(p, z)| *p = z + beta * *p);
        }
        for (k, &i) in idx.iter().enumerate() {
            d[i][comp] = x[k];
        }
    }
    d
}

/// Quality of a moved mesh: the smallest scaled corner Jacobian over its cells,
/// `det(e1, e0) / (|e1| |e0|)` (the sine of the corner angle: 1 for a rectangle, 0 for a
/// degenerate corner, negative for an inverted one) and the smallest ratio of a corner
/// Jacobian to its value before the move (a cell squashed to half its height: 0.5), each with
/// the cell where it is, and the count of inverted cells.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MeshQuality {
    pub min_scaled_jacobian: f64,
    pub worst_shape_cell: usize,
    pub min_jacobian_ratio: f64,
    pub worst_ratio_cell: usize,
    /// Cells with a corner Jacobian of zero or below.
    pub inverted: usize,
}

/// [`MeshQuality`] of `mesh` with its nodes moved to `nodes`.
pub fn quality(mesh: &Mesh2, nodes: &[Point2<f64>]) -> MeshQuality {
    let mut q = MeshQuality {
        min_scaled_jacobian: f64::INFINITY,
        worst_shape_cell: 0,
        min_jacobian_ratio: f64::INFINITY,
        worst_ratio_cell: 0,
        inverted: 0,
    };
    let corner = |x: &[Point2<f64>], i: usize| {
        let k = x.len();
        let (e1, e0) = (x[(i + 1) % k] - x[i], x[(i + k - 1) % k] - x[i]);
        (e1.x * e0.y - e1.y * e0.x, e1.norm() * e0.norm())
    };
    for (c, cell) in mesh.cells.iter().enumerate() {
        let x: Vec<Point2<f64>> = cell.nodes().iter().map(|&n| nodes[n]).collect();
        let x0: Vec<Point2<f64>> = cell.nodes().iter().map(|&n| mesh.nodes[n]).collect();
        let (mut shape, mut ratio) = (f64::INFINITY, f64::INFINITY);
        for i in 0..x.len() {
            let ((det, lengths), (det0, _)) = (corner(&x, i), corner(&x0, i));
            let s = det / lengths;
            shape = shape.min(if s.is_finite() { s } else { -1.0 });
            ratio = ratio.min(if det0 > 0.0 { det / det0 } else { -1.0 });
        }
        if shape <= 0.0 {
            q.inverted += 1;
        }
        if shape < q.min_scaled_jacobian {
            (q.min_scaled_jacobian, q.worst_shape_cell) = (shape, c);
        }
        if ratio < q.min_jacobian_ratio {
            (q.min_jacobian_ratio, q.worst_ratio_cell) = (ratio, c);
        }
    }
    q
}
