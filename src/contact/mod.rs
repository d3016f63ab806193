//! Contact as its own layer: the mortar contact law at each multiplier node, the row equations
//! it imposes for the current sets (shared by the monolithic Newton and the condensed interface
//! solve), the contact rows of a pair (first pairing, re-pairing, moving surfaces), and the
//! typed per-node contact field that output, post-processing and wear read.
//!
//! Law (Alart & Curnier, CMAME 92 (1991) 353; mortar form: Popp et al., IJNME 79 (2009) 1354),
//! per multiplier node `k` with weighted gap `g_k`, weighted slip increment `ds_k` and
//! `int Phi_k` (the integral of its hat over the paired part):
//! `lambda_hat_n = lambda_n + eps_n g / int Phi`, `lambda_hat_t = lambda_t + eps_t ds / int Phi`;
//! active if `lambda_hat_n <= 0`; an active node sticks if `|lambda_hat_t| <= -mu lambda_hat_n`,
//! else slips with `lambda_t = -mu lambda_n sign(lambda_hat_t)`. For fixed sets each multiplier
//! row imposes one [`RowLaw`]: its constraint (`g = 0`, `ds = 0`, tie rows), a free multiplier
//! (`lambda = 0`: open), or the Coulomb slip relation.

use crate::fem::element::ReferenceElement;
use crate::mesh::Mesh2;
use crate::mortar::{weighted_gaps, ConstraintRow, ContactRow, MortarSide, MultiplierSpace, Multipliers, OtherSide};
use crate::surface::Embedding;
use nalgebra::{Point2, Vector2};

/// A mortar contact pair; multipliers (contact pressure `p = -lambda_n`, shear `lambda_t` along
/// `t = n` turned +90 degrees, `n` the mortar body's outward normal) on the mortar surface.
#[derive(Debug, Clone)]
pub struct ContactInfo {
    pub name: String,
    pub mortar: usize,
    /// Coulomb coefficient (0: frictionless, no tangential unknowns).
    pub mu: f64,
    pub space: MultiplierSpace,
    /// Index of the pair's first row in `ContactSet::rows`.
    pub first_row: usize,
    /// Per multiplier node, its row in `ContactSet::friction_rows` (none when frictionless, or
    /// unpaired under small sliding; every node has one under finite sliding).
    pub friction_row: Vec<Option<usize>>,
    pub multipliers: Multipliers,
    pub sliding: Sliding,
    /// The pair's geometry, kept for re-pairing: mortar surface (reference), other side,
    /// pairing reach.
    pub side: MortarSide,
    pub other: PairedSide,
    pub max_gap: f64,
    /// The free surface (index into the model's surfaces) that is the other side, if virtual.
    pub other_surface: Option<usize>,
    /// The mortar side is a virtual surface (a worn real boundary, or any cut): its vertices
    /// interpolate their host's displacement.
    pub virtual_mortar: Option<VirtualMortar>,
}

/// A virtual mortar side: its polyline vertices are the side's vertices (the side's `nodes` are
/// stand-ins numbered from `base`, the model's node count), each interpolating the host cell
/// it lies in (or the nearest, outside the host); the surface is linear between vertices.
#[derive(Debug, Clone)]
pub struct VirtualMortar {
    /// Free surface index and host body.
    pub surface: usize,
    pub host: usize,
    pub base: usize,
    /// Per vertex: (global host node, shape value).
    pub interpolation: Vec<Vec<(usize, f64)>>,
}

