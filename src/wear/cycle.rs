//! One wear cycle's bookkeeping, from the steps' swept wear to the moved surfaces:
//!
//! ```text
//! each converged increment:  cycle volumes += k int N_i p |ds| (swept along the step)
//!                            implicit scheme: keep the increment's linearisation (interface
//!                                 stiffness, pressures, couplings where it is paired)
//! end of a computed cycle:   rates = filtered volumes / vertex measures
//!                            dN = jump controller (explicit, or implicit: pressure at the
//!                                 end of the jump at every increment, from the stacked
//!                                 linearisations)
//!                            depth += dN rate; vertices move inward; worn area += dN volume
//! ```
//!
//! Worn areas balance the wear work to round-off: the volumes applied are the ones integrated
//! (the implicit jump moves each row's work by its pressure change, never below zero). The
//! state lives in [`WearState`], which a checkpoint saves.

use super::{
    bounded_implicit_jump, depth_increment, fraction_floor, fraction_scale, fractional_update, next_jump,
    pairing_position, prediction_cap, swept_step_wear, vertex_measure, wear_coupling, wearing_resolution,
    worn_vertices, ControllerState, FractionBounds, JumpContact, JumpOperator, JumpPolicy, JumpScheme, JumpSurface,
    RateFilter, WearLaw, WearModel, WearSide, PRESSURE_PREDICTION_TOLERANCE,
};
use crate::contact::ContactSet;
use crate::fem::material::PlasticState;
use crate::mesh::Mesh2;
use crate::moving::FreeSurface;
use nalgebra::{DMatrix, Point2};

/// Everything a wear run carries from cycle to cycle: where the worn surfaces are, how much
/// each lost, the cycle counters and the cycle-jump controller's memory. Per wearing surface
/// (in the model's wear order), per vertex of its polyline.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct WearState {
    /// Cycles done, the jumped ones included (the cycle being computed is `cycle`).
    pub cycle: u64,
    /// Cycles actually computed.
    pub computed_cycles: u64,
    /// Increments of the current cycle that have converged.
    pub increment: usize,
    /// Jump `dN` the current cycle's wear is applied with: cycles the last update completed (0
    /// for an update that applied only part of a cycle's wear, see `cycle_fraction`).
    pub jump: u64,
    /// The part of the current cycle's wear that earlier passes over it applied (0 <= f < 1):
    /// wear so fast that one cycle's would move the pressure by more than the adaptive bound is
    /// applied in parts, the cycle computed again on the worn geometry after each (see
    /// [`crate::wear::fractional_update`]).
    pub cycle_fraction: f64,
    /// Current vertices (reference configuration of the host).
    pub vertices: Vec<Vec<[f64; 2]>>,
    /// Accumulated wear depth per vertex.
    pub depth: Vec<Vec<f64>>,
    /// Wear volume `k int N_i p |ds|` (per unit thickness) per vertex over the current cycle.
    pub cycle_volume: Vec<Vec<f64>>,
    /// `int p |ds|` (Archard) or `int |q ds|` (energy) of the current cycle, per surface.
    pub cycle_work: Vec<f64>,
    /// Implicit jump: the linearisation of each converged step of the current cycle (see
    /// [`IncrementJump`]); fewer than the cycle's steps: the jump is explicit.
    pub cycle_jumps: Vec<IncrementJump>,
    /// Steps whose wear the current cycle holds: one per increment, more where an increment
    /// was solved in sub-steps (see [`crate::wear::sweep_check`]).
    pub cycle_steps: usize,
    /// Worn area (`sum_i depth_i int N_i`) and the time integral of the wear work, per surface
    /// (jumps included): `worn_area = k * work` is the wear balance.
    pub worn_area: Vec<f64>,
    pub work: Vec<f64>,
    /// Jump controller memory (see [`next_jump`]).
    pub controller: ControllerState,
    /// Finite sliding: per increment of the cycle, the displacements the last computed cycle
    /// converged to there (empty before the first), where the next cycle's step is paired
    /// first.
    pub pairing_guess: Vec<Vec<f64>>,
    /// Per increment of the cycle: the contact rows in contact and the Coulomb status of each
    /// friction row the last computed cycle converged to there (empty before the first). The
    /// next cycle's step starts its active-set iterations from them: a jump later the contact
    /// edges are a node or so from where they were, where the prediction from the step's
    /// start moves them a node or two per iteration. The solution is the same bits (see
    /// [`crate::solve::StaticAnalysis::start_from_sets`]).
    pub start_sets: Vec<crate::contact::ContactSets>,
    /// Yielding bodies: `[eps_p (4 tensor components), alpha]` of every history point at the
    /// start of the current computed cycle (empty: the virgin state, all zero).
    pub plastic_start: Vec<f64>,
    /// Yielding bodies, over the last computed cycle (see [`cycle_plasticity`]): the largest net
    /// equivalent plastic strain of a point (ratcheting) and the largest equivalent plastic
    /// strain it accumulated (reversed flow counted too: the width of a stable loop).
    pub cycle_ratcheting: f64,
    pub cycle_plastic_strain: f64,
}

