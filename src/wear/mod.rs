//! Wear: Archard-type laws integrated with the mortar contact quantities, the move of worn
//! virtual surfaces through their host, and the cycle-jump controller.
//!
//! **Laws** (Archard, Proc. R. Soc. A 236 (1956); energy form: Fouvry et al., Wear 255 (2003)
//! 287). Per mortar multiplier node `j` and converged step, with `lambda_n,j = -p_j` the nodal
//! pressure, `lambda_t,j` the nodal shear and `ds_j = T_j . du` the weighted slip increment
//! (`T_j` the pair's tangential row), the weighted wear work is
//! `W_j = p_j |ds_j|` (Archard) or `W_j = |lambda_t,j ds_j|` (energy). With the traction field
//! `p(x) = sum_j p_j Phi_j(x)`, `sum_j W_j = int p |ds|` exactly wherever the slip keeps its sign
//! over a hat's support.
//!
//! **Where the wear goes** (MorteX wear, DESIGN.md sec. 1): the wearing surface is the pair's
//! virtual other side. The work is spread over the pair's mortar integration points as the
//! density `q(x) = sum_j W_j Phi_j(x) / int Phi_j` and collected on the wearing polyline's own
//! vertices through its hat functions `N_i` at the paired point: the wear volume of a step is
//! `V_i = k sum_points wt q N_i(x_other)`, and the nodal depth `w_i = V_i / int N_i`, the
//! integral over the part of the polyline inside its host. Since the hats sum to one,
//! `sum_i V_i = k sum_j W_j`: the worn area balances the wear work exactly, on every body.
//!
//! **Cycles and jumps.** Wear accumulates over the increments of a computed cycle with the
//! surface held; at the cycle's end it is applied `dN` times (the cycle jump, explicit Euler
//! in cycles), the vertices move along their inward vertex normals in the host's reference
//! configuration, and the host is re-cut on its fixed points. For a flat punch on a Winkler
//! foundation the pressure deviation is multiplied by `1 - a dN` per jump (`a = kappa k dS`),
//! so a jump beyond `2 / a` diverges. The adaptive controller ([`next_jump`]) estimates `a`
//! from the change of the wear rates between computed cycles (no stiffness is given to it),
//! keeps `a dN <= 1`, bounds the depth added per jump by a fraction of the surface's
//! resolution, and doubles `dN` at most per jump while the rates are steady.
//!
//! **Implicit jump** (the default, [`JumpScheme::Implicit`]): the cycle's wear is taken at the
//! pressure at the *end* of the jump, linearised at *every* increment of the cycle: each
//! converged increment keeps its interface stiffness (`dlambda/dg` on the normal rows in
//! contact and the open candidate rows around them, each held at its gap, which the condensed
//! solve has at hand: one small dense solve per row), its pressures and the coupling of its
//! rows with the worn vertices where it is paired. The jump stacks them: a block-diagonal
//! stiffness, one block per stroke position, sharing the depth change of the jump (see
//! [`implicit_pressure_change`]). Under finite sliding each stroke position reads the scar
//! where it is then; a linearisation at one position only (the cycle's last) leaves the wear of
//! the others explicit, and a scar that is smooth as seen from there grows element-scale
//! roughness where the stroke ends (measured on McColl at 1,000 cycles, 4 increments: 25-29% off
//! the run without jumps in L2 with the last increment only, 10-14% stacked). On the Winkler
//! scene it divides the
//! deviation by `1 + a dN` per jump: stable for any `dN`. The contact set may change over the
//! jump ([`implicit_contact_change`]: rows whose end pressure would pull open, open rows whose
//! end gap would penetrate close), so a scar that deepens widens its contact within the jump:
//! on a unilateral Winkler foundation the jump is the exact backward-Euler step. What bounds the
//! jump then is accuracy: the pressure change a jump causes, in the mean square over the
//! contact, at most `pressure_change` (default 0.2) of the pressure
//! ([`bounded_implicit_jump`]), besides the depth bound and the doubling. The linearisation also keeps each row's slip of the
//! computed cycle: where the slip distribution changes with the wear (partial slip, whose slip
//! zone widens as the scar deepens under force control) the jump's predicted wear rate is off at
//! first order in `dN`. So each jump is checked a posteriori against the next computed cycle,
//! which caps the following jump ([`prediction_cap`]): its predicted pressure and its predicted
//! worn-area rate per surface (`prediction_tolerance`, default 1%; in gross slip the area rate
//! is `k P S` and this check is silent).
//!
//! **Plastic history over a jump.** The history advances only in computed cycles: over the
//! jumped cycles it is frozen, the standard assumption of shakedown to an elastic state or to a
//! stable (closed) plastic loop. The interface stiffness of the implicit jump is the one of the
//! last converged state (the consistent tangent where points yield). Where the body still
//! ratchets, each jumped cycle would drop the net plastic strain of a computed cycle, so a jump
//! drops at most `ratcheting_tolerance` of it (`dN` times the largest net equivalent plastic
//! strain of the last computed cycle, [`cycle_plasticity`]); a body that ratchets more per
//! cycle than that is computed cycle by cycle, with a warning.

mod cycle;

pub use cycle::{
    accumulate_step_wear, apply_cycle_wear, cycle_plasticity, plastic_snapshot, GapSensitivity, IncrementJump,
    IncrementSurface, StepPath, WearError, WearScene, WearState,
};

use crate::contact::{ContactSet, PairedSide};
use crate::mesh::Mesh2;
use crate::moving::FreeSurface;
use crate::solver::dense::DenseLu;
use nalgebra::{DMatrix, DVector, Point2, Vector2};

/// Wear law of a surface.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum WearLaw {
    /// `dw = k p |ds|` (`k` in 1/pressure).
    #[default]
    Archard,
    /// `dw = alpha |q ds|` (dissipated energy; `alpha` in 1/pressure).
    Energy,
}

/// A wearing virtual surface of the model.
#[derive(Debug, Clone, PartialEq)]
pub struct WearingSurface {
    /// The cut's name, its index among the model's free surfaces and the contact pair whose
    /// other side it is.
    pub name: String,
    pub surface: usize,
    pub contact: usize,
    /// The surface is the pair's (virtual) mortar side, not its other side.
    pub on_mortar_side: bool,
    pub coefficient: f64,
    pub law: WearLaw,
    /// Deepest wear the host was prepared for (its band of fixed points).
    pub max_depth: f64,
}

/// How many cycles one computed cycle stands for.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum JumpPolicy {
    /// Always `dN` cycles (the last jump shortened to the run's end).
    Fixed(u64),
    /// Adaptive (see the module documentation): depth per jump at most `depth_fraction` of the
    /// surface's smallest segment in contact, `dN <= max_jump`; with the implicit scheme the
    /// pressure change a jump causes at most `pressure_change` of the peak pressure.
    /// Implicit jumps are also checked a posteriori against the next computed cycle: the
    /// predicted pressure (5%, second order) and each surface's predicted worn-area rate
    /// (relative error `prediction_tolerance`, first order), see [`prediction_cap`].
    Adaptive { depth_fraction: f64, max_jump: u64, pressure_change: f64, prediction_tolerance: f64 },
}

/// Default bound of the implicit jump's pressure change, relative to the peak pressure.
pub const DEFAULT_PRESSURE_CHANGE: f64 = 0.2;

impl Default for JumpPolicy {
    fn default() -> Self {
        JumpPolicy::Adaptive {
            depth_fraction: 0.1,
            max_jump: 1_000_000,
            pressure_change: DEFAULT_PRESSURE_CHANGE,
            prediction_tolerance: DEFAULT_PREDICTION_TOLERANCE,
        }
    }
}

/// The wear part of a model.
#[derive(Debug, Clone, PartialEq)]
pub struct WearModel {
    pub surfaces: Vec<WearingSurface>,
    pub jump: JumpPolicy,
    pub scheme: JumpScheme,
    /// Filter length of the wear-rate smoothing in segments (see [`smooth_rate`]; 0: none).
    pub smoothing: f64,
    /// Yielding bodies: the largest net equivalent plastic strain a jump may drop at a point
    /// (`dN` times that of the last computed cycle, see [`cycle_plasticity`]).
    pub ratcheting_tolerance: f64,
    /// Adaptive implicit jumps: the smallest fraction of a computed cycle's wear one update may
    /// apply (see [`fractional_update`]); 1: a computed cycle's wear is always applied whole.
    /// Yielding bodies always take whole cycles (a repeated pass would advance their history).
    pub min_fraction: f64,
}

/// Default smallest wear fraction of an update: 1/256. An adaptive implicit update whose
/// predicted pressure change exceeds the bound applies half, a quarter, ... of the computed
/// cycle's wear and computes the cycle again on the worn geometry, so an accelerated coefficient
/// (one cycle's wear large against the contact's compliance) follows the path of a realistic
/// one; where a whole cycle's wear stays within the bound (realistic coefficients, fretting)
/// nothing changes. On the rounded punch (12 um of wear per cycle against 0.6 um of elastic
/// approach) about three passes per cycle, 5x the wall time of whole cycles, for a smooth groove
/// that 16 and 32 increments give alike to 0.25% (L2); whole cycles (`min_fraction = 1`) grew
/// pits there (17% of the depth at 32 increments).
pub const DEFAULT_MIN_FRACTION: f64 = 1.0 / 256.0;

/// Default ratcheting tolerance: 1e-4 per jump (5% of the yield strain of a 400 MPa steel).
pub const DEFAULT_RATCHETING_TOLERANCE: f64 = 1e-4;

