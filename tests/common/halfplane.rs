//! An independent reference for fretting wear of a cylinder on a flat: both bodies as elastic
//! half-planes (plane strain), the pressure on uniform panels, both surfaces worn by Archard's
//! law, the flat slid under the held cylinder. No finite elements, no mortar, no cycle jump.
//!
//! Surface deflection of a half-plane under a pressure `p(s)`, both bodies together (Johnson,
//! Contact Mechanics, 1985, eq. 2.25b; `1/E* = (1 - nu1^2)/E1 + (1 - nu2^2)/E2`):
//! `v(x) = -(2 / (pi E*)) int p(s) ln|x - s| ds + C`, so a uniform pressure on the panel
//! `[x_j - h/2, x_j + h/2]` gives at `x_i` the influence coefficient
//! `K_ij = -(2 / (pi E*)) [F(r + h/2) - F(r - h/2)]`, `r = x_i - x_j`, `F(t) = t ln|t| - t`.
//! In the cylinder's frame the gap at panel `i` with the flat slid by `s` is
//! `g_i = x_i^2 / 2R + w_cyl(x_i) + w_flat(x_i - s) + (K p)_i - delta`, with
//! `p >= 0, g >= 0, p g = 0` and `h sum p = P` (the approach `delta` absorbs `C`); solved by
//! active sets, each a Cholesky of `K` on the contact (SPD: the contact is far shorter than
//! 4 length units, Johnson sec. 2.9).
//!
//! Wear per increment from `s0` to `s1` (Archard, `dw = k p |ds|`): the pressure is taken
//! linear in `s` between the increment's start and end, the cylinder's point `x_i` sees it for
//! `|s1 - s0|`, and the flat's material point `X` is swept under it, `x = X + s`
//! (`substeps` midpoint samples of `s`). The geometry is updated after every increment, which
//! is explicit Euler far below its stability bound (the stiffest mode, a panel-scale ripple,
//! has `E* pi / (2 h)`: with the figures of the McColl scene it loses 4% of itself per
//! increment at 8 increments per cycle, against 200% for instability).

use nalgebra::{DMatrix, DVector};

/// The scene and its discretisation (lengths in mm, pressures in MPa, load in N/mm).
#[derive(Debug, Clone)]
pub struct HalfPlaneFretting {
    pub radius: f64,
    pub load: f64,
    pub e_star: f64,
    /// Stroke amplitude: the flat goes 0 -> +stroke -> -stroke -> 0 each cycle.
    pub stroke: f64,
    pub k_flat: f64,
    pub k_cylinder: f64,
    /// Panel width and the half-width of the window of panels in the cylinder's frame.
    pub panel: f64,
    pub window: f64,
    pub increments: usize,
    pub substeps: usize,
}

/// State of the model: panel centres (cylinder frame), the cylinder's depth there, the flat's
/// material grid and depth, and the latest pressure.
#[derive(Debug, Clone)]
pub struct HalfPlaneState {
    pub x: Vec<f64>,
    pub cylinder_depth: Vec<f64>,
    pub flat_x: Vec<f64>,
    pub flat_depth: Vec<f64>,
    pub pressure: Vec<f64>,
}

impl HalfPlaneState {
    /// Linear interpolation of the flat's depth at material point `xm` (0 off the grid).
    fn flat_depth_at(&self, xm: f64) -> f64 {
        interpolate(&self.flat_x, &self.flat_depth, xm)
    }
}

/// Piecewise-linear interpolation on an increasing uniform grid, 0 outside.
fn interpolate(xs: &[f64], ys: &[f64], x: f64) -> f64 {
    let n = xs.len();
    let h = xs[1] - xs[0];
    let t = (x - xs[0]) / h;
    if t < 0.0 || t > (n - 1) as f64 {
        return 0.0;
    }
    let i = (t.floor() as usize).min(n - 2);
    let f = t - i as f64;
    ys[i] * (1.0 - f) + ys[i + 1] * f
}

/// Stroke position of the flat at cycle fraction `t` in [0, 1]: a triangle 0 -> 1 -> -1 -> 0.
pub fn stroke_shape(t: f64) -> f64 {
    if t <= 0.25 {
        4.0 * t
    } else if t <= 0.75 {
        2.0 - 4.0 * t
    } else {
        4.0 * t - 4.0
    }
}

/// A piecewise-linear profile through points given in any order, 0 outside them.
pub struct Profile(Vec<(f64, f64)>);

impl Profile {
    pub fn new(x: &[f64], v: &[f64]) -> Self {
        let mut o: Vec<(f64, f64)> = x.iter().cloned().zip(v.iter().cloned()).collect();
        o.sort_by(|a, b| a.0.total_cmp(&b.0));
        Profile(o)
    }

    pub fn at(&self, t: f64) -> f64 {
        let o = &self.0;
        let k = o.partition_point(|p| p.0 < t);
        if k == 0 || k == o.len() {
            return 0.0;
        }
        let (a, b) = (o[k - 1], o[k]);
        a.1 + (b.1 - a.1) * (t - a.0) / (b.0 - a.0)
    }
}

impl HalfPlaneFretting {
    fn influence(&self, x: &[f64]) -> DMatrix<f64> {
        let f = |t: f64| if t == 0.0 { 0.0 } else { t * t.abs().ln() - t };
        let (h, c) = (self.panel, 2.0 / (std::f64::consts::PI * self.e_star));
        DMatrix::from_fn(x.len(), x.len(), |i, j| {
            let r = x[i] - x[j];
            -c * (f(r + 0.5 * h) - f(r - 0.5 * h))
        })
    }

