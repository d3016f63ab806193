//! Global assembly: degree-of-freedom map (Dirichlet DOFs eliminated), a CSC sparsity pattern
//! over the free DOFs built once with a per-element scatter table, and an assembler that
//! evaluates element kernels in parallel (rayon, contiguous element blocks writing into
//! caller-owned buffers) and scatters them serially in element order. Because the scatter
//! order never depends on the thread count, serial and parallel assembly are bit-identical.

use crate::fem::element::ShapeEval;
use crate::fem::kernel::{element_kernel, element_stresses, point_geometry, ElementInput, ElementOutput, Formulation};
use crate::fem::material::{Material, PlasticState, Stress4};
use crate::fem::quadrature::QuadratureRule;
use crate::mesh::CellKind;
use faer::sparse::SymbolicSparseColMat;
use nalgebra::Point2;
use rayon::prelude::*;

/// Marks a constrained DOF in [`DofMap::eq`].
pub const CONSTRAINED: usize = usize::MAX;

/// Two DOFs per node (`2 n`, `2 n + 1`); free DOFs numbered in increasing global order.
#[derive(Debug, Clone)]
pub struct DofMap {
    pub num_dofs: usize,
    pub num_free: usize,
    /// Global DOF -> free equation number, or [`CONSTRAINED`].
    pub eq: Vec<usize>,
    /// Free equation number -> global DOF.
    pub free: Vec<usize>,
}

impl DofMap {
    pub fn new(num_nodes: usize, constrained: &[usize]) -> Self {
        let num_dofs = 2 * num_nodes;
        let mut is_c = vec![false; num_dofs];
        for &d in constrained {
            is_c[d] = true;
        }
        let mut eq = vec![CONSTRAINED; num_dofs];
        let mut free = Vec::with_capacity(num_dofs);
        for d in 0..num_dofs {
            if !is_c[d] {
                eq[d] = free.len();
                free.push(d);
            }
        }
        DofMap { num_dofs, num_free: free.len(), eq, free }
    }
}

/// Everything the element loop needs per element, in flat arrays (one entry per element).
#[derive(Debug, Clone, Default)]
pub struct ElementTable {
    pub kind: Vec<CellKind>,
    /// Global node ids (a `Tri3` uses the first three).
    pub nodes: Vec<[usize; 4]>,
    pub material: Vec<usize>,
    pub formulation: Vec<Formulation>,
    pub thickness: Vec<f64>,
    /// Index into the rule table.
    pub rule: Vec<usize>,
    /// Offsets into the point arrays (stress): `point_offset[e]..point_offset[e + 1]`.
    pub point_offset: Vec<usize>,
    /// Offsets into the history array (empty range for materials without state).
    pub state_offset: Vec<usize>,
}

impl ElementTable {
    pub fn len(&self) -> usize {
        self.kind.len()
    }
    pub fn is_empty(&self) -> bool {
        self.kind.is_empty()
    }
    pub fn num_points(&self) -> usize {
        self.point_offset.last().copied().unwrap_or(0)
    }
    pub fn num_states(&self) -> usize {
        self.state_offset.last().copied().unwrap_or(0)
    }
}

/// CSC pattern of the free-DOF matrix (both triangles) and the element scatter table.
pub struct SparsityPattern {
    pub symbolic: SymbolicSparseColMat<usize>,
    /// For element `e`, local entry `i * 8 + j` goes to `values[scatter[64 e + i * 8 + j]]`
    /// (row `i`, column `j`), or nowhere if [`CONSTRAINED`].
    scatter: Vec<usize>,
    /// `(row r, position of C_re, position of C^T_er, coefficient)` for every constraint entry.
    pub constraint_scatter: Vec<(usize, usize, usize, f64)>,
    /// Rows from this index on are inequality (contact) rows: the assembler leaves their values
    /// to the analysis, and each has a diagonal entry at `diag_scatter[r - fixed_rows]`.
    pub fixed_rows: usize,
    pub diag_scatter: Vec<usize>,
    /// Position of each requested multiplier-block entry `(row r, column c)` (both >= `fixed_rows`;
    /// the Coulomb slip rows `lambda_t + mu s lambda_n = 0` couple a tangential to a normal row).
    pub coupling_scatter: Vec<usize>,
    /// `(position, value)` of every constant penalty entry.
    penalty_scatter: Vec<(usize, f64)>,
}

