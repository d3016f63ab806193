//! Case files: TOML read with serde into plain data (`deny_unknown_fields`), then validated
//! once into a typed [`Model`]. Every error names the file, the key and what is wrong.
//!
//! Units are the user's, consistent; the shipped cases use mm, N, MPa (so stiffness in MPa,
//! pressure in MPa, forces in N, distributed loads in N/mm, plane-strain forces per mm of depth).
//! `problem.units` says which system the numbers are in, for what the command line prints.
//!
//! ```toml
//! [problem]
//! hypothesis = "plane_strain"          # or "plane_stress"
//! units = "mm"                         # mm, N, MPa (default); or "m": m, N, Pa
//!
//! [[materials]]
//! name = "steel"
//! model = "elastic"                    # or "j2_plastic" (plane strain only)
//! young = 210000.0
//! poisson = 0.3
//!
//! [[bodies]]
//! name = "block"
//! material = "steel"
//! mesh = { type = "rectangle", origin = [0.0, 0.0], size = [10.0, 2.0], divisions = [20, 4] }
//!
//! [[bcs]]
//! body = "block"
//! set = "left"
//! ux = 0.0
//! uy = 0.0
//!
//! [[loads]]
//! body = "block"
//! set = "right"
//! traction = [0.0, -1.0]
//!
//! [steps]
//! path = [[0.0, 0.0], [1.0, 1.0]]      # (pseudo-time, load factor)
//! increments = 4
//! ```

use crate::fem::kernel::Formulation;
use crate::fem::material::{Elastic, J2Plastic, Material, PlaneHypothesis};
use crate::mesh::{generate, gmsh, CellKind, Mesh2};
use crate::model::Num;
use crate::model::{ContactOther, LoadPath, Model, ModelBuilder, ModelError};
use crate::mortar::MultiplierSpace;
use crate::solver::linear::LinearSolverKind;
use crate::solver::newton::NewtonParams;
use nalgebra::{Point2, Vector2};
use serde::Deserialize;
use std::path::{Path, PathBuf};

#[derive(Debug, thiserror::Error)]
pub enum CaseError {
    #[error("{path}: cannot read case file: {source}")]
    Io { path: String, source: std::io::Error },
    #[error("{path}: invalid TOML: {message}")]
    Toml { path: String, message: String },
    /// Valid TOML that does not fit the case format (an unknown key, a wrong type).
    #[error("{path}: not a valid case (the TOML itself reads): {message}")]
    Format { path: String, message: String },
    #[error("{path}: key '{key}': {message}")]
    Invalid { path: String, key: String, message: String },
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CaseFile {
    pub problem: ProblemSpec,
    pub materials: Vec<MaterialSpec>,
    pub bodies: Vec<BodySpec>,
    #[serde(default)]
    pub bcs: Vec<BcSpec>,
    #[serde(default)]
    pub loads: Vec<LoadSpec>,
    /// Named load curves beyond `steps.path` (for loads with their own history).
    #[serde(default)]
    pub curves: Vec<CurveSpec>,
    #[serde(default)]
    pub steps: StepsSpec,
    #[serde(default)]
    pub solver: SolverSpec,
    #[serde(default)]
    pub output: OutputSpec,
    #[serde(default)]
    pub ties: Vec<TieSpec>,
    #[serde(default)]
    pub cuts: Vec<CutSpec>,
    #[serde(default)]
    pub contacts: Vec<ContactSpec>,
    /// Rigid sets (platens): the nodes of the set move as one translation.
    #[serde(default)]
    pub rigid: Vec<RigidSpec>,
    /// Wearing surfaces (cuts that are the other side of a contact pair).
    #[serde(default)]
    pub wear: Vec<WearSpec>,
    /// Cycle jump of wear runs (default: adaptive).
    pub cycle_jump: Option<CycleJumpSpec>,
    /// The analytical solution of the case's contact, written to the result file and drawn by
    /// `mortex plot` beside the computed profile.
    pub reference: Option<ReferenceSpec>,
    /// Fatigue followed at the material points of one body through a wear run's cycles.
    pub fatigue: Option<FatigueSpec>,
}

/// `[fatigue]`: the SWT critical plane and Miner damage at the Gauss points of `body`'s cells
/// in the box `region = [[xmin, ymin], [xmax, ymax]]` (default: the whole body), with the
/// Basquin-Coffin-Manson constants `sigma_f` (`sigma_f'`, a stress), `b`, `eps_f` (`eps_f'`),
/// `c`; `E` is the body's.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FatigueSpec {
    pub body: String,
    pub region: Option<[[f64; 2]; 2]>,
    pub sigma_f: f64,
    pub b: f64,
    pub eps_f: f64,
    pub c: f64,
    /// End the run after the computed cycle in which a point's damage reaches 1.
    #[serde(default)]
    pub stop_at_initiation: bool,
}

/// `[reference]`: Hertz line contact (`kind = "hertz"`: effective `radius`, normal `load` per
/// unit thickness) or Cattaneo-Mindlin partial slip (`"cattaneo_mindlin"`, also the
/// `tangential` force below `mu load`, `mu` the contact's friction, and a `bulk` stress of the
/// lower body in phase with it), centred at `centre` (default: the computed contact's pressure
/// centroid), for `contact` (a `[[contacts]]` name; default the first). The contact modulus
/// follows from the two bodies' materials.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ReferenceSpec {
    pub kind: ReferenceKind,
    pub contact: Option<String>,
    pub radius: f64,
    pub load: f64,
    pub tangential: Option<f64>,
    /// Centre of the contact along x (default: the computed contact's pressure centroid).
    pub centre: Option<f64>,
    /// Cattaneo-Mindlin: bulk stress of the lower body in phase with the tangential force
    /// (Nowell-Hills stick-zone offset; default 0).
    pub bulk: Option<f64>,
}

#[derive(Debug, Clone, Copy, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum ReferenceKind {
    Hertz,
    CattaneoMindlin,
}

/// A wearing surface: `cut` (a `[[cuts]]` name, the other side of a contact pair), the wear
/// `coefficient` (Archard `k` or energy `alpha`, 1/pressure), `law` and `max_depth`, the deepest
/// wear the host is prepared for (its band of fixed points).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WearSpec {
    /// A cut, or a real boundary (`body` and its edge sets `surface`, turned into a cut
    /// coinciding with it, named `<body>.<set>`).
    pub cut: Option<String>,
    pub body: Option<String>,
    pub surface: Option<Vec<String>>,
    pub coefficient: f64,
    #[serde(default)]
    pub law: crate::wear::WearLaw,
    pub max_depth: f64,
}

/// `fixed = dN` for a fixed jump, otherwise adaptive with `depth_fraction` (default 0.1) of the
/// worn surface's resolution per jump and at most `max_jump` cycles per jump.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CycleJumpSpec {
    pub fixed: Option<u64>,
    /// Wear-rate smoothing length in segments of the worn polyline (default 1; 0: none).
    pub smoothing: Option<f64>,
    pub depth_fraction: Option<f64>,
    pub max_jump: Option<u64>,
    /// Adaptive jumps with the implicit scheme: largest pressure change per jump relative to
    /// the peak pressure (default 0.2).
    pub pressure_change: Option<f64>,
    /// Adaptive jumps with the implicit scheme: largest relative error of a jump's predicted
    /// worn-area rate (each surface) against the next computed cycle's (default 0.01).
    pub prediction_tolerance: Option<f64>,
    /// "implicit" (default: linearised backward Euler, stable for any jump) or "explicit".
    pub scheme: Option<crate::wear::JumpScheme>,
    /// Yielding bodies: largest net equivalent plastic strain a jump may drop at a point (`dN`
    /// times that of the last computed cycle; default 1e-4). A body that ratchets more than
    /// this per cycle is computed cycle by cycle.
    pub ratcheting_tolerance: Option<f64>,
    /// Adaptive jumps with the implicit scheme: smallest fraction of a computed cycle's wear one
    /// update applies when a whole cycle's would change the pressure by more than
    /// `pressure_change` (default 1: whole cycles only; 1/256 a good floor for accelerated
    /// coefficients).
    pub min_fraction: Option<f64>,
}

/// A rigid set: the nodes of a node or edge set move together (no rotation); load it with a
/// `total_force` on the same set.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RigidSpec {
    pub body: String,
    pub set: String,
}

/// Mortar contact (small sliding): the `mortar` body's surface carries the contact pressure
/// and shear; the other surface is the `other` body's edge sets or the virtual surface of a
/// named `[[cuts]]` entry in it.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ContactSpec {
    pub name: Option<String>,
    pub mortar: String,
    #[serde(default)]
    pub mortar_surface: Vec<String>,
    /// Instead of `mortar_surface`: a cut of the mortar body (its virtual surface carries the
    /// multipliers).
    pub mortar_cut: Option<String>,
    pub other: String,
    pub other_surface: Option<Vec<String>>,
    pub other_cut: Option<String>,
    /// Coulomb coefficient (default 0: frictionless, no tangential unknowns).
    #[serde(default)]
    pub friction: f64,
    /// Multiplier space on the mortar surface (default coarse-grained: spaced like the other
    /// side's elements where the mortar side is finer, classical elsewhere).
    pub multipliers: Option<MultiplierSpace>,
    /// "small" (pairing from the reference geometry) or "finite" (every step paired in its own
    /// end configuration). Default: finite for a pair that wears and whose prescribed stroke
    /// (peak to peak) exceeds half its surfaces' smallest element, small otherwise (see
    /// [`default_sliding`]).
    pub sliding: Option<crate::model::Sliding>,
}