/// Default wear-rate smoothing: one segment.
pub const DEFAULT_SMOOTHING: f64 = 1.0;

impl Default for WearModel {
    fn default() -> Self {
        WearModel {
            surfaces: vec![],
            jump: JumpPolicy::default(),
            scheme: JumpScheme::default(),
            smoothing: DEFAULT_SMOOTHING,
            ratcheting_tolerance: DEFAULT_RATCHETING_TOLERANCE,
            min_fraction: DEFAULT_MIN_FRACTION,
        }
    }
}

impl WearModel {
    pub fn is_empty(&self) -> bool {
        self.surfaces.is_empty()
    }
}

/// What one converged step wears on one wearing surface.
#[derive(Debug, Clone, PartialEq)]
pub struct StepWear {
    /// Wear volume `V_i` (per unit thickness) per vertex of the polyline.
    pub volume: Vec<f64>,
    /// The step's wear work `int p |ds|` (or `int |q ds|`).
    pub work: f64,
    /// Per multiplier node of the pair: its wear work `W_j` and weighted slip `|ds_j|`.
    pub row_work: Vec<f64>,
    pub row_slip: Vec<f64>,
}

/// The mortar coupling of a pair's multiplier nodes with a wearing polyline's vertices over one
/// pairing: `entries (i, l, G_li)` with `G_li = int Phi_l N_i` (gap row `l` opens by
/// `sum_i G_li dh_i` when vertex `i` wears `dh_i`), and `phi_l = int Phi_l = sum_i G_li` over
/// the same points. Wear volumes are `V_i = k sum_l G_li W_l / phi_l`.
#[derive(Debug, Clone, PartialEq)]
pub struct WearCoupling {
    pub entries: Vec<(usize, usize, f64)>,
    pub phi: Vec<f64>,
}

impl WearCoupling {
    /// Vertex volumes `k sum_l G_li W_l / phi_l` of row works `work`.
    pub fn volumes(&self, coefficient: f64, work: &[f64], nv: usize) -> Vec<f64> {
        let mut v = vec![0.0; nv];
        for &(i, l, g) in &self.entries {
            if work[l] != 0.0 && self.phi[l] > 0.0 {
                v[i] += coefficient * work[l] * g / self.phi[l];
            }
        }
        v
    }
}

/// The coupling of `ws`'s contact pair with its polyline (see [`WearCoupling`]); `x` places
/// the nodes where the pair is paired (see [`step_wear`]). `None` when the surface is neither
/// the pair's embedded other side nor its mortar side.
pub fn wear_coupling(
    set: &ContactSet,
    hosts: &[(&Mesh2, usize)],
    ws: &WearingSurface,
    surface: &FreeSurface,
    x: &dyn Fn(usize) -> Point2<f64>,
    rows: Option<&[bool]>,
) -> Option<WearCoupling> {
    let c = &set.pairs[ws.contact];
    let n_lm = c.multipliers.num_nodes;
    let nv = surface.vertices.len();
    let embedding = match &c.other {
        PairedSide::Embedded { embedding, .. } => Some(embedding),
        PairedSide::Edges(_) => None,
    };
    if !ws.on_mortar_side && embedding.is_none() {
        return None;
    }
    // Paired where the surfaces meet (the wear lands on the material that is under the point
    // then), weighted by the reference length (small strain).
    let mut points = crate::contact::paired_points(hosts, c, x, rows);
    let ns = c.side.points.len();
    for p in points.iter_mut() {
        let reference = (c.side.points[p.vb % ns] - c.side.points[p.va % ns]).norm();
        if p.segment_length > 0.0 {
            p.wt *= reference / p.segment_length;
        }
    }
    let mut phi = vec![0.0; n_lm];
    let mut entries = Vec::with_capacity(4 * points.len());
    for p in &points {
        // The point on the wearing surface: the mortar point (side vertices are the polyline's
        // vertices) or its partner on the other side's piece.
        let (a, b, tau) = match embedding {
            Some(e) if !ws.on_mortar_side => {
                let piece = &e.pieces[p.other];
                (piece.segment, (piece.segment + 1) % nv, piece.t0 + p.sigma * (piece.t1 - piece.t0))
            }
            _ => (p.va % nv, p.vb % nv, p.tau),
        };
        for &(l, v) in &p.hats {
            if v == 0.0 {
                continue;
            }
            phi[l] += p.wt * v;
            entries.push((a, l, p.wt * v * (1.0 - tau)));
            entries.push((b, l, p.wt * v * tau));
        }
    }
    Some(WearCoupling { entries, phi })
}

/// One wearing surface in its step's pairing: the contact set, the host meshes (with their node
/// offsets), the surface's wear declaration and where it is now.
#[derive(Clone, Copy)]
pub struct WearSide<'a> {
    pub set: &'a ContactSet,
    pub hosts: &'a [(&'a Mesh2, usize)],
    pub ws: &'a WearingSurface,
    pub surface: &'a FreeSurface,
}

/// Wear of one converged step on one wearing surface. `sub`: displacements at the start and
/// end of the step (or of a part of it); `x` places nodes where the pair is paired for the step: the
/// reference geometry under small sliding (the material points that meet stay paired, as in its
/// mechanics), the configuration halfway through the step under finite sliding (the wear lands
/// on the material that slid under the point).
pub fn step_wear(
    side: WearSide<'_>,
    sub: SubStep<'_>,
    multipliers: &[f64],
    x: &dyn Fn(usize) -> Point2<f64>,
) -> StepWear {
    let WearSide { set, hosts, ws, surface } = side;
    let c = &set.pairs[ws.contact];
    let (nt, nn) = (set.first_multiplier, set.rows.len());
    let n_lm = c.multipliers.num_nodes;
    let nv = surface.vertices.len();
    let mut out = StepWear { volume: vec![0.0; nv], work: 0.0, row_work: vec![0.0; n_lm], row_slip: vec![0.0; n_lm] };
    for l in 0..n_lm {
        let k = c.first_row + l;
        if set.phi[k] <= 0.0 {
            continue;
        }
        let ds: f64 = set.tangents[k].iter().map(|&(d, v)| v * (sub.to(d) - sub.from(d))).sum();
        out.row_slip[l] = ds.abs();
        out.row_work[l] = match ws.law {
            WearLaw::Archard => (-multipliers[nt + k]).max(0.0) * ds.abs(),
            WearLaw::Energy => c.friction_row[l].map_or(0.0, |j| (multipliers[nt + nn + j] * ds).abs()),
        };
    }
    if out.row_work.iter().all(|&w| w == 0.0) {
        return out;
    }
    // Only the rows that did work, and their neighbours for margin: the coupling of the
    // others is not needed (a row's `phi` and entries come from the segments its hat covers,
    // all of them visited).
    let did_work = |l: usize| out.row_work.get(l).is_some_and(|&w| w != 0.0);
    let working: Vec<bool> = (0..n_lm).map(|l| did_work(l) || did_work(l + 1) || (l > 0 && did_work(l - 1))).collect();
    let Some(coupling) = wear_coupling(set, hosts, ws, surface, x, Some(&working)) else {
        out.row_work.iter_mut().for_each(|w| *w = 0.0);
        return out;
    };
    // Work of rows that pair nowhere lands nowhere (and does not count).
    for (w, phi) in out.row_work.iter_mut().zip(&coupling.phi) {
        if *phi <= 0.0 {
            *w = 0.0;
        }
    }
    out.volume = coupling.volumes(ws.coefficient, &out.row_work, nv);
    out.work = out.row_work.iter().sum();
    out
}

/// The wear of one converged step on one wearing surface, swept along the step's path.
///
/// Small sliding keeps the reference pairing (the material points that meet stay paired, as in
/// its mechanics) and the converged step's tractions: one [`step_wear`]. Under finite sliding
/// the step's work of each multiplier row lands on the other side's material that slid under
/// it: the step is swept in sub-positions (see [`sweep_positions`]), each paired where the
/// surfaces meet halfway through it, with the tractions (in the mortar side's frame)
/// interpolated linearly from the step's start (`lambda.0`, if given) to its end (`lambda.1`),
/// each shear as the fraction of the pressure it mobilises at the end (see
/// [`interpolated_tractions`]): the Archard work of a row is `(p_start + p_end) / 2 |ds|` on
/// both sides, exact for tractions linear over the step (the mortar side's own wear stays on its
/// nodes: one position at mid-step). The worn area balances that work exactly; only where it
/// lands follows the path (sampling one position per step aliases: spikes in the scar at the
/// increment ends).
pub fn swept_step_wear(side: WearSide<'_>, coords: &[Point2<f64>], path: StepPath<'_>) -> StepWear {
    let WearSide { set, ws, surface, .. } = side;
    let StepPath { u_prev, u: u_end, lambda_prev, multipliers: lambda_end } = path;
    let finite = set.pairs[ws.contact].sliding == crate::contact::Sliding::Finite;
    let lambda_prev = lambda_prev.filter(|_| finite);
    let subs = sweep_positions(set, ws, surface, u_prev, u_end, lambda_end);
    let at = |j: usize| {
        let f = (j as f64 + 0.5) / subs as f64;
        let interpolated: Vec<f64>;
        let multipliers = match lambda_prev {
            Some(l0) => {
                interpolated = interpolated_tractions(set, l0, lambda_end, f);
                &interpolated
            }
            None => lambda_end,
        };
        let sub = match subs {
            1 => SubStep::whole(u_prev, u_end),
            _ => SubStep {
                u_prev,
                u_end,
                from: Some(j as f64 / subs as f64),
                to: (j + 1 < subs).then(|| (j + 1) as f64 / subs as f64),
            },
        };
        let x = sub_step_position(set, ws, coords, sub);
        step_wear(side, sub, multipliers, &x)
    };
    // The sub-positions are independent: paired side by side, summed in their order (the
    // same sums on any thread count).
    let parts: Vec<StepWear> = if subs > 1 {
        use rayon::prelude::*;
        (0..subs).into_par_iter().map(at).collect()
    } else {
        (0..subs).map(at).collect()
    };
    let mut total: Option<StepWear> = None;
    for sw in parts {
        total = Some(match total {
            None => sw,
            Some(mut t) => {
                t.volume.iter_mut().zip(&sw.volume).for_each(|(a, v)| *a += v);
                t.row_work.iter_mut().zip(&sw.row_work).for_each(|(a, v)| *a += v);
                t.row_slip.iter_mut().zip(&sw.row_slip).for_each(|(a, v)| *a += v);
                t.work += sw.work;
                t
            }
        });
    }
    total.unwrap_or_else(|| StepWear {
        volume: vec![0.0; surface.vertices.len()],
        work: 0.0,
        row_work: vec![0.0; set.pairs[ws.contact].multipliers.num_nodes],
        row_slip: vec![0.0; set.pairs[ws.contact].multipliers.num_nodes],
    })
}