/// What the saddle-point pattern holds beside the bulk (see
/// [`SparsityPattern::with_constraints`]): the constraint rows over global DOFs, the constant
/// penalty entries `(dof_i, dof_j, value)`, the number of leading rows without a diagonal of
/// their own (ties), and the `(row, column)` couplings between constraint rows (friction).
#[derive(Debug, Clone, Copy, Default)]
pub struct SaddleRows<'a> {
    pub constraints: &'a [Vec<(usize, f64)>],
    pub penalty: &'a [(usize, usize, f64)],
    pub fixed_rows: usize,
    pub couplings: &'a [(usize, usize)],
}

impl SparsityPattern {
    /// Builds the pattern from node adjacency (no triplet sort): column `j` of node `n` holds the
    /// free DOFs of all nodes sharing a cell with `n`, in increasing order.
    pub fn new(num_nodes: usize, elements: &ElementTable, dofs: &DofMap) -> Self {
        Self::with_constraints(num_nodes, elements, dofs, SaddleRows::default())
    }

    /// Pattern of the saddle-point matrix `[K + P, C^T; C 0]`: the free DOFs first, then one
    /// unknown per constraint row (`sum coef u[dof] = 0`, global DOFs). `penalty` holds constant
    /// extra stiffness entries `(dof_i, dof_j, value)` in global DOFs (ghost penalty).
    pub fn with_constraints(num_nodes: usize, elements: &ElementTable, dofs: &DofMap, rows: SaddleRows<'_>) -> Self {
        let SaddleRows { constraints, penalty, fixed_rows, couplings } = rows;
        let nf = dofs.num_free;
        let n = nf + constraints.len();
        let (col_ptr, row_idx) = columns(num_nodes, elements, dofs, rows);
        let entry = |row: usize, col: usize| {
            row_idx[col_ptr[col]..col_ptr[col + 1]].binary_search(&row).ok().map(|p| col_ptr[col] + p)
        };
        let diag_scatter = (fixed_rows..constraints.len()).filter_map(|r| entry(nf + r, nf + r)).collect();
        // Always found: the coupling entries were inserted by `columns`.
        let coupling_scatter = couplings.iter().map(|&(r, c)| entry(nf + r, nf + c).unwrap_or(usize::MAX)).collect();
        // Where each constraint coefficient goes: (row r, column e) and (row e, column r).
        let mut constraint_scatter = Vec::new();
        for (r, row) in constraints.iter().enumerate() {
            let cr = nf + r;
            for &(d, coef) in row {
                let e = dofs.eq[d];
                if e == CONSTRAINED {
                    continue;
                }
                if let (Some(p1), Some(p2)) = (entry(cr, e), entry(e, cr)) {
                    constraint_scatter.push((r, p1, p2, coef));
                }
            }
        }
        let scatter = element_scatter(elements, dofs, &col_ptr, &row_idx);
        let mut penalty_scatter = Vec::new();
        for &(i, j, v) in penalty {
            let (ri, cj) = (dofs.eq[i], dofs.eq[j]);
            if ri == CONSTRAINED || cj == CONSTRAINED {
                continue;
            }
            if let Some(p) = entry(ri, cj) {
                penalty_scatter.push((p, v));
            }
        }
        let symbolic = SymbolicSparseColMat::new_checked(n, n, col_ptr, None, row_idx);
        SparsityPattern {
            symbolic,
            scatter,
            constraint_scatter,
            fixed_rows,
            diag_scatter,
            coupling_scatter,
            penalty_scatter,
        }
    }

    pub fn nnz(&self) -> usize {
        self.symbolic.row_idx().len()
    }

    /// Replaces the constant penalty entries (values and positions) in this pattern, which
    /// stays as it is. Returns `false`, leaving the old entries, if an entry between free DOFs
    /// has no place in it (the pattern must then be rebuilt with it).
    pub fn set_penalty(&mut self, dofs: &DofMap, penalty: &[(usize, usize, f64)]) -> bool {
        let (col_ptr, row_idx) = (self.symbolic.col_ptr(), self.symbolic.row_idx());
        let mut scatter = Vec::with_capacity(penalty.len());
        for &(i, j, v) in penalty {
            let (ri, cj) = (dofs.eq[i], dofs.eq[j]);
            if ri == CONSTRAINED || cj == CONSTRAINED {
                continue;
            }
            match row_idx[col_ptr[cj]..col_ptr[cj + 1]].binary_search(&ri) {
                Ok(p) => scatter.push((col_ptr[cj] + p, v)),
                Err(_) => return false,
            }
        }
        self.penalty_scatter = scatter;
        true
    }
}