/// A free virtual surface cutting a body's mesh (X-FEM): the body keeps its material on one
/// side; the surface is traction-free.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CutSpec {
    pub name: Option<String>,
    pub body: String,
    /// Polyline vertices (reference coordinates).
    pub points: Vec<[f64; 2]>,
    #[serde(default)]
    pub closed: bool,
    /// Side of the polyline (walking from the first point) on which material is kept.
    #[serde(default)]
    pub keep: KeepSide,
    /// Prescribed motion during the run: the surface moves through its host, re-cut on fixed
    /// integration points (no remeshing).
    pub motion: Option<MotionSpec>,
}

/// Motion of a virtual surface: `translation = [dx, dy]` or `offset = d` (along the normal
/// into the kept material; negative: outwards), scaled by a load curve.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MotionSpec {
    pub translation: Option<[f64; 2]>,
    pub offset: Option<f64>,
    /// Load curve scaling the motion (default: `steps.path`).
    pub curve: Option<String>,
}

#[derive(Debug, Clone, Copy, Deserialize, PartialEq, Eq, Default)]
#[serde(rename_all = "snake_case")]
pub enum KeepSide {
    #[default]
    Left,
    Right,
}

/// A mortar tie: the patch body's boundary (edge sets forming one closed loop) is embedded in the
/// host body as a virtual surface; the host material inside it is cut away. With
/// `host_surface`, the patch boundary (any polyline) is tied to a coinciding real surface of the
/// host instead (classical mortar). The patch side carries the multipliers.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TieSpec {
    pub name: Option<String>,
    pub host: String,
    pub patch: String,
    pub boundary: Vec<String>,
    /// Edge sets of the host forming a real surface that coincides with the patch boundary:
    /// classical mortar between two real surfaces instead of an embedded one.
    pub host_surface: Option<Vec<String>>,
    #[serde(default)]
    pub multipliers: MultiplierSpace,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ProblemSpec {
    pub hypothesis: PlaneHypothesis,
    #[serde(default)]
    pub description: String,
    #[serde(default)]
    pub units: Units,
}

/// The case's consistent unit system, for what the command line prints (the engine itself is
/// unit-free): lengths in mm with stresses in MPa (N, mm, MPa: the default), or SI (m, N, Pa).
#[derive(Debug, Clone, Copy, Deserialize, PartialEq, Eq, Default)]
pub enum Units {
    #[default]
    #[serde(rename = "mm")]
    Millimetre,
    #[serde(rename = "m")]
    Metre,
}

impl Units {
    /// A length with the unit that reads best (nm to m), four significant digits.
    pub fn length(self, v: f64) -> String {
        let metres = v * if self == Units::Millimetre { 1e-3 } else { 1.0 };
        let (scale, unit) = match metres.abs() {
            a if a >= 1.0 => (1.0, "m"),
            a if a >= 1e-3 => (1e3, "mm"),
            a if a >= 1e-6 || a == 0.0 => (1e6, "µm"),
            _ => (1e9, "nm"),
        };
        format!("{} {unit}", significant(metres * scale))
    }

    /// A stress with the unit that reads best (Pa to GPa), four significant digits.
    pub fn stress(self, v: f64) -> String {
        let pascal = v * if self == Units::Millimetre { 1e6 } else { 1.0 };
        let (scale, unit) = match pascal.abs() {
            a if a >= 1e9 => (1e-9, "GPa"),
            a if a >= 1e6 => (1e-6, "MPa"),
            a if a >= 1e3 => (1e-3, "kPa"),
            _ => (1.0, "Pa"),
        };
        format!("{} {unit}", significant(pascal * scale))
    }
}

/// `v` with four significant digits, without trailing zeros.
fn significant(v: f64) -> String {
    let digits = if v == 0.0 { 0 } else { (3 - v.abs().log10().floor() as i32).max(0) as usize };
    let s = format!("{v:.digits$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

#[derive(Debug, Clone, Copy, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum MaterialModel {
    Elastic,
    J2Plastic,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MaterialSpec {
    pub name: String,
    pub model: MaterialModel,
    pub young: f64,
    pub poisson: f64,
    pub yield_stress: Option<f64>,
    #[serde(default)]
    pub isotropic_hardening: f64,
    #[serde(default)]
    pub kinematic_hardening: f64,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BodySpec {
    pub name: String,
    pub material: String,
    pub mesh: MeshSpec,
    pub thickness: Option<f64>,
    pub formulation: Option<Formulation>,
}

#[derive(Debug, Clone, Copy, Deserialize, PartialEq, Eq, Default)]
#[serde(rename_all = "snake_case")]
pub enum CellSpec {
    #[default]
    Quad4,
    Tri3,
}

/// A uniform fine zone in the middle of a generated mesh direction (see `MeshSpec`).
#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FineZone {
    /// Length of the zone (arc length on a half disc).
    pub width: f64,
    /// Divisions inside the zone (even on a half disc, so that its lowest point is a node).
    pub divisions: usize,
}

/// Grid coordinates in [0, 1] with the fine zone `zone` (relative width `fraction`) in the middle
/// of `n` divisions.
fn fine_zone_lines(zone: &FineZone, fraction: f64, n: usize, what: &str) -> Result<Vec<f64>, String> {
    if !(zone.width > 0.0 && fraction > 0.0 && fraction < 1.0) {
        return Err(format!("fine_zone.width must be positive and less than the {what} (got {})", Num(zone.width)));
    }
    if zone.divisions == 0 || zone.divisions + 2 > n {
        return Err(format!(
            "fine_zone.divisions must be at least 1 and leave at least one division on each side of the {} \
             divisions (got {})",
            n, zone.divisions
        ));
    }
    let side = (n - zone.divisions) / 2;
    Ok(generate::plateau_graded(zone.divisions, fraction, side))
}

fn one() -> f64 {
    1.0
}
fn ones() -> [f64; 2] {
    [1.0, 1.0]
}

#[derive(Debug, Clone, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum MeshSpec {
    Rectangle {
        #[serde(default)]
        origin: [f64; 2],
        size: [f64; 2],
        divisions: [usize; 2],
        #[serde(default = "ones")]
        grading: [f64; 2],
        #[serde(default)]
        cell: CellSpec,
        /// Rotation in degrees about `origin` (counter-clockwise).
        #[serde(default)]
        rotation: f64,
        /// Refine toward the middle instead of one end, per direction: `grading` is then the
        /// spacing ratio end/middle (e.g. a block refined under a contact).
        #[serde(default)]
        refine_to_centre: [bool; 2],
        /// A uniform fine zone centred in x (a contact zone resolved evenly, e.g. a fretting
        /// scar): `fine_zone.divisions` of the x divisions over `fine_zone.width`, the rest
        /// growing geometrically toward both ends (replaces `grading[0]`).
        fine_zone: Option<FineZone>,
    },
    Disc {
        centre: [f64; 2],
        radius: f64,
        /// Rings and sectors.
        divisions: [usize; 2],
    },
    AnnulusSector {
        inner_radius: f64,
        outer_radius: f64,
        /// Start and end angle in degrees.
        angles: [f64; 2],
        divisions: [usize; 2],
        #[serde(default = "one")]
        radial_grading: f64,
    },
    HalfDisc {
        centre: [f64; 2],
        radius: f64,
        divisions: [usize; 2],
        #[serde(default = "one")]
        radial_grading: f64,
        #[serde(default = "one")]
        angular_grading: f64,
        /// Turned by 180 degrees about the centre (arc on top: the lower body of a pair).
        #[serde(default)]
        upside_down: bool,
        /// A uniform fine zone of the arc centred on its lowest point: `fine_zone.divisions` of
        /// the angular divisions over the arc length `fine_zone.width`, the rest growing
        /// geometrically toward the flat side (replaces `angular_grading`).
        fine_zone: Option<FineZone>,
    },
    Gmsh {
        /// Path of a MSH 4.1 ASCII file, relative to the case file.
        file: PathBuf,
    },
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BcSpec {
    pub body: String,
    pub set: String,
    pub ux: Option<f64>,
    pub uy: Option<f64>,
    /// Load curve scaling the values (default: `steps.path`).
    pub curve: Option<String>,
}

/// A piecewise-linear load curve `[[time, factor], ...]`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CurveSpec {
    pub name: String,
    pub path: Vec<[f64; 2]>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LoadSpec {
    pub body: String,
    pub set: String,
    /// Uniform pressure on an edge set (positive pushes into the body).
    pub pressure: Option<f64>,
    /// Traction vector on an edge set (force per unit length): uniform, or its value at the
    /// origin when `traction_gradient` is given.
    pub traction: Option<[f64; 2]>,
    /// `[[dtx/dx, dtx/dy], [dty/dx, dty/dy]]`: the traction varies linearly in space,
    /// `t(x) = traction + G x` (reference positions).
    pub traction_gradient: Option<[[f64; 2]; 2]>,
    /// Force applied at every node of a node set.
    pub force: Option<[f64; 2]>,
    /// Resultant force applied at the set's first node (for rigid sets, whose nodes move
    /// together: the force on the platen).
    pub total_force: Option<[f64; 2]>,
    /// Load curve scaling the load (default: `steps.path`).
    pub curve: Option<String>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StepsSpec {
    #[serde(default = "default_path")]
    pub path: Vec<[f64; 2]>,
    /// Equally spaced output steps over the whole path (ignored if `times` is given).
    #[serde(default = "default_increments")]
    pub increments: usize,
    /// Explicit output times.
    pub times: Option<Vec<f64>>,
    /// Cyclic history: the window `[start, end]` of the history repeats `cycles` times with
    /// `increments` output steps per cycle; before `start`, `ramp_increments` steps (default 1).
    pub cycle: Option<[f64; 2]>,
    pub cycles: Option<usize>,
    pub ramp_increments: Option<usize>,
}

fn default_path() -> Vec<[f64; 2]> {
    vec![[0.0, 0.0], [1.0, 1.0]]
}
fn default_increments() -> usize {
    1
}
impl Default for StepsSpec {
    fn default() -> Self {
        StepsSpec { path: default_path(), increments: 1, times: None, cycle: None, cycles: None, ramp_increments: None }
    }
}

#[derive(Debug, Clone, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct SolverSpec {
    #[serde(default)]
    pub linear: LinearSolverKind,
    #[serde(default)]
    pub newton: NewtonParams,
    /// Serial element loop (default: parallel).
    #[serde(default)]
    pub serial: bool,
    /// Ghost-penalty factor on cut bodies (default 0.05; 0 switches it off).
    pub ghost_penalty: Option<f64>,
}

#[derive(Debug, Clone, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct OutputSpec {
    /// Output HDF5 file (relative to the working directory); default `results/<case>.h5`.
    pub file: Option<PathBuf>,
    /// A checkpoint (the whole state, for `mortex run --restart`) every this many output steps;
    /// default 1, 0 for none.
    pub checkpoint_every: Option<usize>,
    /// The last this many checkpoints are kept (older ones are removed as new ones are
    /// written, and their space reused: a long run's file stays bounded); default
    /// [`DEFAULT_KEEP_CHECKPOINTS`], 0 keeps every one.
    pub keep_checkpoints: Option<usize>,
    /// Full fields (nodal, cell and point fields) every this many output steps (default 1; the
    /// last step always has them). Contact and surface series are written every step.
    pub fields_every: Option<usize>,
}

/// A validated case: the model plus run options.
pub struct Case {
    pub name: String,
    /// The unit system the case's numbers are in (for printing).
    pub units: Units,
    pub source: PathBuf,
    pub model: Model,
    pub output: PathBuf,
    pub serial: bool,
    /// Checkpoint interval in output steps (0: none).
    pub checkpoint_every: usize,
    /// Checkpoints kept (the last ones; 0: all).
    pub keep_checkpoints: usize,
    /// Names of the contact pairs whose `sliding` the case sets (the others take the default).
    pub sliding_set: Vec<String>,
    /// Full-field interval in output steps (>= 1).
    pub fields_every: usize,
    /// `[reference]`: the contact pair's name and its analytical solution.
    pub reference: Option<(String, crate::post::AnalyticContact)>,
}

/// Checkpoints a run keeps when its case does not say (`[output] keep_checkpoints`).
pub const DEFAULT_KEEP_CHECKPOINTS: usize = 10;

/// Contact multipliers when a case does not choose: coarse-grained, never finer than the other
/// side's elements (equal to the classical space where the mortar side is at most 1.5x finer):
/// classical multipliers on a finer side oscillate and stop converging under refinement.
pub const DEFAULT_CONTACT_MULTIPLIERS: MultiplierSpace = MultiplierSpace::CoarseGrained;

/// Largest number of output steps a case may ask for (each is a group in the result file).
pub const MAX_OUTPUT_STEPS: usize = 10_000_000;
/// Largest number of cells a generated mesh may have (about 2 GB of model data).
pub const MAX_GENERATED_CELLS: usize = 20_000_000;

struct Ctx<'a> {
    path: &'a str,
}

