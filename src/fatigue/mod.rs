//! Fatigue at a material point: the Smith-Watson-Topper critical-plane parameter of a
//! stress-strain history and the life it gives through the Basquin-Coffin-Manson relation.
//!
//! **Critical plane (SWT).** For a history of in-plane stress and strain tensors at one point
//! (`[xx, yy, zz, xy]`, tensor shear components, as [`crate::fem::material::Stress4`]), on
//! the plane of in-plane unit normal `n = (cos t, sin t)` the normal stress and strain are
//! `s_n = n . s . n`, `e_n = n . e . n`, and
//!
//! ```text
//! SWT(t) = max_k s_n(t, k) * (max_k e_n(t, k) - min_k e_n(t, k)) / 2
//! SWT    = max over t in [0, pi) of SWT(t)      (the critical plane's angle t*)
//! ```
//!
//! (Smith, Watson & Topper, J. Materials 5 (1970) 767; as a critical-plane parameter in
//! fretting: Szolwinski & Farris, Wear 198 (1996) 93). Planes containing the out-of-plane
//! axis only: the plane-strain and plane-stress scenes of this engine load those.
//!
//! **Life.** The Basquin-Coffin-Manson strain-life relation with the mean-stress correction
//! of SWT:
//!
//! ```text
//! SWT = (sigma_f'^2 / E) (2 N)^(2 b) + sigma_f' eps_f' (2 N)^(b + c)
//! ```
//!
//! solved for `N` (cycles to crack initiation): the right-hand side falls strictly with `N`
//! (`b, c < 0`), so the root is unique; it is found by Newton's method on `ln(2 N)`, kept in a
//! bracket that bisection narrows whenever a Newton step would leave it.

use crate::fem::material::Stress4;

mod points;
pub use points::{distance_to_polylines, CycleFatigue, FatigueModel, FatiguePoint, FatigueState, Initiation, RECORD};

/// Fatigue constants of a material (strain-life): `E`, `sigma_f'`, `b`, `eps_f'`, `c`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StrainLife {
    pub young: f64,
    /// Fatigue strength coefficient (a stress).
    pub sigma_f: f64,
    /// Fatigue strength exponent (negative).
    pub b: f64,
    /// Fatigue ductility coefficient.
    pub eps_f: f64,
    /// Fatigue ductility exponent (negative).
    pub c: f64,
}

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FatigueError {
    #[error("strain-life constants: {what} must be {must}, got {value}")]
    Constants { what: &'static str, must: &'static str, value: f64 },
    #[error("the SWT parameter must be finite and >= 0, got {0}")]
    Parameter(f64),
    #[error("an empty stress-strain history (or stress and strain of different lengths: {stress} and {strain})")]
    History { stress: usize, strain: usize },
    #[error("fatigue of body '{body}': no integration point of its cells lies in the region")]
    NoPoints { body: String },
}

/// Cycles beyond which a life is reported as infinite (the relation is extrapolated far past
/// any test data there).
pub const ENDURANCE_CYCLES: f64 = 1e12;

impl StrainLife {
    fn check(&self) -> Result<(), FatigueError> {
        let positive = [("young", self.young), ("sigma_f", self.sigma_f), ("eps_f", self.eps_f)];
        for (what, value) in positive {
            if !(value.is_finite() && value > 0.0) {
                return Err(FatigueError::Constants { what, must: "finite and > 0", value });
            }
        }
        for (what, value) in [("b", self.b), ("c", self.c)] {
            if !(value.is_finite() && value < 0.0) {
                return Err(FatigueError::Constants { what, must: "finite and < 0", value });
            }
        }
        Ok(())
    }

    /// The SWT value of the relation at `2 N = reversals`.
    pub fn swt_at(&self, reversals: f64) -> f64 {
        self.sigma_f * self.sigma_f / self.young * reversals.powf(2.0 * self.b)
            + self.sigma_f * self.eps_f * reversals.powf(self.b + self.c)
    }