impl VirtualMortar {
    /// Interpolation of every vertex of a polyline embedded in `mesh` (body nodes from
    /// `node_offset`): the cell of a piece starting or ending at the vertex, or for a vertex
    /// outside the host the cell of the nearest piece of an adjacent segment (extrapolated).
    pub fn interpolation(
        mesh: &Mesh2,
        node_offset: usize,
        embedding: &Embedding,
        vertices: &[Point2<f64>],
        closed: bool,
    ) -> Vec<Vec<(usize, f64)>> {
        let nv = vertices.len();
        let nseg = if closed { nv } else { nv - 1 };
        (0..nv)
            .map(|i| {
                let before = if i > 0 {
                    Some(i - 1)
                } else if closed {
                    Some(nseg - 1)
                } else {
                    None
                };
                let after = if i < nseg { Some(i) } else { None };
                // Nearest piece end to the vertex on an adjacent segment.
                let mut best: Option<(f64, usize)> = None;
                for (k, p) in embedding.pieces.iter().enumerate() {
                    let d = if Some(p.segment) == after {
                        p.t0
                    } else if Some(p.segment) == before {
                        1.0 - p.t1
                    } else {
                        continue;
                    };
                    if best.is_none_or(|b| d < b.0) {
                        best = Some((d, k));
                    }
                }
                let cell = match best {
                    Some((_, k)) => embedding.pieces[k].cell,
                    None => {
                        // No adjacent piece (a long stretch outside): nearest piece overall.
                        let Some(p) = embedding
                            .pieces
                            .iter()
                            .min_by(|a, b| (a.a - vertices[i]).norm().total_cmp(&(b.a - vertices[i]).norm()))
                        else {
                            return vec![];
                        };
                        p.cell
                    }
                };
                let mapped = crate::fem::element::MappedElement::new(mesh.cells[cell].kind, mesh.cell_coords(cell));
                let xi = mapped.inverse_map(vertices[i]).unwrap_or([0.0, 0.0]);
                let mut n = [0.0; 4];
                mesh.cells[cell].kind.shape(xi, &mut n);
                mesh.cells[cell].nodes().iter().zip(n).map(|(&a, v)| (a + node_offset, v)).collect()
            })
            .collect()
    }

    /// Rewrites a row on stand-in vertex DOFs onto the host's DOFs (`slot`: scratch of
    /// [`crate::mortar::summed_by_dof`], kept between rows).
    pub fn expand(&self, row: ConstraintRow, slot: &mut Vec<usize>) -> ConstraintRow {
        let mut entries = Vec::with_capacity(4 * row.len());
        for (d, v) in row {
            let n = d / 2;
            if n >= self.base {
                entries.extend(self.interpolation[n - self.base].iter().map(|&(g, w)| (2 * g + d % 2, v * w)));
            } else {
                entries.push((d, v));
            }
        }
        // Summed per DOF in the order they come (what a map accumulating them gives).
        crate::mortar::summed_by_dof(&entries, slot).into_iter().filter(|(_, v)| *v != 0.0).collect()
    }

    /// Displacement of vertex `i` in `u`.
    pub fn displacement(&self, i: usize, u: &[f64]) -> Vector2<f64> {
        self.interpolation[i].iter().fold(Vector2::zeros(), |s, &(g, w)| s + Vector2::new(u[2 * g], u[2 * g + 1]) * w)
    }
}

impl ContactInfo {
    /// Global node of each multiplier node (multiplier nodes sit on mortar vertices).
    /// (Stand-in nodes numbered from `VirtualMortar::base` on a virtual mortar side.)
    pub fn multiplier_nodes(&self) -> Vec<usize> {
        let n = self.side.nodes.len();
        self.multipliers
            .chains
            .iter()
            .flat_map(|ch| ch.lm_at.iter().map(|&k| self.side.nodes[ch.vertices[k] % n]))
            .collect()
    }

    /// Displacement in `u` of a mortar-side node (a mesh node, or a virtual side's stand-in).
    pub fn node_displacement(&self, node: usize, u: &[f64]) -> Vector2<f64> {
        match &self.virtual_mortar {
            Some(vm) if node >= vm.base => vm.displacement(node - vm.base, u),
            _ => Vector2::new(u[2 * node], u[2 * node + 1]),
        }
    }
}

/// The other side of a contact pair as the model keeps it.
#[derive(Debug, Clone)]
pub enum PairedSide {
    /// Real edges (global node ids).
    Edges(Vec<[usize; 2]>),
    /// A virtual surface embedded in host body `host`.
    Embedded { host: usize, embedding: Embedding },
}

/// How far the surfaces of a contact pair may slide along each other.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Sliding {
    /// Pairing from the reference geometry (fretting, partial slip: slides well below the
    /// contact width; beyond it a typed `SlidingBeyondPairing` error).
    #[default]
    Small,
    /// Pairing refreshed from the converged configuration at every step (sliding strokes
    /// longer than the contact).
    Finite,
}