impl Ctx<'_> {
    fn err(&self, key: impl Into<String>, message: impl Into<String>) -> CaseError {
        CaseError::Invalid { path: self.path.to_string(), key: key.into(), message: message.into() }
    }
    fn finite(&self, key: &str, v: f64) -> Result<f64, CaseError> {
        if v.is_finite() {
            Ok(v)
        } else {
            Err(self.err(key, format!("must be a finite number, got {}", Num(v))))
        }
    }
    fn positive(&self, key: &str, v: f64) -> Result<f64, CaseError> {
        if v.is_finite() && v > 0.0 {
            Ok(v)
        } else {
            Err(self.err(key, format!("must be positive and finite, got {}", Num(v))))
        }
    }
}

/// Reads and validates a case file.
pub fn load(path: &Path) -> Result<Case, CaseError> {
    let p = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|e| CaseError::Io { path: p.clone(), source: e })?;
    let base = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let name = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "case".into());
    parse(&text, &p, &base, &name)
}

/// The pairing of a contact whose case does not choose one: finite sliding when the pair wears
/// and its prescribed stroke (peak to peak) is more than half its surfaces' smallest element
/// `h`: the scar is then swept by the stroke, which the reference pairing of small sliding
/// cannot follow (it pairs each material point with the one it met first). Small sliding
/// otherwise (no wear, partial slip under a tangential force, strokes within an element).
pub fn default_sliding(wears: bool, stroke: f64, h: f64) -> crate::model::Sliding {
    if wears && stroke > 0.5 * h {
        crate::model::Sliding::Finite
    } else {
        crate::model::Sliding::Small
    }
}

/// Smallest element of a contact's real (edge-set) surfaces; infinite if it has none.
fn real_surface_spacing(b: &ModelBuilder, c: &ContactSpec) -> f64 {
    let mut h = f64::INFINITY;
    for (body, sets) in [(&c.mortar, Some(&c.mortar_surface)), (&c.other, c.other_surface.as_ref())] {
        if let (Ok(bi), Some(sets)) = (b.body_index(body), sets) {
            h = h.min(b.smallest_edge(bi, sets).unwrap_or(f64::INFINITY));
        }
    }
    h
}

/// [`default_sliding`] for contact `c` (after worn boundaries became cuts): whether it wears,
/// its prescribed stroke, and its smallest element (`h_real` of its real surfaces, or the
/// vertex spacing of its cuts).
fn scene_sliding(raw: &CaseFile, c: &ContactSpec, h_real: f64, wear_cuts: &[String]) -> crate::model::Sliding {
    let wears = [&c.mortar_cut, &c.other_cut].into_iter().flatten().any(|cut| wear_cuts.contains(cut));
    let mut h = h_real;
    for cs in &raw.cuts {
        let named = |n: &Option<String>| n.as_ref() == cs.name.as_ref();
        if named(&c.mortar_cut) || named(&c.other_cut) {
            let spacing = cs.points.windows(2).map(|w| f64::hypot(w[1][0] - w[0][0], w[1][1] - w[0][1]));
            h = h.min(spacing.fold(f64::INFINITY, f64::min));
        }
    }
    default_sliding(wears, prescribed_stroke(raw, &[&c.mortar, &c.other]), h)
}

/// Largest peak-to-peak range of a displacement prescribed on the named bodies (the value times
/// the range of its load curve); 0 where none is prescribed.
fn prescribed_stroke(raw: &CaseFile, bodies: &[&String]) -> f64 {
    let range = |curve: &Option<String>| -> f64 {
        let path: Vec<f64> = match curve {
            None => raw.steps.path.iter().map(|p| p[1]).collect(),
            Some(n) => {
                raw.curves.iter().find(|c| &c.name == n).map_or(vec![], |c| c.path.iter().map(|p| p[1]).collect())
            }
        };
        let (lo, hi) = path.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
        if hi >= lo {
            (hi - lo).abs()
        } else {
            0.0
        }
    };
    raw.bcs
        .iter()
        .filter(|bc| bodies.contains(&&bc.body))
        .flat_map(|bc| [bc.ux, bc.uy].into_iter().flatten().map(|v| (v * range(&bc.curve)).abs()))
        .filter(|v| v.is_finite())
        .fold(0.0, f64::max)
}

/// Parses and validates case text; `path` names the file in errors, relative mesh files are
/// resolved against `base`.
pub fn parse(text: &str, path: &str, base: &Path, name: &str) -> Result<Case, CaseError> {
    parse_with_nodes(text, path, base, name, &[])
}