/// The largest jump that drops at most `tolerance` of net plastic strain at the rate
/// `ratcheting` per cycle (unbounded without ratcheting).
fn ratcheting_cap(ratcheting: f64, tolerance: f64) -> u64 {
    if ratcheting > 0.0 {
        (tolerance / ratcheting).floor().min(u64::MAX as f64) as u64
    } else {
        u64::MAX
    }
}

/// Values per history point in [`WearState::plastic_start`].
const PLASTIC_SNAPSHOT: usize = 5;

/// The plastic strain of every history point, as [`WearState::plastic_start`] keeps it.
pub fn plastic_snapshot(history: &[PlasticState]) -> Vec<f64> {
    history.iter().flat_map(|h| [h.eps_p[0], h.eps_p[1], h.eps_p[2], h.eps_p[3], h.alpha]).collect()
}

/// Over a cycle from `start` (a [`plastic_snapshot`], empty: virgin) to `history`: the largest
/// net equivalent plastic strain `sqrt(2/3) |eps_p(end) - eps_p(start)|` of a point, which is
/// zero for elastic shakedown and for a stable (closed) plastic loop and positive while the
/// body ratchets, and the largest accumulated `alpha(end) - alpha(start)` (zero only for
/// elastic shakedown).
pub fn cycle_plasticity(start: &[f64], history: &[PlasticState]) -> (f64, f64) {
    let virgin = [0.0; PLASTIC_SNAPSHOT];
    let start_of = |i: usize| start.get(PLASTIC_SNAPSHOT * i..PLASTIC_SNAPSHOT * (i + 1)).unwrap_or(&virgin);
    history.iter().enumerate().fold((0.0_f64, 0.0_f64), |(net, acc), (i, h)| {
        let s = start_of(i);
        let d = [h.eps_p[0] - s[0], h.eps_p[1] - s[1], h.eps_p[2] - s[2], h.eps_p[3] - s[3]];
        // Tensor norm of the symmetric increment (xy stored once, as a tensor component).
        let norm = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2] + 2.0 * d[3] * d[3]).sqrt();
        (net.max((2.0_f64 / 3.0).sqrt() * norm), acc.max(h.alpha - s[4]))
    })
}

/// How the multipliers of a set of normal rows answer a change of their weighted gaps with the
/// loads and the friction sets held and every row of the set held at its gap:
/// `dlambda = dlambda_dgap * dg`, the interface stiffness of the converged state (floating
/// bodies held by their loads included: a uniform gap change of a force-loaded body leaves the
/// total force unchanged). The set is the rows in contact, and for the wear jump also the open
/// candidate rows around them (so that the jump can close them).
#[derive(Debug, Clone, PartialEq)]
pub struct GapSensitivity {
    /// Contact normal rows (model contact-row order).
    pub rows: Vec<usize>,
    /// Per row: in contact in the converged state (false: an open row held at its gap).
    pub closed: Vec<bool>,
    pub dlambda_dgap: DMatrix<f64>,
}

/// A wear update that cannot go on: the cycle, the surface and why.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("cycle {cycle}: wear of '{surface}': {msg}")]
pub struct WearError {
    pub cycle: u64,
    pub surface: String,
    pub msg: String,
}

/// What a wear update reads of the current discretisation: the contact set, the host meshes
/// (with their node offsets), the free surfaces (the wearing ones among them), the point
/// coordinates, the wear model and the increments per cycle.
pub struct WearScene<'a> {
    pub contact: &'a ContactSet,
    pub hosts: Vec<(&'a Mesh2, usize)>,
    pub surfaces: &'a [FreeSurface],
    pub coords: &'a [Point2<f64>],
    pub model: &'a WearModel,
    pub increments: usize,
}

/// The path of a converged step that wear is swept along: displacements from `u_prev` to `u`,
/// tractions from `lambda_prev` at its start (if given; else the end's throughout) to
/// `multipliers` at its end.
#[derive(Clone, Copy)]
pub struct StepPath<'a> {
    pub u_prev: &'a [f64],
    pub u: &'a [f64],
    pub lambda_prev: Option<&'a [f64]>,
    pub multipliers: &'a [f64],
}