/// Every contact pair of a model and its rows: normal rows `g_k = g0_k + rows[k] . u` (one per
/// multiplier node, in pair order), the integral `phi` of each multiplier hat over its paired
/// part, the augmentation `eps` (`eps_n = eps_t`) and Coulomb coefficient `mu` of the node's
/// pair; tangential rows (weighted relative tangential displacement `s_j = s0_j + row . u`),
/// one per node of a frictional pair, and the normal row each belongs to. Multipliers: the
/// model's first `first_multiplier` (ties, rigid sets), then the normals, then the tangents.
#[derive(Debug, Clone, Default)]
pub struct ContactSet {
    pub first_multiplier: usize,
    pub rows: Vec<ConstraintRow>,
    pub g0: Vec<f64>,
    pub phi: Vec<f64>,
    pub eps: Vec<f64>,
    pub mu: Vec<f64>,
    pub friction_rows: Vec<ConstraintRow>,
    pub friction_normal: Vec<usize>,
    /// The weighted tangential row of every normal row (frictionless pairs too): wear reads the
    /// weighted slip increment `tangents[k] . du` of a step from it.
    pub tangents: Vec<ConstraintRow>,
    /// `friction_rows[j] . u` at the pairing (0 for the reference pairing): slides are measured
    /// from it.
    pub friction_s0: Vec<f64>,
    pub pairs: Vec<ContactInfo>,
}

/// Coulomb status of a tangential multiplier in one iteration.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FrictionStatus {
    /// The node is not in contact: `lambda_t = 0`.
    Open,
    /// `|lambda_t_hat| <= -mu lambda_n_hat`: no slip in this step (`ds_t = 0`).
    Stick,
    /// `lambda_t = -mu lambda_n sign(lambda_t_hat)`; `true` for a positive sign.
    Slip(bool),
}

impl FrictionStatus {
    /// The field code of the state and the output: 0 open, 1 stick, 2 slip.
    pub fn code(self) -> u8 {
        match self {
            FrictionStatus::Open => 0,
            FrictionStatus::Stick => 1,
            FrictionStatus::Slip(_) => 2,
        }
    }

    /// The code with the slip's sign, where a solve restarts from the status (the sets a
    /// checkpoint keeps): 0 open, 1 stick, 2 slip along `+t`, 3 slip along `-t`.
    pub fn signed_code(self) -> u8 {
        match self {
            FrictionStatus::Slip(false) => 3,
            s => s.code(),
        }
    }

    /// The status of a [`Self::signed_code`], `None` for another value.
    pub fn from_signed_code(code: u8) -> Option<Self> {
        match code {
            0 => Some(FrictionStatus::Open),
            1 => Some(FrictionStatus::Stick),
            2 => Some(FrictionStatus::Slip(true)),
            3 => Some(FrictionStatus::Slip(false)),
            _ => None,
        }
    }
}

/// The contact sets of a solution: per normal row whether it is in contact, per friction row
/// its Coulomb status (where a later solve of the same increment starts its iteration).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ContactSets {
    pub active: Vec<bool>,
    pub status: Vec<FrictionStatus>,
}

/// What one multiplier row imposes for the current sets.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum RowLaw {
    /// The row's constraint: tie rows `C u = 0`, active normal rows `g = 0`, stick rows `ds = 0`.
    Constraint,
    /// The multiplier vanishes (open node).
    Free,
    /// Coulomb slip: `lambda = coef * lambda_normal` (`coef = -mu sign`), `normal` the row of the
    /// node's normal multiplier.
    Slip { normal: usize, coef: f64 },
}

/// Multiplier rows of the model, in order: ties (and rigid sets), contact normals, friction.
pub fn row_laws(m: &ContactSet, active: &[bool], status: &[FrictionStatus]) -> Vec<RowLaw> {
    let nt = m.first_multiplier;
    let mut v = vec![RowLaw::Constraint; nt];
    v.extend(active.iter().map(|&a| if a { RowLaw::Constraint } else { RowLaw::Free }));
    v.extend(status.iter().enumerate().map(|(j, s)| match s {
        FrictionStatus::Stick => RowLaw::Constraint,
        FrictionStatus::Open => RowLaw::Free,
        FrictionStatus::Slip(pos) => {
            let k = m.friction_normal[j];
            RowLaw::Slip { normal: nt + k, coef: -m.mu[k] * if *pos { 1.0 } else { -1.0 } }
        }
    }));
    v
}