/// [`parse`], with the nodes of the named bodies at given coordinates (same mesh topology; the
/// node-relocation baseline moves them, see [`crate::relocation`]). A body whose node count
/// differs, or whose moved mesh inverts a cell, is an error naming the body.
pub fn parse_with_nodes(
    text: &str,
    path: &str,
    base: &Path,
    name: &str,
    nodes: &[(String, Vec<Point2<f64>>)],
) -> Result<Case, CaseError> {
    let mut raw: CaseFile = toml::from_str(text).map_err(|e| {
        let (path, message) = (path.to_string(), e.to_string());
        if text.parse::<toml::Table>().is_ok() {
            CaseError::Format { path, message }
        } else {
            CaseError::Toml { path, message }
        }
    })?;
    let cx = Ctx { path };
    let hyp = raw.problem.hypothesis;
    let mut b = ModelBuilder::new(hyp);

    let materials = add_materials(&cx, hyp, &raw.materials, &mut b)?;
    let body_names = add_bodies(&cx, hyp, &raw.bodies, &materials, MeshSources { base, nodes }, &mut b)?;
    let curves = add_curves(&cx, &raw.curves, &mut b)?;
    add_rigid_sets(&cx, &raw.rigid, &body_names, &mut b)?;
    add_bcs(&cx, &raw.bcs, &body_names, &curves, &mut b)?;
    add_loads(&cx, &raw.loads, &body_names, &curves, &mut b)?;
    b.use_curve(0);
    let curves_end = b.curves_end_time();
    add_ties(&cx, &raw.ties, &body_names, &mut b)?;

    // The smallest element of each contact's real surfaces (before worn boundaries become cuts).
    let contact_spacing: Vec<f64> = raw.contacts.iter().map(|c| real_surface_spacing(&b, c)).collect();
    let wear_cuts = worn_boundaries_to_cuts(&cx, &raw.wear, &mut raw.contacts, &body_names, &mut b)?;
    add_free_cuts(&cx, &raw.cuts, &body_names, &curves, &mut b)?;
    add_contacts(&cx, &raw, &body_names, &contact_spacing, &wear_cuts, &mut b)?;
    add_wear(&cx, &raw.wear, &raw.cuts, &wear_cuts, &mut b)?;
    if let Some(j) = &raw.cycle_jump {
        add_cycle_jump(&cx, j, &raw.wear, &mut b)?;
    }
    if !raw.wear.is_empty() && raw.steps.cycle.is_none() {
        return Err(cx.err("wear", "wear runs are cyclic: give steps.cycle = [start, end] and steps.cycles = N"));
    }
    if let Some(f) = &raw.fatigue {
        add_fatigue(&cx, f, raw.wear.is_empty(), &body_names, &mut b)?;
    }

    if let Some(g) = raw.solver.ghost_penalty {
        if !(g.is_finite() && g >= 0.0) {
            return Err(cx.err("solver.ghost_penalty", format!("must be finite and >= 0, got {}", Num(g))));
        }
        b.set_ghost_penalty(g);
    }

    let (load_path, times) = steps(&cx, &raw, curves_end, &mut b)?;
    let np = newton_params(&cx, &raw.solver)?;
    let model = b
        .build(load_path, times, np, raw.solver.linear)
        .map_err(|e| model_err(&cx, build_error_key(&raw, &wear_cuts, &e), e))?;
    let reference = match &raw.reference {
        Some(r) => Some(analytic_reference(&cx, r, &raw.contacts, &model)?),
        None => None,
    };
    let output = raw.output.file.clone().unwrap_or_else(|| PathBuf::from("results").join(format!("{name}.h5")));
    Ok(Case {
        name: name.to_string(),
        units: raw.problem.units,
        source: PathBuf::from(path),
        model,
        output,
        serial: raw.solver.serial,
        checkpoint_every: raw.output.checkpoint_every.unwrap_or(1),
        keep_checkpoints: raw.output.keep_checkpoints.unwrap_or(DEFAULT_KEEP_CHECKPOINTS),
        sliding_set: raw
            .contacts
            .iter()
            .enumerate()
            .filter(|(_, c)| c.sliding.is_some())
            .map(|(i, c)| c.name.clone().unwrap_or_else(|| format!("contact{i}")))
            .collect(),
        fields_every: match raw.output.fields_every {
            None => 1,
            Some(0) => return Err(cx.err("output.fields_every", "must be at least 1")),
            Some(k) => k,
        },
        reference,
    })
}

/// `[reference]`: the contact it names (its pair's name) and its analytical solution, with the
/// contact modulus `1/E* = sum (1 - nu^2) / E` of the pair's two bodies (plane stress: `1/E`).
fn analytic_reference(
    cx: &Ctx,
    r: &ReferenceSpec,
    contacts: &[ContactSpec],
    model: &Model,
) -> Result<(String, crate::post::AnalyticContact), CaseError> {
    let names: Vec<String> =
        contacts.iter().enumerate().map(|(i, c)| c.name.clone().unwrap_or(format!("contact{i}"))).collect();
    let i = match &r.contact {
        None if !contacts.is_empty() => 0,
        None => return Err(cx.err("reference", "the case has no contact to compare")),
        Some(n) => contacts.iter().position(|c| c.name.as_ref() == Some(n)).ok_or_else(|| {
            cx.err("reference.contact", format!("no contact named '{n}' (defined: {})", names.join(", ")))
        })?,
    };
    let radius = cx.positive("reference.radius", r.radius)?;
    let load = cx.positive("reference.load", r.load)?;
    let centre = r.centre.map(|c| cx.finite("reference.centre", c)).transpose()?;
    let mut compliance = 0.0;
    for body in [&contacts[i].mortar, &contacts[i].other] {
        let Some(b) = model.bodies.iter().find(|b| &b.name == body) else {
            return Err(cx.err("reference.contact", format!("contact body '{body}' not found")));
        };
        let e = model.materials[b.material].elastic();
        compliance += match e.hypothesis {
            PlaneHypothesis::PlaneStrain => (1.0 - e.poisson * e.poisson) / e.young,
            PlaneHypothesis::PlaneStress => 1.0 / e.young,
        };
    }
    let hertz = crate::post::AnalyticContact {
        centre_from_profile: centre.is_none(),
        ..crate::post::AnalyticContact::hertz(load, radius, 1.0 / compliance, centre.unwrap_or(0.0))
    };
    if r.bulk.is_some() && r.kind == ReferenceKind::Hertz {
        return Err(cx.err("reference.bulk", "a bulk stress offsets a stick zone: use kind = \"cattaneo_mindlin\""));
    }
    let pair = model.initial().contact.pairs.get(i).map(|p| p.name.clone()).unwrap_or_else(|| names[i].clone());
    match (r.kind, r.tangential) {
        (ReferenceKind::Hertz, None) => Ok((pair, hertz)),
        (ReferenceKind::Hertz, Some(_)) => Err(cx.err(
            "reference.tangential",
            "a Hertz reference has no tangential force (use kind = \"cattaneo_mindlin\")",
        )),
        (ReferenceKind::CattaneoMindlin, None) => {
            Err(cx.err("reference.tangential", "missing: Cattaneo-Mindlin needs the tangential force"))
        }
        (ReferenceKind::CattaneoMindlin, Some(q)) => {
            let q = cx.finite("reference.tangential", q)?;
            let mu = contacts[i].friction;
            let cm = hertz.with_tangential(load, q, mu).ok_or_else(|| {
                cx.err(
                    "reference.tangential",
                    format!(
                        "|Q| = {} is not below mu P = {} (friction {mu}): gross slip has no stick zone",
                        q.abs(),
                        mu * load
                    ),
                )
            })?;
            let Some(bulk) = r.bulk else { return Ok((pair, cm)) };
            let bulk = cx.finite("reference.bulk", bulk)?;
            cm.with_bulk_stress(bulk, q).map(|h| (pair, h)).ok_or_else(|| {
                let e = bulk * cm.a / (4.0 * mu * cm.p0);
                cx.err(
                    "reference.bulk",
                    format!(
                        "the stick zone offset by {} (sigma a / (4 mu p0)) would leave the contact: Nowell-Hills holds while |e| + c <= a = {}",
                        Num(e.abs()),
                        Num(cm.a)
                    ),
                )
            })
        }
    }
}

/// `[[materials]]`: adds each material's law; returns their names and models, in order.
fn add_materials<'a>(
    cx: &Ctx,
    hyp: PlaneHypothesis,
    materials: &'a [MaterialSpec],
    b: &mut ModelBuilder,
) -> Result<MaterialTable<'a>, CaseError> {
    let mut mat_names: Vec<&str> = vec![];
    let mut mat_models = vec![];
    for (i, m) in materials.iter().enumerate() {
        let k = |f: &str| format!("materials[{i}].{f}");
        if mat_names.contains(&m.name.as_str()) {
            return Err(cx.err(k("name"), format!("duplicate material name '{}'", m.name)));
        }
        let young = cx.positive(&k("young"), m.young)?;
        let nu = cx.finite(&k("poisson"), m.poisson)?;
        if !(nu > -1.0 && nu < 0.5) {
            return Err(cx.err(
                k("poisson"),
                format!("Poisson ratio must satisfy -1 < nu < 0.5, got {nu} (nu = 0.5 is incompressible: the {} law needs a finite bulk modulus)", match hyp { PlaneHypothesis::PlaneStrain => "plane-strain", PlaneHypothesis::PlaneStress => "plane-stress" }),
            ));
        }
        let elastic = Elastic { young, poisson: nu, hypothesis: hyp };
        let mat = match m.model {
            MaterialModel::Elastic => {
                if m.yield_stress.is_some() {
                    return Err(cx.err(k("yield_stress"), "only a j2_plastic material takes a yield stress"));
                }
                Material::Elastic(elastic)
            }
            MaterialModel::J2Plastic => {
                if hyp != PlaneHypothesis::PlaneStrain {
                    return Err(cx.err(
                        k("model"),
                        "j2_plastic is implemented for plane strain only (problem.hypothesis = \"plane_strain\")",
                    ));
                }
                let sy = m
                    .yield_stress
                    .ok_or_else(|| cx.err(k("yield_stress"), "missing: a j2_plastic material needs a yield stress"))?;
                let sy = cx.positive(&k("yield_stress"), sy)?;
                for (f, v) in
                    [("isotropic_hardening", m.isotropic_hardening), ("kinematic_hardening", m.kinematic_hardening)]
                {
                    if !(v.is_finite() && v >= 0.0) {
                        return Err(cx.err(
                            k(f),
                            format!("must be finite and >= 0 (softening is not supported), got {}", Num(v)),
                        ));
                    }
                }
                Material::J2Plastic(J2Plastic {
                    elastic,
                    yield_stress: sy,
                    isotropic_hardening: m.isotropic_hardening,
                    kinematic_hardening: m.kinematic_hardening,
                })
            }
        };
        mat_names.push(&m.name);
        mat_models.push(m.model);
        b.add_material(&m.name, mat);
    }
    Ok(MaterialTable { names: mat_names, models: mat_models })
}