/// Adds the wear of the step that just converged along `path` to the cycle's volumes and work
/// (see [`swept_step_wear`]). With the interface stiffness `sensitivity` of the converged
/// state, the increment's linearisation is kept for the implicit jump ([`IncrementJump`]).
pub fn accumulate_step_wear(
    scene: &WearScene<'_>,
    wear: &mut WearState,
    path: StepPath,
    sensitivity: Option<GapSensitivity>,
) {
    let StepPath { u, multipliers, .. } = path;
    let mut steps = Vec::with_capacity(scene.model.surfaces.len());
    for (w, ws) in scene.model.surfaces.iter().enumerate() {
        let side = WearSide { set: scene.contact, hosts: &scene.hosts, ws, surface: &scene.surfaces[ws.surface] };
        let sw = swept_step_wear(side, scene.coords, path);
        for (a, v) in wear.cycle_volume[w].iter_mut().zip(&sw.volume) {
            *a += v;
        }
        wear.cycle_work[w] += sw.work;
        steps.push(sw);
    }
    wear.cycle_steps += 1;
    if let Some(sens) = sensitivity.filter(|s| !s.rows.is_empty()) {
        if let Some(jump) = IncrementJump::of(scene, sens, u, multipliers, &steps) {
            wear.cycle_jumps.push(jump);
        }
    }
}

/// One wearing surface's part in an [`IncrementJump`], on the rows of its stiffness.
#[derive(Debug, Clone, PartialEq)]
pub struct IncrementSurface {
    /// `(vertex i, row position r, G_ri = int Phi_r N_i)` where the increment is paired.
    pub entries: Vec<(usize, usize, f64)>,
    /// Per row position: `int Phi_r`, the increment's wear work, and its change per unit
    /// pressure change (the increment's weighted slip `|ds_r|`, Archard; `mu |ds_r|` on
    /// slipping rows, energy law).
    pub phi: Vec<f64>,
    pub work: Vec<f64>,
    pub work_per_pressure: Vec<f64>,
}

/// The implicit jump's linearisation at one converged increment of a computed cycle: its
/// interface stiffness on the rows in contact and the open candidates around them, their
/// pressures and open gaps, and how each wearing surface's vertices couple to them where the
/// increment is paired. The jump stacks the increments of the cycle (see
/// [`implicit_correction`]): the pressure at the end of the jump is linearised at every
/// stroke position, not at the cycle's last one only.
#[derive(Debug, Clone, PartialEq)]
pub struct IncrementJump {
    pub sensitivity: GapSensitivity,
    /// Per row of the stiffness: pressure (0 on open rows), open gap (0 on closed rows) and
    /// `int Phi` of the increment's pairing.
    pub pressure: Vec<f64>,
    pub gap: Vec<f64>,
    pub weight: Vec<f64>,
    /// The pressure of every contact row (the next computed cycle checks the prediction).
    pub all_pressure: Vec<f64>,
    pub surfaces: Vec<IncrementSurface>,
    /// The last piece of its increment: the state the next pass over the cycle meets again at
    /// the same time (an increment's sub-steps can differ from one pass to the next, so only
    /// increment ends carry the prediction the next pass checks).
    pub increment_end: bool,
}

impl IncrementJump {
    fn of(
        scene: &WearScene<'_>,
        sensitivity: GapSensitivity,
        u: &[f64],
        multipliers: &[f64],
        steps: &[super::StepWear],
    ) -> Option<Self> {
        let nt = scene.contact.first_multiplier;
        let pressure_of = |k: usize| (-multipliers[nt + k]).max(0.0);
        let pressure = sensitivity
            .rows
            .iter()
            .zip(&sensitivity.closed)
            .map(|(&k, &c)| if c { pressure_of(k) } else { 0.0 })
            .collect();
        let gap = open_row_gaps(scene, &sensitivity, u);
        let weight = sensitivity.rows.iter().map(|&k| scene.contact.phi[k]).collect();
        let all_pressure = (0..scene.contact.rows.len()).map(pressure_of).collect();
        let mut surfaces = Vec::with_capacity(steps.len());
        for (ws, sw) in scene.model.surfaces.iter().zip(steps) {
            let c = &scene.contact.pairs[ws.contact];
            let mut pos_of = vec![None; c.multipliers.num_nodes];
            for (r, &k) in sensitivity.rows.iter().enumerate() {
                if (c.first_row..c.first_row + c.multipliers.num_nodes).contains(&k) {
                    pos_of[k - c.first_row] = Some(r);
                }
            }
            // Only the stiffness's rows are paired (every segment their hats cover is visited,
            // so their entries are those of the whole coupling).
            let held: Vec<bool> = pos_of.iter().map(Option::is_some).collect();
            let x = pairing_position(scene.contact, ws, scene.coords, u, u);
            let coupling =
                wear_coupling(scene.contact, &scene.hosts, ws, &scene.surfaces[ws.surface], &x, Some(&held))?;
            let na = sensitivity.rows.len();
            let mut s = IncrementSurface {
                entries: vec![],
                phi: vec![0.0; na],
                work: vec![0.0; na],
                work_per_pressure: vec![0.0; na],
            };
            for &(i, l, v) in &coupling.entries {
                if let Some(r) = pos_of[l] {
                    s.entries.push((i, r, v));
                }
            }
            for (l, r) in pos_of.iter().enumerate() {
                if let Some(r) = *r {
                    let per_pressure = match ws.law {
                        WearLaw::Archard => 1.0,
                        WearLaw::Energy => c.friction_row[l].map_or(0.0, |_| scene.contact.mu[c.first_row + l]),
                    };
                    s.phi[r] = coupling.phi[l];
                    s.work[r] = sw.row_work[l];
                    s.work_per_pressure[r] = if s.phi[r] > 0.0 { per_pressure * sw.row_slip[l] } else { 0.0 };
                }
            }
            surfaces.push(s);
        }
        Some(IncrementJump { sensitivity, pressure, gap, weight, all_pressure, surfaces, increment_end: false })
    }
}