/// Read-only inputs of one assembly.
pub struct AssemblyInput<'a> {
    pub coords: &'a [Point2<f64>],
    pub elements: &'a ElementTable,
    pub materials: &'a [Material],
    pub rules: &'a [QuadratureRule],
    /// Global displacement vector (constrained DOFs hold their prescribed values).
    pub u: &'a [f64],
    pub state_old: &'a [PlasticState],
}

/// Outputs of one assembly, all caller-owned.
pub struct AssemblyOutput<'a> {
    /// Matrix values in pattern order (`None`: internal force only).
    pub values: Option<&'a mut [f64]>,
    /// Internal force over all global DOFs.
    pub f_int: &'a mut [f64],
    pub stress: &'a mut [Stress4],
    pub state_new: &'a mut [PlasticState],
}

/// Element-local buffers reused across assemblies.
pub struct Assembler {
    pub pattern: SparsityPattern,
    ke: Vec<[f64; 64]>,
    fe: Vec<[f64; 8]>,
    /// Element block boundaries for the parallel loop.
    blocks: Vec<usize>,
    /// Mapped geometry at every quadrature point (point order).
    geometry: Vec<ShapeEval>,
    /// Per element, the fingerprint of the node coordinates and rule points its points'
    /// geometry was computed from: an element whose input changed (a re-cut moved a band
    /// cell's points) is recomputed, the others are kept.
    geometry_of: Vec<Option<u64>>,
    /// Per element, its stiffness from an assembly where all its points stayed elastic, with
    /// the fingerprint of its geometry, rule weights and material (`None`: none kept): reused
    /// while they stay elastic and the fingerprint holds (see `ElementInput::elastic_ke`), so a
    /// re-cut recomputes only the cells whose rules it changed.
    elastic_ke: Vec<KeptStiffness>,
    /// Linear elastic elements with a kept stiffness take their force as `K_e u_e` and leave
    /// their stresses unwritten (see [`Assembler::set_elastic_force_from_kept`]).
    elastic_force_from_kept: bool,
    /// The rule table last shared by the caller (see [`Assembler::share_rules`]) and the
    /// hashes of its points and weights, once computed.
    shared_rules: Option<SharedRules>,
}

const BLOCK: usize = 512;

/// An element's kept elastic stiffness and the fingerprint of what it was computed from.
#[derive(Clone, Copy)]
struct KeptStiffness {
    ke: [f64; 64],
    of: Option<u64>,
}