/// The materials a case declared: their names and models, in order.
struct MaterialTable<'a> {
    names: Vec<&'a str>,
    models: Vec<MaterialModel>,
}

/// Where the bodies' meshes come from: mesh files relative to `base`, and per body the node
/// positions that replace its mesh's (`nodes`, by body name: a relocated mesh).
#[derive(Clone, Copy)]
struct MeshSources<'a> {
    base: &'a Path,
    nodes: &'a [(String, Vec<Point2<f64>>)],
}

/// `[[bodies]]`: adds each body's mesh (its nodes moved where `sources` names it), material,
/// thickness and formulation; returns their names.
fn add_bodies<'a>(
    cx: &Ctx,
    hyp: PlaneHypothesis,
    bodies: &'a [BodySpec],
    materials: &MaterialTable,
    sources: MeshSources<'_>,
    b: &mut ModelBuilder,
) -> Result<Vec<&'a str>, CaseError> {
    let MeshSources { base, nodes } = sources;
    if bodies.is_empty() {
        return Err(cx.err("bodies", "the case defines no body"));
    }
    let mut body_names: Vec<&str> = vec![];
    for (i, bs) in bodies.iter().enumerate() {
        let k = |f: &str| format!("bodies[{i}].{f}");
        if body_names.contains(&bs.name.as_str()) {
            return Err(cx.err(k("name"), format!("duplicate body name '{}'", bs.name)));
        }
        body_names.push(&bs.name);
        let mi = materials.names.iter().position(|&n| n == bs.material).ok_or_else(|| {
            cx.err(
                k("material"),
                format!("no material named '{}' (defined: {})", bs.material, materials.names.join(", ")),
            )
        })?;
        let thickness = match (bs.thickness, hyp) {
            (None, _) => 1.0,
            (Some(t), PlaneHypothesis::PlaneStress) => cx.positive(&k("thickness"), t)?,
            (Some(_), PlaneHypothesis::PlaneStrain) => {
                return Err(cx.err(
                    k("thickness"),
                    "plane-strain results are per unit depth; thickness applies to plane stress only",
                ))
            }
        };
        let formulation = match bs.formulation {
            Some(Formulation::BBar) if hyp == PlaneHypothesis::PlaneStress => {
                return Err(cx.err(
                    k("formulation"),
                    "B-bar treats the plane-strain volumetric constraint; use \"standard\" in plane stress",
                ))
            }
            Some(f) => f,
            None if materials.models[mi] == MaterialModel::J2Plastic => Formulation::BBar,
            None => Formulation::Standard,
        };
        let mut mesh = build_mesh(&bs.mesh, base).map_err(|msg| cx.err(k("mesh"), msg))?;
        if let Some((_, moved)) = nodes.iter().find(|(n, _)| n == &bs.name) {
            if moved.len() != mesh.num_nodes() {
                let msg = format!("{} moved nodes given for a mesh of {} nodes", moved.len(), mesh.num_nodes());
                return Err(cx.err(k("mesh"), msg));
            }
            mesh.nodes.clone_from(moved);
            mesh.validate().map_err(|e| cx.err(k("mesh"), format!("with its nodes moved: {e}")))?;
        }
        b.add_body(&bs.name, mesh, mi, formulation, thickness);
    }
    Ok(body_names)
}

/// The names of the `[[curves]]`, in order: curve `i` has id `i + 1` (id 0 is `steps.path`).
struct CurveNames(Vec<String>);

impl CurveNames {
    /// The id of the curve `name` (0, `steps.path`, if none is named); `key` names it in errors.
    fn id(&self, cx: &Ctx, name: &Option<String>, key: String) -> Result<usize, CaseError> {
        let curve_names = &self.0;
        match name {
            None => Ok(0),
            Some(n) => curve_names
                .iter()
                .position(|c| c == n)
                .map(|i| i + 1)
                .ok_or_else(|| cx.err(key, format!("no curve named '{n}' (defined: {})", curve_names.join(", ")))),
        }
    }
}

/// `[[curves]]`: adds the named load curves (ids 1, 2, ...; id 0 is `steps.path`).
fn add_curves(cx: &Ctx, curves: &[CurveSpec], b: &mut ModelBuilder) -> Result<CurveNames, CaseError> {
    let mut curve_names: Vec<String> = Vec::new();
    for (i, c) in curves.iter().enumerate() {
        if curve_names.contains(&c.name) || c.name == "path" {
            return Err(cx.err(format!("curves[{i}].name"), format!("curve name '{}' is used twice", c.name)));
        }
        let pts: Vec<(f64, f64)> = c.path.iter().map(|p| (p[0], p[1])).collect();
        let path = LoadPath::new(pts).map_err(|e| model_err(cx, format!("curves[{i}].path"), e))?;
        b.add_curve(path);
        curve_names.push(c.name.clone());
    }
    Ok(CurveNames(curve_names))
}

/// `[[rigid]]`: makes each set of nodes move as one translation.
fn add_rigid_sets(cx: &Ctx, rigid: &[RigidSpec], body_names: &[&str], b: &mut ModelBuilder) -> Result<(), CaseError> {
    for (i, r) in rigid.iter().enumerate() {
        let k = |f: &str| format!("rigid[{i}].{f}");
        let bi = b.body_index(&r.body).map_err(|_| {
            cx.err(k("body"), format!("no body named '{}' (defined: {})", r.body, body_names.join(", ")))
        })?;
        b.rigid_set(bi, &r.set).map_err(|e| model_err(cx, k("set"), e))?;
    }
    Ok(())
}

/// `[[bcs]]`: prescribes displacements on sets, each following its load curve.
fn add_bcs(
    cx: &Ctx,
    bcs: &[BcSpec],
    body_names: &[&str],
    curves: &CurveNames,
    b: &mut ModelBuilder,
) -> Result<(), CaseError> {
    for (i, bc) in bcs.iter().enumerate() {
        let k = |f: &str| format!("bcs[{i}].{f}");
        let bi = b.body_index(&bc.body).map_err(|_| {
            cx.err(k("body"), format!("no body named '{}' (defined: {})", bc.body, body_names.join(", ")))
        })?;
        if bc.ux.is_none() && bc.uy.is_none() {
            return Err(cx.err(format!("bcs[{i}]"), "give ux, uy or both"));
        }
        b.use_curve(curves.id(cx, &bc.curve, k("curve"))?);
        for (comp, v, f) in [(0, bc.ux, "ux"), (1, bc.uy, "uy")] {
            if let Some(v) = v {
                let v = cx.finite(&k(f), v)?;
                b.fix(bi, &bc.set, comp, v).map_err(|e| model_err(cx, k("set"), e))?;
            }
        }
    }
    Ok(())
}

/// `[[loads]]`: adds pressures, tractions and forces on sets, each following its load curve.
fn add_loads(
    cx: &Ctx,
    loads: &[LoadSpec],
    body_names: &[&str],
    curves: &CurveNames,
    b: &mut ModelBuilder,
) -> Result<(), CaseError> {
    for (i, l) in loads.iter().enumerate() {
        let k = |f: &str| format!("loads[{i}].{f}");
        let bi = b.body_index(&l.body).map_err(|_| {
            cx.err(k("body"), format!("no body named '{}' (defined: {})", l.body, body_names.join(", ")))
        })?;
        let given = [l.pressure.is_some(), l.traction.is_some(), l.force.is_some(), l.total_force.is_some()]
            .iter()
            .filter(|&&x| x)
            .count();
        if given != 1 {
            return Err(cx.err(format!("loads[{i}]"), "give exactly one of pressure, traction, force, total_force"));
        }
        b.use_curve(curves.id(cx, &l.curve, k("curve"))?);
        if let Some(p) = l.pressure {
            b.pressure(bi, &l.set, cx.finite(&k("pressure"), p)?).map_err(|e| model_err(cx, k("set"), e))?;
        }
        if l.traction_gradient.is_some() && l.traction.is_none() {
            return Err(cx.err(k("traction_gradient"), "needs traction (the traction at the origin)"));
        }
        if let Some(t) = l.traction {
            let t = Vector2::new(cx.finite(&k("traction"), t[0])?, cx.finite(&k("traction"), t[1])?);
            let mut g = nalgebra::Matrix2::zeros();
            for (r, row) in l.traction_gradient.unwrap_or_default().iter().enumerate() {
                for (c, &v) in row.iter().enumerate() {
                    g[(r, c)] = cx.finite(&k("traction_gradient"), v)?;
                }
            }
            b.linear_traction(bi, &l.set, t, g).map_err(|e| model_err(cx, k("set"), e))?;
        }
        if let Some(f) = l.force {
            let f = Vector2::new(cx.finite(&k("force"), f[0])?, cx.finite(&k("force"), f[1])?);
            b.point_load(bi, &l.set, f).map_err(|e| model_err(cx, k("set"), e))?;
        }
        if let Some(f) = l.total_force {
            let f = Vector2::new(cx.finite(&k("total_force"), f[0])?, cx.finite(&k("total_force"), f[1])?);
            b.total_load(bi, &l.set, f).map_err(|e| model_err(cx, k("set"), e))?;
        }
    }
    Ok(())
}

