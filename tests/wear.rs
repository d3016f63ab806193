//! Wear engine against exact references (see each test).

use mortex::driver::{run, RunOptions};
use mortex::solve::StaticAnalysis;
use mortex::wear::{
    bounded_implicit_jump, implicit_contact_change, implicit_pressure_change, JumpContact, JumpOperator, JumpPolicy,
    JumpScheme, JumpSurface, RateFilter,
};
use nalgebra::{DMatrix, DVector, Point2};
use std::path::Path;

/// Every material point of the model carries `sigma_yy = -p` and no other in-plane stress, to
/// 1e-8 p (the uniform state is exact; round-off stays far below that).
fn assert_uniaxial_pressure(
    m: &mortex::model::Model,
    d: &mortex::model::Discretisation,
    st: &mortex::state::SimState,
    p: f64,
    at: &str,
) {
    let el = &m.elements;
    for e in 0..el.len() {
        for (q, &w) in d.rules[el.rule[e]].weights.iter().enumerate() {
            if w == 0.0 {
                continue;
            }
            let s = st.stress[el.point_offset[e] + q];
            let d = [s[0].abs(), (s[1] + p).abs(), s[3].abs()].into_iter().fold(0.0, f64::max);
            assert!(d < 1e-8 * p, "{at}: element {e} point {q}: stress {s:?}");
        }
    }
}

/// Uniform wear (wear_cases/uniform_wear.toml; exact). A block pressed with p = 50 MPa slides
/// +-0.1 mm (frictionless, so the stress stays uniform) on a host whose virtual top wears by
/// Archard's law, k = 4e-3 /MPa. Each cycle removes k p S = 0.08 mm everywhere (S = 0.4 mm of
/// slip); 20 cycles take the surface down 1.6 mm, through three element layers (h = 0.5 mm).
///
/// ```text
///   p = 50 MPa                     ux = +-0.1 mm at the block's top-left node
///  +---------------------------+
///  |   block 4 x 1 (7 x 3)     |
///  +===========================+   virtual host top (a cut), sinks by k p S per cycle
///  |   host 4 x 3 (8 x 6)      |
///  +---------------------------+   uy = 0
/// ```
///
/// Checked after every wear update: depth `k p S N` at every vertex, to 1e-8 relative
/// (round-off accumulated over 20 updates and 80 solves is about 1e-13); stresses of every
/// material point of both bodies `sigma_yy = -p`, the rest 0, to 1e-8 p (exact sub-triangulation
/// rules make the cut host pass the patch test to round-off); worn area = `k * int p |ds|` to
/// 1e-10 (the balance holds by construction up to round-off), and the host's material area lost
/// (from the cut itself) equal to depth x width to 1e-10. Run with a jump of 1 (every cycle
/// computed) and a fixed jump of 4: uniform wear is linear in the cycles, so both are exact.
#[test]
fn uniform_wear_is_exact() {
    const P: f64 = 50.0;
    const K: f64 = 4e-3;
    const S: f64 = 0.4;
    const WIDTH: f64 = 4.0;
    const LAYERS_CROSSED: f64 = 3.0 * 0.5;
    let case = mortex::case::load(Path::new("wear_cases/uniform_wear.toml")).unwrap();
    for jump in [1, 4] {
        let mut model = case.model.clone();
        model.wear.jump = JumpPolicy::Fixed(jump);
        let host = 0;
        let area0 = model.initial().material_area(&model, host);
        let mut state = StaticAnalysis::initial_state_of(&model);
        let (mut updates, mut checked_geometry) = (0, 0);
        let mut last_depth = 0.0;
        run(&model, &mut state, RunOptions::default(), |r, st, m, d| {
            assert_uniaxial_pressure(m, d, st, P, &format!("jump {jump} step {}", r.step));
            let w = &st.wear;
            let exact = K * P * S * w.cycle as f64;
            if r.increment == 1 && w.cycle > 0 {
                // The step model has the surface where the last update put it.
                let lost = area0 - d.material_area(m, host);
                assert!((lost - exact * WIDTH).abs() < 1e-10 * exact * WIDTH, "jump {jump}: area lost {lost}");
                checked_geometry += 1;
            }
            if r.increment == 4 && w.increment == 0 {
                updates += 1;
                for (i, d) in w.depth[0].iter().enumerate() {
                    assert!(
                        (d - exact).abs() < 1e-8 * exact,
                        "jump {jump} cycle {}: vertex {i}: depth {d} vs {exact}",
                        w.cycle
                    );
                }
                let balance = (w.worn_area[0] - K * w.work[0]).abs() / w.worn_area[0];
                assert!(balance < 1e-10, "jump {jump}: worn area {} vs k * work {}", w.worn_area[0], K * w.work[0]);
                assert!((w.worn_area[0] - exact * WIDTH).abs() < 1e-8 * exact * WIDTH);
                last_depth = exact;
            }
            Ok(())
        })
        .unwrap();
        assert_eq!(state.wear.cycle, 20);
        assert_eq!(updates, 20 / jump as usize, "jump {jump}: computed cycles");
        assert!(checked_geometry >= updates - 1);
        assert!(last_depth > LAYERS_CROSSED, "the surface must cross three element layers: {last_depth}");
    }
}

/// Flat rigid punch of half-width b on a Winkler foundation (stiffness kappa per unit length
/// and depth), load P, the foundation wearing with k and slip dS per cycle: the exact pressure
/// relaxes as `p(x, N) - P/(2b) = (p0(x) - P/(2b)) exp(-a N)`, `a = kappa k dS`, and the punch
/// sinks at `k dS P/(2b)` per cycle (Archard on a Winkler foundation; e.g. Pödra & Andersson,
/// Wear 207 (1997) 79). `p0` from a parabolic punch face `g0 = x^2 / (2R)`.
/// The integrator is the engine's: [`mortex::wear::next_jump`] picks `dN`, the depth grows by
/// `dN * rate` ([`mortex::wear::depth_increment`]).
struct Winkler {
    x: Vec<f64>,
    weight: Vec<f64>,
    g0: Vec<f64>,
    kappa: f64,
    k_ds: f64,
    load: f64,
}