/// The multipliers at the fraction `f` of a step, from `l0` at its start to `l1` at its end:
/// ties and normals linearly; a shear as its mobilised fraction `q / p` at the end of the step
/// (at its start if the node left contact) times the interpolated pressure, since the shear of a
/// step that starts from stick or at a stroke reversal reaches `mu p` after an elastic slip far
/// below the step's slide.
pub fn interpolated_tractions(set: &ContactSet, l0: &[f64], l1: &[f64], f: f64) -> Vec<f64> {
    let (nt, nc) = (set.first_multiplier, set.rows.len());
    let pressure = |l: &[f64], k: usize| (-l[nt + k]).max(0.0);
    (0..l1.len())
        .map(|i| {
            if i < nt + nc {
                return l0[i] + f * (l1[i] - l0[i]);
            }
            let k = set.friction_normal[i - nt - nc];
            let (p0, p1) = (pressure(l0, k), pressure(l1, k));
            let (q, p) = if p1 > 0.0 { (l1[i], p1) } else { (l0[i], p0) };
            if p > 0.0 {
                q / p * (p0 + f * (p1 - p0))
            } else {
                0.0
            }
        })
        .collect()
}

/// Largest number of sub-positions of one step's sweep.
pub const MAX_SWEEP_POSITIONS: usize = 512;

/// How many sub-positions the step from `u_prev` to `u` is swept in for wearing surface `ws`:
/// 1 under small sliding and for the mortar side; otherwise enough that each slides at most half
/// the surface's smallest segment (the largest slide of a multiplier row carrying pressure).
pub fn sweep_positions(
    set: &ContactSet,
    ws: &WearingSurface,
    surface: &FreeSurface,
    u_prev: &[f64],
    u: &[f64],
    multipliers: &[f64],
) -> usize {
    let c = &set.pairs[ws.contact];
    let mortar_side = c.virtual_mortar.as_ref().is_some_and(|v| v.surface == ws.surface);
    if c.sliding != crate::contact::Sliding::Finite || mortar_side {
        return 1;
    }
    let nt = set.first_multiplier;
    let slide = (c.first_row..c.first_row + c.multipliers.num_nodes)
        .filter(|&k| set.phi[k] > 0.0 && -multipliers[nt + k] > 0.0)
        .map(|k| (set.tangents[k].iter().map(|&(d, v)| v * (u[d] - u_prev[d])).sum::<f64>() / set.phi[k]).abs())
        .fold(0.0_f64, f64::max);
    let h = surface.vertices.windows(2).map(|s| (s[1] - s[0]).norm()).fold(f64::INFINITY, f64::min);
    let usable = slide > 0.0 && slide.is_finite() && h > 0.0 && h.is_finite();
    if !usable {
        return 1;
    }
    ((2.0 * slide / h).ceil() as usize).clamp(1, MAX_SWEEP_POSITIONS)
}

/// Most sub-steps one increment of a computed cycle is solved in (see [`sweep_check`]): its
/// length halved at most `log2` of this many times.
pub const MAX_SUB_STEPS: usize = 256;

/// Largest change of the pressure field over one finite-sliding step, relative to the load it
/// carries ([`SweepCheck::change`]), that the step's sweep may interpolate across. Above the
/// change a field riding along shows from the discretisation alone: a Hertzian pin sliding on
/// a flat, its coarse-grained rows passing over the flat's elements, changes by 11-14% from one
/// step to the next whatever their length (measured on a steel pin R = 2 mm on aluminium, 20 um
/// elements); entering the end of its own groove, by 50-60%.
pub const SWEEP_CHANGE_TOLERANCE: f64 = 0.25;

/// Slide of a step, as a fraction of the contact's width, within which its sweep may
/// interpolate the tractions whatever their change. Measured on a steel pin (R = 2 mm, 20 N/mm,
/// contact width 52 um) slid +-1 mm on aluminium (20 um elements, mu 0.5), 10 cycles of
/// accelerated wear: with increments sliding 1.2 contact widths the track is within 0.3% of
/// the one swept from increments of a quarter width everywhere, with 2.4 widths 1.4% short
/// where the pin enters its groove's end, with 4.8 widths 7.5% short.
pub const SWEEP_WIDTH_FRACTION: f64 = 1.0;

/// How far the sweep of a finite-sliding step can be trusted (see [`swept_step_wear`]): the
/// sweep interpolates each multiplier row's pressure linearly from the step's start to its end,
/// which is the pressure under the row at every sub-position only if the pressure field rides
/// with the rows. A pin sliding on a flat carries its Hertzian pressure with it (no change
/// whatever the slide); the same pin entering the end of the groove it wore, or a contact
/// moving over the rows of a stationary mortar side, changes the field under the rows, and a
/// step sliding many contact widths would then put the wear of its middle where its ends
/// were. Per finite-sliding pair, with `p0`, `p1` the rows' pressures at the step's start and
/// end and `phi` their weights:
///
/// ```text
/// change = sum |p1 - p0| phi / max(sum p0 phi, sum p1 phi)      (0: the field rides along)
/// slide  = max over pressed rows of |T_k . du| / phi_k          (the step's slide)
/// width  = min(sum_{p0 > 0} phi, sum_{p1 > 0} phi)              (the contact's width)
/// ```
///
/// The worst pair is returned.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SweepCheck {
    pub change: f64,
    pub slide: f64,
    pub width: f64,
}

impl SweepCheck {
    /// The step's sweep is exact enough: the pressure field rode along, or the step slid at
    /// most [`SWEEP_WIDTH_FRACTION`] of the contact's width.
    pub fn acceptable(&self) -> bool {
        self.change <= SWEEP_CHANGE_TOLERANCE || self.slide <= SWEEP_WIDTH_FRACTION * self.width
    }

    /// Even pieces a step is to be split into so that each slides at most
    /// [`SWEEP_WIDTH_FRACTION`] of the contact's width (at least 1).
    pub fn pieces(&self) -> usize {
        let per_piece = SWEEP_WIDTH_FRACTION * self.width;
        if per_piece > 0.0 && self.slide.is_finite() {
            ((self.slide / per_piece).ceil() as usize).max(1)
        } else {
            MAX_SUB_STEPS
        }
    }
}

/// The [`SweepCheck`] of the finite-sliding step along `path` (from `(u_prev, lambda_prev)`, a
/// start without tractions if none are given, to `(u, multipliers)`) in the step's pairing `set`
/// (`None`: no finite-sliding pair carries pressure).
pub fn sweep_check(set: &ContactSet, path: StepPath<'_>) -> Option<SweepCheck> {
    let StepPath { u_prev: u0, u: u1, lambda_prev, multipliers: l1 } = path;
    let l0 = lambda_prev.unwrap_or(&[]);
    let nt = set.first_multiplier;
    let mut worst: Option<SweepCheck> = None;
    for c in set.pairs.iter().filter(|c| c.sliding == crate::contact::Sliding::Finite) {
        let rows = c.first_row..c.first_row + c.multipliers.num_nodes;
        let p = |l: &[f64], k: usize| l.get(nt + k).map_or(0.0, |&v| (-v).max(0.0));
        let (mut diff, mut load0, mut load1, mut width0, mut width1, mut slide) = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0_f64);
        for k in rows.filter(|&k| set.phi[k] > 0.0) {
            let (p0, p1, phi) = (p(l0, k), p(l1, k), set.phi[k]);
            diff += (p1 - p0).abs() * phi;
            load0 += p0 * phi;
            load1 += p1 * phi;
            if p0 > 0.0 {
                width0 += phi;
            }
            if p1 > 0.0 {
                width1 += phi;
                let du = set.tangents[k].iter().map(|&(d, v)| v * (u1[d] - u0[d])).sum::<f64>();
                slide = slide.max((du / phi).abs());
            }
        }
        let load = f64::max(load0, load1);
        if load <= 0.0 || !slide.is_finite() {
            continue;
        }
        let check = SweepCheck { change: diff / load, slide, width: width0.min(width1) };
        let worse = |w: &SweepCheck| {
            check.slide / check.width.max(f64::MIN_POSITIVE) > w.slide / w.width.max(f64::MIN_POSITIVE)
        };
        // An unacceptable pair over an acceptable one, then the one sliding more widths.
        let replaces = |w: &SweepCheck| !check.acceptable() && (w.acceptable() || worse(w));
        if worst.as_ref().is_none_or(replaces) {
            worst = Some(check);
        }
    }
    worst
}