/// One parallel job of [`Assembler::assemble`]: its first element, its slices of the element
/// stiffnesses, kept elastic stiffnesses with their fingerprints, element forces, point
/// stresses and point histories, and its end.
type ElementBlock<'a, 'b> = (
    (
        ((((&'b usize, &'a mut [[f64; 64]]), &'a mut [KeptStiffness]), &'a mut [[f64; 8]]), &'a mut [Stress4]),
        &'a mut [PlasticState],
    ),
    usize,
);

/// Four interleaved FNV-style lanes over a stream of `f64` bits (independent chains, so the
/// hash runs at the memory's pace rather than one multiply's latency per value).
struct Fingerprint {
    lanes: [u64; 4],
    next: usize,
}

impl Fingerprint {
    fn new(seed: u64) -> Self {
        Fingerprint { lanes: [seed, seed ^ 1, seed ^ 2, seed ^ 3], next: 0 }
    }

    #[inline]
    fn mix(&mut self, v: f64) {
        let h = &mut self.lanes[self.next & 3];
        *h = (*h ^ v.to_bits()).wrapping_mul(0x0100_0000_01b3).rotate_left(17);
        self.next += 1;
    }

    /// Four values at once, one per lane (the lanes stay in registers).
    #[inline]
    fn mix4(&mut self, v: [f64; 4]) {
        for (h, x) in self.lanes.iter_mut().zip(v) {
            *h = (*h ^ x.to_bits()).wrapping_mul(0x0100_0000_01b3).rotate_left(17);
        }
    }

    /// A slice, four values at a time.
    fn mix_slice(&mut self, v: &[f64]) {
        let mut chunks = v.chunks_exact(4);
        for c in &mut chunks {
            self.mix4([c[0], c[1], c[2], c[3]]);
        }
        for &x in chunks.remainder() {
            self.mix(x);
        }
    }

    fn finish(&self) -> u64 {
        self.lanes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &l| (h ^ l).wrapping_mul(0x0100_0000_01b3).rotate_left(17))
    }
}

/// A rule table shared with the assembler (held weakly: a re-cut that owns the table then
/// changes it in place, which cuts this link), and the hashes of its rules, once computed.
struct SharedRules {
    rules: std::sync::Weak<Vec<QuadratureRule>>,
    hashes: Option<std::sync::Arc<Vec<RuleHash>>>,
    /// The element fingerprints over this table (see [`Assembler::element_keys`]), with the
    /// hash of the element table and coordinates they were formed for.
    keys: Option<(u64, ElementKeys)>,
}

/// Per element, the fingerprint of its point geometry and that of its elastic stiffness.
#[derive(Clone)]
struct ElementKeys {
    geometry: std::sync::Arc<Vec<u64>>,
    stiffness: std::sync::Arc<Vec<u64>>,
}

/// A hash of the coordinates and of every element's kind, nodes, rule index, material,
/// formulation and thickness (their bits): what the element fingerprints depend on besides
/// the rules.
fn elements_fingerprint(inp: &AssemblyInput) -> u64 {
    let mut h = Fingerprint::new(0xcbf2_9ce4_8422_2325);
    for c in inp.coords {
        h.mix(c.x);
        h.mix(c.y);
    }
    let el = inp.elements;
    for e in 0..el.len() {
        let n = &el.nodes[e];
        h.mix4([n[0] as f64, n[1] as f64, n[2] as f64, n[3] as f64]);
        h.mix4([el.kind[e].num_nodes() as f64, el.rule[e] as f64, el.material[e] as f64, el.thickness[e]]);
        h.mix(formulation_code(el.formulation[e]));
    }
    h.finish()
}

fn formulation_code(f: Formulation) -> f64 {
    match f {
        Formulation::Standard => 0.0,
        Formulation::BBar => 1.0,
    }
}

/// Hashes of one rule's points and of its weights (their bits, in order).
#[derive(Clone, Copy)]
struct RuleHash {
    points: u64,
    weights: u64,
}

fn rule_hashes(rules: &[QuadratureRule]) -> Vec<RuleHash> {
    rules
        .iter()
        .map(|r| {
            let mut points = Fingerprint::new(0xcbf2_9ce4_8422_2325);
            points.mix(r.points.len() as f64);
            points.mix_slice(r.points.as_flattened());
            let mut weights = Fingerprint::new(0x9e37_79b9_7f4a_7c15);
            weights.mix(r.weights.len() as f64);
            weights.mix_slice(&r.weights);
            RuleHash { points: points.finish(), weights: weights.finish() }
        })
        .collect()
}

/// A hash of what element `e`'s point geometry depends on: its kind, node coordinates and
/// rule points (their bits).
fn element_geometry_fingerprint(inp: &AssemblyInput, e: usize, rule: RuleHash) -> u64 {
    let el = inp.elements;
    let mut h = Fingerprint::new(rule.points);
    let nn = el.kind[e].num_nodes();
    h.mix(nn as f64);
    for &n in &el.nodes[e][..nn] {
        h.mix(inp.coords[n].x);
        h.mix(inp.coords[n].y);
    }
    h.finish()
}

/// [`element_geometry_fingerprint`] extended by what the element's elastic stiffness also
/// depends on: its rule weights (a re-cut of a band cell changes them), material, formulation
/// and thickness.
fn element_stiffness_fingerprint(inp: &AssemblyInput, e: usize, geometry: u64, rule: RuleHash) -> u64 {
    let el = inp.elements;
    let mut h = Fingerprint::new(geometry);
    h.mix(f64::from_bits(rule.weights));
    h.mix(el.material[e] as f64);
    h.mix(formulation_code(el.formulation[e]));
    h.mix(el.thickness[e]);
    h.finish()
}

/// Element `e`'s node coordinates and displacements `[u_x0, u_y0, u_x1, ...]` from `inp`.
fn element_values(inp: &AssemblyInput, e: usize) -> ([Point2<f64>; 4], [f64; 8]) {
    let nodes = &inp.elements.nodes[e];
    let mut coords = [Point2::origin(); 4];
    let mut u = [0.0; 8];
    for a in 0..inp.elements.kind[e].num_nodes() {
        coords[a] = inp.coords[nodes[a]];
        u[2 * a] = inp.u[2 * nodes[a]];
        u[2 * a + 1] = inp.u[2 * nodes[a] + 1];
    }
    (coords, u)
}

fn split_mut<'a, T>(mut s: &'a mut [T], bounds: impl Iterator<Item = usize>) -> Vec<&'a mut [T]> {
    let mut out = Vec::new();
    let mut start = 0;
    for b in bounds {
        let (head, tail) = s.split_at_mut(b - start);
        out.push(head);
        s = tail;
        start = b;
    }
    out
}