impl Winkler {
    const B: f64 = 1.0;
    fn new(kappa: f64, k_ds: f64) -> Self {
        let n = 201;
        let h = 2.0 * Self::B / (n - 1) as f64;
        let x: Vec<f64> = (0..n).map(|i| -Self::B + h * i as f64).collect();
        let weight = (0..n).map(|i| if i == 0 || i == n - 1 { 0.5 * h } else { h }).collect();
        let g0 = x.iter().map(|x| x * x / (2.0 * 4.0)).collect();
        Winkler { x, weight, g0, kappa, k_ds, load: 2.0 }
    }
    /// Pressure for a worn depth `w`: `p = kappa (delta - g0 - w)` with `delta` from the load.
    fn pressure(&self, w: &[f64]) -> Vec<f64> {
        let total: f64 = self.weight.iter().sum();
        let mean_gap: f64 =
            self.weight.iter().zip(self.g0.iter().zip(w)).map(|(q, (g, w))| q * (g + w)).sum::<f64>() / total;
        let delta = self.load / (self.kappa * total) + mean_gap;
        self.g0.iter().zip(w).map(|(g, w)| self.kappa * (delta - g - w)).collect()
    }
    fn exact(&self, cycles: f64) -> Vec<f64> {
        let p0 = self.pressure(&vec![0.0; self.x.len()]);
        let mean = self.load / (2.0 * Self::B);
        let decay = (-self.kappa * self.k_ds * cycles).exp();
        p0.iter().map(|p| mean + (p - mean) * decay).collect()
    }
    /// Unilateral pressure for a worn depth `w` and a scaled approach (`scale = 1 / (1 + a)` of
    /// a backward-Euler jump), `delta` from the load by bisection.
    fn unilateral(&self, w: &[f64], scale: f64) -> Vec<f64> {
        let n = self.x.len();
        let p_of = |delta: f64| -> Vec<f64> {
            (0..n).map(|i| scale * self.kappa * (delta - self.g0[i] - w[i]).max(0.0)).collect()
        };
        let load = |delta: f64| p_of(delta).iter().zip(&self.weight).map(|(p, q)| p * q).sum::<f64>();
        let (mut lo, mut hi) = (0.0, 1.0);
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if load(mid) < self.load {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        p_of(0.5 * (lo + hi))
    }
    /// `dlambda / dg` of the foundation under its load (`lambda = -p`, `g` the weighted gap
    /// `weight * gap`): `dp = -kappa (dgap - mean dgap)`.
    fn stiffness(&self) -> DMatrix<f64> {
        let total: f64 = self.weight.iter().sum();
        let n = self.x.len();
        DMatrix::from_fn(n, n, |i, j| {
            self.kappa * (if i == j { 1.0 } else { 0.0 } - self.weight[j] / total) / self.weight[j]
        })
    }
    /// Runs `cycles` cycles with `policy` and `scheme`; returns the final pressure, the
    /// computed cycles and the largest `a dN` used. The implicit jump sees the foundation as the
    /// engine sees a contact: rows = nodes (`G = diag(weight)`, `phi = weight`), weighted slip
    /// `weight * dS` per cycle (dS = 1, the coefficient is `k dS`), and the stiffness above.
    fn run(&self, policy: JumpPolicy, scheme: JumpScheme, cycles: u64, resolution: f64) -> (Vec<f64>, u64, f64) {
        let mut c = mortex::wear::ControllerState::default();
        let mut w = vec![0.0; self.x.len()];
        let measure = self.weight.clone();
        let verts: Vec<Point2<f64>> = self.x.iter().map(|&x| Point2::new(x, 0.0)).collect();
        let stiffness = self.stiffness();
        let (mut n, mut computed, mut worst) = (0u64, 0u64, 0.0_f64);
        while n < cycles {
            let p = self.pressure(&w);
            let rate: Vec<f64> = p.iter().map(|p| self.k_ds * p).collect();
            let mut dn = mortex::wear::next_jump(policy, scheme, &mut c, &rate, resolution, cycles - n);
            let applied = match scheme {
                JumpScheme::Explicit => rate,
                JumpScheme::Implicit => {
                    let filter = RateFilter::new(&verts, false, &measure, &rate, 0.0);
                    let surface = JumpSurface {
                        coupling: DMatrix::from_diagonal(&DVector::from_column_slice(&self.weight)),
                        phi: self.weight.clone(),
                        measure: &measure,
                        coefficient: self.k_ds,
                        work_per_pressure: self.weight.clone(),
                        rate: &rate,
                        filter: &filter,
                    };
                    let solve = |dn: u64| implicit_pressure_change(&stiffness, std::slice::from_ref(&surface), dn);
                    let (jump, dp) =
                        bounded_implicit_jump(policy, &mut c, dn, &p, &self.weight, &solve).expect("regular");
                    dn = jump;
                    p.iter().zip(&dp).map(|(p, d)| self.k_ds * (p + d)).collect()
                }
            };
            for (wi, d) in w.iter_mut().zip(mortex::wear::depth_increment(&applied, &measure, dn as f64)) {
                *wi += d;
            }
            worst = worst.max(self.kappa * self.k_ds * dn as f64);
            n += dn;
            computed += 1;
        }
        (self.pressure(&w), computed, worst)
    }
}

/// A unilateral Winkler foundation (the parabolic punch above, `p = kappa max(0, delta - g0 -
/// w)`, load-controlled) worn in one implicit jump of `a = dN kappa k dS = 1`: the contact
/// widens, rows open and close. The jump with a free contact set ([`implicit_contact_change`])
/// is, for this linear foundation, the exact backward-Euler step of the unilateral problem,
/// whose independent solution is a scalar root (`delta'` from the load, each node's end
/// pressure `kappa max(0, delta' - g0 - w) / (1 + a)`): equal to 1e-9 (round-off of the
/// 201-row dense solves). The jump with the set held misses it (checked to fail by > 1%).
#[test]
fn implicit_jump_lets_a_worn_contact_widen_exactly() {
    const KAPPA: f64 = 100.0;
    const K_DS: f64 = 1e-6;
    const DN: u64 = 10_000; // a = dN kappa k dS = 1
    let scene = Winkler::new(KAPPA, K_DS);
    let n = scene.x.len();
    let w0 = vec![0.0; n];
    let p0 = scene.unilateral(&w0, 1.0);
    let a = DN as f64 * KAPPA * K_DS;
    let exact = scene.unilateral(&w0, 1.0 / (1.0 + a));
    let delta0 = scene.g0[n / 2] + p0[n / 2] / KAPPA;
    let closed: Vec<bool> = p0.iter().map(|&p| p > 0.0).collect();
    let gap: Vec<f64> =
        (0..n).map(|i| if closed[i] { 0.0 } else { scene.weight[i] * (scene.g0[i] - delta0) }).collect();
    let rate: Vec<f64> = p0.iter().map(|p| K_DS * p).collect();
    let verts: Vec<Point2<f64>> = scene.x.iter().map(|&x| Point2::new(x, 0.0)).collect();
    let filter = RateFilter::new(&verts, false, &scene.weight, &rate, 0.0);
    let surface = JumpSurface {
        coupling: DMatrix::from_diagonal(&DVector::from_column_slice(&scene.weight)),
        phi: scene.weight.clone(),
        measure: &scene.weight,
        coefficient: K_DS,
        work_per_pressure: scene.weight.clone(),
        rate: &rate,
        filter: &filter,
    };
    let stiffness = scene.stiffness();
    let contact = JumpContact { pressure: p0.clone(), gap, closed: closed.clone() };
    let dp = implicit_contact_change(&stiffness, std::slice::from_ref(&surface), DN, &contact).expect("sets settle");
    let p_end: Vec<f64> = p0.iter().zip(&dp).map(|(p, d)| p + d).collect();
    let in_contact = |p: &[f64]| p.iter().filter(|&&v| v > 1e-12).count();
    eprintln!("contact rows: {} before, {} after (exact {})", in_contact(&p0), in_contact(&p_end), in_contact(&exact));
    assert!(in_contact(&exact) > in_contact(&p0) + 10, "the jump must widen the contact");
    let err = max_rel(&p_end, &exact);
    assert!(err < 1e-9, "free contact set against exact backward Euler: {err:e}");
    let held = implicit_pressure_change(&stiffness, std::slice::from_ref(&surface), DN).expect("regular");
    let p_held: Vec<f64> = p0.iter().zip(&held).map(|(p, d)| p + d).collect();
    assert!(max_rel(&p_held, &exact) > 1e-2, "the held set should miss the widening");
}

/// The jump's factored solve (block-diagonal stiffness, Sherman-Morrison-Woodbury on the rank
/// of the wear coupling) against one dense system per contact set, on the unilateral Winkler
/// punch above stacked like a cycle: 3 stroke positions (blocks of 201 rows), a held body
/// paired with the same vertices at each and a sliding one paired 4 vertices further per
/// position (rate filter on), jumps of `a = 0.01, 1, 100`, of which the last two widen the
/// contact. Same sets, and the end pressures agree to 1e-10 of the largest (the eliminations
/// differ in order only: round-off, at most 1.4e-13 measured).
#[test]
fn factored_jump_solve_equals_the_dense_one() {
    const KAPPA: f64 = 100.0;
    const K_DS: f64 = 1e-6;
    const BLOCKS: usize = 3;
    const SHIFT: usize = 4;
    let scene = Winkler::new(KAPPA, K_DS);
    let n = scene.x.len();
    let na = BLOCKS * n;
    let p0 = scene.unilateral(&vec![0.0; n], 1.0);
    let delta0 = scene.g0[n / 2] + p0[n / 2] / KAPPA;
    let single = scene.stiffness();
    let mut stiffness = DMatrix::<f64>::zeros(na, na);
    for b in 0..BLOCKS {
        stiffness.view_mut((b * n, b * n), (n, n)).copy_from(&single);
    }
    let h = scene.x[1] - scene.x[0];
    let nv = [n, n + SHIFT * (BLOCKS - 1)];
    let measures: Vec<Vec<f64>> =
        nv.iter().map(|&m| (0..m).map(|i| if i == 0 || i == m - 1 { 0.5 * h } else { h }).collect()).collect();
    let verts: Vec<Vec<Point2<f64>>> =
        nv.iter().map(|&m| (0..m).map(|i| Point2::new(i as f64 * h, 0.0)).collect()).collect();
    let mut rates: Vec<Vec<f64>> = nv.iter().map(|&m| vec![0.0; m]).collect();
    for b in 0..BLOCKS {
        for i in 0..n {
            rates[0][i] += 0.5 * K_DS * p0[i] / BLOCKS as f64;
            rates[1][i + SHIFT * b] += 0.5 * K_DS * p0[i] / BLOCKS as f64;
        }
    }
    let filters: Vec<RateFilter> =
        (0..2).map(|s| RateFilter::new(&verts[s], false, &measures[s], &rates[s], 2.0 * h)).collect();
    let surfaces: Vec<JumpSurface> = (0..2)
        .map(|s| {
            let mut coupling = DMatrix::<f64>::zeros(na, nv[s]);
            for b in 0..BLOCKS {
                for i in 0..n {
                    coupling[(b * n + i, i + s * SHIFT * b)] = scene.weight[i];
                }
            }
            JumpSurface {
                coupling,
                phi: (0..BLOCKS).flat_map(|_| scene.weight.iter().copied()).collect(),
                measure: &measures[s],
                coefficient: 0.5 * K_DS,
                work_per_pressure: (0..BLOCKS).flat_map(|_| scene.weight.iter().map(|w| w / BLOCKS as f64)).collect(),
                rate: &rates[s],
                filter: &filters[s],
            }
        })
        .collect();
    let closed: Vec<bool> = (0..BLOCKS).flat_map(|_| p0.iter().map(|&p| p > 0.0)).collect();
    let contact = JumpContact {
        pressure: (0..BLOCKS).flat_map(|_| p0.iter().copied()).collect(),
        gap: (0..na).map(|r| if closed[r] { 0.0 } else { scene.weight[r % n] * (scene.g0[r % n] - delta0) }).collect(),
        closed,
    };
    let operator = JumpOperator::with_blocks(&stiffness, &[n; BLOCKS], &surfaces);
    let in_contact = |dp: &[f64]| (0..na).filter(|&r| contact.pressure[r] + dp[r] > 1e-12).count();
    let before = in_contact(&vec![0.0; na]);
    let mut widened = 0;
    for dn in [100, 10_000, 1_000_000] {
        let dense = operator.contact_change_dense(dn, &contact).expect("dense sets settle");
        let factored = operator.contact_change(dn, &contact).expect("factored sets settle");
        assert_eq!(in_contact(&factored), in_contact(&dense), "dN = {dn}: contact sets");
        let err = max_rel(&factored, &dense);
        eprintln!("dN = {dn}: rows in contact {before} -> {}, factored against dense {err:.1e}", in_contact(&dense));
        assert!(err <= 1e-10, "dN = {dn}: factored against dense {err:e}");
        widened += usize::from(in_contact(&dense) > before);
        let held = operator.pressure_change(dn).expect("held set regular");
        let one_block = implicit_pressure_change(&stiffness, &surfaces, dn).expect("held set regular");
        let err = max_rel(&held, &one_block);
        assert!(err <= 1e-10, "dN = {dn}: held set, blocks against one block {err:e}");
    }
    assert_eq!(widened, 2, "the two long jumps widen the contact");
}

fn max_rel(a: &[f64], b: &[f64]) -> f64 {
    let scale = b.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max) / scale
}

