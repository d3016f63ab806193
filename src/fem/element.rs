//! Elements in three layers (as in fenris): a reference element (shape functions on the
//! reference cell), a mapped element (reference element + physical corner coordinates: Jacobian,
//! physical gradients), and a surface element (`Seg2`: a straight boundary segment).
//!
//! Reference cells: `Tri3` on `(0,0), (1,0), (0,1)`; `Quad4` on `[-1, 1]^2`, nodes
//! counter-clockwise from `(-1,-1)`. All kernels write into caller-owned fixed-size buffers.

use crate::fem::quadrature::{quad_gauss, triangle_rule, QuadratureRule};
use crate::mesh::CellKind;
use nalgebra::{Matrix2, Point2, Vector2};

/// Shape functions on a reference cell.
pub trait ReferenceElement {
    fn num_nodes(&self) -> usize;
    /// `N_i(xi)` into `n[..num_nodes]`.
    fn shape(&self, xi: [f64; 2], n: &mut [f64; 4]);
    /// `dN_i/dxi_k(xi)` into `dn[i][k]`.
    fn shape_grad(&self, xi: [f64; 2], dn: &mut [[f64; 2]; 4]);
    /// Reference coordinates of the nodes.
    fn node_coords(&self) -> &'static [[f64; 2]];
    /// Is a reference point inside the reference cell (with tolerance `tol`)?
    fn contains(&self, xi: [f64; 2], tol: f64) -> bool;
    /// The default rule for a stiffness matrix of this element.
    fn stiffness_rule(&self) -> QuadratureRule;
}

#[derive(Debug, Clone, Copy)]
pub struct Tri3;
#[derive(Debug, Clone, Copy)]
pub struct Quad4;

impl ReferenceElement for Tri3 {
    fn num_nodes(&self) -> usize {
        3
    }
    fn shape(&self, xi: [f64; 2], n: &mut [f64; 4]) {
        n[0] = 1.0 - xi[0] - xi[1];
        n[1] = xi[0];
        n[2] = xi[1];
        n[3] = 0.0;
    }
    fn shape_grad(&self, _xi: [f64; 2], dn: &mut [[f64; 2]; 4]) {
        dn[0] = [-1.0, -1.0];
        dn[1] = [1.0, 0.0];
        dn[2] = [0.0, 1.0];
        dn[3] = [0.0, 0.0];
    }
    fn node_coords(&self) -> &'static [[f64; 2]] {
        &[[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]
    }
    fn contains(&self, xi: [f64; 2], tol: f64) -> bool {
        xi[0] >= -tol && xi[1] >= -tol && xi[0] + xi[1] <= 1.0 + tol
    }
    fn stiffness_rule(&self) -> QuadratureRule {
        triangle_rule(1)
    }
}

impl ReferenceElement for Quad4 {
    fn num_nodes(&self) -> usize {
        4
    }
    fn shape(&self, xi: [f64; 2], n: &mut [f64; 4]) {
        let (x, y) = (xi[0], xi[1]);
        n[0] = 0.25 * (1.0 - x) * (1.0 - y);
        n[1] = 0.25 * (1.0 + x) * (1.0 - y);
        n[2] = 0.25 * (1.0 + x) * (1.0 + y);
        n[3] = 0.25 * (1.0 - x) * (1.0 + y);
    }
    fn shape_grad(&self, xi: [f64; 2], dn: &mut [[f64; 2]; 4]) {
        let (x, y) = (xi[0], xi[1]);
        dn[0] = [-0.25 * (1.0 - y), -0.25 * (1.0 - x)];
        dn[1] = [0.25 * (1.0 - y), -0.25 * (1.0 + x)];
        dn[2] = [0.25 * (1.0 + y), 0.25 * (1.0 + x)];
        dn[3] = [-0.25 * (1.0 + y), 0.25 * (1.0 - x)];
    }
    fn node_coords(&self) -> &'static [[f64; 2]] {
        &[[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]]
    }
    fn contains(&self, xi: [f64; 2], tol: f64) -> bool {
        xi[0].abs() <= 1.0 + tol && xi[1].abs() <= 1.0 + tol
    }
    fn stiffness_rule(&self) -> QuadratureRule {
        quad_gauss(2)
    }
}