/// Per wearing surface: the vertex measures, the rate filters and the filtered wear rates
/// (volume per measure) of the current cycle.
struct CycleRates {
    measures: Vec<Vec<f64>>,
    filters: Vec<RateFilter>,
    rates: Vec<Vec<f64>>,
}

fn per_measure(volume: &[f64], measure: &[f64]) -> Vec<f64> {
    volume.iter().zip(measure).map(|(v, a)| if *a > 0.0 { v / a } else { 0.0 }).collect()
}

impl CycleRates {
    fn of(scene: &WearScene<'_>, wear: &WearState) -> Self {
        let measures: Vec<Vec<f64>> =
            scene.model.surfaces.iter().map(|ws| vertex_measure(&scene.surfaces[ws.surface])).collect();
        let raw: Vec<Vec<f64>> = wear.cycle_volume.iter().zip(&measures).map(|(v, a)| per_measure(v, a)).collect();
        let filters: Vec<RateFilter> = scene
            .model
            .surfaces
            .iter()
            .enumerate()
            .map(|(k, ws)| {
                let s = &scene.surfaces[ws.surface];
                RateFilter::new(&s.vertices, s.base.closed, &measures[k], &raw[k], scene.model.smoothing)
            })
            .collect();
        let rates: Vec<Vec<f64>> = filters.iter().zip(&raw).map(|(f, r)| f.apply(r)).collect();
        CycleRates { measures, filters, rates }
    }

    /// The filtered rates of the cycle volumes `volumes`.
    fn of_volumes(&self, volumes: &[Vec<f64>]) -> Vec<Vec<f64>> {
        self.filters.iter().zip(volumes).zip(&self.measures).map(|((f, v), a)| f.apply(&per_measure(v, a))).collect()
    }
}