/// Winkler relaxation: fixed jumps converge at first order (explicit Euler in cycles) and
/// reach 1e-4 of the exact pressure at the finest setting (dN = 1); past `a dN = 2` a fixed
/// jump multiplies the deviation by `|1 - a dN| > 1` per jump (exact for this linear scene,
/// checked to 1e-9); the adaptive controller, told nothing of kappa, keeps `a dN <= 1`
/// (JUMP_SAFETY) and reaches the steady state in few computed cycles.
#[test]
fn winkler_relaxation_and_jump_stability() {
    const KAPPA: f64 = 100.0;
    const K_DS: f64 = 1e-6; // a = 1e-4 per cycle
    let a = KAPPA * K_DS;
    let scene = Winkler::new(KAPPA, K_DS);
    let cycles = 10_000; // a N = 1
    let exact = scene.exact(cycles as f64);
    let mut errors = vec![];
    for dn in [1u64, 10, 100, 1000] {
        let (p, computed, _) = scene.run(JumpPolicy::Fixed(dn), JumpScheme::Explicit, cycles, f64::INFINITY);
        assert_eq!(computed, cycles / dn);
        errors.push((dn, max_rel(&p, &exact)));
    }
    eprintln!("Winkler, fixed jumps: (dN, max |p - p_exact| / max p) = {errors:?}");
    for w in errors.windows(2) {
        let order = (w[1].1 / w[0].1).log10() / ((w[1].0 as f64) / (w[0].0 as f64)).log10();
        eprintln!("observed order dN {} -> {}: {order:.3}", w[0].0, w[1].0);
        // First order (explicit Euler); the coarsest pair (a dN = 0.1) is still near it.
        assert!((order - 1.0).abs() < 0.1, "order {order}");
    }
    assert!(errors[0].1 < 1e-4, "finest setting: {}", errors[0].1);

    // Unstable past a dN = 2: the deviation grows by |1 - a dN| per jump, exactly.
    let mean = scene.load / (2.0 * Winkler::B);
    let p0 = scene.pressure(&vec![0.0; scene.x.len()]);
    let dev0 = p0.iter().map(|p| (p - mean).abs()).fold(0.0, f64::max);
    for (a_dn, jumps) in [(1.9, 20u64), (2.5, 20)] {
        let dn = (a_dn / a).round() as u64;
        let (p, _, _) = scene.run(JumpPolicy::Fixed(dn), JumpScheme::Explicit, dn * jumps, f64::INFINITY);
        let dev = p.iter().map(|p| (p - mean).abs()).fold(0.0, f64::max);
        let factor = (1.0 - a * dn as f64).abs().powi(jumps as i32);
        assert!(
            (dev / dev0 - factor).abs() < 1e-9 * factor.max(1.0),
            "a dN = {a_dn}: growth {} vs {factor}",
            dev / dev0
        );
        if a_dn > 2.0 {
            assert!(dev > 100.0 * dev0, "a dN = {a_dn} must diverge");
        }
    }

    // Adaptive: 10^6 cycles (a N = 100), never past the bound.
    let long = 1_000_000;
    let (p, computed, worst) = scene.run(JumpPolicy::default(), JumpScheme::Explicit, long, f64::INFINITY);
    let err = max_rel(&p, &scene.exact(long as f64));
    eprintln!("Winkler, adaptive: {computed} computed cycles for {long}, largest a dN = {worst:.3}, error {err:.2e}");
    assert!(worst <= mortex::wear::JUMP_SAFETY * (1.0 + 1e-6), "a dN = {worst}");
    assert!(err < 1e-6, "steady state reached: {err}");
    assert!(computed < 500, "computed cycles {computed}");
}

/// Winkler relaxation with the implicit jump (linearised backward Euler on the interface
/// stiffness): the pressure deviation is divided by `1 + a dN` per jump, exactly for this linear
/// scene (1e-9), so no fixed jump diverges (a dN = 2.5 and 100); fixed jumps converge at first
/// order to the exact relaxation, 1e-4 at dN = 1; the adaptive controller (no `a dN` bound,
/// pressure change per jump <= 5% of the peak) reaches the steady state of 10^6 cycles to 1e-6
/// in fewer computed cycles than the explicit one.
#[test]
fn winkler_implicit_jump_is_stable_for_any_jump() {
    const KAPPA: f64 = 100.0;
    const K_DS: f64 = 1e-6; // a = 1e-4 per cycle
    let a = KAPPA * K_DS;
    let scene = Winkler::new(KAPPA, K_DS);
    let mean = scene.load / (2.0 * Winkler::B);
    let p0 = scene.pressure(&vec![0.0; scene.x.len()]);
    let dev0 = p0.iter().map(|p| (p - mean).abs()).fold(0.0, f64::max);
    for (a_dn, jumps) in [(2.5, 20u64), (100.0, 3)] {
        let dn = (a_dn / a).round() as u64;
        let (p, _, _) = scene.run(JumpPolicy::Fixed(dn), JumpScheme::Implicit, dn * jumps, f64::INFINITY);
        let dev = p.iter().map(|p| (p - mean).abs()).fold(0.0, f64::max);
        let factor = (1.0 + a * dn as f64).powi(-(jumps as i32));
        // Round-off of the dense solve relative to the initial deviation.
        assert!((dev / dev0 - factor).abs() < 1e-9, "a dN = {a_dn}: decay {} vs {factor}", dev / dev0);
    }
    let cycles = 10_000; // a N = 1
    let exact = scene.exact(cycles as f64);
    let mut errors = vec![];
    for dn in [1u64, 10, 100, 1000] {
        let (p, _, _) = scene.run(JumpPolicy::Fixed(dn), JumpScheme::Implicit, cycles, f64::INFINITY);
        errors.push((dn, max_rel(&p, &exact)));
    }
    eprintln!("Winkler, implicit fixed jumps: (dN, max |p - p_exact| / max p) = {errors:?}");
    for w in errors.windows(2) {
        let order = (w[1].1 / w[0].1).log10() / ((w[1].0 as f64) / (w[0].0 as f64)).log10();
        eprintln!("observed order dN {} -> {}: {order:.3}", w[0].0, w[1].0);
        // First order (backward Euler); at a dN = 0.1 still within 0.1 of it.
        assert!((order - 1.0).abs() < 0.1, "order {order}");
    }
    assert!(errors[0].1 < 1e-4, "finest setting: {}", errors[0].1);
    let long = 1_000_000;
    let (p, computed, worst) = scene.run(JumpPolicy::default(), JumpScheme::Implicit, long, f64::INFINITY);
    let err = max_rel(&p, &scene.exact(long as f64));
    let (_, computed_explicit, _) = scene.run(JumpPolicy::default(), JumpScheme::Explicit, long, f64::INFINITY);
    eprintln!(
        "Winkler, adaptive implicit: {computed} computed cycles for {long} (explicit {computed_explicit}), \
         largest a dN = {worst:.1}, error {err:.2e}"
    );
    assert!(err < 1e-6, "steady state reached: {err}");
    assert!(computed < computed_explicit, "implicit {computed} vs explicit {computed_explicit}");
}