impl Assembler {
    pub fn new(pattern: SparsityPattern, elements: &ElementTable) -> Self {
        let ne = elements.len();
        let mut blocks: Vec<usize> = (0..ne).step_by(BLOCK).collect();
        blocks.push(ne);
        Assembler {
            pattern,
            ke: vec![[0.0; 64]; ne],
            fe: vec![[0.0; 8]; ne],
            blocks,
            geometry: Vec::new(),
            geometry_of: Vec::new(),
            elastic_ke: vec![KeptStiffness { ke: [0.0; 64], of: None }; ne],
            elastic_force_from_kept: false,
            shared_rules: None,
        }
    }

    /// The rule table the next assemblies will mostly read (a model's discretisation shares
    /// its table between re-pairings): linked to it, the assembler hashes its points and
    /// weights once, not at every assembly (136k points on the McColl scene). An assembly whose
    /// `rules` are this table's (same buffer) uses the kept hashes while the link holds: a
    /// shared table cannot change, and the only way to change it in place (`Arc::make_mut` by
    /// its sole owner) cuts the weak link first. Any other table is hashed afresh.
    pub fn share_rules(&mut self, rules: &std::sync::Arc<Vec<QuadratureRule>>) {
        let linked = |s: &SharedRules| s.rules.upgrade().is_some_and(|held| std::sync::Arc::ptr_eq(&held, rules));
        if !self.shared_rules.as_ref().is_some_and(linked) {
            let rules = std::sync::Arc::downgrade(rules);
            self.shared_rules = Some(SharedRules { rules, hashes: None, keys: None });
        }
    }

    /// The hashes of `rules`, kept for a shared table.
    fn rule_hashes(&mut self, rules: &[QuadratureRule]) -> std::sync::Arc<Vec<RuleHash>> {
        match self.shared_rules.as_mut() {
            Some(s) if s.rules.upgrade().is_some_and(|held| std::ptr::eq(held.as_slice(), rules)) => {
                s.hashes.get_or_insert_with(|| std::sync::Arc::new(rule_hashes(rules))).clone()
            }
            _ => std::sync::Arc::new(rule_hashes(rules)),
        }
    }

    /// Every element's fingerprints (geometry, stiffness), kept for a shared rule table while
    /// the elements and coordinates are those they were formed for.
    fn element_keys(&mut self, inp: &AssemblyInput) -> ElementKeys {
        let hashes = self.rule_hashes(inp.rules);
        let of = elements_fingerprint(inp);
        let shared = self
            .shared_rules
            .as_mut()
            .filter(|s| s.rules.upgrade().is_some_and(|held| std::ptr::eq(held.as_slice(), inp.rules)));
        if let Some((_, keys)) = shared.as_ref().and_then(|s| s.keys.as_ref()).filter(|(k, _)| *k == of) {
            return keys.clone();
        }
        let el = inp.elements;
        let geometry: Vec<u64> =
            (0..el.len()).map(|e| element_geometry_fingerprint(inp, e, hashes[el.rule[e]])).collect();
        let stiffness =
            (0..el.len()).map(|e| element_stiffness_fingerprint(inp, e, geometry[e], hashes[el.rule[e]])).collect();
        let keys = ElementKeys { geometry: std::sync::Arc::new(geometry), stiffness: std::sync::Arc::new(stiffness) };
        if let Some(s) = shared {
            s.keys = Some((of, keys.clone()));
        }
        keys
    }