/// Where the nodes of wearing surface `ws`'s pair are paired for the part of a step from
/// `u_prev` to `u`: the reference geometry `coords` for small sliding, the configuration halfway
/// through it for finite.
pub fn pairing_position<'a>(
    set: &ContactSet,
    ws: &WearingSurface,
    coords: &'a [Point2<f64>],
    u_prev: &'a [f64],
    u: &'a [f64],
) -> impl Fn(usize) -> Point2<f64> + 'a {
    sub_step_position(set, ws, coords, SubStep::whole(u_prev, u))
}

/// [`pairing_position`] for a sub-position of a step's sweep.
fn sub_step_position<'a>(
    set: &ContactSet,
    ws: &WearingSurface,
    coords: &'a [Point2<f64>],
    sub: SubStep<'a>,
) -> impl Fn(usize) -> Point2<f64> + 'a {
    let finite = set.pairs[ws.contact].sliding == crate::contact::Sliding::Finite;
    move |node: usize| {
        let p = coords[node];
        if !finite {
            return p;
        }
        let (x, y) = (2 * node, 2 * node + 1);
        let (ux, uy) = (0.5 * (sub.from(x) + sub.to(x)), 0.5 * (sub.from(y) + sub.to(y)));
        Point2::new(p.x + ux, p.y + uy)
    }
}

/// The part of a step from `u_prev` to `u_end` between the fractions `from` and `to` of it
/// (`None`: the step's start, its end), its displacements read per DOF: a sweep on fine meshes
/// has dozens of sub-positions, and each reads a few hundred DOFs of the whole field.
#[derive(Clone, Copy)]
pub struct SubStep<'a> {
    u_prev: &'a [f64],
    u_end: &'a [f64],
    from: Option<f64>,
    to: Option<f64>,
}

impl<'a> SubStep<'a> {
    /// The whole step from `u_prev` to `u_end`.
    pub fn whole(u_prev: &'a [f64], u_end: &'a [f64]) -> Self {
        SubStep { u_prev, u_end, from: None, to: None }
    }

    fn at(&self, f: Option<f64>, d: usize, end: f64) -> f64 {
        match f {
            None => end,
            Some(f) => self.u_prev[d] + f * (self.u_end[d] - self.u_prev[d]),
        }
    }

    /// Displacement `d` at the sub-position's start.
    fn from(&self, d: usize) -> f64 {
        self.at(self.from, d, self.u_prev[d])
    }

    /// Displacement `d` at the sub-position's end.
    fn to(&self, d: usize) -> f64 {
        self.at(self.to, d, self.u_end[d])
    }
}

/// `int N_i` of every vertex hat of the surface over its part inside the host.
pub fn vertex_measure(surface: &FreeSurface) -> Vec<f64> {
    let v = &surface.vertices;
    let nv = v.len();
    let mut m = vec![0.0; nv];
    for piece in &surface.embedding.pieces {
        let (a, b) = (piece.segment, (piece.segment + 1) % nv);
        let len = (v[b] - v[a]).norm();
        let (t0, t1) = (piece.t0.min(piece.t1), piece.t0.max(piece.t1));
        let second = 0.5 * (t1 * t1 - t0 * t0);
        m[a] += len * ((t1 - t0) - second);
        m[b] += len * second;
    }
    m
}

/// Inward unit normal at each vertex (average of the adjacent segments' left normals: the
/// material is on the polyline's left).
pub fn vertex_normals(v: &[Point2<f64>], closed: bool) -> Vec<Vector2<f64>> {
    let n = v.len();
    let left = |a: Point2<f64>, b: Point2<f64>| {
        let t = (b - a).normalize();
        Vector2::new(-t.y, t.x)
    };
    (0..n)
        .map(|i| {
            let mut s = Vector2::zeros();
            if i > 0 || closed {
                s += left(v[(i + n - 1) % n], v[i]);
            }
            if i + 1 < n || closed {
                s += left(v[i], v[(i + 1) % n]);
            }
            s.normalize()
        })
        .collect()
}

/// Depth added at each vertex by `dn` cycles of `rate` (depth per cycle); vertices outside the
/// host (`measure == 0`) take the nearest inside vertex's depth so the polyline leaves the host
/// parallel to itself.
pub fn depth_increment(rate: &[f64], measure: &[f64], dn: f64) -> Vec<f64> {
    let n = rate.len();
    let inside: Vec<usize> = (0..n).filter(|&i| measure[i] > 0.0).collect();
    (0..n)
        .map(|i| {
            let j = if measure[i] > 0.0 {
                i
            } else {
                match inside.iter().min_by_key(|&&j| j.abs_diff(i)) {
                    Some(&j) => j,
                    None => return 0.0,
                }
            };
            rate[j] * dn
        })
        .collect()
}

/// Volume-conserving smoothing of a wear rate along an open polyline (a Helmholtz filter):
/// `(M + K_s) r_s = M r` with `M = diag(int N_i)` (the vertices' measures inside the host) and
/// `K_s` the 1D stiffness `(s l)^2 / l` per segment of length `l` (both ends inside the host
/// and wearing: the filter acts within the scar and never spreads wear beyond it),
/// `s` the filter length in units of the local segment length. Constants pass unchanged
/// (`K_s 1 = 0`) and `sum M r_s = sum M r` exactly (`1^T K_s = 0`): the worn area is kept.
/// Modes of wavelength `lambda` are damped by `1 / (1 + (2 pi s l / lambda)^2)`: element-scale
/// roughness (which sets the explicit jump's stability bound through its high contact
/// stiffness, see the module documentation) is removed, a scar many segments wide is not.
/// `s = 0`, or a closed polyline: no smoothing.
pub fn smooth_rate(v: &[Point2<f64>], closed: bool, measure: &[f64], rate: &[f64], s: f64) -> Vec<f64> {
    RateFilter::new(v, closed, measure, rate, s).apply(rate)
}

/// The factored filter of [`smooth_rate`] for the wearing vertices of one rate, applicable to
/// other vectors (the implicit jump filters its corrections with the same operator).
#[derive(Debug, Clone)]
pub struct RateFilter {
    measure: Vec<f64>,
    /// Thomas factors: elimination multipliers, pivots, upper diagonal (empty: identity).
    w: Vec<f64>,
    pivot: Vec<f64>,
    upper: Vec<f64>,
}

impl RateFilter {
    pub fn new(v: &[Point2<f64>], closed: bool, measure: &[f64], rate: &[f64], s: f64) -> Self {
        let n = rate.len();
        let mut f = RateFilter { measure: measure.to_vec(), w: vec![], pivot: vec![], upper: vec![] };
        if s <= 0.0 || closed || n < 3 {
            return f;
        }
        // Tridiagonal system: lower a, diagonal b, upper c.
        let (mut a, mut b, mut c) = (vec![0.0; n], measure.to_vec(), vec![0.0; n]);
        // Only between vertices that wear: the filter never spreads wear where there is none (a
        // stick zone, the unworn surface beyond the scar). Round-off rates (a sticking node's
        // slip is zero to about 1e-17) do not count as wear.
        let floor = 1e-12 * rate.iter().fold(0.0_f64, |m, r| m.max(r.abs()));
        let wears = |r: f64| r.abs() > floor;
        for i in 0..n - 1 {
            if measure[i] > 0.0 && measure[i + 1] > 0.0 && wears(rate[i]) && wears(rate[i + 1]) {
                let l = (v[i + 1] - v[i]).norm();
                let k = s * s * l;
                b[i] += k;
                b[i + 1] += k;
                c[i] -= k;
                a[i + 1] -= k;
            }
        }
        // Vertices outside the host keep their value (unit row).
        for bi in b.iter_mut() {
            if *bi == 0.0 {
                *bi = 1.0;
            }
        }
        // Thomas algorithm (the matrix is diagonally dominant: M + a weighted graph Laplacian).
        let mut w = vec![0.0; n];
        for i in 1..n {
            w[i] = a[i] / b[i - 1];
            b[i] -= w[i] * c[i - 1];
        }
        f.w = w;
        f.pivot = b;
        f.upper = c;
        f
    }

    /// `(M + K_s)^{-1} M x` (`x` itself at vertices outside the host).
    pub fn apply(&self, x: &[f64]) -> Vec<f64> {
        let n = x.len();
        if self.pivot.is_empty() {
            return x.to_vec();
        }
        let mut d: Vec<f64> = self.measure.iter().zip(x).map(|(m, r)| if *m > 0.0 { m * r } else { *r }).collect();
        for i in 1..n {
            d[i] -= self.w[i] * d[i - 1];
        }
        let mut y = vec![0.0; n];
        y[n - 1] = d[n - 1] / self.pivot[n - 1];
        for i in (0..n - 1).rev() {
            y[i] = (d[i] - self.upper[i] * y[i + 1]) / self.pivot[i];
        }
        y
    }
}

/// The polyline moved inward by `depth` at each vertex (along the vertex normals).
pub fn worn_vertices(v: &[Point2<f64>], closed: bool, depth: &[f64]) -> Vec<Point2<f64>> {
    let normals = vertex_normals(v, closed);
    v.iter().zip(&normals).zip(depth).map(|((p, n), &d)| if d != 0.0 { p + n * d } else { *p }).collect()
}