/// A rigid flat punch of half-width `b` pressed with load `P` on an elastic half-plane (plane
/// strain, `E*`), the surface discretised in `n` cells of width `h` carrying uniform pressures:
/// the compliance `C_ij = -(2 / (pi E*)) int_cell_j ln|x_i - s| ds` (Johnson, Contact
/// Mechanics, 1985, eq. 2.25b; `b < 1/2`, so every distance is below 1 and `C` is positive
/// definite), the load held by the approach `delta`. Unlike the Winkler foundation, the
/// half-plane couples the cells: its stiffest mode is the element-scale ripple (alternating
/// cells), of stiffness about `pi E* / (2 h)`, the roughness mode of one wear update.
struct HalfPlanePunch {
    weight: Vec<f64>,
    /// `-dp/dgap` under the load: `K - K 1 1^T K / (1^T K 1)`, `K = C^-1`, symmetric,
    /// uniform pressure its null vector.
    m: DMatrix<f64>,
    k: DMatrix<f64>,
    load: f64,
}

impl HalfPlanePunch {
    const B: f64 = 0.4;
    const E_STAR: f64 = 1e5;
    fn new(n: usize) -> Self {
        let h = 2.0 * Self::B / n as f64;
        let x: Vec<f64> = (0..n).map(|i| -Self::B + h * (i as f64 + 0.5)).collect();
        let antiderivative = |t: f64| if t == 0.0 { 0.0 } else { t * t.abs().ln() - t };
        let c = DMatrix::from_fn(n, n, |i, j| {
            let d = x[i] - x[j];
            -2.0 / (std::f64::consts::PI * Self::E_STAR) * (antiderivative(d + 0.5 * h) - antiderivative(d - 0.5 * h))
        });
        let k = c.try_inverse().expect("the half-plane compliance is positive definite");
        let ones = DVector::from_element(n, 1.0);
        let k1 = &k * &ones;
        let m = &k - &k1 * k1.transpose() / ones.dot(&k1);
        HalfPlanePunch { weight: vec![h; n], m, k, load: 100.0 }
    }
    /// The pressure under the punch for a worn depth `w` (gap `w`, flat face).
    fn pressure(&self, w: &DVector<f64>) -> DVector<f64> {
        let n = w.len();
        let ones = DVector::from_element(n, 1.0);
        let h = self.weight[0];
        let (k1, kw) = (&self.k * &ones, &self.k * w);
        let delta = (self.load / h + ones.dot(&kw)) / ones.dot(&k1);
        &k1 * delta - kw
    }
    /// `dlambda / dg` for the engine (`lambda = -p`, `g_j = weight_j * gap_j`).
    fn stiffness(&self) -> DMatrix<f64> {
        let mut s = self.m.clone();
        for (j, mut col) in s.column_iter_mut().enumerate() {
            col /= self.weight[j];
        }
        s
    }
}

/// The roughness mode of one wear update on a half-plane (the flat punch above, n = 80 cells):
/// a worn ripple along the stiffest mode `v` of the loaded contact (`-dp/dgap v = mu v`, the
/// element-scale mode, `mu` within 20% of `pi E* / (2 h)`), one update wearing `k S p` with
/// `a = mu k S` from 0.1 to 1,000. The engine's implicit update multiplies the ripple's
/// pressure by `1 / (1 + a)` (exactly for this linear scene: 1e-9, round-off of the dense
/// solves; the recomputed pressure of the worn surface agrees to the same 1e-9, so the update
/// is the backward-Euler step of the mechanics, not an estimate): the mode decays at every `a`,
/// where the wear as computed (explicit) multiplies it by `1 - a` and grows past `a = 2`.
/// The scar converges: the wear that relaxes the longest mode by 1/e, from the unworn punch
/// (edge peaks, plus the ripple), taken in 1 to 1,000 updates (`a` = 54 to 0.054 per update),
/// has a depth error against the exact relaxation (`exp(-t M)`, modal) that falls
/// monotonically at first order (backward Euler: order within 0.1 of 1 over the finest pair;
/// measured 16%, 1.7%, 0.17%, 0.017% of the scar's shape); one update at a = 1,000 stays
/// within 5% of the shape (measured 1.8%: the stiff modes relax exactly either way, the slow
/// ones by `1 / (1 + T mu_k)` in place of `exp(-T mu_k)`).
#[test]
fn roughness_mode_of_a_wear_update_decays_at_any_rate_on_a_half_plane() {
    let scene = HalfPlanePunch::new(80);
    let n = scene.weight.len();
    let h = scene.weight[0];
    let eig = scene.m.clone().symmetric_eigen();
    let top = eig.eigenvalues.imax();
    let (mu, v) = (eig.eigenvalues[top], eig.eigenvectors.column(top).into_owned());
    let element_scale = std::f64::consts::PI * HalfPlanePunch::E_STAR / (2.0 * h);
    eprintln!("stiffest mode: mu = {mu:.4e}, pi E*/(2h) = {element_scale:.4e}");
    assert!((mu / element_scale - 1.0).abs() < 0.2, "the stiffest mode is element-scale: {mu:e}");
    let alternating = (0..n).filter(|&i| v[i] * v[(i + 1).min(n - 1)] < 0.0).count();
    assert!(alternating >= n - 3, "the stiffest mode alternates cell by cell ({alternating} sign changes)");
    let stiffness = scene.stiffness();
    let verts: Vec<Point2<f64>> = (0..n).map(|i| Point2::new(i as f64 * h, 0.0)).collect();
    // One update of wear `k_ds p` implicit in the contact: the engine's pressure change.
    let implicit_update = |p: &DVector<f64>, k_ds: f64| -> DVector<f64> {
        let rate: Vec<f64> = p.iter().map(|p| k_ds * p).collect();
        let filter = RateFilter::new(&verts, false, &scene.weight, &rate, 0.0);
        let surface = JumpSurface {
            coupling: DMatrix::from_diagonal(&DVector::from_column_slice(&scene.weight)),
            phi: scene.weight.clone(),
            measure: &scene.weight,
            coefficient: k_ds,
            work_per_pressure: scene.weight.clone(),
            rate: &rate,
            filter: &filter,
        };
        let dp = implicit_pressure_change(&stiffness, std::slice::from_ref(&surface), 1).expect("regular");
        p + DVector::from_vec(dp)
    };
    let mean = DVector::from_element(n, scene.load / (2.0 * HalfPlanePunch::B));
    // A ripple of 1 nm: the pressure stays positive everywhere.
    let w0 = &v * (1e-6 / v.amax());
    for a in [0.1, 1.0, 10.0, 100.0, 1000.0] {
        let k_ds = a / mu;
        let p0 = scene.pressure(&w0);
        assert!(p0.min() > 0.0);
        let p_end = implicit_update(&p0, k_ds);
        let w1 = &w0 + &p_end * k_ds;
        let recomputed = scene.pressure(&w1);
        let worn_check = (&recomputed - &p_end).amax() / p0.amax();
        assert!(worn_check < 1e-9, "a = {a}: the update's pressure against the worn surface's: {worn_check:e}");
        let mode = |p: &DVector<f64>| (p - &mean).dot(&v);
        let decay = mode(&p_end) / mode(&p0);
        let explicit = mode(&scene.pressure(&(&w0 + &p0 * k_ds))) / mode(&p0);
        eprintln!(
            "a = {a}: ripple x {decay:.6e} implicit (1/(1+a) = {:.6e}), x {explicit:.4e} explicit",
            1.0 / (1.0 + a)
        );
        assert!((decay * (1.0 + a) - 1.0).abs() < 1e-9, "a = {a}: implicit decay {decay:e}");
        assert!((explicit - (1.0 - a)).abs() < 1e-9 * a.max(1.0), "a = {a}: explicit factor {explicit:e}");
    }
    // The scar of a fixed wear `T = k S N` from the unworn punch (its edge peaks, plus the
    // ripple) in `updates` implicit updates, against the exact relaxation: the error of the
    // worn depth relative to the scar's shape (its departure from uniform wear).
    let p_start = scene.pressure(&w0);
    let e0 = &p_start - &mean;
    let scar = |total: f64, updates: usize| -> (f64, f64) {
        // w(T) = w0 + T pbar + sum_k v_k (v_k . e0) (1 - exp(-T mu_k)) / mu_k (mu_k > 0).
        let mut exact = &w0 + &mean * total;
        for (k, &mk) in eig.eigenvalues.iter().enumerate() {
            let vk = eig.eigenvectors.column(k);
            if mk > 1e-9 * mu {
                exact += vk * (vk.dot(&e0) * (1.0 - (-total * mk).exp()) / mk);
            }
        }
        let shape = exact.add_scalar(-exact.mean()).amax();
        let k_ds = total / updates as f64;
        let mut w = w0.clone();
        for _ in 0..updates {
            let p_end = implicit_update(&scene.pressure(&w), k_ds);
            w += DVector::from_vec(mortex::wear::depth_increment(p_end.as_slice(), &scene.weight, k_ds));
        }
        ((&w - &exact).amax() / shape, mu * k_ds)
    };
    // The longest mode relaxed by 1/e: the slow modes' transient is what the updates resolve.
    let slowest = eig.eigenvalues.iter().copied().filter(|&m| m > 1e-9 * mu).fold(f64::INFINITY, f64::min);
    let errors: Vec<(f64, f64)> = [1usize, 10, 100, 1000].iter().map(|&m| scar(1.0 / slowest, m)).collect();
    eprintln!("half-plane scar at T mu_min = 1, (shape error, a per update) = {errors:?}");
    for pair in errors.windows(2) {
        assert!(pair[1].0 < pair[0].0, "the scar converges: {errors:?}");
    }
    let order = (errors[2].0 / errors[3].0).log10();
    assert!((order - 1.0).abs() < 0.1, "first order (backward Euler): {order}");
    // a = 1,000 in one update: the stiff modes relax as exactly (their integral is 1 / mu_k
    // either way), the slow ones by 1 / (1 + T mu_k) in place of exp(-T mu_k).
    let (one_update, a) = scar(1000.0 / mu, 1);
    eprintln!("one update at a = {a}: shape error {one_update:.3e}");
    assert!(one_update < 0.05, "one update at a = 1,000: {one_update}");
}