/// Enum dispatch so that meshes with mixed cells use one code path.
impl ReferenceElement for CellKind {
    fn num_nodes(&self) -> usize {
        CellKind::num_nodes(*self)
    }
    fn shape(&self, xi: [f64; 2], n: &mut [f64; 4]) {
        match self {
            CellKind::Tri3 => Tri3.shape(xi, n),
            CellKind::Quad4 => Quad4.shape(xi, n),
        }
    }
    fn shape_grad(&self, xi: [f64; 2], dn: &mut [[f64; 2]; 4]) {
        match self {
            CellKind::Tri3 => Tri3.shape_grad(xi, dn),
            CellKind::Quad4 => Quad4.shape_grad(xi, dn),
        }
    }
    fn node_coords(&self) -> &'static [[f64; 2]] {
        match self {
            CellKind::Tri3 => Tri3.node_coords(),
            CellKind::Quad4 => Quad4.node_coords(),
        }
    }
    fn contains(&self, xi: [f64; 2], tol: f64) -> bool {
        match self {
            CellKind::Tri3 => Tri3.contains(xi, tol),
            CellKind::Quad4 => Quad4.contains(xi, tol),
        }
    }
    fn stiffness_rule(&self) -> QuadratureRule {
        match self {
            CellKind::Tri3 => Tri3.stiffness_rule(),
            CellKind::Quad4 => Quad4.stiffness_rule(),
        }
    }
}

/// Shape functions and physical gradients at one point of a mapped element.
#[derive(Debug, Clone, Copy, Default)]
pub struct ShapeEval {
    pub n: [f64; 4],
    /// `dN_i/dx`, `dN_i/dy`.
    pub grad: [[f64; 2]; 4],
    pub det_j: f64,
    pub x: Point2<f64>,
}

/// A reference element placed at physical corner coordinates.
#[derive(Debug, Clone, Copy)]
pub struct MappedElement<E: ReferenceElement> {
    pub element: E,
    pub coords: [Point2<f64>; 4],
}

impl<E: ReferenceElement> MappedElement<E> {
    pub fn new(element: E, coords: [Point2<f64>; 4]) -> Self {
        MappedElement { element, coords }
    }

    /// Physical position of a reference point.
    pub fn map(&self, xi: [f64; 2]) -> Point2<f64> {
        let mut n = [0.0; 4];
        self.element.shape(xi, &mut n);
        let mut x = Vector2::zeros();
        for (k, c) in self.coords.iter().take(self.element.num_nodes()).enumerate() {
            x += n[k] * c.coords;
        }
        Point2::from(x)
    }

    /// Jacobian `dx/dxi` (columns: derivative along xi, along eta).
    pub fn jacobian(&self, xi: [f64; 2]) -> Matrix2<f64> {
        let mut dn = [[0.0; 2]; 4];
        self.element.shape_grad(xi, &mut dn);
        let mut j = Matrix2::zeros();
        for (k, c) in self.coords.iter().take(self.element.num_nodes()).enumerate() {
            j[(0, 0)] += c.x * dn[k][0];
            j[(0, 1)] += c.x * dn[k][1];
            j[(1, 0)] += c.y * dn[k][0];
            j[(1, 1)] += c.y * dn[k][1];
        }
        j
    }

    /// Shape values, physical gradients and `det J` at `xi` (no allocation).
    pub fn eval(&self, xi: [f64; 2], out: &mut ShapeEval) {
        let nn = self.element.num_nodes();
        let mut dn = [[0.0; 2]; 4];
        self.element.shape(xi, &mut out.n);
        self.element.shape_grad(xi, &mut dn);
        let (mut j00, mut j01, mut j10, mut j11) = (0.0, 0.0, 0.0, 0.0);
        let mut x = Vector2::zeros();
        for k in 0..nn {
            let c = self.coords[k];
            j00 += c.x * dn[k][0];
            j01 += c.x * dn[k][1];
            j10 += c.y * dn[k][0];
            j11 += c.y * dn[k][1];
            x += out.n[k] * c.coords;
        }
        let det = j00 * j11 - j01 * j10;
        let inv = 1.0 / det;
        // grad N = J^{-T} dN/dxi
        for k in 0..nn {
            let (a, b) = (dn[k][0], dn[k][1]);
            out.grad[k] = [(j11 * a - j10 * b) * inv, (-j01 * a + j00 * b) * inv];
        }
        for k in nn..4 {
            out.grad[k] = [0.0, 0.0];
        }
        out.det_j = det;
        out.x = Point2::from(x);
    }