/// Smallest segment length next to a vertex that wears (`rate > 0`): the surface's resolution
/// where it wears.
pub fn wearing_resolution(v: &[Point2<f64>], rate: &[f64]) -> f64 {
    let mut h = f64::INFINITY;
    for i in 0..v.len().saturating_sub(1) {
        if rate[i] > 0.0 || rate[i + 1] > 0.0 {
            h = h.min((v[i + 1] - v[i]).norm());
        }
    }
    h
}

/// How a computed cycle's wear is extrapolated over its jump.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum JumpScheme {
    /// `h += dN r(h)`: stable only while `a dN < 2` for the stiffest wear mode (see the module
    /// documentation); the adaptive controller keeps `a dN <= 1`.
    Explicit,
    /// Linearised backward Euler, `h += dN r(h + dh)` with the pressure's answer to `dh` from
    /// the interface stiffness of every converged increment of the cycle
    /// ([`implicit_pressure_change`] on the stacked increments): stable for any `dN`. Needs interface condensation (linear elastic bodies); otherwise the
    /// explicit jump is used.
    #[default]
    Implicit,
}

/// One wearing surface's part in the implicit jump, on the active normal rows `A` of the
/// interface stiffness.
pub struct JumpSurface<'a> {
    /// `G_li = int Phi_l N_i` for the rows of `A` (rows) and the polyline's vertices (columns).
    pub coupling: DMatrix<f64>,
    /// `phi_l = int Phi_l` of the rows of `A` (as paired for this surface).
    pub phi: Vec<f64>,
    /// `int N_i` of the vertices (0 outside the host).
    pub measure: &'a [f64],
    pub coefficient: f64,
    /// Change of the cycle's wear work per unit pressure change, per row of `A`: the cycle's
    /// weighted slip `sum |ds_l|` (Archard) or `mu` times it (energy law, slipping rows).
    pub work_per_pressure: Vec<f64>,
    /// The cycle's wear rate (depth per cycle per vertex, filtered by `filter`).
    pub rate: &'a [f64],
    pub filter: &'a RateFilter,
}

/// Pressure change `dp_A` at the end of a jump of `dn` cycles (linearised backward Euler):
/// with `dlambda_A = L dg_A` (`L = dlambda_dgap`, the interface stiffness of the converged
/// state, `lambda = -p`), each surface's depth change
/// `dh_b = dN F_b M_b^{-1} (V_b + k_b G_b^T Phi^{-1} c_b dp)` (its cycle's wear volumes `V_b`
/// at the end-of-jump pressure; `F_b` the rate filter, `c_b` work per pressure) opens the gaps
/// by `dg = sum_b G_b dh_b`, hence
/// `(I + dN L sum_b G_b F_b M_b^{-1} k_b G_b^T Phi^{-1} c_b) dp = -dN L sum_b G_b r_b`.
/// For a Winkler foundation (`L = kappa (I - mean)`) this multiplies the pressure deviation by
/// `1 / (1 + a dN)` per jump, `a = kappa k dS`: stable for any jump, first order, and exact in
/// the steady state. The contact set is held (see [`implicit_contact_change`] for the jump that
/// lets it change). The rows `A` may be those of several increments of a cycle stacked, each
/// with its own pairing in `G_b`: `L` is then block-diagonal and the depth change `dh_b` is
/// the one all of them share. `None` if the system is singular.
pub fn implicit_pressure_change(dlambda_dgap: &DMatrix<f64>, surfaces: &[JumpSurface], dn: u64) -> Option<Vec<f64>> {
    JumpOperator::new(dlambda_dgap, surfaces).pressure_change(dn)
}

/// The parts of the implicit jump's system that do not depend on the jump, in factored form:
/// `H = sum_b G_b F_b M_b^{-1} k_b G_b^T Phi^{-1} c_b = U V` of [`implicit_pressure_change`]
/// (column r: the gap opening per cycle of a unit pressure change at row r), `U` the
/// couplings `G_b` on the vertices any row touches, `V` the filtered depth change per cycle of
/// a unit pressure change at each row on those vertices; `L U` and `L sum_b G_b r_b`. Formed
/// once per computed cycle.
///
/// The rank of `H` is the number of touched vertices `k`, well below the stacked rows `n` (on
/// McColl about 165 against about 600), and `L` is block-diagonal (one block per
/// increment), so a trial jump solves `(B + dN L U V D_C) x = rhs` (`B` block-diagonal: unit
/// columns on the closed rows, `-L` on the open ones; `D_C` the closed rows) by the
/// Sherman-Morrison-Woodbury identity, a `k x k` system, instead of an `n x n` one. The block
/// factors and `V D_C B^{-1} L U` depend on the contact set only and are kept for the next
/// trial `dN` (a trial starts from the cycle's contact set, and an iteration changes few
/// blocks). A singular block falls back to the dense system.
pub struct JumpOperator<'a> {
    stiffness: &'a DMatrix<f64>,
    /// Row ranges of the diagonal blocks of `L`.
    blocks: Vec<std::ops::Range<usize>>,
    /// `L U`, `n x k`.
    l_coupling: DMatrix<f64>,
    /// `V`, `k x n`.
    depth_per_pressure: DMatrix<f64>,
    l_gap_rate: DVector<f64>,
    /// Per diagonal block, its factors for the last few contact sets of its rows.
    factored: std::cell::RefCell<Vec<Vec<BlockFactor>>>,
}

/// What a trial jump needs of one diagonal block `R` for a contact set `closed` of its rows:
/// the factor of `B_R` (`None`: a unit block, every row closed), `Y_R = B_R^{-1} (L U)_R` and
/// `V_R D_C Y_R` (its share of `V D_C B^{-1} L U`).
struct BlockFactor {
    closed: Vec<bool>,
    lu: Option<DenseLu>,
    y: DMatrix<f64>,
    vy: DMatrix<f64>,
}

/// Contact sets kept per block.
const KEPT_BLOCK_SETS: usize = 4;

impl<'a> JumpOperator<'a> {
    /// The operator of one stiffness block (`L` dense).
    pub fn new(dlambda_dgap: &'a DMatrix<f64>, surfaces: &[JumpSurface]) -> Self {
        Self::with_blocks(dlambda_dgap, &[dlambda_dgap.nrows()], surfaces)
    }

    /// The operator of a block-diagonal `L` whose diagonal blocks have the sizes `blocks` (in
    /// order; entries outside them are not read).
    pub fn with_blocks(dlambda_dgap: &'a DMatrix<f64>, blocks: &[usize], surfaces: &[JumpSurface]) -> Self {
        let na = dlambda_dgap.nrows();
        let mut ranges = Vec::with_capacity(blocks.len());
        let mut first = 0;
        for &b in blocks {
            ranges.push(first..first + b);
            first += b;
        }
        assert_eq!(first, na, "stiffness blocks cover the rows");
        let mut gap_rate = DVector::<f64>::zeros(na);
        let (mut u_cols, mut v_rows): (Vec<DVector<f64>>, Vec<DVector<f64>>) = (vec![], vec![]);
        for sf in surfaces {
            let nv = sf.measure.len();
            debug_assert_eq!(sf.coupling.nrows(), na);
            debug_assert_eq!(sf.coupling.ncols(), nv);
            gap_rate += &sf.coupling * DVector::from_column_slice(sf.rate);
            let touched: Vec<usize> = (0..nv).filter(|&i| sf.coupling.column(i).iter().any(|&g| g != 0.0)).collect();
            let mut v = DMatrix::<f64>::zeros(touched.len(), na);
            for r in 0..na {
                if sf.work_per_pressure[r] == 0.0 || sf.phi[r] <= 0.0 {
                    continue;
                }
                let scale = sf.coefficient * sf.work_per_pressure[r] / sf.phi[r];
                let y: Vec<f64> = (0..nv)
                    .map(|i| if sf.measure[i] > 0.0 { scale * sf.coupling[(r, i)] / sf.measure[i] } else { 0.0 })
                    .collect();
                let y = sf.filter.apply(&y);
                for (t, &i) in touched.iter().enumerate() {
                    v[(t, r)] = y[i];
                }
            }
            u_cols.extend(touched.iter().map(|&i| sf.coupling.column(i).into_owned()));
            v_rows.extend(v.row_iter().map(|row| row.transpose()));
        }
        let k = u_cols.len();
        let u = if k > 0 { DMatrix::from_columns(&u_cols) } else { DMatrix::zeros(na, 0) };
        let depth_per_pressure = if k > 0 { DMatrix::from_columns(&v_rows).transpose() } else { DMatrix::zeros(0, na) };
        let mut l_coupling = DMatrix::<f64>::zeros(na, k);
        let mut l_gap_rate = DVector::<f64>::zeros(na);
        for r in &ranges {
            let l = dlambda_dgap.view((r.start, r.start), (r.len(), r.len()));
            l_coupling.rows_mut(r.start, r.len()).copy_from(&(l * u.rows(r.start, r.len())));
            l_gap_rate.rows_mut(r.start, r.len()).copy_from(&(l * gap_rate.rows(r.start, r.len())));
        }
        JumpOperator {
            stiffness: dlambda_dgap,
            blocks: ranges,
            l_coupling,
            depth_per_pressure,
            l_gap_rate,
            factored: std::cell::RefCell::new(Vec::new()),
        }
    }