/// `[[ties]]`: mortar coupling of overlapping meshes (embedded) or of coinciding surfaces.
fn add_ties(cx: &Ctx, ties: &[TieSpec], body_names: &[&str], b: &mut ModelBuilder) -> Result<(), CaseError> {
    for (i, t) in ties.iter().enumerate() {
        let k = |f: &str| format!("ties[{i}].{f}");
        let body = |name: &str, key: &str| {
            b.body_index(name)
                .map_err(|_| cx.err(k(key), format!("no body named '{name}' (defined: {})", body_names.join(", "))))
        };
        let host = body(&t.host, "host")?;
        let patch = body(&t.patch, "patch")?;
        let name = t.name.clone().unwrap_or_else(|| format!("tie{i}"));
        match &t.host_surface {
            None => b.add_tie(&name, host, patch, &t.boundary, t.multipliers),
            Some(hs) => b.add_surface_tie(&name, patch, &t.boundary, host, hs, t.multipliers),
        }
        .map_err(|e| model_err(cx, k("boundary"), e))?;
    }
    Ok(())
}

/// `[[wear]]` on real boundaries: each becomes a cut coinciding with it, and contacts on that
/// boundary use the cut; returns the cut of every wear entry, in order.
fn worn_boundaries_to_cuts(
    cx: &Ctx,
    wear: &[WearSpec],
    contacts: &mut [ContactSpec],
    body_names: &[&str],
    b: &mut ModelBuilder,
) -> Result<Vec<String>, CaseError> {
    let mut wear_cuts: Vec<String> = Vec::with_capacity(wear.len());
    for (i, w) in wear.iter().enumerate() {
        let k = |f: &str| format!("wear[{i}].{f}");
        match (&w.cut, &w.body, &w.surface) {
            (Some(cut), None, None) => wear_cuts.push(cut.clone()),
            (None, Some(body_name), Some(sets)) => {
                let bi = b.body_index(body_name).map_err(|_| {
                    cx.err(k("body"), format!("no body named '{body_name}' (defined: {})", body_names.join(", ")))
                })?;
                let name = format!("{body_name}.{}", sets.join("+"));
                b.add_boundary_cut(&name, bi, sets).map_err(|e| model_err(cx, k("surface"), e))?;
                for c in contacts.iter_mut() {
                    if c.mortar == *body_name && c.mortar_cut.is_none() && c.mortar_surface == *sets {
                        c.mortar_surface.clear();
                        c.mortar_cut = Some(name.clone());
                    }
                    if c.other == *body_name && c.other_surface.as_ref() == Some(sets) {
                        c.other_surface = None;
                        c.other_cut = Some(name.clone());
                    }
                }
                wear_cuts.push(name);
            }
            _ => return Err(cx.err(format!("wear[{i}]"), "give either cut, or body and surface")),
        }
    }
    Ok(wear_cuts)
}

/// `[[cuts]]`: free virtual surfaces (without a partner), fixed or moving along a load curve.
fn add_free_cuts(
    cx: &Ctx,
    cuts: &[CutSpec],
    body_names: &[&str],
    curves: &CurveNames,
    b: &mut ModelBuilder,
) -> Result<(), CaseError> {
    for (i, c) in cuts.iter().enumerate() {
        let k = |f: &str| format!("cuts[{i}].{f}");
        let bi = b.body_index(&c.body).map_err(|_| {
            cx.err(k("body"), format!("no body named '{}' (defined: {})", c.body, body_names.join(", ")))
        })?;
        let mut pts = Vec::with_capacity(c.points.len());
        for p in &c.points {
            pts.push(Point2::new(cx.finite(&k("points"), p[0])?, cx.finite(&k("points"), p[1])?));
        }
        let name = c.name.clone().unwrap_or_else(|| format!("cut{i}"));
        b.add_cut(&name, bi, pts, c.closed, c.keep == KeepSide::Left).map_err(|e| model_err(cx, k("points"), e))?;
        if let Some(m) = &c.motion {
            let curve = curves.id(cx, &m.curve, k("motion.curve"))?;
            let motion = match (m.translation, m.offset) {
                (Some(d), None) => crate::moving::SurfaceMotion::Translation {
                    direction: Vector2::new(
                        cx.finite(&k("motion.translation"), d[0])?,
                        cx.finite(&k("motion.translation"), d[1])?,
                    ),
                    curve,
                },
                (None, Some(d)) => {
                    // Offsets are along the normal into the kept material; the model keeps the
                    // material on the left of its polyline.
                    crate::moving::SurfaceMotion::NormalOffset { distance: cx.finite(&k("motion.offset"), d)?, curve }
                }
                _ => return Err(cx.err(k("motion"), "give exactly one of translation, offset")),
            };
            b.set_cut_motion(&name, motion).map_err(|e| model_err(cx, k("motion"), e))?;
        }
    }
    Ok(())
}

/// `[[contacts]]` (after worn boundaries became cuts): mortar contact pairs on edge sets or cuts.
fn add_contacts(
    cx: &Ctx,
    raw: &CaseFile,
    body_names: &[&str],
    contact_spacing: &[f64],
    wear_cuts: &[String],
    b: &mut ModelBuilder,
) -> Result<(), CaseError> {
    for (i, c) in raw.contacts.iter().enumerate() {
        let k = |f: &str| format!("contacts[{i}].{f}");
        let body = |name: &str, key: &str| {
            b.body_index(name)
                .map_err(|_| cx.err(k(key), format!("no body named '{name}' (defined: {})", body_names.join(", "))))
        };
        let mortar = body(&c.mortar, "mortar")?;
        let other_body = body(&c.other, "other")?;
        let other = match (&c.other_surface, &c.other_cut) {
            (Some(sets), None) => {
                ContactOther::Edges(b.global_edges(other_body, sets).map_err(|e| model_err(cx, k("other_surface"), e))?)
            }
            (None, Some(cut)) => {
                if !wear_cuts.contains(cut)
                    && !raw.cuts.iter().enumerate().any(|(j, cs)| {
                        cs.name.clone().unwrap_or_else(|| format!("cut{j}")) == *cut && cs.body == c.other
                    })
                {
                    return Err(cx.err(k("other_cut"), format!("no cut named '{cut}' in body '{}'", c.other)));
                }
                ContactOther::Cut(cut.clone())
            }
            _ => return Err(cx.err(format!("contacts[{i}]"), "give exactly one of other_surface, other_cut")),
        };
        let name = c.name.clone().unwrap_or_else(|| format!("contact{i}"));
        if !(c.friction.is_finite() && c.friction >= 0.0) {
            return Err(cx.err(
                k("friction"),
                format!("the friction coefficient must be finite and >= 0, got {}", Num(c.friction)),
            ));
        }
        let sliding = c.sliding.unwrap_or_else(|| scene_sliding(raw, c, contact_spacing[i], wear_cuts));
        let params = crate::model::ContactParams {
            friction: c.friction,
            multipliers: c.multipliers.unwrap_or(DEFAULT_CONTACT_MULTIPLIERS),
            sliding,
        };
        let added = match (&c.mortar_cut, c.mortar_surface.is_empty()) {
            (None, false) => b.add_contact(&name, mortar, &c.mortar_surface, other_body, other, params),
            (Some(cut), true) => {
                let known = wear_cuts.contains(cut)
                    || raw.cuts.iter().enumerate().any(|(j, cs)| {
                        cs.name.clone().unwrap_or_else(|| format!("cut{j}")) == *cut && cs.body == c.mortar
                    });
                if !known {
                    return Err(cx.err(k("mortar_cut"), format!("no cut named '{cut}' in body '{}'", c.mortar)));
                }
                b.add_contact_on_cut(&name, cut, other_body, other, params)
            }
            _ => return Err(cx.err(format!("contacts[{i}]"), "give exactly one of mortar_surface, mortar_cut")),
        };
        added.map_err(|e| {
            let key = match &e {
                ModelError::Contact { key, .. } => k(key),
                _ => k("mortar_surface"),
            };
            model_err(cx, key, e)
        })?;
    }
    Ok(())
}

/// `[[wear]]`: the wear law, coefficient and depth of each worn surface (`wear_cuts`, in order).
fn add_wear(
    cx: &Ctx,
    wear: &[WearSpec],
    cuts: &[CutSpec],
    wear_cuts: &[String],
    b: &mut ModelBuilder,
) -> Result<(), CaseError> {
    for (i, (w, cut)) in wear.iter().zip(wear_cuts).enumerate() {
        let k = |f: &str| format!("wear[{i}].{f}");
        let declared =
            cuts.iter().enumerate().any(|(j, c)| c.name.clone().unwrap_or_else(|| format!("cut{j}")) == *cut);
        if w.cut.is_some() && !declared {
            return Err(cx.err(k("cut"), format!("no cut named '{cut}'")));
        }
        // A surface given as `body` + `surface` is named by those keys, not by its internal cut.
        let surface_key = if w.cut.is_some() { "cut" } else { "surface" };
        b.set_cut_wear(cut, w.law, w.coefficient, w.max_depth).map_err(|e| {
            let key = match &e {
                ModelError::Wear { key, .. } if *key != "cut" => k(key),
                _ => k(surface_key),
            };
            model_err(cx, key, e)
        })?;
    }
    Ok(())
}

