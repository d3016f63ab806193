//! Constitutive laws at one material point, small strain.
//!
//! Voigt convention used everywhere in the engine: strain `[e_xx, e_yy, e_zz, g_xy]` with the
//! engineering shear `g_xy = 2 e_xy`, stress `[s_xx, s_yy, s_zz, s_xy]`; the tangent `D` maps
//! the one to the other (`D[a][b] = C_ijkl` for the pairs of `a` and `b`, no factors).
//!
//! * [`Elastic`]: isotropic, plane strain (`e_zz = 0`, `s_zz = lambda tr e`) or plane stress
//!   (`s_zz = 0`; the `e_zz` row is inert).
//! * [`J2Plastic`]: von Mises plasticity with linear isotropic (`K`) and linear kinematic
//!   (Prager, `H`) hardening, plane strain, implicit radial return with its consistent tangent
//!   (Simo & Hughes, *Computational Inelasticity*, 1998, Box 3.2 and eq. 3.3.13):
//!   `xi_tr = dev(sigma_tr) - beta_n`, `f = |xi_tr| - sqrt(2/3) (sigma_y + K alpha_n)`,
//!   `dgamma = f / (2 mu (1 + (K + H) / (3 mu)))`, `n = xi_tr / |xi_tr|`,
//!   `sigma = kappa tr(e) 1 + s_tr - 2 mu dgamma n`, `beta += 2/3 H dgamma n`,
//!   `alpha += sqrt(2/3) dgamma`, `eps_p += dgamma n`;
//!   `C = kappa 1(x)1 + 2 mu theta I_dev - 2 mu theta_bar n(x)n`,
//!   `theta = 1 - 2 mu dgamma / |xi_tr|`, `theta_bar = 1 / (1 + (K + H)/(3 mu)) - (1 - theta)`.

use nalgebra::{Matrix4, Vector4};

pub type Strain4 = Vector4<f64>;
pub type Stress4 = Vector4<f64>;
pub type Tangent4 = Matrix4<f64>;

/// In-plane modelling hypothesis.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PlaneHypothesis {
    PlaneStrain,
    PlaneStress,
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Elastic {
    pub young: f64,
    pub poisson: f64,
    pub hypothesis: PlaneHypothesis,
}

impl Elastic {
    pub fn shear_modulus(&self) -> f64 {
        self.young / (2.0 * (1.0 + self.poisson))
    }
    pub fn bulk_modulus(&self) -> f64 {
        self.young / (3.0 * (1.0 - 2.0 * self.poisson))
    }
    pub fn lame_lambda(&self) -> f64 {
        self.young * self.poisson / ((1.0 + self.poisson) * (1.0 - 2.0 * self.poisson))
    }
    /// Effective plane-strain modulus `E / (1 - nu^2)` (plane stress: `E`).
    pub fn plane_modulus(&self) -> f64 {
        match self.hypothesis {
            PlaneHypothesis::PlaneStrain => self.young / (1.0 - self.poisson * self.poisson),
            PlaneHypothesis::PlaneStress => self.young,
        }
    }

    pub fn tangent(&self) -> Tangent4 {
        let (e, nu) = (self.young, self.poisson);
        match self.hypothesis {
            PlaneHypothesis::PlaneStrain => {
                let l = self.lame_lambda();
                let m = self.shear_modulus();
                Matrix4::new(
                    l + 2.0 * m,
                    l,
                    l,
                    0.0, //
                    l,
                    l + 2.0 * m,
                    l,
                    0.0, //
                    l,
                    l,
                    l + 2.0 * m,
                    0.0, //
                    0.0,
                    0.0,
                    0.0,
                    m,
                )
            }
            PlaneHypothesis::PlaneStress => {
                let c = e / (1.0 - nu * nu);
                Matrix4::new(
                    c,
                    c * nu,
                    0.0,
                    0.0, //
                    c * nu,
                    c,
                    0.0,
                    0.0, //
                    0.0,
                    0.0,
                    0.0,
                    0.0, //
                    0.0,
                    0.0,
                    0.0,
                    c * (1.0 - nu) / 2.0,
                )
            }
        }
    }
}

