//! Load curves and the cycle a cyclic load history repeats.

use super::*;

/// Piecewise-linear load factor `lambda(t)`; constant beyond its ends.
#[derive(Debug, Clone, PartialEq)]
pub struct LoadPath {
    pub points: Vec<(f64, f64)>,
}

impl LoadPath {
    pub fn new(points: Vec<(f64, f64)>) -> Result<Self, ModelError> {
        if points.is_empty() {
            return Err(ModelError::LoadPath("needs at least one (time, factor) point".into()));
        }
        for w in points.windows(2) {
            if w[1].0 <= w[0].0 {
                return Err(ModelError::LoadPath(format!("times must increase strictly ({} then {})", w[0].0, w[1].0)));
            }
        }
        if points.iter().any(|p| !p.0.is_finite() || !p.1.is_finite()) {
            return Err(ModelError::LoadPath("times and factors must be finite".into()));
        }
        Ok(LoadPath { points })
    }
    pub fn factor(&self, t: f64) -> f64 {
        let p = &self.points;
        if t <= p[0].0 {
            return p[0].1;
        }
        for w in p.windows(2) {
            if t <= w[1].0 {
                let s = (t - w[0].0) / (w[1].0 - w[0].0);
                return w[0].1 + s * (w[1].1 - w[0].1);
            }
        }
        p[p.len() - 1].1
    }
    pub fn end_time(&self) -> f64 {
        self.points[self.points.len() - 1].0
    }
}

/// A load history declared as one cycle repeated: every curve is evaluated at
/// `start + (t - start) mod period` beyond `start` (the part before it, e.g. the normal load,
/// runs once). Output steps carry `(cycle, increment)`: cycle 0 is the part before the window.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cycle {
    pub start: f64,
    pub period: f64,
    pub count: usize,
    /// Output steps per cycle, and before the window.
    pub increments: usize,
    pub ramp_increments: usize,
}

impl Cycle {
    /// Pseudo-time inside the first cycle that the curves see at time `t`.
    pub fn local_time(&self, t: f64) -> f64 {
        if t <= self.start + self.period {
            t
        } else {
            let r = (t - self.start).rem_euclid(self.period);
            // The end of a cycle is the end of the window, not its start (same factors for a
            // periodic history, but the window's last point is where the cycle ends).
            if r == 0.0 {
                self.start + self.period
            } else {
                self.start + r
            }
        }
    }
    /// Output times: `ramp_increments` steps up to `start`, then `increments` per cycle.
    pub fn times(&self, t0: f64) -> Vec<f64> {
        let mut v = Vec::with_capacity(self.ramp_increments + self.count * self.increments);
        if self.start > t0 {
            for i in 1..=self.ramp_increments {
                v.push(t0 + (self.start - t0) * i as f64 / self.ramp_increments as f64);
            }
        }
        for c in 0..self.count {
            for i in 1..=self.increments {
                v.push(self.start + self.period * (c as f64 + i as f64 / self.increments as f64));
            }
        }
        v
    }
    /// `(cycle, increment)` of output step `step` (1-based; cycle 0 is the part before the window).
    pub fn label(&self, step: usize, has_ramp: bool) -> (usize, usize) {
        let ramp = if has_ramp { self.ramp_increments } else { 0 };
        if step <= ramp {
            (0, step)
        } else {
            let k = step - ramp - 1;
            (k / self.increments + 1, k % self.increments + 1)
        }
    }
}