    /// The factors of block `b` for the contact set `closed` of its rows (see
    /// [`BlockFactor`]); `None` if `B_R` is singular.
    fn factor_block(&self, b: usize, closed: &[bool]) -> Option<BlockFactor> {
        let r = self.blocks[b].clone();
        let mut y = self.l_coupling.rows(r.start, r.len()).into_owned();
        let lu = if closed.iter().all(|&c| c) {
            None
        } else {
            let mut m = DMatrix::<f64>::identity(r.len(), r.len());
            for (c, row) in r.clone().enumerate() {
                if !closed[c] {
                    m.set_column(c, &(-self.stiffness.column(row).rows(r.start, r.len())));
                }
            }
            let lu = DenseLu::new(m)?;
            y = lu.solve_columns(&y)?;
            Some(lu)
        };
        let mut v_closed = self.depth_per_pressure.columns(r.start, r.len()).into_owned();
        for (c, &closed) in closed.iter().enumerate() {
            if !closed {
                v_closed.column_mut(c).fill(0.0);
            }
        }
        let vy = v_closed * &y;
        Some(BlockFactor { closed: closed.to_vec(), lu, y, vy })
    }

    /// `x` with `(B + dN L U V D_C) x = rhs` for the contact set `closed` (`B`, `D_C` of
    /// [`JumpOperator`]).
    fn solve(&self, dn: f64, closed: &[bool], rhs: &DVector<f64>) -> Option<DVector<f64>> {
        let mut cache = self.factored.borrow_mut();
        cache.resize_with(self.blocks.len(), Vec::new);
        let mut at = Vec::with_capacity(self.blocks.len());
        for (b, r) in self.blocks.iter().enumerate() {
            let set = &closed[r.clone()];
            let i = match cache[b].iter().position(|f| f.closed == set) {
                Some(i) => i,
                None => {
                    let Some(f) = self.factor_block(b, set) else {
                        drop(cache);
                        return self.solve_dense(dn, closed, rhs);
                    };
                    if cache[b].len() == KEPT_BLOCK_SETS {
                        cache[b].remove(0);
                    }
                    cache[b].push(f);
                    cache[b].len() - 1
                }
            };
            at.push(i);
        }
        let factors: Vec<&BlockFactor> = at.iter().enumerate().map(|(b, &i)| &cache[b][i]).collect();
        let mut z = rhs.clone();
        for (r, f) in self.blocks.iter().zip(&factors) {
            if let Some(lu) = &f.lu {
                let zb = lu.solve(&rhs.rows(r.start, r.len()).into_owned())?;
                z.rows_mut(r.start, r.len()).copy_from(&zb);
            }
        }
        let k = self.depth_per_pressure.nrows();
        if k == 0 {
            return Some(z);
        }
        let mut s = DMatrix::<f64>::identity(k, k);
        let mut vz = DVector::<f64>::zeros(k);
        for f in &factors {
            s += &f.vy * dn;
        }
        for (r, &c) in closed.iter().enumerate() {
            if c && z[r] != 0.0 {
                vz.axpy(dn * z[r], &self.depth_per_pressure.column(r), 1.0);
            }
        }
        let w = DenseLu::new(s)?.solve(&vz)?;
        let mut x = z;
        for (r, f) in self.blocks.iter().zip(&factors) {
            let mut xb = x.rows_mut(r.start, r.len());
            xb -= &f.y * &w;
        }
        x.iter().all(|v| v.is_finite()).then_some(x)
    }

    /// [`Self::solve`] by one dense `n x n` system (the form before the factored one; for a
    /// contact set whose `B` is singular).
    fn solve_dense(&self, dn: f64, closed: &[bool], rhs: &DVector<f64>) -> Option<DVector<f64>> {
        let na = rhs.len();
        let mut v_closed = self.depth_per_pressure.clone() * dn;
        let mut m = DMatrix::<f64>::zeros(na, na);
        for (r, &c) in closed.iter().enumerate() {
            if c {
                m[(r, r)] = 1.0;
            } else {
                v_closed.column_mut(r).fill(0.0);
                m.set_column(r, &(-self.stiffness.column(r)));
            }
        }
        m += &self.l_coupling * v_closed;
        DenseLu::new(m)?.solve(rhs)
    }

    /// `(I + dN L H) x` (`L H = (L U) V`).
    fn apply_system(&self, dn: f64, x: &DVector<f64>) -> DVector<f64> {
        x + &self.l_coupling * (&self.depth_per_pressure * x) * dn
    }

    /// [`implicit_pressure_change`] of a jump of `dn` cycles.
    pub fn pressure_change(&self, dn: u64) -> Option<Vec<f64>> {
        let closed = vec![true; self.l_gap_rate.len()];
        let dp = self.solve(dn as f64, &closed, &(&self.l_gap_rate * -(dn as f64)))?;
        dp.iter().all(|v| v.is_finite()).then(|| dp.iter().copied().collect())
    }

    /// [`implicit_contact_change`] of a jump of `dn` cycles.
    pub fn contact_change(&self, dn: u64, contact: &JumpContact) -> Option<Vec<f64>> {
        self.contact_change_with(dn as f64, contact, false)
    }

    /// [`Self::contact_change`] of an update applying the fraction `f` of one cycle's wear
    /// (see [`fractional_update`]).
    pub fn fractional_contact_change(&self, f: f64, contact: &JumpContact) -> Option<Vec<f64>> {
        self.contact_change_with(f, contact, false)
    }

    /// [`Self::contact_change`], each contact set's system solved densely: the reference the
    /// factored solve is tested against.
    pub fn contact_change_dense(&self, dn: u64, contact: &JumpContact) -> Option<Vec<f64>> {
        self.contact_change_with(dn as f64, contact, true)
    }

    fn contact_change_with(&self, dnf: f64, contact: &JumpContact, dense: bool) -> Option<Vec<f64>> {
        let dlambda_dgap = self.stiffness;
        let na = dlambda_dgap.nrows();
        debug_assert!(contact.pressure.len() == na && contact.gap.len() == na && contact.closed.len() == na);
        let b = &self.l_gap_rate * -dnf;
        let (p, g) = (&contact.pressure, &contact.gap);
        let p_max = p.iter().fold(0.0_f64, |m, &v| m.max(v));
        let g_scale = g.iter().fold(0.0_f64, |m, &v| m.max(v.abs())).max(f64::MIN_POSITIVE);
        let mut closed = contact.closed.clone();
        for _ in 0..MAX_JUMP_CONTACT_ITERATIONS {
            // rhs = b - L[:, C] G_C + (I + dN L H)[:, O] p_O
            let (mut g_closed, mut p_open) = (DVector::<f64>::zeros(na), DVector::<f64>::zeros(na));
            for r in 0..na {
                if closed[r] {
                    g_closed[r] = g[r];
                } else {
                    p_open[r] = p[r];
                }
            }
            let mut l_g = DVector::<f64>::zeros(na);
            for r in &self.blocks {
                let l = dlambda_dgap.view((r.start, r.start), (r.len(), r.len()));
                l_g.rows_mut(r.start, r.len()).copy_from(&(l * g_closed.rows(r.start, r.len())));
            }
            let rhs = &b - l_g + self.apply_system(dnf, &p_open);
            let x = if dense { self.solve_dense(dnf, &closed, &rhs)? } else { self.solve(dnf, &closed, &rhs)? };
            if x.iter().any(|v| !v.is_finite()) {
                return None;
            }
            let dp: Vec<f64> = (0..na).map(|r| if closed[r] { x[r] } else { -p[r] }).collect();
            let mut changed = false;
            for r in 0..na {
                if closed[r] && p[r] + dp[r] < -1e-12 * p_max {
                    closed[r] = false;
                    changed = true;
                } else if !closed[r] && g[r] + x[r] < -1e-12 * g_scale {
                    closed[r] = true;
                    changed = true;
                }
            }
            if !changed {
                return Some(dp);
            }
        }
        None
    }
}

/// The interface at the start of a jump, per row of the stiffness: its pressure `p >= 0` and
/// weighted gap `g >= 0` (zero where the row is closed).
#[derive(Debug, Clone, PartialEq)]
pub struct JumpContact {
    pub pressure: Vec<f64>,
    pub gap: Vec<f64>,
    /// In contact at the start (the others are open rows held at their gap by the stiffness).
    pub closed: Vec<bool>,
}

/// Passes of the contact-set iteration of [`implicit_contact_change`] before it gives up.
pub const MAX_JUMP_CONTACT_ITERATIONS: usize = 30;

/// The end-of-jump pressure change of [`implicit_pressure_change`] with the contact set free to
/// change over the jump: a wear jump widens a worn contact (its edge rows close) and unloads
/// rows the wear has hollowed (they open), which a held set gets wrong in sign at the edge.
/// With the rows' gap change `dG` (the stiffness `L` holds every row at its gap, so
/// `dp = -L (dg_wear - dG)`), the end state is complementary: closed rows keep `G + dG = 0`
/// with `p + dp >= 0`, open rows carry `p + dp = 0` with `G + dG >= 0`. Unknowns `dp` on the
/// closed rows and `dG` on the open ones:
/// `(I + dN L H)[:, C] dp_C - L[:, O] dG_O = -dN L G r + (I + dN L H)[:, O] p_O - L[:, C] G_C`,
/// the sets updated (a closed row pulling opens, an open row penetrating closes) until they
/// hold (a primal-dual active set on the linear complementarity problem). Returns `dp` on every
/// row (`-p` on the rows that end open); `None` if a system is singular or the sets cycle.
pub fn implicit_contact_change(
    dlambda_dgap: &DMatrix<f64>,
    surfaces: &[JumpSurface],
    dn: u64,
    contact: &JumpContact,
) -> Option<Vec<f64>> {
    JumpOperator::new(dlambda_dgap, surfaces).contact_change(dn, contact)
}