/// Both bodies wear (exact): the uniform-wear scene with real contact boundaries, each turned
/// into a virtual surface by the engine (the block's bottom carries the multipliers, so the
/// mortar side moves too). The two surfaces share the slip: per cycle the host loses
/// k1 p S = 0.08 mm and the block k2 p S = 0.04 mm, everywhere, to 1e-8 relative; the
/// stress stays uniform to 1e-8 p; each body's material area lost equals its depth x width to
/// 1e-10.
#[test]
fn both_bodies_wear_their_own_share() {
    const P: f64 = 50.0;
    const S: f64 = 0.4;
    const K: [f64; 2] = [4e-3, 2e-3];
    let text = std::fs::read_to_string("wear_cases/uniform_wear.toml").unwrap();
    let start = text.find("[[cuts]]").unwrap();
    let end = text.find("[[bcs]]").unwrap();
    let text = format!(
        "{}{}{}",
        &text[..start],
        r#"
[[contacts]]
name = "interface"
mortar = "block"
mortar_surface = ["bottom"]
other = "host"
other_surface = ["top"]

[[wear]]
body = "host"
surface = ["top"]
coefficient = 4e-3
max_depth = 2.0

[[wear]]
body = "block"
surface = ["bottom"]
coefficient = 2e-3
max_depth = 0.9
"#,
        &text[end..]
    )
    .replace("origin = [0.0, 2.75]", "origin = [0.0, 3.0]")
    .replace("cycles = 20", "cycles = 10");
    let case = mortex::case::parse(&text, "both_wear", Path::new("."), "both_wear").unwrap();
    let model = case.model;
    assert_eq!(model.wear.surfaces.len(), 2);
    assert!(model.wear.surfaces[1].on_mortar_side && !model.wear.surfaces[0].on_mortar_side);
    let area0 = [model.initial().material_area(&model, 0), model.initial().material_area(&model, 1)];
    let mut state = StaticAnalysis::initial_state_of(&model);
    let mut updates = 0;
    run(&model, &mut state, RunOptions::default(), |r, st, m, d| {
        assert_uniaxial_pressure(m, d, st, P, &format!("step {}", r.step));
        let w = &st.wear;
        if r.increment == 1 && w.cycle > 0 {
            for b in 0..2 {
                let exact = K[b] * P * S * w.cycle as f64 * 4.0;
                let lost = area0[b] - d.material_area(m, b);
                assert!((lost - exact).abs() < 1e-10 * exact, "body {b}: area lost {lost} vs {exact}");
            }
        }
        if r.increment == 4 && w.increment == 0 {
            updates += 1;
            for b in 0..2 {
                let exact = K[b] * P * S * w.cycle as f64;
                for (i, d) in w.depth[b].iter().enumerate() {
                    assert!((d - exact).abs() < 1e-8 * exact, "body {b} cycle {}: vertex {i}: {d} vs {exact}", w.cycle);
                }
                assert!((w.worn_area[b] - K[b] * w.work[b]).abs() < 1e-10 * w.worn_area[b]);
            }
            // The two surfaces see the same slip: the same work.
            assert!((w.work[0] - w.work[1]).abs() < 1e-12 * w.work[0]);
        }
        Ok(())
    })
    .unwrap();
    assert_eq!(updates, 10);
}

/// Partial slip (wear_cases/partial_slip_wear.toml, reduced from 10^5 to 40 cycles): the McColl
/// cylinder on flat under a cyclic tangential force Q = +-0.5 mu P. Multiplier nodes that stick
/// through the whole run (Mindlin: |x| < c = 0.707 a, a = 36 um) carry no slip, hence no wear
/// work: every surface vertex farther than one multiplier spacing inside that stick interval
/// (its hat sees only sticking nodes) keeps a depth of zero to round-off, <= 1e-12 of the
/// largest depth (the case's smoothing acts only where the surface wears).
#[test]
fn partial_slip_stick_zone_never_wears() {
    let text =
        std::fs::read_to_string("wear_cases/partial_slip_wear.toml").unwrap().replace("cycles = 100000", "cycles = 40");
    let case = mortex::case::parse(&text, "partial_slip", Path::new("wear_cases"), "partial_slip").unwrap();
    let model = case.model;
    let pair = &model.initial().contact.pairs[0];
    let n_lm = pair.multipliers.num_nodes;
    let mut always_stick = vec![true; n_lm];
    let mut area_rates: Vec<f64> = vec![];
    let mut last_area = 0.0;
    let mut state = StaticAnalysis::initial_state_of(&model);
    run(&model, &mut state, RunOptions::default(), |r, st, _, d| {
        if r.cycle >= 1 {
            for (l, s) in always_stick.iter_mut().enumerate() {
                let j = d.contact.pairs[0].friction_row[l].unwrap();
                *s &= st.friction_status[j] == 1;
            }
        }
        if r.cycle >= 1 && st.wear.increment == 0 {
            let area: f64 = st.wear.worn_area.iter().sum();
            area_rates.push((area - last_area) / st.wear.jump as f64);
            last_area = area;
        }
        Ok(())
    })
    .unwrap();
    let x: Vec<f64> = pair.multipliers.points.iter().map(|p| p.x).collect();
    let centre = (0..n_lm).min_by(|&a, &b| x[a].abs().total_cmp(&x[b].abs())).unwrap();
    assert!(always_stick[centre], "the centre must stick");
    let (mut lo, mut hi) = (centre, centre);
    while lo > 0 && always_stick[lo - 1] {
        lo -= 1;
    }
    while hi + 1 < n_lm && always_stick[hi + 1] {
        hi += 1;
    }
    let spacing = (lo..hi).map(|l| (x[l + 1] - x[l]).abs()).fold(0.0, f64::max);
    let (x0, x1) = (x[lo].min(x[hi]) + spacing, x[lo].max(x[hi]) - spacing);
    let a_hertz = 0.0359;
    eprintln!(
        "stick interval [{:.4}, {:.4}] mm (Mindlin c = {:.4}), {} nodes",
        x[lo].min(x[hi]),
        x[lo].max(x[hi]),
        0.707 * a_hertz,
        hi - lo + 1
    );
    assert!(hi - lo >= 4, "a stick zone of several nodes");
    let deepest = state.wear.depth.iter().flatten().fold(0.0_f64, |a, &b| a.max(b));
    assert!(deepest > 0.0);
    let mut checked = 0;
    for (verts, depth) in state.wear.vertices.iter().zip(&state.wear.depth) {
        for (p, d) in verts.iter().zip(depth) {
            if p[0] > x0 && p[0] < x1 {
                assert!(d.abs() <= 1e-12 * deepest, "vertex at x = {}: depth {d} (max {deepest})", p[0]);
                checked += 1;
            }
        }
    }
    assert!(checked >= 4, "vertices checked in the stick zone: {checked}");
    eprintln!("worn area per cycle at each update: {area_rates:?}");
    assert!(area_rates.iter().all(|r| *r > 0.0), "the slip zones wear at every update");
}