/// `[fatigue]`: the fatigue points of one body (see [`crate::fatigue`]).
fn add_fatigue(
    cx: &Ctx,
    f: &FatigueSpec,
    no_wear: bool,
    body_names: &[&str],
    b: &mut ModelBuilder,
) -> Result<(), CaseError> {
    if no_wear {
        return Err(cx.err("fatigue", "fatigue is followed through the cycles of a wear run: give a [[wear]] surface"));
    }
    let body = b.body_index(&f.body).map_err(|_| {
        cx.err("fatigue.body", format!("no body named '{}' (defined: {})", f.body, body_names.join(", ")))
    })?;
    let life = crate::fatigue::StrainLife {
        young: 1.0,
        sigma_f: cx.finite("fatigue.sigma_f", f.sigma_f)?,
        b: cx.finite("fatigue.b", f.b)?,
        eps_f: cx.finite("fatigue.eps_f", f.eps_f)?,
        c: cx.finite("fatigue.c", f.c)?,
    };
    let region = match f.region {
        Some([lo, hi]) => {
            let (lo, hi) = (Point2::new(lo[0], lo[1]), Point2::new(hi[0], hi[1]));
            if !(lo.x < hi.x && lo.y < hi.y) {
                return Err(
                    cx.err("fatigue.region", "give [[xmin, ymin], [xmax, ymax]] with xmin < xmax and ymin < ymax")
                );
            }
            Some([lo, hi])
        }
        None => None,
    };
    b.set_fatigue(body, life, region, f.stop_at_initiation).map_err(|e| model_err(cx, "fatigue".into(), e))
}

/// `[cycle_jump]`: the jump policy, scheme and wear-rate smoothing of a wear run.
fn add_cycle_jump(cx: &Ctx, j: &CycleJumpSpec, wear: &[WearSpec], b: &mut ModelBuilder) -> Result<(), CaseError> {
    let policy = jump_policy(cx, j)?;
    if wear.is_empty() {
        return Err(cx.err("cycle_jump", "there is no [[wear]] surface to jump cycles for"));
    }
    b.set_wear_jump(policy);
    if let Some(scheme) = j.scheme {
        b.set_wear_scheme(scheme);
    }
    if let Some(sm) = j.smoothing {
        if !(sm.is_finite() && sm >= 0.0) {
            return Err(cx.err("cycle_jump.smoothing", format!("must be finite and >= 0, got {}", Num(sm))));
        }
        b.set_wear_smoothing(sm);
    }
    if let Some(f) = j.min_fraction {
        if !(f.is_finite() && f > 0.0 && f <= 1.0) {
            return Err(cx.err("cycle_jump.min_fraction", format!("must be in (0, 1], got {}", Num(f))));
        }
        if j.fixed.is_some() {
            return Err(cx.err("cycle_jump.min_fraction", "applies to adaptive jumps; fixed jumps apply whole cycles"));
        }
        b.set_wear_min_fraction(f);
    }
    if let Some(tol) = j.ratcheting_tolerance {
        if !(tol.is_finite() && tol >= 0.0) {
            return Err(cx.err("cycle_jump.ratcheting_tolerance", format!("must be finite and >= 0, got {}", Num(tol))));
        }
        b.set_ratcheting_tolerance(tol);
    }
    Ok(())
}

/// The jump policy of `[cycle_jump]`: fixed, or adaptive with its (defaulted) limits.
fn jump_policy(cx: &Ctx, j: &CycleJumpSpec) -> Result<crate::wear::JumpPolicy, CaseError> {
    let adaptive_keys = j.depth_fraction.is_some()
        || j.max_jump.is_some()
        || j.pressure_change.is_some()
        || j.prediction_tolerance.is_some();
    let policy = match (j.fixed, adaptive_keys) {
        (Some(0), _) => return Err(cx.err("cycle_jump.fixed", "must be at least 1")),
        (Some(n), false) => crate::wear::JumpPolicy::Fixed(n),
        (Some(_), true) => {
            return Err(cx.err(
                "cycle_jump",
                "fixed cannot be combined with depth_fraction, max_jump, pressure_change or prediction_tolerance",
            ))
        }
        (None, _) => {
            let (f, m, pc) = (j.depth_fraction, j.max_jump, j.pressure_change);
            let depth_fraction = f.unwrap_or(0.1);
            if !(depth_fraction.is_finite() && depth_fraction > 0.0 && depth_fraction <= 1.0) {
                return Err(
                    cx.err("cycle_jump.depth_fraction", format!("must be in (0, 1], got {}", Num(depth_fraction)))
                );
            }
            let max_jump = m.unwrap_or(1_000_000);
            if max_jump == 0 {
                return Err(cx.err("cycle_jump.max_jump", "must be at least 1"));
            }
            let pressure_change = pc.unwrap_or(crate::wear::DEFAULT_PRESSURE_CHANGE);
            if !(pressure_change.is_finite() && pressure_change > 0.0) {
                return Err(cx.err(
                    "cycle_jump.pressure_change",
                    format!("must be finite and > 0, got {}", Num(pressure_change)),
                ));
            }
            let prediction_tolerance = j.prediction_tolerance.unwrap_or(crate::wear::DEFAULT_PREDICTION_TOLERANCE);
            if !(prediction_tolerance.is_finite() && prediction_tolerance > 0.0) {
                return Err(cx.err(
                    "cycle_jump.prediction_tolerance",
                    format!("must be finite and > 0, got {}", Num(prediction_tolerance)),
                ));
            }
            crate::wear::JumpPolicy::Adaptive { depth_fraction, max_jump, pressure_change, prediction_tolerance }
        }
    };
    Ok(policy)
}

/// `[steps]`: the load path, cycle and output times (the history ends with the path or a later curve).
fn steps(cx: &Ctx, raw: &CaseFile, curves_end: f64, b: &mut ModelBuilder) -> Result<(LoadPath, Vec<f64>), CaseError> {
    let path_pts: Vec<(f64, f64)> = raw.steps.path.iter().map(|p| (p[0], p[1])).collect();
    let load_path = LoadPath::new(path_pts).map_err(|e| model_err(cx, "steps.path".into(), e))?;
    let (t0, t1) = (load_path.points[0].0, load_path.end_time().max(curves_end));
    let cyclic = cycle(cx, raw, &load_path, t0, t1, b)?;
    let times = output_times(cx, &raw.steps, cyclic, t0, t1, b)?;
    Ok((load_path, times))
}

/// `steps.cycle` and `steps.cycles`: the repeated window of the history `[t0, t1]`, if any.
fn cycle(
    cx: &Ctx,
    raw: &CaseFile,
    load_path: &LoadPath,
    t0: f64,
    t1: f64,
    b: &ModelBuilder,
) -> Result<Option<crate::model::Cycle>, CaseError> {
    let cyclic = match (raw.steps.cycle, raw.steps.cycles) {
        (None, None) => None,
        (Some(w), Some(n)) => {
            let (start, end) = (cx.finite("steps.cycle", w[0])?, cx.finite("steps.cycle", w[1])?);
            if !(start >= t0 && end > start && end <= t1 + 1e-12 * t1.abs().max(1.0)) {
                return Err(cx.err(
                    "steps.cycle",
                    format!(
                        "the window [{start}, {end}] must lie inside the load history [{t0}, {t1}] with start < end"
                    ),
                ));
            }
            if n == 0 {
                return Err(cx.err("steps.cycles", "must be at least 1"));
            }
            if raw.steps.times.is_some() {
                return Err(cx.err("steps.times", "cannot be combined with steps.cycle (output steps come per cycle)"));
            }
            let increments = raw.steps.increments;
            let ramp = raw.steps.ramp_increments.unwrap_or(1);
            if increments == 0 || ramp == 0 {
                return Err(cx.err("steps.increments", "increments and ramp_increments must be at least 1"));
            }
            if increments == 1 && !raw.wear.is_empty() {
                return Err(cx.err(
                    "steps.increments",
                    "a wear run needs several increments per cycle: one increment samples only the cycle's end, \
                     where the stroke is back where it started, so nothing would slide (4 or more resolve a stroke)",
                ));
            }
            if ramp > MAX_OUTPUT_STEPS {
                return Err(
                    cx.err("steps.ramp_increments", format!("{ramp} is more than {MAX_OUTPUT_STEPS} output steps"))
                );
            }
            if n.checked_mul(increments).is_none_or(|v| v > MAX_OUTPUT_STEPS - ramp) {
                return Err(cx.err(
                    "steps.cycles",
                    format!("{n} cycles x {increments} increments is more than {MAX_OUTPUT_STEPS} output steps"),
                ));
            }
            // Every history must close over the window, or the cycles would jump.
            let mut histories: Vec<(&str, &LoadPath)> = vec![("steps.path", load_path)];
            for (c, cs) in b.curves().iter().zip(&raw.curves) {
                histories.push((cs.name.as_str(), c));
            }
            // Curves that move surfaces are read at the absolute time (not wrapped).
            let motion_curves: Vec<&str> =
                raw.cuts.iter().filter_map(|c| c.motion.as_ref().and_then(|m| m.curve.as_deref())).collect();
            for (name, h) in histories.into_iter().filter(|(n, _)| !motion_curves.contains(n)) {
                let (fa, fb) = (h.factor(start), h.factor(end));
                if (fa - fb).abs() > 1e-12 * fa.abs().max(fb.abs()).max(1.0) {
                    return Err(cx.err(
                        "steps.cycle",
                        format!("curve '{name}' does not close over the cycle: factor {fa} at {start}, {fb} at {end}"),
                    ));
                }
            }
            Some(crate::model::Cycle { start, period: end - start, count: n, increments, ramp_increments: ramp })
        }
        _ => return Err(cx.err("steps.cycle", "give both steps.cycle = [start, end] and steps.cycles = N")),
    };
    Ok(cyclic)
}