/// History of a plastic point: plastic strain and back stress as tensor components
/// `[xx, yy, zz, xy]` (no factor 2 on the shear), equivalent plastic strain `alpha`.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct PlasticState {
    pub eps_p: [f64; 4],
    pub back: [f64; 4],
    pub alpha: f64,
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct J2Plastic {
    pub elastic: Elastic,
    pub yield_stress: f64,
    /// Linear isotropic hardening modulus `K` (yield stress grows by `K alpha`).
    pub isotropic_hardening: f64,
    /// Linear kinematic hardening modulus `H` (Prager: `d beta = 2/3 H d eps_p`).
    pub kinematic_hardening: f64,
}

/// Tensor norm of a symmetric 3x3 tensor stored as `[xx, yy, zz, xy]` (plane: xz = yz = 0).
fn tnorm(t: &[f64; 4]) -> f64 {
    (t[0] * t[0] + t[1] * t[1] + t[2] * t[2] + 2.0 * t[3] * t[3]).sqrt()
}

impl J2Plastic {
    /// Radial return from `old` for the total strain `eps` (Voigt). Writes the stress, the
    /// consistent tangent and the updated history (`new`); `old` is never modified, so a failed
    /// Newton step leaves the converged history intact. Returns whether the point yielded.
    pub fn update(
        &self,
        eps: &Strain4,
        old: &PlasticState,
        new: &mut PlasticState,
        sigma: &mut Stress4,
        d: &mut Tangent4,
    ) -> bool {
        let mu = self.elastic.shear_modulus();
        let kappa = self.elastic.bulk_modulus();
        let (k_iso, h_kin) = (self.isotropic_hardening, self.kinematic_hardening);
        // Elastic trial strain, tensor components.
        let ee = [eps[0] - old.eps_p[0], eps[1] - old.eps_p[1], eps[2] - old.eps_p[2], 0.5 * eps[3] - old.eps_p[3]];
        let tr = ee[0] + ee[1] + ee[2];
        let s_tr = [
            2.0 * mu * (ee[0] - tr / 3.0),
            2.0 * mu * (ee[1] - tr / 3.0),
            2.0 * mu * (ee[2] - tr / 3.0),
            2.0 * mu * ee[3],
        ];
        let xi = [s_tr[0] - old.back[0], s_tr[1] - old.back[1], s_tr[2] - old.back[2], s_tr[3] - old.back[3]];
        let xi_norm = tnorm(&xi);
        let radius = (2.0f64 / 3.0).sqrt() * (self.yield_stress + k_iso * old.alpha);
        let f = xi_norm - radius;
        if f <= 0.0 {
            *new = *old;
            for a in 0..4 {
                sigma[a] = kappa * tr * if a < 3 { 1.0 } else { 0.0 } + s_tr[a];
            }
            *d = self.elastic.tangent();
            return false;
        }
        let denom = 2.0 * mu * (1.0 + (k_iso + h_kin) / (3.0 * mu));
        let dgamma = f / denom;
        let n = [xi[0] / xi_norm, xi[1] / xi_norm, xi[2] / xi_norm, xi[3] / xi_norm];
        for a in 0..4 {
            let vol = if a < 3 { kappa * tr } else { 0.0 };
            sigma[a] = vol + s_tr[a] - 2.0 * mu * dgamma * n[a];
            new.back[a] = old.back[a] + 2.0 / 3.0 * h_kin * dgamma * n[a];
            new.eps_p[a] = old.eps_p[a] + dgamma * n[a];
        }
        new.alpha = old.alpha + (2.0f64 / 3.0).sqrt() * dgamma;
        let theta = 1.0 - 2.0 * mu * dgamma / xi_norm;
        let theta_bar = 1.0 / (1.0 + (k_iso + h_kin) / (3.0 * mu)) - (1.0 - theta);
        for a in 0..4 {
            for b in 0..4 {
                let one_one = if a < 3 && b < 3 { 1.0 } else { 0.0 };
                let i_sym = if a == b {
                    if a < 3 {
                        1.0
                    } else {
                        0.5
                    }
                } else {
                    0.0
                };
                d[(a, b)] =
                    kappa * one_one + 2.0 * mu * theta * (i_sym - one_one / 3.0) - 2.0 * mu * theta_bar * n[a] * n[b];
            }
        }
        true
    }
}