    /// Fills the per-point geometry table for the elements whose geometry (coordinates, rule
    /// points) is not the one it holds; returns every element's fingerprints.
    fn ensure_geometry(&mut self, inp: &AssemblyInput, parallel: bool) -> ElementKeys {
        let element_keys = self.element_keys(inp);
        let keys = &element_keys.geometry;
        let el = inp.elements;
        if self.geometry.len() != el.num_points() || self.geometry_of.len() != el.len() {
            self.geometry = vec![ShapeEval::default(); el.num_points()];
            self.geometry_of = vec![None; el.len()];
        }
        let ends = self.blocks[1..].to_vec();
        let blocks = split_mut(&mut self.geometry, ends.iter().map(|&b| el.point_offset[b]));
        let held = split_mut(&mut self.geometry_of, ends.iter().copied());
        let starts = &self.blocks[..self.blocks.len() - 1];
        let work = |(((&b0, g), of), b1): (((&usize, &mut [ShapeEval]), &mut [Option<u64>]), usize)| {
            let p0 = el.point_offset[b0];
            for e in b0..b1 {
                if of[e - b0] == Some(keys[e]) {
                    continue;
                }
                let nodes = &el.nodes[e];
                let mut coords = [Point2::origin(); 4];
                for a in 0..el.kind[e].num_nodes() {
                    coords[a] = inp.coords[nodes[a]];
                }
                let (pa, pb) = (el.point_offset[e] - p0, el.point_offset[e + 1] - p0);
                point_geometry(el.kind[e], coords, &inp.rules[el.rule[e]], &mut g[pa..pb]);
                of[e - b0] = Some(keys[e]);
            }
        };
        let jobs: Vec<_> = starts.iter().zip(blocks).zip(held).zip(ends.iter().copied()).collect();
        if parallel {
            jobs.into_par_iter().for_each(work);
        } else {
            jobs.into_iter().for_each(work);
        }
        element_keys
    }

    /// With `on`, the linear elastic elements of later assemblies take their internal force
    /// from their kept stiffness, `f_e = K_e u_e` (kept from a tangent assembly of the same
    /// geometry and rules), and leave their points' stresses as they were: a yielding run's
    /// elastic bodies then cost a matrix-vector product per Newton pass. The caller fills
    /// those stresses with [`Assembler::elastic_stresses`] before it reads them.
    pub fn set_elastic_force_from_kept(&mut self, on: bool) {
        self.elastic_force_from_kept = on;
    }

    /// Whether [`Self::set_elastic_force_from_kept`] is on.
    pub fn elastic_force_from_kept(&self) -> bool {
        self.elastic_force_from_kept
    }

    /// The stresses of the linear elastic elements at `inp.u` into `stress` (point order);
    /// the points of other materials are left alone.
    pub fn elastic_stresses(&self, inp: &AssemblyInput, stress: &mut [Stress4]) {
        let el = inp.elements;
        for e in 0..el.len() {
            let material = &inp.materials[el.material[e]];
            if !matches!(material, Material::Elastic(_)) {
                continue;
            }
            let (coords, u) = element_values(inp, e);
            let input = ElementInput {
                kind: el.kind[e],
                coords,
                u,
                rule: &inp.rules[el.rule[e]],
                formulation: el.formulation[e],
                material,
                thickness: el.thickness[e],
                state_old: &[],
                geometry: None,
                elastic_ke: None,
                elastic_force_from_ke: false,
            };
            element_stresses(&input, &mut stress[el.point_offset[e]..el.point_offset[e + 1]]);
        }
    }