/// Applies the current cycle's wear: the jump `dN` (the controller's, or 1 for the ramp when
/// `jump` is false), depths, vertices, sums and counters; `count` the run's cycles. With the
/// implicit scheme and every increment of the cycle linearised ([`WearState::cycle_jumps`]),
/// the cycle's wear is taken at the end-of-jump pressure (see [`implicit_correction`]).
pub fn apply_cycle_wear(scene: &WearScene<'_>, wear: &mut WearState, count: u64, jump: bool) -> Result<(), WearError> {
    let cycle = CycleRates::of(scene, wear);
    // The history advances only in computed cycles, so a jump of dN cycles drops dN times the
    // net plastic strain of the last computed cycle: at most the ratcheting tolerance. A body
    // that ratchets more per cycle than that is not jumped over at all.
    let plastic_cap = ratcheting_cap(wear.cycle_ratcheting, scene.model.ratcheting_tolerance);
    let ratcheting = jump && plastic_cap <= 1;
    // Implicit where the scheme asks for it and every step of the cycle was linearised.
    let linearised = jump
        && !ratcheting
        && scene.model.scheme == JumpScheme::Implicit
        && wear.cycle_steps >= scene.increments
        && wear.cycle_jumps.len() == wear.cycle_steps;
    let scheme = if linearised { JumpScheme::Implicit } else { JumpScheme::Explicit };
    let mut dn = if jump {
        let resolution = scene
            .model
            .surfaces
            .iter()
            .zip(&cycle.rates)
            .map(|(ws, r)| wearing_resolution(&scene.surfaces[ws.surface].vertices, r))
            .fold(f64::INFINITY, f64::min);
        let flat: Vec<f64> = cycle.rates.iter().flatten().copied().collect();
        let remaining = count.saturating_sub(wear.cycle);
        next_jump(scene.model.jump, scheme, &mut wear.controller, &flat, resolution, remaining)
    } else {
        1
    };
    if jump && dn > plastic_cap {
        if ratcheting && (wear.computed_cycles + 1).is_power_of_two() {
            tracing::warn!(
                cycle = wear.cycle,
                computed = wear.computed_cycles + 1,
                net_plastic_strain = wear.cycle_ratcheting,
                tolerance = scene.model.ratcheting_tolerance,
                "cycle jump refused: the body ratchets (the net plastic strain of the last computed cycle is \
                 above [cycle_jump] ratcheting_tolerance); cycles are computed one by one until it slows down"
            );
        }
        dn = plastic_cap.max(1);
        wear.controller.last_jump = dn;
    }
    if jump && wear.computed_cycles == 0 {
        check_something_wears(scene, &cycle.rates, count)?;
    }
    let mut size = UpdateSize { dn, fraction: 1.0 };
    let (volumes, works, rates) = applied_cycle_wear(scene, wear, &cycle, linearised, &mut size);
    let (mut dn, fraction) = (size.dn, size.fraction);
    wear.cycle_jumps.clear();
    wear.cycle_steps = 0;
    // Cycles of wear this update applies: the jump, or a part of one cycle.
    let scale = if fraction < 1.0 { fraction } else { dn as f64 };
    for (k, ws) in scene.model.surfaces.iter().enumerate() {
        let measure = &cycle.measures[k];
        // Never negative: wear only removes material, and an implicit update's rate at a vertex
        // without pressure is zero only to round-off (-3.7e-12 mm lifted an unworn vertex of a
        // surface lying on its host's edge out of the host: the free rounded punch, mu 0.3).
        let inc: Vec<f64> = depth_increment(&rates[k], measure, scale).into_iter().map(|d| d.max(0.0)).collect();
        let verts: Vec<Point2<f64>> = wear.vertices[k].iter().map(|p| Point2::new(p[0], p[1])).collect();
        let moved = worn_vertices(&verts, scene.surfaces[ws.surface].base.closed, &inc);
        for (d, (i, a)) in wear.depth[k].iter_mut().zip(inc.iter().zip(measure)) {
            if *a > 0.0 {
                *d += i;
            }
        }
        let deepest = wear.depth[k].iter().fold(0.0_f64, |a, &b| a.max(b));
        if !deepest.is_finite() || deepest > ws.max_depth {
            return Err(WearError {
                cycle: wear.cycle + if fraction < 1.0 { 1 } else { dn },
                surface: ws.name.clone(),
                msg: format!(
                    "wear depth {deepest:.6e} passes max_depth = {} (the band of fixed points prepared for it): \
                     raise [[wear]] max_depth",
                    ws.max_depth
                ),
            });
        }
        wear.vertices[k] = moved.iter().map(|p| [p.x, p.y]).collect();
        wear.worn_area[k] += scale * volumes[k].iter().sum::<f64>();
        wear.work[k] += scale * works[k];
        wear.cycle_volume[k].iter_mut().for_each(|v| *v = 0.0);
        wear.cycle_work[k] = 0.0;
    }
    if jump {
        // A part of a cycle's wear completes the cycle when the parts sum to one (they are
        // powers of two: the sum is exact).
        if fraction < 1.0 {
            wear.cycle_fraction += fraction;
            if wear.cycle_fraction >= 1.0 {
                wear.cycle_fraction = 0.0;
            } else {
                dn = 0;
            }
        }
        wear.cycle += dn;
        wear.computed_cycles += 1;
        wear.jump = dn;
        wear.increment = 0;
    }
    Ok(())
}

/// How much wear one update applies: `dn` cycles of the computed cycle's, or (`fraction` < 1) a
/// part of one cycle's (see [`crate::wear::fractional_update`]).
struct UpdateSize {
    dn: u64,
    fraction: f64,
}