    /// Inverse map by Newton iteration (exact in one step for `Tri3`).
    /// Returns `None` if it does not converge (point far outside a strongly distorted cell).
    pub fn inverse_map(&self, x: Point2<f64>) -> Option<[f64; 2]> {
        let mut xi = [0.0, 0.0];
        if self.element.num_nodes() == 3 {
            xi = [1.0 / 3.0, 1.0 / 3.0];
        }
        let scale = (self.coords[1] - self.coords[0]).norm().max(f64::MIN_POSITIVE);
        // Converged at round-off: relative to the cell size, but never below the spacing of
        // floating-point numbers at `x` (small cells far from the origin).
        let tol = 1e-14 * scale + 8.0 * f64::EPSILON * x.coords.amax();
        for _ in 0..30 {
            let r = x - self.map(xi);
            let j = self.jacobian(xi);
            let d = j.try_inverse()? * r;
            xi[0] += d.x;
            xi[1] += d.y;
            if r.norm() <= tol {
                return Some(xi);
            }
        }
        None
    }
}

/// A straight two-node boundary segment `a -> b` (linear shape functions in `s in [0, 1]`).
#[derive(Debug, Clone, Copy)]
pub struct Seg2 {
    pub a: Point2<f64>,
    pub b: Point2<f64>,
}

impl Seg2 {
    pub fn length(&self) -> f64 {
        (self.b - self.a).norm()
    }
    pub fn shape(&self, s: f64) -> [f64; 2] {
        [1.0 - s, s]
    }
    pub fn point(&self, s: f64) -> Point2<f64> {
        self.a + (self.b - self.a) * s
    }
    /// Unit tangent `a -> b`.
    pub fn tangent(&self) -> Vector2<f64> {
        (self.b - self.a) / self.length()
    }
    /// Unit normal on the right of `a -> b` (outward when the cell is on the left).
    pub fn normal(&self) -> Vector2<f64> {
        let t = self.tangent();
        Vector2::new(t.y, -t.x)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn partition_of_unity_and_gradient_sum() {
        for kind in [CellKind::Tri3, CellKind::Quad4] {
            let xi = [0.13, -0.27_f64.abs() * 0.5];
            let mut n = [0.0; 4];
            let mut dn = [[0.0; 2]; 4];
            kind.shape(xi, &mut n);
            kind.shape_grad(xi, &mut dn);
            let s: f64 = n.iter().sum();
            let gx: f64 = dn.iter().map(|d| d[0]).sum();
            let gy: f64 = dn.iter().map(|d| d[1]).sum();
            assert!((s - 1.0).abs() < 1e-15 && gx.abs() < 1e-15 && gy.abs() < 1e-15);
        }
    }

    #[test]
    fn mapped_gradients_reproduce_linear_fields_and_inverse_map() {
        let coords = [Point2::new(0.1, 0.0), Point2::new(1.3, 0.2), Point2::new(1.1, 1.4), Point2::new(-0.2, 0.9)];
        let e = MappedElement::new(Quad4, coords);
        let f = |p: &Point2<f64>| 2.0 * p.x - 3.0 * p.y + 0.5;
        let mut ev = ShapeEval::default();
        e.eval([0.3, -0.6], &mut ev);
        let gx: f64 = (0..4).map(|k| ev.grad[k][0] * f(&coords[k])).sum();
        let gy: f64 = (0..4).map(|k| ev.grad[k][1] * f(&coords[k])).sum();
        assert!((gx - 2.0).abs() < 1e-13 && (gy + 3.0).abs() < 1e-13);
        let xi = e.inverse_map(e.map([0.3, -0.6])).expect("inside point");
        assert!((xi[0] - 0.3).abs() < 1e-12 && (xi[1] + 0.6).abs() < 1e-12);
    }
}