    /// Evaluates all element kernels (in parallel if `parallel`) and scatters them.
    pub fn assemble(&mut self, inp: &AssemblyInput, out: AssemblyOutput, parallel: bool) {
        let keys = self.ensure_geometry(inp, parallel);
        let with_tangent = out.values.is_some();
        let el = inp.elements;
        // The kept stiffnesses serve an assembly of their own element geometry, rules and
        // material only (per element: a re-cut leaves most elements as they were).
        let stiffness_keys: &[u64] = if with_tangent || self.elastic_force_from_kept { &keys.stiffness } else { &[] };
        if self.elastic_ke.len() != el.len() {
            self.elastic_ke = vec![KeptStiffness { ke: [0.0; 64], of: None }; el.len()];
        }
        let geometry = &self.geometry;
        let from_kept = self.elastic_force_from_kept;
        let ends = self.blocks[1..].to_vec();
        let ke_blocks = split_mut(&mut self.ke, ends.iter().copied());
        let kept_blocks = split_mut(&mut self.elastic_ke, ends.iter().copied());
        let fe_blocks = split_mut(&mut self.fe, ends.iter().copied());
        let st_blocks = split_mut(out.stress, ends.iter().map(|&b| el.point_offset[b]));
        let hs_blocks = split_mut(out.state_new, ends.iter().map(|&b| el.state_offset[b]));
        let starts = &self.blocks[..self.blocks.len() - 1];
        let work = |((((((&b0, ke), kept), fe), st), hs), b1): ElementBlock| {
            let p0 = el.point_offset[b0];
            let s0 = el.state_offset[b0];
            for e in b0..b1 {
                let k = e - b0;
                let key = stiffness_keys.get(e).copied();
                let usable = key.is_some() && kept[k].of == key;
                let kind = el.kind[e];
                let (coords, u) = element_values(inp, e);
                let (pa, pb) = (el.point_offset[e] - p0, el.point_offset[e + 1] - p0);
                let (sa, sb) = (el.state_offset[e] - s0, el.state_offset[e + 1] - s0);
                let input = ElementInput {
                    kind,
                    coords,
                    u,
                    rule: &inp.rules[el.rule[e]],
                    formulation: el.formulation[e],
                    material: &inp.materials[el.material[e]],
                    thickness: el.thickness[e],
                    state_old: &inp.state_old[el.state_offset[e]..el.state_offset[e + 1]],
                    geometry: Some(&geometry[el.point_offset[e]..el.point_offset[e + 1]]),
                    elastic_ke: usable.then_some(&kept[k].ke),
                    elastic_force_from_ke: from_kept,
                };
                let mut output = ElementOutput {
                    ke: if with_tangent { Some(&mut ke[k]) } else { None },
                    fe: &mut fe[k],
                    stress: &mut st[pa..pb],
                    state_new: &mut hs[sa..sb],
                    elastic: false,
                };
                element_kernel(&input, &mut output);
                if with_tangent && output.elastic && !usable {
                    kept[k] = KeptStiffness { ke: ke[k], of: key };
                }
            }
        };
        let jobs: Vec<_> = starts
            .iter()
            .zip(ke_blocks)
            .zip(kept_blocks)
            .zip(fe_blocks)
            .zip(st_blocks)
            .zip(hs_blocks)
            .zip(ends.iter().copied())
            .collect();
        if parallel {
            jobs.into_par_iter().for_each(work);
        } else {
            jobs.into_iter().for_each(work);
        }
        // Serial scatter in element order: deterministic.
        out.f_int.iter_mut().for_each(|v| *v = 0.0);
        for e in 0..el.len() {
            let nn = el.kind[e].num_nodes();
            let nodes = &el.nodes[e];
            for i in 0..2 * nn {
                out.f_int[2 * nodes[i / 2] + i % 2] += self.fe[e][i];
            }
        }
        if let Some(values) = out.values {
            values.iter_mut().for_each(|v| *v = 0.0);
            for e in 0..el.len() {
                let sc = &self.pattern.scatter[64 * e..64 * e + 64];
                let ke = &self.ke[e];
                for k in 0..64 {
                    let p = sc[k];
                    if p != CONSTRAINED {
                        values[p] += ke[k];
                    }
                }
            }
            for &(r, p1, p2, coef) in &self.pattern.constraint_scatter {
                if r < self.pattern.fixed_rows {
                    values[p1] += coef;
                    values[p2] += coef;
                }
            }
            for &(p, v) in &self.pattern.penalty_scatter {
                values[p] += v;
            }
        }
    }
}