/// The cycle's wear volumes, works and rates as applied (see [`apply_cycle_wear`]), and the
/// jump `dn` (or the fraction of a cycle) the implicit correction settles on.
fn applied_cycle_wear(
    scene: &WearScene<'_>,
    wear: &mut WearState,
    cycle: &CycleRates,
    linearised: bool,
    size: &mut UpdateSize,
) -> (Vec<Vec<f64>>, Vec<f64>, Vec<Vec<f64>>) {
    // The cycle's wear volumes and work as applied: the computed ones (explicit), or
    // (implicit) those at the end-of-jump pressure. A computed cycle not jumped over (dN = 1)
    // is taken implicitly too (backward Euler over the cycle): the roughness mode of an element-scale ripple on a contact of stiffness
    // `E*/h` has, for one cycle's wear of slide `S`, the amplification `1 - a` explicitly and
    // `1 / (1 + a)` implicitly, `a = (E*/h) k S`: explicit oscillates past `a = 1` and diverges
    // past 2 (accelerated coefficients reach hundreds: the contact rests on islands), implicit
    // decays at any `a`, and the two agree to `a^2` where `a` is small.
    if linearised {
        match implicit_correction(scene, wear, cycle, size) {
            Some((volumes, works)) => {
                let rates = cycle.of_volumes(&volumes);
                // What the next computed cycle should find (checked by `prediction_cap`).
                if size.dn > 1 {
                    wear.controller.predicted_area_rate = volumes.iter().map(|v| v.iter().sum()).collect();
                }
                (volumes, works, rates)
            }
            None if size.dn == 1 => {
                // No linearised update solved, not even the smallest part: the cycle's wear as
                // computed (explicit). In parts of a cycle only the smallest part, `a f` below
                // one where `a` (one cycle's wear against the contact's elastic approach) is
                // below `1 / min_fraction`; whole, the roughness mode of an accelerated
                // coefficient grows by `1 - a` (the free rounded punch grew pits 20% deep at
                // a = 20). Otherwise the rest of the cycle if passes over it applied a part.
                let remaining = 1.0 - wear.cycle_fraction;
                let in_parts =
                    matches!(scene.model.jump, JumpPolicy::Adaptive { .. }) && scene.model.min_fraction < 1.0;
                size.fraction = if in_parts { fraction_floor(scene.model.min_fraction, remaining) } else { remaining };
                tracing::debug!(
                    cycle = wear.cycle,
                    fraction = size.fraction,
                    "linearised wear update failed; applied as computed"
                );
                wear.controller.last_fraction = if size.fraction < 1.0 { size.fraction } else { 0.0 };
                wear.controller.forget_prediction();
                (wear.cycle_volume.clone(), wear.cycle_work.clone(), cycle.rates.clone())
            }
            None => {
                // The facts only: which row lacks stiffness is not checked here.
                tracing::warn!(
                    cycle = wear.cycle,
                    "implicit wear jump: the factorisation of the linearised interface system failed (singular \
                     or not finite); this cycle's wear is applied as computed, without a jump"
                );
                size.dn = 1;
                wear.controller.last_jump = 1;
                size.fraction = 1.0 - wear.cycle_fraction;
                wear.controller.last_fraction = 0.0;
                wear.controller.forget_prediction();
                (wear.cycle_volume.clone(), wear.cycle_work.clone(), cycle.rates.clone())
            }
        }
    } else {
        tracing::debug!(
            cycle = wear.cycle,
            steps = wear.cycle_steps,
            linearised = wear.cycle_jumps.len(),
            "explicit cycle"
        );
        size.fraction = 1.0 - wear.cycle_fraction;
        wear.controller.last_fraction = 0.0;
        wear.controller.forget_prediction();
        (wear.cycle_volume.clone(), wear.cycle_work.clone(), cycle.rates.clone())
    }
}

/// Nothing wears if the whole run at the first cycle's rate stays below round-off of the
/// surface's resolution (a zero stroke leaves slips of order 1e-17): an error, not a run that
/// computes nothing.
fn check_something_wears(scene: &WearScene<'_>, rates: &[Vec<f64>], count: u64) -> Result<(), WearError> {
    let rmax = rates.iter().flatten().fold(0.0_f64, |a, &b| a.max(b.abs()));
    let h_min = scene
        .model
        .surfaces
        .iter()
        .map(|ws| {
            let vertices = &scene.surfaces[ws.surface].vertices;
            wearing_resolution(vertices, &vec![1.0; vertices.len()])
        })
        .fold(f64::INFINITY, f64::min);
    if rmax * count as f64 > 1e-9 * h_min {
        return Ok(());
    }
    let surface = scene.model.surfaces.iter().map(|s| s.name.as_str()).collect::<Vec<_>>().join(", ");
    if scene.model.surfaces.iter().all(|s| s.coefficient == 0.0) {
        // The cause is the input, not the contact: say so rather than list the others.
        return Err(WearError {
            cycle: 1,
            surface,
            msg: "every [[wear]] coefficient is 0: nothing would ever wear; give a coefficient > 0 (for \
                  fatigue without a scar, one small enough that the scar stays negligible)"
                .into(),
        });
    }
    Err(WearError {
        cycle: 1,
        surface,
        msg: format!(
            "no wear in the first cycle: the wearing surfaces never slid under pressure at the {} increments \
             of the cycle (zero stroke, not in contact, or too few steps.increments to sample the stroke); \
             nothing would ever wear",
            scene.increments
        ),
    })
}

/// Each wearing surface's part in the implicit jump on the stacked rows of the cycle's
/// increments (increment after increment, each with its own rows and pairing).
fn jump_surfaces<'a>(jumps: &[IncrementJump], cycle: &'a CycleRates, coefficients: &[f64]) -> Vec<JumpSurface<'a>> {
    let total: usize = jumps.iter().map(|j| j.sensitivity.rows.len()).sum();
    (0..cycle.measures.len())
        .map(|b| {
            let nv = cycle.measures[b].len();
            let mut g = DMatrix::zeros(total, nv);
            let (mut phi, mut work_per_pressure) = (Vec::with_capacity(total), Vec::with_capacity(total));
            let mut first = 0;
            for j in jumps {
                let s = &j.surfaces[b];
                for &(i, r, v) in &s.entries {
                    g[(first + r, i)] += v;
                }
                phi.extend_from_slice(&s.phi);
                work_per_pressure.extend_from_slice(&s.work_per_pressure);
                first += j.sensitivity.rows.len();
            }
            JumpSurface {
                coupling: g,
                phi,
                measure: &cycle.measures[b],
                coefficient: coefficients[b],
                work_per_pressure,
                rate: &cycle.rates[b],
                filter: &cycle.filters[b],
            }
        })
        .collect()
}