/// Largest `a * dN` the adaptive controller allows (`1 - a dN >= 0`: the deviation from the
/// steady wear state decays without changing sign; the explicit jump diverges beyond 2).
pub const JUMP_SAFETY: f64 = 1.0;

/// The jump `dN` to apply to a computed cycle whose wear rates (depth per cycle, all wearing
/// surfaces' vertices in one vector) are `rate`; `resolution` is the smallest wearing segment,
/// `remaining` the cycles left. Updates the controller memory `c`. The bound `a dN <= 1` applies
/// to the explicit scheme only (the implicit one is stable for any jump; its accuracy bound is
/// the pressure change, see [`bounded_implicit_jump`]).
pub fn next_jump(
    policy: JumpPolicy,
    scheme: JumpScheme,
    c: &mut ControllerState,
    rate: &[f64],
    resolution: f64,
    remaining: u64,
) -> u64 {
    let dn = match policy {
        JumpPolicy::Fixed(n) => n,
        JumpPolicy::Adaptive { depth_fraction, max_jump, .. } => {
            let mut dn = if c.last_jump == 0 { 1 } else { c.last_jump.saturating_mul(2) };
            let rmax = rate.iter().fold(0.0_f64, |m, r| m.max(r.abs()));
            if rmax > 0.0 && resolution.is_finite() {
                dn = dn.min(((depth_fraction * resolution / rmax).floor() as u64).max(1));
            }
            if c.last_rate.len() == rate.len() {
                let change: Vec<f64> = rate.iter().zip(&c.last_rate).map(|(r, p)| r - p).collect();
                let norm_r = rate.iter().map(|r| r * r).sum::<f64>().sqrt();
                let cc: f64 = c.last_change.iter().map(|v| v * v).sum();
                if c.last_change.len() == rate.len() && c.jump_before > 0 && cc.sqrt() > 1e-9 * norm_r {
                    // change_n = (J_{n-1} / J_{n-2}) (1 - a J_{n-2}) change_{n-1}
                    let rho = change.iter().zip(&c.last_change).map(|(a, b)| a * b).sum::<f64>() / cc;
                    let (j1, j2) = (c.last_jump as f64, c.jump_before as f64);
                    let a = (1.0 - rho * j2 / j1) / j2;
                    // Follow a larger estimate at once, a smaller one only by halves.
                    c.decay = if a >= c.decay { a } else { (0.5 * c.decay).max(a.max(0.0)) };
                }
                c.last_change = change;
            }
            c.last_rate = rate.to_vec();
            if c.decay > 0.0 && scheme == JumpScheme::Explicit {
                dn = dn.min(((JUMP_SAFETY / c.decay).floor() as u64).max(1));
            }
            dn.min(max_jump)
        }
    };
    let dn = dn.min(remaining).max(1);
    c.jump_before = c.last_jump;
    c.last_jump = dn;
    dn
}

/// The implicit jump under the adaptive policy's accuracy bound: the pressure change
/// `dp = solve(dN)` ([`implicit_pressure_change`]) of the jump, in the mean square over the
/// contact rows (`weights`: their `int Phi`), must stay within `pressure_change` of the
/// pressure `pressure`; a larger `dn` is cut back by a bracketed search in `log dN` (each
/// trial is one small dense solve), never below 1. A fixed policy takes `dn` as it is.
/// Updates the controller's last jump. `None` if `solve` fails.
pub fn bounded_implicit_jump(
    policy: JumpPolicy,
    c: &mut ControllerState,
    dn: u64,
    pressure: &[f64],
    weights: &[f64],
    solve: &dyn Fn(u64) -> Option<Vec<f64>>,
) -> Option<(u64, Vec<f64>)> {
    let mean_square = |v: &[f64]| v.iter().zip(weights).map(|(x, w)| w * x * x).sum::<f64>().sqrt();
    let mut dp = solve(dn)?;
    let mut dn = dn;
    if let JumpPolicy::Adaptive { pressure_change, .. } = policy {
        let allowed = pressure_change * mean_square(pressure);
        let (mut lo, mut hi) = (1u64, dn);
        if dn > 1 && mean_square(&dp) > allowed {
            // hi is too long, lo = 1 always allowed: bisect in log dN.
            let mut best = (1u64, None);
            for _ in 0..8 {
                if hi <= lo + 1 {
                    break;
                }
                let mid = ((lo as f64 * hi as f64).sqrt().round() as u64).clamp(lo + 1, hi - 1);
                let trial = solve(mid)?;
                tracing::trace!(mid, change = mean_square(&trial) / mean_square(pressure), "implicit jump trial");
                if mean_square(&trial) <= allowed {
                    lo = mid;
                    best = (mid, Some(trial));
                } else {
                    hi = mid;
                }
            }
            dn = best.0;
            dp = match best.1 {
                Some(d) => d,
                None => solve(1)?,
            };
        }
    }
    c.last_jump = dn;
    Some((dn, dp))
}

/// Wear updates of less than one cycle's wear, where one cycle's moves the pressure by more than
/// the adaptive bound: an accelerated coefficient that wears, in one cycle, many times the
/// contact's elastic approach (`a = (E*/h) k S` of tens to thousands). The implicit update is
/// stable at any `a` (the roughness mode is multiplied by `1 / (1 + a f)` per update of
/// fraction `f`), but it is linearised at the cycle's converged contact: where one update moves
/// the pressure by the whole of itself the linearisation is no longer the mechanics (a rigid
/// punch lifting off its flat onto two bumps and wearing pits under them). So the cycle's wear is
/// applied in parts, each bounded like a jump (`pressure_change` of the pressure, mean square),
/// and the cycle is computed again on the worn geometry until its parts sum to one cycle. This is
/// the path of the same scene at a realistic coefficient (`k / m` over `m` cycles, the scar
/// depending on `k N` only), whose jumps the same bound limits.
///
/// The bound adapts a posteriori: each fraction predicts the pressure of every stacked increment,
/// the next pass over the cycle finds it, and [`fraction_scale`] widens the bound (up to 8x)
/// where the linearisation held and narrows it where it missed (the caller passes
/// `pressure_change` times that scale). On the rounded punch this takes 25 passes for 8 cycles in
/// place of 83 with the bound fixed, for a groove within 0.5% (L2).
///
/// `remaining` (<= 1) is the part of the cycle's wear not yet applied, `whole` the pressure change
/// of one whole cycle's if known, `solve(f)` that of a fraction `f`. The proposal is twice the last fraction (or `remaining`),
/// halved until the bound holds or `min_fraction` (rounded down to a power of two, so that the
/// parts sum to one cycle exactly) is reached. Returns the fraction and its pressure change, and
/// records the fraction in the controller (0 when the whole remainder was applied at once).
pub fn fractional_update(
    pressure_change: f64,
    c: &mut ControllerState,
    bounds: FractionBounds,
    pressure: &[f64],
    weights: &[f64],
    solve: &dyn Fn(f64) -> Option<Vec<f64>>,
) -> Option<(f64, Vec<f64>)> {
    let FractionBounds { remaining, min_fraction, whole } = bounds;
    debug_assert!(remaining > 0.0 && remaining <= 1.0);
    let mean_square = |v: &[f64]| v.iter().zip(weights).map(|(x, w)| w * x * x).sum::<f64>().sqrt();
    let allowed = pressure_change * mean_square(pressure);
    let floor = fraction_floor(min_fraction, remaining);
    let mut f = if c.last_fraction > 0.0 { (2.0 * c.last_fraction).min(remaining) } else { remaining };
    let mut dp = match whole {
        Some(w) if f == 1.0 => Some(w),
        _ => solve(f),
    };
    // A failed solve (a singular system, or contact sets that cycle: a large update moves many
    // rows at once) counts as too large an update: a smaller part changes fewer rows.
    while dp.as_ref().is_none_or(|d| mean_square(d) > allowed) && f > floor {
        f = (0.5 * f).max(floor);
        dp = solve(f);
        tracing::trace!(
            fraction = f,
            change = dp.as_ref().map(|d| mean_square(d) / mean_square(pressure)),
            "fractional wear update trial"
        );
    }
    let dp = dp?;
    c.last_fraction = if f == remaining && remaining == 1.0 { 0.0 } else { f };
    Some((f, dp))
}

/// The smallest part of a cycle's wear one update applies: `min_fraction` rounded down to a
/// power of two (so that parts sum to one cycle exactly), at most the `remaining` part.
pub fn fraction_floor(min_fraction: f64, remaining: f64) -> f64 {
    2f64.powi(min_fraction.log2().floor() as i32).min(remaining)
}

/// The bound on the next fraction's pressure change, relative to `pressure_change`, after a
/// pass that checked the last fraction's predicted pressure (`error`, relative, mean square,
/// see [`prediction_cap`]): the linearisation's error is second order in the update, so the
/// scale is multiplied by `sqrt(tolerance / error)`, at most doubled or halved per pass and
/// kept within [`FRACTION_SCALE_RANGE`]. `scale` 0 stands for 1 (no fraction yet).
pub fn fraction_scale(scale: f64, error: f64, tolerance: f64) -> f64 {
    let scale = if scale > 0.0 { scale } else { 1.0 };
    let factor = if error > 0.0 { (tolerance / error).sqrt().clamp(0.5, 2.0) } else { 2.0 };
    (scale * factor).clamp(FRACTION_SCALE_RANGE.0, FRACTION_SCALE_RANGE.1)
}