/// Node adjacency through the elements, then the compressed columns of the saddle-point
/// matrix: per free equation the free DOFs of its node's neighbours, the penalty couplings and
/// the constraint rows touching it; per constraint row its free DOFs, its own diagonal (rows
/// from `fixed_rows` on) and its coupled rows.
fn columns(num_nodes: usize, elements: &ElementTable, dofs: &DofMap, rows: SaddleRows<'_>) -> (Vec<usize>, Vec<usize>) {
    let SaddleRows { constraints, penalty, fixed_rows, couplings } = rows;
    let mut coupled_rows: Vec<Vec<usize>> = vec![Vec::new(); constraints.len()];
    for &(r, c) in couplings {
        assert!(r >= fixed_rows && c >= fixed_rows && r < constraints.len() && c < constraints.len());
        coupled_rows[c].push(r);
    }
    let mut adj: Vec<Vec<usize>> = vec![Vec::new(); num_nodes];
    for (e, nodes) in elements.nodes.iter().enumerate() {
        let nn = elements.kind[e].num_nodes();
        for &a in &nodes[..nn] {
            adj[a].extend_from_slice(&nodes[..nn]);
        }
    }
    adj.par_iter_mut().for_each(|v| {
        v.sort_unstable();
        v.dedup();
    });
    let nf = dofs.num_free;
    let n = nf + constraints.len();
    // Constraint rows touching each free equation.
    let mut eq_rows: Vec<Vec<usize>> = vec![Vec::new(); nf];
    for (r, row) in constraints.iter().enumerate() {
        for &(d, _) in row {
            let e = dofs.eq[d];
            if e != CONSTRAINED && eq_rows[e].last() != Some(&(nf + r)) {
                eq_rows[e].push(nf + r);
            }
        }
    }
    // Penalty couplings beyond the element adjacency, per free column.
    let mut extra_rows: Vec<Vec<usize>> = vec![Vec::new(); nf];
    for &(i, j, _) in penalty {
        let (ri, cj) = (dofs.eq[i], dofs.eq[j]);
        if ri != CONSTRAINED && cj != CONSTRAINED {
            extra_rows[cj].push(ri);
        }
    }
    let mut col_ptr = Vec::with_capacity(n + 1);
    col_ptr.push(0usize);
    let mut row_idx = Vec::new();
    for (e, &g) in dofs.free.iter().enumerate() {
        let node = g / 2;
        let start = row_idx.len();
        for &m in &adj[node] {
            for d in [2 * m, 2 * m + 1] {
                let r = dofs.eq[d];
                if r != CONSTRAINED {
                    row_idx.push(r);
                }
            }
        }
        if !extra_rows[e].is_empty() {
            row_idx.extend_from_slice(&extra_rows[e]);
            row_idx[start..].sort_unstable();
            let mut col: Vec<usize> = row_idx.split_off(start);
            col.dedup();
            row_idx.extend_from_slice(&col);
        }
        let mut cr = eq_rows[e].clone();
        cr.sort_unstable();
        cr.dedup();
        row_idx.extend_from_slice(&cr);
        col_ptr.push(row_idx.len());
    }
    for (r, row) in constraints.iter().enumerate() {
        let mut rows: Vec<usize> = row.iter().map(|&(d, _)| dofs.eq[d]).filter(|&e| e != CONSTRAINED).collect();
        if r >= fixed_rows {
            rows.push(nf + r);
        }
        rows.extend(coupled_rows[r].iter().map(|&q| nf + q));
        rows.sort_unstable();
        rows.dedup();
        row_idx.extend_from_slice(&rows);
        col_ptr.push(row_idx.len());
    }
    (col_ptr, row_idx)
}

/// Per element, where each of its (up to 8 x 8) stiffness entries goes in the matrix values
/// (`CONSTRAINED`: nowhere).
fn element_scatter(elements: &ElementTable, dofs: &DofMap, col_ptr: &[usize], row_idx: &[usize]) -> Vec<usize> {
    let mut scatter = vec![CONSTRAINED; 64 * elements.len()];
    scatter.par_chunks_mut(64).enumerate().for_each(|(e, sc)| {
        let nn = elements.kind[e].num_nodes();
        let nodes = &elements.nodes[e];
        for j in 0..2 * nn {
            let cj = dofs.eq[2 * nodes[j / 2] + j % 2];
            if cj == CONSTRAINED {
                continue;
            }
            let col = &row_idx[col_ptr[cj]..col_ptr[cj + 1]];
            for i in 0..2 * nn {
                let ri = dofs.eq[2 * nodes[i / 2] + i % 2];
                if ri == CONSTRAINED {
                    continue;
                }
                // Rows of a column are sorted: binary search.
                if let Ok(p) = col.binary_search(&ri) {
                    sc[i * 8 + j] = col_ptr[cj] + p;
                }
            }
        }
    });
    scatter
}