/// The weighted gap of each row of the stiffness at `u`: zero where the row is closed (the
/// solve holds it), the open rows' own gap (never below zero) elsewhere.
fn open_row_gaps(scene: &WearScene<'_>, sens: &GapSensitivity, u: &[f64]) -> Vec<f64> {
    sens.rows
        .iter()
        .zip(&sens.closed)
        .map(|(&k, &c)| {
            if c {
                0.0
            } else {
                let g = scene.contact.g0[k] + scene.contact.rows[k].iter().map(|&(d, v)| v * u[d]).sum::<f64>();
                g.max(0.0)
            }
        })
        .collect()
}

/// The jump `dn` capped by the last implicit jump's prediction against this computed cycle:
/// the pressure of every contact row at every increment (`all_pressure`, over `increments`
/// stacked increments) and the worn-area rate of each surface (see [`prediction_cap`]); with
/// the pressure's relative error if it was checked.
fn capped_by_last_prediction(
    scene: &WearScene<'_>,
    wear: &WearState,
    controller: &ControllerState,
    all_pressure: &[f64],
    increments: usize,
    mut dn: u64,
) -> (u64, Option<f64>) {
    let mut pressure_error = None;
    if let JumpPolicy::Adaptive { prediction_tolerance, .. } = scene.model.jump {
        let area_rate: Vec<f64> = wear.cycle_volume.iter().map(|v| v.iter().sum()).collect();
        let (last, ones) = (controller.last_jump, vec![1.0; area_rate.len()]);
        let phi: Vec<f64> = (0..increments).flat_map(|_| scene.contact.phi.iter().copied()).collect();
        let pressure_check =
            prediction_cap(&controller.predicted, all_pressure, &phi, last, PRESSURE_PREDICTION_TOLERANCE, 2);
        let area_check =
            prediction_cap(&controller.predicted_area_rate, &area_rate, &ones, last, prediction_tolerance, 1);
        pressure_error = pressure_check.map(|(error, _)| error);
        for (what, check) in [("pressure", pressure_check), ("area rate", area_check)] {
            if let Some((error, cap)) = check {
                tracing::debug!(cycle = wear.cycle, what, error, cap, proposed = dn, "implicit jump: last prediction");
                dn = dn.min(cap);
            }
        }
    }
    (dn, pressure_error)
}

/// The pressure of every contact row at each increment's end, `pressure` (stacked, `nrows` per
/// end), moved by the update's change `dp` (on the stiffness rows of every step of `jumps`).
fn predicted_pressure(jumps: &[IncrementJump], mut pressure: Vec<f64>, dp: &[f64], nrows: usize) -> Vec<f64> {
    let mut first = 0;
    let mut slot = 0;
    for j in jumps {
        if j.increment_end {
            for (r, &k) in j.sensitivity.rows.iter().enumerate() {
                pressure[slot * nrows + k] += dp[first + r];
            }
            slot += 1;
        }
        first += j.sensitivity.rows.len();
    }
    pressure
}