/// Multiplier-block entries of the Coulomb slip rows: (tangential row, its normal row).
pub fn friction_couplings(m: &ContactSet) -> Vec<(usize, usize)> {
    let (nt, nc) = (m.first_multiplier, m.rows.len());
    m.friction_normal.iter().enumerate().map(|(j, &k)| (nt + nc + j, nt + k)).collect()
}

/// Every friction node in contact slips, all in one direction: a load-controlled body held only
/// by friction then has no equilibrium (gross sliding). Returns the number of slipping nodes.
pub fn gross_sliding(status: &[FrictionStatus]) -> Option<usize> {
    let slipping: Vec<bool> =
        status.iter().filter_map(|s| if let FrictionStatus::Slip(d) = s { Some(*d) } else { None }).collect();
    let stick = status.contains(&FrictionStatus::Stick);
    (!stick && !slipping.is_empty() && slipping.iter().all(|&d| d == slipping[0])).then_some(slipping.len())
}

/// Largest slide of a node in contact from its pairing, and the contact width (the sum of
/// `int Phi` over the nodes in contact), over the small-sliding pairs. Small sliding pairs
/// from the reference geometry: a converged state whose nodes slid further than the contact is
/// wide has left its range. (Finite sliding pairs each step in its own end configuration.)
pub fn slide_from_pairing(m: &ContactSet, u: &[f64], status: &[FrictionStatus]) -> Option<(f64, f64)> {
    let small = |k: usize| {
        m.pairs
            .iter()
            .find(|c| (c.first_row..c.first_row + c.multipliers.num_nodes).contains(&k))
            .is_some_and(|c| c.sliding == Sliding::Small)
    };
    let in_contact: Vec<usize> =
        (0..status.len()).filter(|&j| status[j] != FrictionStatus::Open && small(m.friction_normal[j])).collect();
    if in_contact.is_empty() {
        return None;
    }
    let width: f64 = in_contact.iter().map(|&j| m.phi[m.friction_normal[j]]).sum();
    let slide = in_contact
        .iter()
        .map(|&j| {
            let s: f64 = m.friction_rows[j].iter().map(|&(d, c)| c * u[d]).sum::<f64>() - m.friction_s0[j];
            (s / m.phi[m.friction_normal[j]]).abs()
        })
        .fold(0.0, f64::max);
    Some((slide, width))
}

/// Active set and Coulomb statuses of one semi-smooth Newton iteration (see the module
/// documentation). `gaps` are the weighted gaps, `slip` the weighted slip increments of the
/// step, `mult` all multipliers. In the first iteration of a step with nothing active, the
/// closest paired nodes start active so that no body floats. `live` (if given) marks the rows
/// that take part in the solve (the condensed interface set): the others stay open, and the
/// closest rows are sought among the live ones (sought among all, a closest row outside the
/// set left a punch that only contact holds with nothing active, and its solve ran away).
pub fn update_sets(
    m: &ContactSet,
    values: SetValues,
    first_iteration: bool,
    live: Option<&[bool]>,
    active: &mut [bool],
    status: &mut [FrictionStatus],
) {
    let SetValues { mult, gaps, slip, augmentation } = values;
    debug_assert!(augmentation > 0.0, "the augmentation factor must be positive");
    let (nt, nc) = (m.first_multiplier, m.rows.len());
    let is_live = |k: usize| live.is_none_or(|l| l[k]);
    for k in 0..nc {
        let phi = m.phi[k];
        active[k] = is_live(k) && phi > 0.0 && mult[nt + k] + augmentation * m.eps[k] * gaps[k] / phi <= 0.0;
    }
    if first_iteration && !active.iter().any(|&a| a) {
        activate_closest(m, gaps, live, active);
    }
    for (j, st) in status.iter_mut().enumerate() {
        let k = m.friction_normal[j];
        *st = if !active[k] {
            FrictionStatus::Open
        } else {
            let (phi, eps) = (m.phi[k], augmentation * m.eps[k]);
            let lt_hat = mult[nt + nc + j] + eps * slip[j] / phi;
            let ln_hat = mult[nt + k] + eps * gaps[k] / phi;
            if lt_hat.abs() <= m.mu[k] * (-ln_hat).max(0.0) {
                FrictionStatus::Stick
            } else {
                FrictionStatus::Slip(lt_hat > 0.0)
            }
        };
    }
}