/// Range of the adapted fraction bound, relative to `pressure_change` (see [`fraction_scale`]):
/// down to a quarter where the linearisation misses, up to 8 times where it holds.
pub const FRACTION_SCALE_RANGE: (f64, f64) = (0.25, 8.0);

/// What [`fractional_update`] may apply: the fraction of the cycle's wear not yet applied, the
/// smallest fraction of an update, and the pressure change of one whole cycle's if known.
pub struct FractionBounds {
    pub remaining: f64,
    pub min_fraction: f64,
    pub whole: Option<Vec<f64>>,
}

/// Largest error the adaptive controller accepts in an implicit jump's predicted pressure,
/// relative, in the mean square over the contact (see [`prediction_cap`]).
pub const PRESSURE_PREDICTION_TOLERANCE: f64 = 0.05;

/// Default of the largest relative error the adaptive controller aims at in an implicit jump's
/// predicted worn-area rate of each surface (see [`prediction_cap`]).
pub const DEFAULT_PREDICTION_TOLERANCE: f64 = 0.01;

/// An a-posteriori check of the last implicit jump: what it `predicted` for the end of its
/// cycles against what the next computed cycle `found`, relative error in the mean square with
/// `weights`. If the error grows like `dN^order`, the next jump is capped at
/// `last_jump * (tolerance / error)^(1/order)` (at least 1). `None` without a prediction (or
/// for another layout). The driver checks two things:
/// - the pressure per contact row (`order` 2, [`PRESSURE_PREDICTION_TOLERANCE`]): the
///   linearisation's own error, rows joining the contact;
/// - the worn-area rate of each surface (`order` 1, `prediction_tolerance`): what the
///   linearisation leaves out, a slip distribution that changes with the wear (it keeps each
///   row's slip of the computed cycle). Under partial slip this error is first order in `dN`
///   (measured on the partial-slip case: 0.8, 1.6, 3.1% after jumps of 4,096, 8,192, 16,384
///   cycles); in gross slip the area rate is `k P S` and the check stays silent.
pub fn prediction_cap(
    predicted: &[f64],
    found: &[f64],
    weights: &[f64],
    last_jump: u64,
    tolerance: f64,
    order: i32,
) -> Option<(f64, u64)> {
    if predicted.len() != found.len() || found.is_empty() || last_jump == 0 {
        return None;
    }
    let (mut diff, mut norm) = (0.0, 0.0);
    for ((p, q), w) in found.iter().zip(predicted).zip(weights) {
        diff += w * (p - q) * (p - q);
        norm += w * p * p;
    }
    if norm <= 0.0 {
        return None;
    }
    let error = (diff / norm).sqrt();
    let cap = if error > 0.0 {
        ((last_jump as f64 * (tolerance / error).powf(1.0 / order as f64)).floor() as u64).max(1)
    } else {
        u64::MAX
    };
    Some((error, cap))
}

/// The adaptive cycle-jump controller's memory: the last computed cycle's wear rates, the
/// change from the cycle before, the jumps that separated them and the stiffness estimate.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ControllerState {
    pub last_rate: Vec<f64>,
    pub last_change: Vec<f64>,
    pub last_jump: u64,
    pub jump_before: u64,
    /// Estimated decay rate `a` per cycle of the rate deviation (Winkler: `kappa k dS`).
    pub decay: f64,
    /// Implicit jumps: the contact pressure per contact row the last jump predicted for the end
    /// of its cycles (empty after an explicit jump); the next computed cycle checks it.
    pub predicted: Vec<f64>,
    /// Implicit jumps: the worn-area rate (per cycle) of each wearing surface the last jump
    /// predicted for the end of its cycles (empty after an explicit jump).
    pub predicted_area_rate: Vec<f64>,
    /// The fraction of a cycle's wear the last update applied when it applied less than one
    /// cycle's (see [`fractional_update`]); 0 after an update of whole cycles.
    pub last_fraction: f64,
    /// The factor on `pressure_change` that bounds a fraction's pressure change, adapted from
    /// each fraction's predicted pressure against the next pass (see [`fraction_scale`]); 0 (as
    /// 1) before the first.
    pub fraction_scale: f64,
}

impl ControllerState {
    /// After a jump that predicted nothing (explicit, or a singular implicit system): the next
    /// computed cycle has nothing to check.
    pub fn forget_prediction(&mut self) {
        self.predicted.clear();
        self.predicted_area_rate.clear();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A fractional update whose linearised system fails for large parts (contact sets that
    /// cycle) halves the part as it would for too large a pressure change: with solves failing
    /// above 1/8 of a cycle and a pressure change `f` times the pressure below, a bound of 0.5
    /// gives the part 1/8 (the first that solves, within the bound), not a failure (which
    /// applied the whole cycle explicitly: pits 20% deep on the free rounded punch). A system
    /// that fails at every part down to `min_fraction` fails.
    #[test]
    fn fractional_update_halves_past_a_failed_solve() {
        let (pressure, weights) = ([2.0, 1.0], [1.0, 1.0]);
        let solve = |f: f64| (f <= 0.125).then(|| pressure.iter().map(|p| -f * p).collect::<Vec<f64>>());
        let bounds = || FractionBounds { remaining: 1.0, min_fraction: 1.0 / 256.0, whole: None };
        let mut c = ControllerState::default();
        let (f, dp) = fractional_update(0.5, &mut c, bounds(), &pressure, &weights, &solve).expect("a part solves");
        assert_eq!(f, 0.125);
        assert_eq!(dp, vec![-0.25, -0.125]);
        assert_eq!(c.last_fraction, 0.125);
        let never = |_: f64| None;
        assert!(
            fractional_update(0.5, &mut ControllerState::default(), bounds(), &pressure, &weights, &never).is_none()
        );
        assert_eq!(fraction_floor(0.3, 1.0), 0.25);
        assert_eq!(fraction_floor(1.0 / 256.0, 0.001), 0.001);
    }

    /// The a-posteriori cap: a prediction 10% off (everywhere) with a tolerance of 5% halves the
    /// last jump at first order (rounded down) and divides it by sqrt(2) at second order; an
    /// exact one leaves the jump free; no prediction, no cap.
    #[test]
    fn prediction_cap_scales_the_last_jump_by_tolerance_over_error() {
        let found = [1.0, 2.0, 0.0, 4.0];
        let weights = [1.0, 0.5, 2.0, 1.0];
        assert_eq!(prediction_cap(&[], &found, &weights, 4001, 0.05, 1), None);
        let predicted: Vec<f64> = found.iter().map(|r| r * 0.9).collect();
        let (error, cap) = prediction_cap(&predicted, &found, &weights, 4001, 0.05, 1).expect("a prediction");
        // Exact: |r - 0.9 r| / |r| = 0.1 in any weighted norm (round-off only).
        assert!((error - 0.1).abs() < 1e-14, "error {error}");
        assert_eq!(cap, 2000);
        let (_, cap) = prediction_cap(&predicted, &found, &weights, 4001, 0.05, 2).expect("a prediction");
        assert_eq!(cap, 2829, "4001 / sqrt(2) = 2829.1");
        assert_eq!(prediction_cap(&found, &found, &weights, 4001, 0.05, 1), Some((0.0, u64::MAX)));
        assert_eq!(prediction_cap(&predicted[..3], &found, &weights, 4001, 0.05, 1), None, "another layout: no check");
    }

    /// The fraction bound's scale: the linearisation's error is second order in the update, so
    /// an error a quarter of the tolerance doubles it, four times halves it (exact: powers of
    /// two), an exact prediction doubles it; never past [`FRACTION_SCALE_RANGE`]; 0 is 1.
    #[test]
    fn fraction_scale_follows_the_prediction_error_at_second_order() {
        assert_eq!(fraction_scale(0.0, 0.0125, 0.05), 2.0);
        assert_eq!(fraction_scale(2.0, 0.2, 0.05), 1.0);
        assert_eq!(fraction_scale(1.0, 0.0, 0.05), 2.0);
        assert_eq!(fraction_scale(1.0, 1e-6, 0.05), 2.0, "at most doubled per pass");
        assert_eq!(fraction_scale(1.0, 10.0, 0.05), 0.5, "at most halved per pass");
        assert_eq!(fraction_scale(8.0, 0.0, 0.05), FRACTION_SCALE_RANGE.1);
        assert_eq!(fraction_scale(0.25, 10.0, 0.05), FRACTION_SCALE_RANGE.0);
        // In between: sqrt(0.05 / 0.08) = 0.790569...
        assert!((fraction_scale(1.0, 0.08, 0.05) - (0.625f64).sqrt()).abs() < 1e-15);
    }

    #[test]
    fn vertex_normals_point_into_the_material() {
        // Material on the left of a left-to-right line: above it.
        let v = [Point2::new(0.0, 0.0), Point2::new(1.0, 0.0), Point2::new(2.0, 0.0)];
        for n in vertex_normals(&v, false) {
            assert!((n - Vector2::new(0.0, 1.0)).norm() < 1e-15);
        }
    }

    #[test]
    fn fixed_jump_is_shortened_at_the_end() {
        let mut c = ControllerState::default();
        assert_eq!(next_jump(JumpPolicy::Fixed(10), JumpScheme::Explicit, &mut c, &[1.0], 1.0, 4), 4);
    }
}