    /// Pressure for the gap without load `gap0` (active-set iteration from `active`).
    fn contact(&self, k: &DMatrix<f64>, gap0: &[f64], active: &mut [bool]) -> Vec<f64> {
        let n = gap0.len();
        if !active.iter().any(|&a| a) {
            let m = gap0.iter().cloned().fold(f64::INFINITY, f64::min);
            for i in 0..n {
                active[i] = gap0[i] <= m + 1e-4;
            }
        }
        for _ in 0..200 {
            let a: Vec<usize> = (0..n).filter(|&i| active[i]).collect();
            let kaa = DMatrix::from_fn(a.len(), a.len(), |i, j| k[(a[i], a[j])]);
            let chol = kaa.cholesky().expect("half-plane influence matrix on the contact is SPD");
            let y = chol.solve(&DVector::from_iterator(a.len(), a.iter().map(|&i| gap0[i])));
            let z = chol.solve(&DVector::from_element(a.len(), 1.0));
            // K p = delta - gap0 on the contact, h sum p = P.
            let delta = (self.load / self.panel + y.sum()) / z.sum();
            let mut p = vec![0.0; n];
            for (r, &i) in a.iter().enumerate() {
                p[i] = delta * z[r] - y[r];
            }
            let mut changed = false;
            for &i in &a {
                if p[i] < 0.0 {
                    active[i] = false;
                    changed = true;
                }
            }
            if !changed {
                let open: Vec<usize> = (0..n).filter(|&i| !active[i]).collect();
                for i in open {
                    let g = gap0[i] + a.iter().map(|&j| k[(i, j)] * p[j]).sum::<f64>() - delta;
                    if g < -1e-12 {
                        active[i] = true;
                        changed = true;
                    }
                }
            }
            if !changed {
                return p;
            }
        }
        panic!("half-plane contact: active set did not settle in 200 iterations");
    }

    /// A state on this model's grids with the given depth profiles, no pressure yet.
    pub fn state_with(&self, cylinder: &Profile, flat: &Profile) -> HalfPlaneState {
        let grid = |w: f64| {
            let n = (2.0 * w / self.panel).round() as usize + 1;
            (0..n).map(|i| -w + i as f64 * self.panel).collect::<Vec<f64>>()
        };
        let (x, flat_x) = (grid(self.window), grid(self.window + self.stroke));
        HalfPlaneState {
            cylinder_depth: x.iter().map(|&t| cylinder.at(t)).collect(),
            flat_depth: flat_x.iter().map(|&t| flat.at(t)).collect(),
            pressure: vec![0.0; x.len()],
            x,
            flat_x,
        }
    }

    /// The pressure of `st`'s worn geometry with the flat slid by `s`.
    pub fn pressure_at(&self, st: &HalfPlaneState, s: f64) -> Vec<f64> {
        let k = self.influence(&st.x);
        let gap0: Vec<f64> =
            st.x.iter()
                .zip(&st.cylinder_depth)
                .map(|(&x, &w)| x * x / (2.0 * self.radius) + w + st.flat_depth_at(x - s))
                .collect();
        self.contact(&k, &gap0, &mut vec![false; st.x.len()])
    }

    /// Runs `cycles` cycles; `record(cycle, increment, s, state)` sees the state after every
    /// increment's contact solve (cycle 0: the static state before sliding).
    pub fn run(&self, cycles: usize, mut record: impl FnMut(usize, usize, f64, &HalfPlaneState)) -> HalfPlaneState {
        let h = self.panel;
        let n = (2.0 * self.window / h).round() as usize + 1;
        let x: Vec<f64> = (0..n).map(|i| -self.window + i as f64 * h).collect();
        let nf = (2.0 * (self.window + self.stroke) / h).round() as usize + 1;
        let flat_x: Vec<f64> = (0..nf).map(|i| -self.window - self.stroke + i as f64 * h).collect();
        let k = self.influence(&x);
        let mut st = HalfPlaneState {
            cylinder_depth: vec![0.0; n],
            flat_depth: vec![0.0; nf],
            pressure: vec![0.0; n],
            x,
            flat_x,
        };
        let mut active = vec![false; n];
        let gap0 = |st: &HalfPlaneState, s: f64| -> Vec<f64> {
            (0..n)
                .map(|i| st.x[i] * st.x[i] / (2.0 * self.radius) + st.cylinder_depth[i] + st.flat_depth_at(st.x[i] - s))
                .collect()
        };
        st.pressure = self.contact(&k, &gap0(&st, 0.0), &mut active);
        record(0, 0, 0.0, &st);
        let mut s0 = 0.0;
        for cycle in 1..=cycles {
            for inc in 1..=self.increments {
                let s1 = self.stroke * stroke_shape(inc as f64 / self.increments as f64);
                let p0 = st.pressure.clone();
                let p1 = self.contact(&k, &gap0(&st, s1), &mut active);
                let ds = (s1 - s0).abs();
                for i in 0..n {
                    st.cylinder_depth[i] += self.k_cylinder * 0.5 * (p0[i] + p1[i]) * ds;
                }
                let m = self.substeps;
                for (xm, w) in st.flat_x.clone().iter().zip(st.flat_depth.iter_mut()) {
                    let mut swept = 0.0;
                    for q in 0..m {
                        let f = (q as f64 + 0.5) / m as f64;
                        let s = s0 + f * (s1 - s0);
                        let p = (1.0 - f) * interpolate(&st.x, &p0, xm + s) + f * interpolate(&st.x, &p1, xm + s);
                        swept += p * ds / m as f64;
                    }
                    *w += self.k_flat * swept;
                }
                st.pressure = p1;
                s0 = s1;
                record(cycle, inc, s1, &st);
            }
        }
        st
    }
}