/// Activates the paired rows (among the `live` ones, if given) whose gap `gaps[k] / phi[k]` is
/// the smallest: where a body that only contact holds touches first.
pub fn activate_closest(m: &ContactSet, gaps: &[f64], live: Option<&[bool]>, active: &mut [bool]) {
    let gt = |k: usize| gaps[k] / m.phi[k];
    let paired = (0..m.rows.len()).filter(|&k| m.phi[k] > 0.0 && live.is_none_or(|l| l[k]));
    if let Some(gmin) = paired.clone().map(gt).min_by(f64::total_cmp) {
        for k in paired {
            active[k] = gt(k) <= gmin + 1e-6 * gmin.abs() + f64::MIN_POSITIVE;
        }
    }
}

/// Sets given from elsewhere (a step's first solve, the last computed cycle at the same
/// increment), made consistent with this pairing: rows it leaves unpaired are open, friction
/// rows follow their normal row (open where it is open, sticking where it closes).
pub fn given_sets(m: &ContactSet, given: &ContactSets, active: &mut [bool], status: &mut [FrictionStatus]) {
    for (k, a) in active.iter_mut().enumerate() {
        *a = given.active[k] && m.phi[k] > 0.0;
    }
    for (j, st) in status.iter_mut().enumerate() {
        *st = match given.status[j] {
            _ if !active[m.friction_normal[j]] => FrictionStatus::Open,
            FrictionStatus::Open => FrictionStatus::Stick,
            given => given,
        };
    }
}

/// Sets the multipliers of open contact nodes (normal and tangential) to exactly zero.
pub fn zero_open_multipliers(m: &ContactSet, mult: &mut [f64], active: &[bool], status: &[FrictionStatus]) {
    let (nt, nc) = (m.first_multiplier, m.rows.len());
    for (k, _) in active.iter().enumerate().filter(|(_, a)| !**a) {
        mult[nt + k] = 0.0;
    }
    for (j, _) in status.iter().enumerate().filter(|(_, s)| **s == FrictionStatus::Open) {
        mult[nt + nc + j] = 0.0;
    }
}

/// The weighted-gap and slip rows of a pair for the other side's current geometry: `x` maps
/// a global node to where the pair is paired (reference coordinates for small sliding, the
/// converged configuration for finite sliding). The one routine for the first pairing, the
/// re-pairing of finite sliding and the rows of a surface that moved.
/// `hosts[b]` is body `b`'s mesh and node offset (the host of a virtual other side).
pub fn pair_rows(hosts: &[(&Mesh2, usize)], c: &ContactInfo, x: &dyn Fn(usize) -> Point2<f64>) -> Vec<ContactRow> {
    let rows = with_pairing(hosts, c, x, &mut |side, other| weighted_gaps(side, &c.multipliers, other, c.max_gap));
    match &c.virtual_mortar {
        None => rows,
        Some(vm) => {
            let mut slot = Vec::new();
            rows.into_iter()
                .map(|r| ContactRow {
                    normal: vm.expand(r.normal, &mut slot),
                    tangent: vm.expand(r.tangent, &mut slot),
                    ..r
                })
                .collect()
        }
    }
}

/// The mortar integration points of a pair in the configuration `x` (as [`pair_rows`] pairs
/// them): where wear is integrated.
pub fn paired_points(
    hosts: &[(&Mesh2, usize)],
    c: &ContactInfo,
    x: &dyn Fn(usize) -> Point2<f64>,
    rows: Option<&[bool]>,
) -> Vec<crate::mortar::PairedPoint> {
    with_pairing(hosts, c, x, &mut |side, other| {
        crate::mortar::paired_points(side, &c.multipliers, other, c.max_gap, rows)
    })
}

