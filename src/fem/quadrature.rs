//! Quadrature rules: Gauss-Legendre on `[-1, 1]`, tensor rules on the reference square
//! `[-1, 1]^2`, and rules on the reference triangle `(0,0), (1,0), (0,1)` (area 1/2).
//!
//! Triangle rules: degree 1 (centroid), 2 (3 points), 4 (Dunavant 6 points, also used for
//! degree 3 because Dunavant's degree-3 rule has a negative weight), 5 (Radon 7 points, closed
//! form), 6 (Dunavant 12 points); above 6 a collapsed (Duffy) Gauss rule of the needed order.
//! All weights are positive. Source: D.A. Dunavant, IJNME 21 (1985) 1129-1148.

/// Points (reference coordinates) and weights of a 2D rule.
#[derive(Debug, Clone, PartialEq)]
pub struct QuadratureRule {
    pub points: Vec<[f64; 2]>,
    pub weights: Vec<f64>,
}

impl QuadratureRule {
    pub fn len(&self) -> usize {
        self.weights.len()
    }
    pub fn is_empty(&self) -> bool {
        self.weights.is_empty()
    }
}

/// `n`-point Gauss-Legendre rule on `[-1, 1]`, exact for polynomials of degree `2n - 1`.
/// Nodes by Newton iteration on the Legendre polynomial (converges to round-off).
pub fn gauss_legendre(n: usize) -> (Vec<f64>, Vec<f64>) {
    assert!(n >= 1, "a Gauss rule needs at least one point");
    let mut x = vec![0.0; n];
    let mut w = vec![0.0; n];
    for i in 0..n.div_ceil(2) {
        // Tricomi's initial guess.
        let mut z = (std::f64::consts::PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
        let mut dp = 1.0;
        for _ in 0..100 {
            let (mut p0, mut p1) = (1.0, z);
            for k in 2..=n {
                let p2 = ((2 * k - 1) as f64 * z * p1 - (k - 1) as f64 * p0) / k as f64;
                p0 = p1;
                p1 = p2;
            }
            let pn = if n == 1 { z } else { p1 };
            let pm = if n == 1 { 1.0 } else { p0 };
            dp = n as f64 * (z * pn - pm) / (z * z - 1.0);
            let dz = pn / dp;
            z -= dz;
            if dz.abs() < 1e-16 {
                break;
            }
        }
        // Recompute the derivative at the converged node.
        let (mut p0, mut p1) = (1.0, z);
        for k in 2..=n {
            let p2 = ((2 * k - 1) as f64 * z * p1 - (k - 1) as f64 * p0) / k as f64;
            p0 = p1;
            p1 = p2;
        }
        if n > 1 {
            dp = n as f64 * (z * p1 - p0) / (z * z - 1.0);
        }
        let wi = 2.0 / ((1.0 - z * z) * dp * dp);
        x[i] = -z;
        x[n - 1 - i] = z;
        w[i] = wi;
        w[n - 1 - i] = wi;
    }
    if n % 2 == 1 {
        x[n / 2] = 0.0;
    }
    (x, w)
}

/// Tensor `n x n` Gauss rule on `[-1, 1]^2`, exact for `Q_{2n-1}`.
pub fn quad_gauss(n: usize) -> QuadratureRule {
    let (x, w) = gauss_legendre(n);
    let mut points = Vec::with_capacity(n * n);
    let mut weights = Vec::with_capacity(n * n);
    for j in 0..n {
        for i in 0..n {
            points.push([x[i], x[j]]);
            weights.push(w[i] * w[j]);
        }
    }
    QuadratureRule { points, weights }
}

fn push_orbit(r: &mut QuadratureRule, a: f64, b: f64, w: f64) {
    // All distinct permutations of barycentric (a, b, 1 - a - b).
    let c = 1.0 - a - b;
    let mut seen: Vec<[f64; 2]> = Vec::new();
    for (p, q) in [(a, b), (b, c), (c, a), (b, a), (c, b), (a, c)] {
        let pt = [p, q];
        if !seen.iter().any(|s| (s[0] - pt[0]).abs() < 1e-15 && (s[1] - pt[1]).abs() < 1e-15) {
            seen.push(pt);
            r.points.push(pt);
            r.weights.push(0.5 * w);
        }
    }
}

/// Rule on the reference triangle exact for polynomials of total degree `degree`.
pub fn triangle_rule(degree: usize) -> QuadratureRule {
    let mut r = QuadratureRule { points: vec![], weights: vec![] };
    match degree {
        0 | 1 => push_orbit(&mut r, 1.0 / 3.0, 1.0 / 3.0, 1.0),
        2 => push_orbit(&mut r, 1.0 / 6.0, 1.0 / 6.0, 1.0 / 3.0),
        3 | 4 => {
            push_orbit(&mut r, 0.445_948_490_915_965, 0.445_948_490_915_965, 0.223_381_589_678_011);
            push_orbit(&mut r, 0.091_576_213_509_771, 0.091_576_213_509_771, 0.109_951_743_655_322);
        }
        5 => {
            let s15 = 15f64.sqrt();
            push_orbit(&mut r, 1.0 / 3.0, 1.0 / 3.0, 0.225);
            let a = (6.0 + s15) / 21.0;
            let b = (6.0 - s15) / 21.0;
            push_orbit(&mut r, a, a, (155.0 + s15) / 1200.0);
            push_orbit(&mut r, b, b, (155.0 - s15) / 1200.0);
        }
        6 => {
            push_orbit(&mut r, 0.249_286_745_170_910, 0.249_286_745_170_910, 0.116_786_275_726_379);
            push_orbit(&mut r, 0.063_089_014_491_502, 0.063_089_014_491_502, 0.050_844_906_370_207);
            push_orbit(&mut r, 0.053_145_049_844_817, 0.310_352_451_033_784, 0.082_851_075_618_374);
        }
        p => return collapsed_triangle_rule(p),
    }
    r
}

/// Duffy-collapsed Gauss rule: `xi = s`, `eta = (1 - s) t`, Jacobian `1 - s`; exact for degree `p`.
pub fn collapsed_triangle_rule(p: usize) -> QuadratureRule {
    let n = (p + 2).div_ceil(2);
    let (x, w) = gauss_legendre(n);
    let mut r = QuadratureRule { points: vec![], weights: vec![] };
    for j in 0..n {
        for i in 0..n {
            let s = 0.5 * (x[i] + 1.0);
            let t = 0.5 * (x[j] + 1.0);
            r.points.push([s, (1.0 - s) * t]);
            r.weights.push(0.25 * w[i] * w[j] * (1.0 - s));
        }
    }
    r
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Exact integral of x^i y^j over the reference triangle: i! j! / (i + j + 2)!.
    fn tri_moment(i: u32, j: u32) -> f64 {
        let f = |n: u32| (1..=n).map(|k| k as f64).product::<f64>();
        f(i) * f(j) / f(i + j + 2)
    }

    #[test]
    fn gauss_legendre_exact_to_degree_2n_minus_1() {
        for n in 1..=10 {
            let (x, w) = gauss_legendre(n);
            for p in 0..(2 * n) as i32 {
                let q: f64 = x.iter().zip(&w).map(|(x, w)| w * x.powi(p)).sum();
                let exact = if p % 2 == 1 { 0.0 } else { 2.0 / (p as f64 + 1.0) };
                // Round-off only: 1e-14 absolute on O(1) integrals.
                assert!((q - exact).abs() < 1e-14, "n={n} p={p}: {q} vs {exact}");
            }
        }
    }

    #[test]
    fn quad_rules_integrate_tensor_monomials() {
        for n in 1..=6 {
            let r = quad_gauss(n);
            for i in 0..(2 * n) as i32 {
                for j in 0..(2 * n) as i32 {
                    let q: f64 = r.points.iter().zip(&r.weights).map(|(p, w)| w * p[0].powi(i) * p[1].powi(j)).sum();
                    let m = |k: i32| {
                        if k % 2 == 1 {
                            0.0
                        } else {
                            2.0 / (k as f64 + 1.0)
                        }
                    };
                    assert!((q - m(i) * m(j)).abs() < 1e-13, "n={n} i={i} j={j}");
                }
            }
        }
    }

    #[test]
    fn triangle_rules_exact_to_their_degree_with_positive_weights() {
        for deg in 1..=10 {
            let r = triangle_rule(deg);
            assert!(r.weights.iter().all(|&w| w > 0.0), "degree {deg} has a non-positive weight");
            for i in 0..=deg as u32 {
                for j in 0..=(deg as u32 - i) {
                    let q: f64 = r
                        .points
                        .iter()
                        .zip(&r.weights)
                        .map(|(p, w)| w * p[0].powi(i as i32) * p[1].powi(j as i32))
                        .sum();
                    let e = tri_moment(i, j);
                    // Dunavant's tables carry 15 significant digits: 1e-13 relative.
                    assert!((q - e).abs() <= 1e-13 * e.max(1e-3), "degree {deg}: x^{i} y^{j}: {q} vs {e}");
                }
            }
        }
    }
}