    /// Cycles to crack initiation `N` at an SWT value (`f64::INFINITY` beyond
    /// [`ENDURANCE_CYCLES`]; half a cycle at most where the SWT exceeds the relation's value
    /// at one reversal).
    pub fn life(&self, swt: f64) -> Result<f64, FatigueError> {
        self.check()?;
        if !(swt.is_finite() && swt >= 0.0) {
            return Err(FatigueError::Parameter(swt));
        }
        let (mut lo, mut hi) = (0.0_f64, (2.0 * ENDURANCE_CYCLES).ln());
        if swt >= self.swt_at(1.0) {
            return Ok(0.5);
        }
        if swt <= self.swt_at(hi.exp()) {
            return Ok(f64::INFINITY);
        }
        // f(x) = swt_at(e^x) - swt, falling in x = ln(2 N); f(lo) > 0 > f(hi).
        let f = |x: f64| self.swt_at(x.exp()) - swt;
        let df = |x: f64| {
            let r = x.exp();
            2.0 * self.b * self.sigma_f * self.sigma_f / self.young * r.powf(2.0 * self.b)
                + (self.b + self.c) * self.sigma_f * self.eps_f * r.powf(self.b + self.c)
        };
        let mut x = 0.5 * (lo + hi);
        for _ in 0..300 {
            let fx = f(x);
            if fx.abs() <= 1e-15 * swt {
                break;
            }
            if fx > 0.0 {
                lo = x;
            } else {
                hi = x;
            }
            let next = x - fx / df(x);
            x = if next > lo && next < hi { next } else { 0.5 * (lo + hi) };
            if hi - lo <= 1e-15 * hi.abs().max(1.0) {
                break;
            }
        }
        Ok(0.5 * x.exp())
    }
}

/// The critical plane of a history: its SWT value, the in-plane angle `t*` of its normal in
/// `[0, pi)` (radians, from `x`), and the largest normal stress on it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CriticalPlane {
    pub swt: f64,
    pub angle: f64,
    pub sigma_max: f64,
}

/// A tensor `[xx, yy, zz, xy]` in Mohr's form `(mean, half difference, shear)`: its normal
/// component on the in-plane normal at angle `t` is `mean + half_difference cos 2t + shear sin 2t`
/// (two multiply-adds per plane, the history's tensors converted once).
fn mohr(t: &Stress4) -> [f64; 3] {
    [0.5 * (t[0] + t[1]), 0.5 * (t[0] - t[1]), t[3]]
}

/// SWT on the plane at `angle` over a history in Mohr's form, and the largest normal stress.
fn swt_on_plane(stress: &[[f64; 3]], strain: &[[f64; 3]], angle: f64) -> (f64, f64) {
    let (s2, c2) = (2.0 * angle).sin_cos();
    let normal = |m: &[f64; 3]| m[0] + m[1] * c2 + m[2] * s2;
    let sigma_max = stress.iter().map(normal).fold(f64::NEG_INFINITY, f64::max);
    let (e_min, e_max) =
        strain.iter().map(normal).fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| (lo.min(v), hi.max(v)));
    (sigma_max * 0.5 * (e_max - e_min), sigma_max)
}

/// Planes searched first (every `pi / PLANES`, 3 degrees: each factor of `SWT(t)` is a
/// trigonometric polynomial in `2 t` whose peaks are tens of degrees wide), then refined
/// around the best by golden sections to `1e-10` rad.
pub const PLANES: usize = 60;