/// Partial slip over a long run (wear_cases/partial_slip_long.toml: the scene above with ten
/// times its wear coefficients over 10^6 cycles, i.e. over 10^7 cycles, since Archard wear
/// depends on k N only; about 250 computed cycles, 1.5-2 minutes on 2 cores, ignored in CI).
/// The worn-area rate (both bodies, mean over windows of cycles) first rises while the scar
/// spreads (the worn slip annulus loses pressure, the centre takes it and presses the unworn
/// outer surface into contact, which slips): its peak over a tenth of the run is more than 5
/// times its mean over the first 1% (measured 8.6; 9.0 with a tighter jump controller,
/// depth_fraction 0.02, pressure_change 0.05, prediction_tolerance 0.003, 792 computed
/// cycles). Then it decays as the slip zones unload onto the stick zone (which ends on one
/// multiplier node carrying 99% of the load: below the mesh resolution, see the README):
/// over the last 30% of the run it is
/// below a fifth of that peak (measured 0.096; 0.033 with the tighter controller, whose
/// depths agree to 2.5%: the late rate is small and jump-sensitive, the bound sits above
/// both and far below no decay). Since 2026-12-03 (the jump linearised at every stroke
/// position, most likely) this run measures a rise of 6.6 and a late rate of 0.45 of the
/// peak: its late transition falls inside the last 30% of the run, and the decay check
/// fails (docs/validation.md, "Partial slip"; the bound is left as it was).
#[test]
#[ignore]
fn partial_slip_wear_rate_rises_then_decays() {
    let case = mortex::case::load(Path::new("wear_cases/partial_slip_long.toml")).unwrap();
    let model = case.model;
    let cycles = model.cycle.unwrap().count as u64;
    let mut history: Vec<(u64, f64)> = vec![(0, 0.0)];
    let mut state = StaticAnalysis::initial_state_of(&model);
    run(&model, &mut state, RunOptions::default(), |r, st, _, _| {
        if r.cycle >= 1 && st.wear.increment == 0 && st.wear.cycle > history[history.len() - 1].0 {
            history.push((st.wear.cycle, st.wear.worn_area.iter().sum()));
        }
        Ok(())
    })
    .unwrap();
    // Mean rate between the first updates at or after cycles c0 and c1.
    let at = |c: u64| history.iter().copied().find(|h| h.0 >= c).unwrap_or(history[history.len() - 1]);
    let mean_rate = |c0: u64, c1: u64| {
        let (a, b) = (at(c0), at(c1));
        (b.1 - a.1) / (b.0 - a.0) as f64
    };
    let first = mean_rate(1, cycles / 100);
    let peak = (0..9).map(|i| mean_rate(i * cycles / 10, (i + 1) * cycles / 10)).fold(0.0, f64::max);
    let last = mean_rate(cycles * 7 / 10, cycles);
    eprintln!("worn-area rate: first {first:.3e}, peak {peak:.3e}, last {last:.3e} mm^2/cycle");
    assert!(peak > 5.0 * first, "the rate rises while the scar spreads");
    assert!(last < 0.2 * peak, "the rate decays once the scar is conformal");
}

/// Archard wear depends on `k N` only (quasi-static: the wear per cycle is `k` times a work
/// that depends on the worn geometry alone), so the partial-slip scene at ten times the shipped
/// coefficients over 10^5 cycles (`wear_cases/partial_slip_long.toml` cut short) and at a
/// hundred times over 10^4 cycles must reach the same scar: largest depth and worn area of
/// both bodies within 2%, the jump error either run carries (the adaptive controller against
/// fixed jumps of 200 cycles over 10^5 shipped cycles: 1.3% in depth, 1.4% in area,
/// docs/validation.md "Partial slip"). Measured 0.57% and 1.25% (flat), 0.50% and 1.25%
/// (cylinder). Before about 10^5 cycles of the ten-times run the stick zone spans several
/// multiplier nodes and the depths converge in the mesh (123.0, 110.8, 108.0 nm on meshes 1, 2
/// and 4 times finer); after it the stick zone collapses to the mesh scale, and the late stage
/// depends on the mesh and on the jump path (see the test above), not on `k` apart from `k N`.
/// About 45 s.
#[test]
fn partial_slip_wear_depends_on_k_n_only() {
    let text = std::fs::read_to_string("wear_cases/partial_slip_long.toml").unwrap();
    let scar = |text: &str| {
        let case =
            mortex::case::parse(text, "partial_slip_long", Path::new("wear_cases"), "partial_slip_long").unwrap();
        let model = case.model;
        let mut state = StaticAnalysis::initial_state_of(&model);
        run(&model, &mut state, RunOptions::default(), |_, _, _, _| Ok(())).unwrap();
        let w = &state.wear;
        let deepest: Vec<f64> = w.depth.iter().map(|d| d.iter().fold(0.0_f64, |a, &b| a.max(b))).collect();
        (deepest, w.worn_area.clone())
    };
    let times_ten = text.replace("cycles = 1000000", "cycles = 100000");
    let times_hundred = text
        .replace("cycles = 1000000", "cycles = 10000")
        .replace("coefficient = 2.9e-7", "coefficient = 2.9e-6")
        .replace("coefficient = 1.9e-7", "coefficient = 1.9e-6");
    assert!(times_ten != text && times_hundred.matches("e-6").count() == 2, "the case's keys moved");
    let (d10, a10) = scar(&times_ten);
    let (d100, a100) = scar(&times_hundred);
    for s in 0..2 {
        let (dd, da) = (d100[s] / d10[s] - 1.0, a100[s] / a10[s] - 1.0);
        eprintln!(
            "surface {s}: depth {:.4} / {:.4} nm ({dd:+.2e}), area {:.4} / {:.4} um^2 ({da:+.2e})",
            d10[s] * 1e6,
            d100[s] * 1e6,
            a10[s] * 1e6,
            a100[s] * 1e6
        );
        assert!(d10[s] > 1e-5, "surface {s} wears (more than 10 nm): {}", d10[s]);
        assert!(dd.abs() < 0.02, "surface {s}: largest depth at 100 k against 10 k, same k N: {dd:+.3e}");
        assert!(da.abs() < 0.02, "surface {s}: worn area at 100 k against 10 k, same k N: {da:+.3e}");
    }
}