/// Calls `f` with the pair's mortar side and other side placed by `x`.
fn with_pairing<T>(
    hosts: &[(&Mesh2, usize)],
    c: &ContactInfo,
    x: &dyn Fn(usize) -> Point2<f64>,
    f: &mut dyn FnMut(&crate::mortar::MortarSide, &OtherSide) -> T,
) -> T {
    // A virtual side's vertices sit where their host cells put them.
    let place = |n: usize| match &c.virtual_mortar {
        Some(vm) if n >= vm.base => {
            vm.interpolation[n - vm.base].iter().fold(Point2::origin(), |s, &(g, w)| s + x(g).coords * w)
        }
        _ => x(n),
    };
    let side = crate::mortar::MortarSide {
        nodes: c.side.nodes.clone(),
        points: c.side.nodes.iter().map(|&n| place(n)).collect(),
        closed: c.side.closed,
    };
    match &c.other {
        PairedSide::Edges(edges) => {
            let pts: Vec<[Point2<f64>; 2]> = edges.iter().map(|e| [x(e[0]), x(e[1])]).collect();
            f(&side, &OtherSide::Edges { nodes: edges, points: &pts })
        }
        PairedSide::Embedded { host, embedding } => {
            let (mesh, node_offset) = hosts[*host];
            // Only the nodes of the cells the surface crosses are placed (the pairing reads no
            // others).
            let mut coords = vec![Point2::origin(); mesh.nodes.len()];
            for piece in &embedding.pieces {
                for &n in mesh.cells[piece.cell].nodes() {
                    coords[n] = x(node_offset + n);
                }
            }
            // A virtual surface moves with its host through its host reference coordinates
            // (the pairing reads its pieces only).
            let mut e = Embedding {
                cell_pieces: Vec::new(),
                pieces: embedding.pieces.clone(),
                vertices: Vec::new(),
                closed: embedding.closed,
            };
            for piece in e.pieces.iter_mut() {
                let corners = crate::mortar::cell_coords_at(mesh, &coords, piece.cell);
                let mapped = crate::fem::element::MappedElement::new(mesh.cells[piece.cell].kind, corners);
                piece.a = mapped.map(piece.xi_a);
                piece.b = mapped.map(piece.xi_b);
            }
            f(&side, &OtherSide::Embedded { host: mesh, coords: &coords, host_offset: node_offset, embedding: &e })
        }
    }
}

/// Writes a pair's rows into the model: `g0 = g_x - C_x u_pair` keeps the gaps linear in the
/// total displacement when the rows were paired in the displaced configuration `X + u_pair`,
/// and `s0 = T_x u_start` measures the step's slips from its start (zero displacements: the
/// reference pairing).
pub fn install_rows(m: &mut ContactSet, pair: usize, rows: Vec<ContactRow>, u_pair: &[f64], u_start: &[f64]) {
    let (first, friction_row) = (m.pairs[pair].first_row, m.pairs[pair].friction_row.clone());
    for (l, r) in rows.into_iter().enumerate() {
        let k = first + l;
        let cu: f64 = r.normal.iter().map(|&(d, v)| v * u_pair[d]).sum();
        m.g0[k] = r.g0 - cu;
        m.phi[k] = r.phi;
        m.rows[k] = r.normal;
        m.tangents[k] = r.tangent.clone();
        if let Some(j) = friction_row[l] {
            m.friction_s0[j] = r.tangent.iter().map(|&(d, v)| v * u_start[d]).sum();
            m.friction_rows[j] = r.tangent;
        }
    }
}

/// One multiplier node of a contact pair in a state: what output, post-processing and wear read.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactNodeState {
    /// Global mesh node carrying the multiplier (a mortar-side vertex).
    pub node: usize,
    /// Reference and current position.
    pub reference: Point2<f64>,
    pub position: Point2<f64>,
    /// Contact pressure `p = -lambda_n` (>= 0 in contact).
    pub pressure: f64,
    /// Shear `lambda_t` along `t = n` turned +90 degrees (`n` the mortar side's outward normal);
    /// 0 when frictionless.
    pub shear: f64,
    /// The nodal traction of the pressure and of the shear: each node's contact force over its
    /// hat's measure (see [`crate::mortar::Multipliers::nodal_traction`]), what the node
    /// transmits where the coefficients `pressure`, `shear` undershoot beside a concentrated load.
    pub nodal_pressure: f64,
    pub nodal_shear: f64,
    /// Slip of the last increment and accumulated slip, as lengths (weighted slips over
    /// `int Phi`); 0 for unpaired or frictionless nodes.
    pub slip: f64,
    pub accumulated_slip: f64,
    /// Weighted gap over `int Phi` (a length; 0 in contact, positive open; `f64::INFINITY`
    /// for a node that is not paired).
    pub gap: f64,
    /// `int Phi` of the node's hat over its paired part (0: not paired).
    pub phi: f64,
    /// Coulomb status of the last increment (frictionless pairs have none: `Open`).
    pub status: FrictionStatus,
    /// Pressing on the other surface (positive pressure, or a Coulomb status other than open).
    pub in_contact: bool,
}