/// A material assigned to a body.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Material {
    Elastic(Elastic),
    J2Plastic(J2Plastic),
}

impl Material {
    pub fn elastic(&self) -> &Elastic {
        match self {
            Material::Elastic(e) => e,
            Material::J2Plastic(p) => &p.elastic,
        }
    }
    /// Does this material carry history on its points?
    pub fn has_state(&self) -> bool {
        matches!(self, Material::J2Plastic(_))
    }
}

/// Von Mises equivalent stress of `[s_xx, s_yy, s_zz, s_xy]`.
pub fn von_mises(s: &Stress4) -> f64 {
    let p = (s[0] + s[1] + s[2]) / 3.0;
    let dev = [s[0] - p, s[1] - p, s[2] - p, s[3]];
    (1.5f64).sqrt() * tnorm(&dev)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn steel() -> J2Plastic {
        J2Plastic {
            elastic: Elastic { young: 200_000.0, poisson: 0.3, hypothesis: PlaneHypothesis::PlaneStrain },
            yield_stress: 250.0,
            isotropic_hardening: 1000.0,
            kinematic_hardening: 3000.0,
        }
    }

    #[test]
    fn consistent_tangent_matches_finite_differences() {
        let m = steel();
        let old = PlasticState { eps_p: [1e-4, -2e-4, 1e-4, 3e-5], back: [10.0, -20.0, 10.0, 5.0], alpha: 2e-4 };
        let eps = Strain4::new(2.1e-3, -1.3e-3, 0.0, 2.4e-3);
        let (mut s0, mut d) = (Stress4::zeros(), Tangent4::zeros());
        let mut new = PlasticState::default();
        assert!(m.update(&eps, &old, &mut new, &mut s0, &mut d));
        let h = 1e-8;
        for b in 0..4 {
            let mut e1 = eps;
            e1[b] += h;
            let mut e2 = eps;
            e2[b] -= h;
            let (mut s1, mut s2, mut dd) = (Stress4::zeros(), Stress4::zeros(), Tangent4::zeros());
            m.update(&e1, &old, &mut new, &mut s1, &mut dd);
            m.update(&e2, &old, &mut new, &mut s2, &mut dd);
            for a in 0..4 {
                let fd = (s1[a] - s2[a]) / (2.0 * h);
                // Central differences with h = 1e-8 on stresses ~1e2: truncation + round-off ~1e-5 relative to |D| ~ 1e5.
                assert!((fd - d[(a, b)]).abs() < 1e-5 * 2e5, "D[{a}][{b}] = {} vs fd {fd}", d[(a, b)]);
            }
        }
    }

    #[test]
    fn return_lands_on_the_yield_surface() {
        let m = steel();
        let old = PlasticState::default();
        let mut new = PlasticState::default();
        let (mut s, mut d) = (Stress4::zeros(), Tangent4::zeros());
        m.update(&Strain4::new(0.0, 0.0, 0.0, 0.01), &old, &mut new, &mut s, &mut d);
        let p = (s[0] + s[1] + s[2]) / 3.0;
        let xi = [s[0] - p - new.back[0], s[1] - p - new.back[1], s[2] - p - new.back[2], s[3] - new.back[3]];
        let radius = (2.0f64 / 3.0).sqrt() * (m.yield_stress + m.isotropic_hardening * new.alpha);
        // Consistency condition f(sigma_{n+1}) = 0 to round-off (relative 1e-12).
        assert!((tnorm(&xi) - radius).abs() < 1e-12 * radius);
    }
}