/// The McColl fretting case (wear_cases/mccoll_fretting.toml) reduced to 600 cycles, adaptive
/// jumps: the wear balance `worn area = k int p |ds|` holds on both bodies to 1e-10 (it holds by
/// construction; this checks the bookkeeping through jumps and the smoothing filter), the
/// material area each host lost (measured on its cut) matches the worn area within
/// 1e-4 of it (vertices move along averaged normals on a curved surface: second order in the
/// depth) plus the embedding's vertex snapping (a vertex within `SNAP_VERTEX` cell sizes of a
/// host node or edge is embedded there: at most that distance times the worn length, which
/// matters while the scar's tails are shallower than it), the two bodies saw the same wear
/// work, and the run jumped cycles.
#[test]
fn mccoll_wear_balance_through_jumps() {
    let text =
        std::fs::read_to_string("wear_cases/mccoll_fretting.toml").unwrap().replace("cycles = 18000", "cycles = 600");
    let case = mortex::case::parse(&text, "mccoll", Path::new("wear_cases"), "mccoll").unwrap();
    let model = case.model;
    let k: Vec<f64> = model.wear.surfaces.iter().map(|w| w.coefficient).collect();
    let hosts: Vec<usize> = model.wear.surfaces.iter().map(|w| model.initial().surfaces[w.surface].body).collect();
    let area0: Vec<f64> = hosts.iter().map(|&b| model.initial().material_area(&model, b)).collect();
    let mut state = StaticAnalysis::initial_state_of(&model);
    let mut geometric: Vec<(u64, Vec<f64>)> = vec![];
    let mut balance_checks = 0;
    run(&model, &mut state, RunOptions::default(), |r, st, m, d| {
        let w = &st.wear;
        if r.increment == 1 && w.cycle > 0 {
            geometric.push((w.cycle, hosts.iter().zip(&area0).map(|(&b, a0)| a0 - d.material_area(m, b)).collect()));
            for (i, lost) in geometric.last().unwrap().1.iter().enumerate() {
                let v = &w.vertices[i];
                let (mut worn_length, mut h) = (0.0, 0.0_f64);
                for j in 0..v.len() - 1 {
                    if w.depth[i][j] > 0.0 || w.depth[i][j + 1] > 0.0 {
                        let l = ((v[j + 1][0] - v[j][0]).powi(2) + (v[j + 1][1] - v[j][1]).powi(2)).sqrt();
                        worn_length += l;
                        h = h.max(l);
                    }
                }
                let snapping = mortex::surface::SNAP_VERTEX * h * worn_length;
                let bound = 1e-4 * w.worn_area[i] + snapping;
                let diff = (lost - w.worn_area[i]).abs();
                assert!(
                    diff <= bound,
                    "surface {i} cycle {}: area lost {lost} vs worn area {} (bound {bound:.2e})",
                    w.cycle,
                    w.worn_area[i]
                );
            }
        }
        if w.increment == 0 && w.cycle > 0 {
            for i in 0..k.len() {
                let rel = (w.worn_area[i] - k[i] * w.work[i]).abs() / w.worn_area[i];
                assert!(rel < 1e-10, "surface {i}: balance {rel:.1e}");
            }
            assert!((w.work[0] - w.work[1]).abs() < 1e-9 * w.work[0], "same work on both bodies");
            balance_checks += 1;
        }
        Ok(())
    })
    .unwrap();
    assert_eq!(state.wear.cycle, 600);
    assert!(state.wear.computed_cycles < 100, "computed cycles {}", state.wear.computed_cycles);
    assert!(balance_checks as u64 == state.wear.computed_cycles && geometric.len() >= 10);
    eprintln!(
        "McColl 600 cycles: {} computed; last geometric area check {:?}, worn areas {:?}",
        state.wear.computed_cycles,
        geometric.last(),
        state.wear.worn_area
    );
}

/// A real boundary that wears becomes a virtual surface coinciding with it: before any wear the
/// McColl scene (both contact boundaries turned virtual, the cylinder's as the mortar side)
/// gives the real-surface contact pressure to 1e-8 of its peak (measured 7e-10: the virtual
/// vertices interpolate their host cells through an inverse map, which costs digits; the
/// multiplier nodes of the two runs differ by one at a chain end, so pressures are compared at
/// the real run's node positions by linear interpolation, over the contact).
#[test]
fn worn_boundary_turned_virtual_matches_the_real_surface_before_wear() {
    let text =
        std::fs::read_to_string("wear_cases/mccoll_fretting.toml").unwrap().replace("cycles = 18000", "cycles = 1");
    let a = text.find("[[wear]]").unwrap();
    let b = text.find("[steps]").unwrap();
    let real_text = format!("{}{}", &text[..a], &text[b..]);
    let first_step = |t: &str| {
        let case = mortex::case::parse(t, "mccoll", Path::new("wear_cases"), "mccoll").unwrap();
        let model = case.model;
        let mut state = StaticAnalysis::initial_state_of(&model);
        let mut out = None;
        run(&model, &mut state, RunOptions::default(), |r, st, _, d| {
            if r.step == 1 {
                let f = mortex::contact::contact_field(&d.contact, &st.contact_unknowns(), 0);
                let mut v: Vec<(f64, f64)> = f.iter().map(|n| (n.position.x, n.pressure)).collect();
                v.sort_by(|p, q| p.0.total_cmp(&q.0));
                out = Some(v);
            }
            Ok(())
        })
        .unwrap();
        out.unwrap()
    };
    let virt = first_step(&text);
    let real = first_step(&real_text);
    let peak = real.iter().fold(0.0_f64, |m, p| m.max(p.1));
    let interp = |x: f64| {
        let k = virt.partition_point(|p| p.0 < x).clamp(1, virt.len() - 1);
        let (a, b) = (virt[k - 1], virt[k]);
        a.1 + (b.1 - a.1) * (x - a.0) / (b.0 - a.0)
    };
    let mut compared = 0;
    for &(x, p) in real.iter().filter(|p| p.1 > 0.0) {
        let d = (interp(x) - p).abs() / peak;
        assert!(d < 1e-8, "x = {x}: virtual {} vs real {p} ({d:.1e})", interp(x));
        compared += 1;
    }
    assert!(compared >= 10, "nodes in contact compared: {compared}");
}

/// The dissipated-energy law `dw = alpha |q ds|` against Archard in gross slip: a slipping node
/// carries `|q| = mu p`, a sticking one no slip, so with `alpha = k / mu` the two laws give the
/// same wear work node by node. McColl scene, 60 cycles, fixed jump 10: worn areas and largest
/// depths equal to 1e-12 relative (round-off).
#[test]
fn energy_law_equals_archard_over_mu_in_gross_slip() {
    const MU: f64 = 0.9;
    let base = std::fs::read_to_string("wear_cases/mccoll_fretting.toml")
        .unwrap()
        .replace("cycles = 18000", "cycles = 60")
        .replace("[output]", "[cycle_jump]\nfixed = 10\n\n[output]");
    let energy = base
        .replace("coefficient = 2.9e-8", &format!("coefficient = {:e}\nlaw = \"energy\"", 2.9e-8 / MU))
        .replace("coefficient = 1.9e-8", &format!("coefficient = {:e}\nlaw = \"energy\"", 1.9e-8 / MU));
    assert_eq!(energy.matches("law = \"energy\"").count(), 2);
    let finish = |t: &str| {
        let case = mortex::case::parse(t, "mccoll", Path::new("wear_cases"), "mccoll").unwrap();
        let mut state = StaticAnalysis::initial_state_of(&case.model);
        run(&case.model, &mut state, RunOptions::default(), |_, _, _, _| Ok(())).unwrap();
        state.wear
    };
    let (a, e) = (finish(&base), finish(&energy));
    for i in 0..2 {
        let rel = (a.worn_area[i] - e.worn_area[i]).abs() / a.worn_area[i];
        assert!(
            rel < 1e-12,
            "surface {i}: worn area {} (Archard) vs {} (energy): {rel:.1e}",
            a.worn_area[i],
            e.worn_area[i]
        );
        let (da, de) =
            (a.depth[i].iter().fold(0.0_f64, |m, &d| m.max(d)), e.depth[i].iter().fold(0.0_f64, |m, &d| m.max(d)));
        assert!((da - de).abs() < 1e-12 * da, "surface {i}: max depth {da} vs {de}");
    }
}