/// The output times: per cycle (setting the model's cycle), `steps.times`, or equal increments.
fn output_times(
    cx: &Ctx,
    steps: &StepsSpec,
    cyclic: Option<crate::model::Cycle>,
    t0: f64,
    t1: f64,
    b: &mut ModelBuilder,
) -> Result<Vec<f64>, CaseError> {
    let times = match (&steps.times, cyclic) {
        (_, Some(cy)) => {
            b.set_cycle(cy);
            cy.times(t0)
        }
        (Some(ts), None) => {
            if ts.is_empty() || ts.windows(2).any(|w| w[1] <= w[0]) || ts.iter().any(|t| !t.is_finite() || *t <= t0) {
                return Err(cx.err(
                    "steps.times",
                    format!("output times must be finite, strictly increasing and after the path start {t0}"),
                ));
            }
            ts.clone()
        }
        (None, None) => {
            let n = steps.increments;
            if n == 0 {
                return Err(cx.err("steps.increments", "must be at least 1"));
            }
            if n > MAX_OUTPUT_STEPS {
                return Err(cx.err("steps.increments", format!("{n} is more than {MAX_OUTPUT_STEPS} output steps")));
            }
            (1..=n).map(|i| t0 + (t1 - t0) * i as f64 / n as f64).collect()
        }
    };
    Ok(times)
}

/// `[solver.newton]`: the Newton parameters, checked.
fn newton_params(cx: &Ctx, solver: &SolverSpec) -> Result<NewtonParams, CaseError> {
    let np = solver.newton;
    if !(np.rtol > 0.0 && np.rtol < 1.0) {
        return Err(cx.err("solver.newton.rtol", format!("must be in (0, 1), got {}", Num(np.rtol))));
    }
    if np.max_iterations == 0 {
        return Err(cx.err("solver.newton.max_iterations", "must be at least 1"));
    }
    if np.max_set_iterations == Some(0) {
        return Err(cx.err("solver.newton.max_set_iterations", "must be at least 1"));
    }
    Ok(np)
}

/// The case key of an error of [`ModelBuilder::build`]: the tie, cut, contact or wear it names.
fn build_error_key(raw: &CaseFile, wear_cuts: &[String], e: &ModelError) -> String {
    match e {
        ModelError::Tie { tie, .. }
        | ModelError::Cut { cut: tie, .. }
        | ModelError::MovingSurface { surface: tie, .. }
        | ModelError::CutMesh { surface: Some(tie), .. } => raw
            .ties
            .iter()
            .enumerate()
            .find(|(i, t)| t.name.clone().unwrap_or_else(|| format!("tie{i}")) == *tie)
            .map(|(i, _)| format!("ties[{i}]"))
            .or_else(|| {
                raw.cuts
                    .iter()
                    .enumerate()
                    .find(|(i, c)| c.name.clone().unwrap_or_else(|| format!("cut{i}")) == *tie)
                    .map(|(i, _)| format!("cuts[{i}]"))
            })
            .unwrap_or_else(|| "ties".into()),
        ModelError::Contact { contact, key, .. } => raw
            .contacts
            .iter()
            .enumerate()
            .find(|(i, c)| c.name.clone().unwrap_or_else(|| format!("contact{i}")) == *contact)
            .map(|(i, _)| format!("contacts[{i}].{key}"))
            .unwrap_or_else(|| "contacts".into()),
        ModelError::Wear { surface, key, .. } => wear_cuts
            .iter()
            .position(|w| w == surface)
            .map(|i| match (*key, raw.wear[i].cut.is_some()) {
                ("cut", false) => format!("wear[{i}].surface"),
                _ => format!("wear[{i}].{key}"),
            })
            .unwrap_or_else(|| "wear".into()),
        _ => "bcs".into(),
    }
}

fn model_err(cx: &Ctx, key: String, e: ModelError) -> CaseError {
    cx.err(key, e.to_string())
}

fn build_mesh(spec: &MeshSpec, base: &Path) -> Result<Mesh2, String> {
    let divisions = match spec {
        MeshSpec::Rectangle { divisions, .. }
        | MeshSpec::Disc { divisions, .. }
        | MeshSpec::AnnulusSector { divisions, .. }
        | MeshSpec::HalfDisc { divisions, .. } => Some(*divisions),
        MeshSpec::Gmsh { .. } => None,
    };
    let floats: Vec<f64> = match spec {
        MeshSpec::Rectangle { origin, size, grading, rotation, .. } => {
            origin.iter().chain(size).chain(grading).copied().chain([*rotation]).collect()
        }
        MeshSpec::Disc { centre, radius, .. } => vec![centre[0], centre[1], *radius],
        MeshSpec::AnnulusSector { inner_radius, outer_radius, angles, radial_grading, .. } => {
            vec![*inner_radius, *outer_radius, angles[0], angles[1], *radial_grading]
        }
        MeshSpec::HalfDisc { centre, radius, radial_grading, angular_grading, .. } => {
            vec![centre[0], centre[1], *radius, *radial_grading, *angular_grading]
        }
        MeshSpec::Gmsh { .. } => vec![],
    };
    if let Some(v) = floats.iter().find(|v| !v.is_finite()) {
        return Err(format!("mesh parameters must be finite numbers (got {})", Num(*v)));
    }
    if let Some(d) = divisions {
        if d[0].checked_mul(d[1]).and_then(|n| n.checked_mul(4)).is_none_or(|n| n > 4 * MAX_GENERATED_CELLS) {
            return Err(format!("divisions {} x {} exceed {MAX_GENERATED_CELLS} cells", d[0], d[1]));
        }
    }
    let m = match spec {
        MeshSpec::Rectangle { origin, size, divisions, grading, cell, rotation, refine_to_centre, fine_zone } => {
            if divisions[0] == 0 || divisions[1] == 0 || !(grading[0] > 0.0 && grading[1] > 0.0) {
                return Err("rectangle needs divisions >= 1 and positive grading ratios".into());
            }
            if !(size[0] > 0.0 && size[1] > 0.0) {
                return Err(format!("rectangle size must be positive, got [{}, {}]", size[0], size[1]));
            }
            let x_lines = match fine_zone {
                Some(z) => Some(fine_zone_lines(z, z.width / size[0], divisions[0], "rectangle's width")?),
                None => None,
            };
            let lines = |k: usize| {
                if let (0, Some(x)) = (k, &x_lines) {
                    x.clone()
                } else if refine_to_centre[k] {
                    generate::graded_to_centre(divisions[k], grading[k])
                } else {
                    generate::graded(divisions[k], grading[k])
                }
            };
            let kind = match cell {
                CellSpec::Quad4 => CellKind::Quad4,
                CellSpec::Tri3 => CellKind::Tri3,
            };
            let (corner, extent) = (Point2::new(origin[0], origin[1]), Vector2::new(size[0], size[1]));
            let mesh = generate::rectangle_from_divisions(corner, extent, &lines(0), &lines(1), kind);
            // Rotation about the origin corner (orientation and sets are preserved).
            mesh.map(|mut m| {
                if *rotation != 0.0 {
                    let (sn, cs) = rotation.to_radians().sin_cos();
                    let o = Point2::new(origin[0], origin[1]);
                    for p in m.nodes.iter_mut() {
                        let d = *p - o;
                        *p = o + Vector2::new(cs * d.x - sn * d.y, sn * d.x + cs * d.y);
                    }
                }
                m
            })
        }
        MeshSpec::Disc { centre, radius, divisions } => {
            generate::disc(Point2::new(centre[0], centre[1]), *radius, divisions[0], divisions[1])
        }
        MeshSpec::AnnulusSector { inner_radius, outer_radius, angles, divisions, radial_grading } => {
            let sector = generate::Sector {
                r_in: *inner_radius,
                r_out: *outer_radius,
                theta0: angles[0].to_radians(),
                theta1: angles[1].to_radians(),
            };
            generate::annulus_sector(sector, divisions[0], divisions[1], *radial_grading)
        }
        MeshSpec::HalfDisc { centre, radius, divisions, radial_grading, angular_grading, upside_down, fine_zone } => {
            let c = Point2::new(centre[0], centre[1]);
            let disc = match fine_zone {
                Some(z) => {
                    if z.divisions % 2 != 0 {
                        return Err(format!("fine_zone.divisions must be even on a half disc (got {})", z.divisions));
                    }
                    if !(*radius > 0.0 && *radial_grading > 0.0) || divisions[0] == 0 {
                        return Err("half disc needs a positive radius, radial grading and ring count".into());
                    }
                    let arc = std::f64::consts::PI * radius;
                    let ts = fine_zone_lines(z, z.width / arc, divisions[1], "half arc")?;
                    let rs = generate::graded(divisions[0], 1.0 / radial_grading);
                    generate::half_disc_from_divisions(c, *radius, &rs, &ts)
                }
                None => generate::half_disc(c, *radius, divisions[0], divisions[1], *radial_grading, *angular_grading),
            };
            disc.map(|mut m| {
                if *upside_down {
                    // A rotation keeps the cells' orientation and the sets' meaning.
                    let c = Point2::new(centre[0], centre[1]);
                    m.nodes.iter_mut().for_each(|p| *p = c - (*p - c));
                }
                m
            })
        }
        MeshSpec::Gmsh { file } => {
            let p = if file.is_absolute() { file.clone() } else { base.join(file) };
            return gmsh::read_msh(&p).map_err(|e| e.to_string());
        }
    };
    m.map_err(|e| e.to_string())
}