/// The SWT critical plane of a stress and strain history at one point (one entry per instant
/// of a cycle, tensor components `[xx, yy, zz, xy]`). A negative largest normal stress gives a
/// negative value on that plane (no opening: no SWT damage).
pub fn critical_plane(stress: &[Stress4], strain: &[Stress4]) -> Result<CriticalPlane, FatigueError> {
    if stress.is_empty() || stress.len() != strain.len() {
        return Err(FatigueError::History { stress: stress.len(), strain: strain.len() });
    }
    let (stress, strain): (Vec<[f64; 3]>, Vec<[f64; 3]>) =
        (stress.iter().map(mohr).collect(), strain.iter().map(mohr).collect());
    let (stress, strain) = (stress.as_slice(), strain.as_slice());
    let value = |a: f64| swt_on_plane(stress, strain, a).0;
    let step = std::f64::consts::PI / PLANES as f64;
    let best = (0..PLANES).map(|i| i as f64 * step).fold((0.0, f64::NEG_INFINITY), |(ba, bv), a| {
        let v = value(a);
        if v > bv {
            (a, v)
        } else {
            (ba, bv)
        }
    });
    // Golden-section refinement over the neighbouring planes.
    let (mut lo, mut hi) = (best.0 - step, best.0 + step);
    let g = 0.5 * (5.0_f64.sqrt() - 1.0);
    let (mut x1, mut x2) = (hi - g * (hi - lo), lo + g * (hi - lo));
    let (mut f1, mut f2) = (value(x1), value(x2));
    while hi - lo > 1e-10 {
        if f1 < f2 {
            lo = x1;
            (x1, f1) = (x2, f2);
            x2 = lo + g * (hi - lo);
            f2 = value(x2);
        } else {
            hi = x2;
            (x2, f2) = (x1, f1);
            x1 = hi - g * (hi - lo);
            f1 = value(x1);
        }
    }
    let refined = 0.5 * (lo + hi);
    let angle = if value(refined) >= best.1 { refined } else { best.0 };
    let angle = angle.rem_euclid(std::f64::consts::PI);
    let (swt, sigma_max) = swt_on_plane(stress, strain, angle);
    Ok(CriticalPlane { swt, angle, sigma_max })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    /// Strain-life constants of the order of a titanium alloy's (illustrative: the tests check
    /// the root and the planes, not a material).
    const TI64: StrainLife = StrainLife { young: 116000.0, sigma_f: 2030.0, b: -0.104, eps_f: 0.841, c: -0.688 };

    /// The life is the root of the relation: put back into it, the SWT value is recovered to
    /// 1e-8 relative, against an independent root by plain bisection on `N` too.
    #[test]
    fn life_is_the_root_of_the_strain_life_relation() -> Result<(), FatigueError> {
        for n in [10.0, 1e3, 1e5, 1e7, 1e9] {
            let swt = TI64.swt_at(2.0 * n);
            let life = TI64.life(swt)?;
            assert!((life / n - 1.0).abs() < 1e-8, "N = {n}: life {life}");
            assert!((TI64.swt_at(2.0 * life) / swt - 1.0).abs() < 1e-8);
            // Independent root: bisection on log10 N.
            let (mut lo, mut hi) = (0.0_f64, 12.0_f64);
            for _ in 0..200 {
                let mid = 0.5 * (lo + hi);
                if TI64.swt_at(2.0 * 10f64.powf(mid)) > swt {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            assert!((life / 10f64.powf(0.5 * (lo + hi)) - 1.0).abs() < 1e-8, "N = {n}");
        }
        assert_eq!(TI64.life(TI64.swt_at(1e20))?, f64::INFINITY);
        assert_eq!(TI64.life(1e6)?, 0.5);
        assert!(matches!(TI64.life(-1.0), Err(FatigueError::Parameter(_))));
        let bad = StrainLife { b: 0.1, ..TI64 };
        assert!(matches!(bad.life(1.0), Err(FatigueError::Constants { what: "b", .. })));
        Ok(())
    }

    /// Uniaxial cyclic stress `s_xx = s_max sin(w t)` with its elastic strain (plane stress,
    /// E, nu): the critical plane is normal to the load (angle 0) and SWT = s_max * eps_a,
    /// eps_a = s_max / E, to 1e-12.
    #[test]
    fn uniaxial_cycle_gives_sigma_max_times_strain_amplitude_normal_to_the_load() -> Result<(), FatigueError> {
        let (e, nu, s_max) = (200000.0, 0.3, 300.0);
        let (stress, strain): (Vec<Stress4>, Vec<Stress4>) = (0..64)
            .map(|k| {
                let s = s_max * (2.0 * PI * k as f64 / 64.0).sin();
                (Stress4::new(s, 0.0, 0.0, 0.0), Stress4::new(s / e, -nu * s / e, -nu * s / e, 0.0))
            })
            .unzip();
        let cp = critical_plane(&stress, &strain)?;
        assert!((cp.swt / (s_max * s_max / e) - 1.0).abs() < 1e-12, "{cp:?}");
        assert!(cp.angle.min(PI - cp.angle) < 1e-6, "{cp:?}");
        assert!((cp.sigma_max / s_max - 1.0).abs() < 1e-12);
        Ok(())
    }

    /// Pure cyclic shear `s_xy = tau sin(w t)`: the normal stress peaks on the planes at 45 and
    /// 135 degrees (`s_n = tau sin 2t`), where SWT = tau * tau / (2 G): the critical plane is
    /// found at one of them to 1e-6 rad, its value to 1e-12.
    #[test]
    fn pure_shear_finds_the_planes_at_45_degrees() -> Result<(), FatigueError> {
        let (g, tau) = (80000.0, 200.0);
        let (stress, strain): (Vec<Stress4>, Vec<Stress4>) = (0..64)
            .map(|k| {
                let s = tau * (2.0 * PI * k as f64 / 64.0 + 0.1).sin();
                (Stress4::new(0.0, 0.0, 0.0, s), Stress4::new(0.0, 0.0, 0.0, s / (2.0 * g)))
            })
            .unzip();
        let cp = critical_plane(&stress, &strain)?;
        let to_45 = (cp.angle - PI / 4.0).abs().min((cp.angle - 3.0 * PI / 4.0).abs());
        assert!(to_45 < 1e-6, "{cp:?}");
        // On the sampled history: at 45 degrees s_n = s_xy, e_n = e_xy; at 135 their opposites.
        let s_max = stress.iter().map(|s| s[3]).fold(f64::NEG_INFINITY, f64::max);
        let s_min = stress.iter().map(|s| s[3]).fold(f64::INFINITY, f64::min);
        let expected = s_max.max(-s_min) * (s_max - s_min) / (2.0 * g) / 2.0;
        assert!((cp.swt / expected - 1.0).abs() < 1e-12, "{cp:?} against {expected}");
        assert!(matches!(critical_plane(&stress, &strain[1..]), Err(FatigueError::History { .. })));
        Ok(())
    }
}