/// Internal variables stay on their integration points (uniform-wear scene with a J2 host,
/// yield stress 35 MPa, hardening modulus 2 GPa, under the 50 MPa contact pressure (von Mises
/// stress about 44 MPa), so the host yields,
/// and the host wears 1.6 mm through three element layers). A point the surface passes (its
/// material worn away) keeps, bit for bit, the plastic history it had when the surface passed
/// it, at every later step; every wear update (surface moved, host re-cut, band refitted, next
/// cycle's solver set up) leaves the history of every point as it was.
#[test]
fn plastic_history_stays_on_its_points_through_wear() {
    let text = std::fs::read_to_string("wear_cases/uniform_wear.toml")
        .unwrap()
        .replace(
            "[[bodies]]\nname = \"host\"\nmaterial = \"soft\"",
            "[[materials]]\nname = \"soft_j2\"\nmodel = \"j2_plastic\"\nyoung = 200.0\npoisson = 0.3\nyield_stress = 35.0\nisotropic_hardening = 2000.0\n\n[[bodies]]\nname = \"host\"\nmaterial = \"soft_j2\"",
        );
    assert!(text.contains("soft_j2\"\nmesh"));
    let case = mortex::case::parse(&text, "j2_wear", Path::new("wear_cases"), "j2_wear").unwrap();
    let model = case.model;
    let mut state = StaticAnalysis::initial_state_of(&model);
    let bits = |h: &mortex::fem::material::PlasticState| -> Vec<u64> {
        h.eps_p.iter().chain(h.back.iter()).chain(std::iter::once(&h.alpha)).map(|v| v.to_bits()).collect()
    };
    // Per stateful point: the history it had when the surface passed it.
    let mut passed: std::collections::HashMap<usize, Vec<u64>> = std::collections::HashMap::new();
    let (mut updates_checked, mut max_eqps) = (0, 0.0_f64);
    run(&model, &mut state, RunOptions::default(), |r, st, m, d| {
        // Where the host's surface was for the step (the lowest vertex: points above it lie in
        // the worn-away material).
        let y_surface = d.surfaces[m.wear.surfaces[0].surface].vertices.iter().fold(f64::INFINITY, |a, v| a.min(v.y));
        let xs = d.point_coords(m);
        let el = &m.elements;
        for e in 0..el.len() {
            let (s0, s1) = (el.state_offset[e], el.state_offset[e + 1]);
            for q in 0..s1 - s0 {
                let (k, h) = (s0 + q, &st.history[s0 + q]);
                max_eqps = max_eqps.max(h.alpha);
                match passed.get(&k) {
                    Some(b) => assert_eq!(b, &bits(h), "step {}: a point the surface passed changed its history: element {e} point {q} at {:?}, weight {}, surface {y_surface}", r.step, xs[el.point_offset[e] + q], d.rules[el.rule[e]].weights[q]),
                    None if xs[el.point_offset[e] + q].y > y_surface + 1e-12 => {
                        passed.insert(k, bits(h));
                    }
                    None => {}
                }
            }
        }
        if r.increment == 4 && st.wear.increment == 0 {
            let before: Vec<u64> = st.history.iter().flat_map(bits).collect();
            let mut next = d.clone();
            next.place_worn_surfaces(m, &st.wear).unwrap();
            let s2 = st.clone();
            let mut analysis = StaticAnalysis::on(m, std::sync::Arc::new(next)).unwrap();
            analysis.resume(&s2).unwrap();
            let after: Vec<u64> = s2.history.iter().flat_map(bits).collect();
            assert!(before == after, "cycle {}: the wear update changed the history", st.wear.cycle);
            updates_checked += 1;
        }
        Ok(())
    })
    .unwrap();
    eprintln!("J2 wear: {} points passed by the surface, max equivalent plastic strain {max_eqps:.2e}, {updates_checked} updates", passed.len());
    assert!(max_eqps > 1e-3, "the host must yield: {max_eqps}");
    assert!(passed.len() >= 48, "the surface must pass the points of three element layers: {}", passed.len());
    assert_eq!(updates_checked, 20);
}

/// The Winkler scene as a finite-element scene: a thin elastic layer (thickness t = 0.1 mm,
/// E = 1000 MPa, nu = 0, on a rigid base: uniaxial strain, so `kappa = E / t` for long waves)
/// under a stiff flat punch of half-width b = 1 mm = 10 t (load 20 N/mm, mean pressure 10 MPa),
/// frictionless, slid +-0.01 mm (dS = 0.04 mm per cycle). The layer's surface starts as a
/// parabola `g0 = 0.75e-3 (x/b)^2` below the punch, so the initial pressure is
/// `kappa (delta - g0)`, 12.5 MPa in the centre and 5 MPa at the edges; it wears with
/// `k = 2.5e-6 /MPa`: Winkler decay `a = kappa k dS = 1e-3` per cycle. Measured: the decay rate
/// of the pressure deviation over the punch's inner half (|x| < b/2, away from the edge zones
/// where the layer's shear couples the points), fitted between cycles 100 and 1000, against
/// `a`. Tolerance 3%: the finite layer is Winkler only up to `(t / b)^2`-order corrections over
/// the parabola's width, and the explicit jump dN = 5 (a dN = 5e-3) is first order in time
/// (0.25%).
#[test]
fn thin_layer_wears_like_a_winkler_foundation() {
    const T: f64 = 0.1;
    const E: f64 = 1000.0;
    const B: f64 = 1.0;
    const G0: f64 = 0.75e-3;
    const K: f64 = 2.5e-6;
    const STROKE: f64 = 0.01;
    let a_winkler = E / T * K * 4.0 * STROKE;
    let points: Vec<String> = (0..200)
        .map(|i| {
            let x = -2.4875 + 0.025 * i as f64; // no vertex on the host's edges
            format!("[{x}, {}]", T - G0 * (x / B) * (x / B))
        })
        .collect();
    let text = format!(
        r#"
[problem]
hypothesis = "plane_strain"
[[materials]]
name = "layer"
model = "elastic"
young = {E}
poisson = 0.0
[[materials]]
name = "stiff"
model = "elastic"
young = 1.0e6
poisson = 0.3
[[bodies]]
name = "layer"
material = "layer"
mesh = {{ type = "rectangle", origin = [-2.0, 0.0], size = [4.0, {T}], divisions = [160, 8] }}
[[bodies]]
name = "punch"
material = "stiff"
mesh = {{ type = "rectangle", origin = [-{B}, {T}], size = [{w}, 0.25], divisions = [80, 10] }}
[[curves]]
name = "stroke"
path = [[0.0, 0.0], [1.0, 0.0], [1.25, 1.0], [1.75, -1.0], [2.0, 0.0]]
[[cuts]]
name = "surface"
body = "layer"
points = [{pts}]
keep = "right"
[[contacts]]
name = "interface"
mortar = "punch"
mortar_surface = ["bottom"]
other = "layer"
other_cut = "surface"
[[wear]]
cut = "surface"
coefficient = {K}
max_depth = 0.01
[[rigid]]
body = "punch"
set = "top"
[[loads]]
body = "punch"
set = "top"
total_force = [0.0, -20.0]
[[bcs]]
body = "punch"
set = "top_left"
ux = {STROKE}
curve = "stroke"
[[bcs]]
body = "layer"
set = "bottom"
ux = 0.0
uy = 0.0
[steps]
path = [[0.0, 0.0], [1.0, 1.0], [2.0, 1.0]]
cycle = [1.0, 2.0]
cycles = 1000
increments = 4
[cycle_jump]
fixed = 5
scheme = "explicit"
"#,
        w = 2.0 * B,
        pts = points.join(", ")
    );
    let case = mortex::case::parse(&text, "thin_layer", Path::new("."), "thin_layer").unwrap();
    let model = case.model;
    let pair = &model.initial().contact.pairs[0];
    let rows: Vec<(usize, f64)> = (0..pair.multipliers.num_nodes)
        .filter(|&l| pair.multipliers.points[l].x.abs() < 0.5 * B)
        .map(|l| (pair.first_row + l, model.initial().contact.phi[pair.first_row + l]))
        .collect();
    let nt = model.initial().contact.first_multiplier;
    let mut deviation: Vec<(u64, f64)> = vec![];
    let mut state = StaticAnalysis::initial_state_of(&model);
    run(&model, &mut state, RunOptions::default(), |r, st, _, _| {
        // The pressure of the cycle's last increment, before its wear is applied (the state's
        // cycle counter has moved on: that pressure belongs to the cycle before).
        if r.cycle >= 1 && st.wear.increment == 0 {
            let p: Vec<f64> = rows.iter().map(|&(k, _)| -st.multipliers[nt + k]).collect();
            let total: f64 = rows.iter().map(|&(_, w)| w).sum();
            let mean: f64 = p.iter().zip(&rows).map(|(p, (_, w))| p * w).sum::<f64>() / total;
            let rms = (p.iter().zip(&rows).map(|(p, (_, w))| w * (p - mean).powi(2)).sum::<f64>() / total).sqrt();
            deviation.push((st.wear.cycle - st.wear.jump, rms));
        }
        Ok(())
    })
    .unwrap();
    let at = |n: u64| deviation.iter().find(|(c, _)| *c >= n).copied().unwrap();
    let ((n1, d1), (n2, d2)) = (at(100), at(deviation.last().unwrap().0));
    let a_fe = (d1 / d2).ln() / (n2 - n1) as f64;
    eprintln!(
        "thin layer: deviation {d1:.4} MPa at cycle {n1}, {d2:.4} MPa at {n2}: decay {a_fe:.4e} per cycle vs \
         Winkler kappa k dS = {a_winkler:.4e} ({:+.2}%); initial deviation {:.4} MPa",
        100.0 * (a_fe / a_winkler - 1.0),
        deviation[0].1
    );
    assert!((a_fe / a_winkler - 1.0).abs() < 0.03, "decay {a_fe} vs {a_winkler}");
}