/// The unknowns a contact field is read from (borrowed from the simulation state):
/// displacements, multipliers in the model's order, and per friction row the Coulomb status
/// (0 open, 1 stick, 2 slip), the weighted slip of the last increment and the accumulated slip.
#[derive(Debug, Clone, Copy)]
pub struct ContactUnknowns<'a> {
    pub u: &'a [f64],
    pub multipliers: &'a [f64],
    pub friction_status: &'a [u8],
    pub slip_increment: &'a [f64],
    pub accumulated_slip: &'a [f64],
}

/// The per-node contact field of pair `pair`, in multiplier order.
pub fn contact_field(m: &ContactSet, state: &ContactUnknowns<'_>, pair: usize) -> Vec<ContactNodeState> {
    let c = &m.pairs[pair];
    let (nt, nn) = (m.first_multiplier, m.rows.len());
    let nodes = c.multiplier_nodes();
    let n_lm = c.multipliers.num_nodes;
    let pressures: Vec<f64> = (0..n_lm).map(|l| -state.multipliers[nt + c.first_row + l]).collect();
    let shears: Vec<f64> =
        (0..n_lm).map(|l| c.friction_row[l].map_or(0.0, |j| state.multipliers[nt + nn + j])).collect();
    let (nodal_pressure, nodal_shear) =
        (c.multipliers.nodal_traction(&pressures), c.multipliers.nodal_traction(&shears));
    (0..n_lm)
        .map(|l| {
            let k = c.first_row + l;
            let n = nodes[l];
            let reference = c.multipliers.points[l];
            let position = reference + c.node_displacement(n, &state.u);
            let phi = m.phi[k];
            let per_length = |v: f64| if phi > 0.0 { v / phi } else { 0.0 };
            let gap = if phi > 0.0 {
                (m.g0[k] + m.rows[k].iter().map(|&(d, v)| v * state.u[d]).sum::<f64>()) / phi
            } else {
                f64::INFINITY
            };
            let pressure = -state.multipliers[nt + k];
            let (shear, slip, accumulated_slip, status) = match c.friction_row[l] {
                Some(j) => (
                    state.multipliers[nt + nn + j],
                    per_length(state.slip_increment[j]),
                    per_length(state.accumulated_slip[j]),
                    match state.friction_status[j] {
                        1 => FrictionStatus::Stick,
                        2 => FrictionStatus::Slip(state.multipliers[nt + nn + j] > 0.0),
                        _ => FrictionStatus::Open,
                    },
                ),
                None => (0.0, 0.0, 0.0, FrictionStatus::Open),
            };
            let in_contact = pressure > 0.0 || status != FrictionStatus::Open;
            ContactNodeState {
                node: n,
                reference,
                position,
                pressure,
                shear,
                nodal_pressure: nodal_pressure[l],
                nodal_shear: nodal_shear[l],
                slip,
                accumulated_slip,
                gap,
                phi,
                status,
                in_contact,
            }
        })
        .collect()
}

/// What one active-set update decides from: all multipliers, the weighted gaps of the contact
/// rows and the weighted slip increments of the friction rows, and the factor on each node's
/// augmentation `eps` (1: the contact's own). The factor steers which set comes next, not
/// where the iteration stops: a converged set satisfies the law for any `eps > 0`.
#[derive(Clone, Copy)]
pub struct SetValues<'a> {
    pub mult: &'a [f64],
    pub gaps: &'a [f64],
    pub slip: &'a [f64],
    pub augmentation: f64,
}