/// The implicit jump's cycle volumes and works per surface (the computed cycle's, each
/// increment's row work moved by its change at the end-of-jump pressure, never below zero: the
/// wear balance holds exactly), and the jump after the controller's pressure-change bound.
/// The increments of the cycle are stacked: the interface stiffness is block-diagonal (each
/// increment's rows held at their gaps), the couplings are each increment's, so the pressure
/// at the end of the jump is linearised at every stroke position. `None` if the linearised
/// system is singular.
fn implicit_correction(
    scene: &WearScene<'_>,
    wear: &mut WearState,
    cycle: &CycleRates,
    size: &mut UpdateSize,
) -> Option<(Vec<Vec<f64>>, Vec<f64>)> {
    let dn = &mut size.dn;
    let jumps = std::mem::take(&mut wear.cycle_jumps);
    let coefficients: Vec<f64> = scene.model.surfaces.iter().map(|ws| ws.coefficient).collect();
    let surfaces = jump_surfaces(&jumps, cycle, &coefficients);
    let total: usize = jumps.iter().map(|j| j.sensitivity.rows.len()).sum();
    let mut stiffness = DMatrix::zeros(total, total);
    let mut contact = JumpContact { pressure: vec![], gap: vec![], closed: vec![] };
    let mut weights = Vec::with_capacity(total);
    let mut first = 0;
    for j in &jumps {
        let na = j.sensitivity.rows.len();
        stiffness.view_mut((first, first), (na, na)).copy_from(&j.sensitivity.dlambda_dgap);
        contact.pressure.extend_from_slice(&j.pressure);
        contact.gap.extend_from_slice(&j.gap);
        contact.closed.extend_from_slice(&j.sensitivity.closed);
        weights.extend_from_slice(&j.weight);
        first += na;
    }
    let blocks: Vec<usize> = jumps.iter().map(|j| j.sensitivity.rows.len()).collect();
    let operator = JumpOperator::with_blocks(&stiffness, &blocks, &surfaces);
    let solve = |n: u64| operator.contact_change(n, &contact);
    let mut controller = wear.controller.clone();
    // The last jump's prediction against this cycle: the pressure of every contact row at
    // every increment, the worn-area rate of each surface.
    // Checked at the increments' ends only: their sub-steps can differ from pass to pass.
    let ends: Vec<usize> = (0..jumps.len()).filter(|&i| jumps[i].increment_end).collect();
    let all_pressure: Vec<f64> = ends.iter().flat_map(|&i| jumps[i].all_pressure.iter().copied()).collect();
    let pressure_error;
    (*dn, pressure_error) = capped_by_last_prediction(scene, wear, &controller, &all_pressure, ends.len(), *dn);
    // Parts of a cycle's wear: while a cycle's wear is being applied in parts (or the last
    // update was one), the next update is at most the rest of the cycle.
    let parts = match scene.model.jump {
        JumpPolicy::Adaptive { pressure_change, .. } if scene.model.min_fraction < 1.0 => Some(pressure_change),
        _ => None,
    };
    if parts.is_some() && (wear.cycle_fraction > 0.0 || controller.last_fraction > 0.0) {
        *dn = 1;
        // The last fraction's prediction against this pass sets the next fraction's bound.
        if let Some(error) = pressure_error {
            controller.fraction_scale = fraction_scale(controller.fraction_scale, error, PRESSURE_PREDICTION_TOLERANCE);
        }
    }
    let jumped = bounded_implicit_jump(scene.model.jump, &mut controller, *dn, &contact.pressure, &weights, &solve);
    let (n, whole) = match (jumped, parts) {
        (Some((n, dp)), _) => (n, Some(dp)),
        // The whole cycle's system failed (singular, or contact sets that cycle): in parts.
        (None, Some(_)) => {
            controller.last_jump = 1;
            (1, None)
        }
        (None, None) => return None,
    };
    let (fraction, dp) = match parts {
        Some(pressure_change) if n == 1 => {
            let bounds =
                FractionBounds { remaining: 1.0 - wear.cycle_fraction, min_fraction: scene.model.min_fraction, whole };
            let solve_part = |f: f64| operator.fractional_contact_change(f, &contact);
            let scale = if controller.fraction_scale > 0.0 { controller.fraction_scale } else { 1.0 };
            let bound = pressure_change * scale;
            fractional_update(bound, &mut controller, bounds, &contact.pressure, &weights, &solve_part)?
        }
        _ => (1.0, whole?),
    };
    size.fraction = fraction;
    let dn = &mut size.dn;
    if n > 1 || fraction < 1.0 {
        // What the next computed cycle (or the next pass over this one) should find.
        controller.predicted = predicted_pressure(&jumps, all_pressure, &dp, scene.contact.rows.len());
    } else {
        // One cycle (not jumped over): nothing is predicted for the next computed cycle.
        controller.forget_prediction();
    }
    wear.controller = controller;
    tracing::debug!(
        cycle = wear.cycle,
        proposed = *dn,
        jump = n,
        fraction = size.fraction,
        pressure_change = (dp.iter().zip(&weights).map(|(d, w)| w * d * d).sum::<f64>()
            / contact.pressure.iter().zip(&weights).map(|(p, w)| w * p * p).sum::<f64>())
        .sqrt(),
        rows = total,
        "implicit wear jump"
    );
    *dn = n;
    let mut volumes = Vec::with_capacity(surfaces.len());
    let mut works = Vec::with_capacity(surfaces.len());
    for (b, ws) in scene.model.surfaces.iter().enumerate() {
        let nv = cycle.measures[b].len();
        let mut extra = vec![0.0; nv];
        let mut work = wear.cycle_work[b];
        let mut first = 0;
        for j in &jumps {
            let s = &j.surfaces[b];
            // W_end = W + c dp >= 0, landing where the increment was paired.
            let dw: Vec<f64> =
                (0..s.phi.len()).map(|r| (s.work_per_pressure[r] * dp[first + r]).max(-s.work[r])).collect();
            for &(i, r, g) in &s.entries {
                if dw[r] != 0.0 && s.phi[r] > 0.0 {
                    extra[i] += ws.coefficient * dw[r] * g / s.phi[r];
                }
            }
            work += dw.iter().sum::<f64>();
            first += j.sensitivity.rows.len();
        }
        volumes.push(wear.cycle_volume[b].iter().zip(&extra).map(|(a, e)| a + e).collect());
        works.push(work);
    }
    Some((volumes, works))
}
