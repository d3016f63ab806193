//! The `mortex` binary on good and bad input: bad input gives a clear message naming the file,
//! key or element, a non-zero exit code, never a panic, and never damages an earlier result.

mod common;

use std::path::Path;
use std::process::Command;

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_mortex"))
}

/// Width and height of a PNG file from its header, after checking its signature.
fn png_size(path: &Path) -> (u32, u32) {
    let bytes = std::fs::read(path).unwrap();
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n", "{}: PNG signature", path.display());
    let dim = |k: usize| u32::from_be_bytes([bytes[k], bytes[k + 1], bytes[k + 2], bytes[k + 3]]);
    (dim(16), dim(20))
}

/// This test's scratch directory, removed when it passes.
fn tmpdir(name: &str) -> common::ScratchDir {
    common::ScratchDir::new("cli", name)
}

const GOOD: &str = r#"
[problem]
hypothesis = "plane_strain"

[[materials]]
name = "steel"
model = "elastic"
young = 210000.0
poisson = 0.3

[[bodies]]
name = "block"
material = "steel"
mesh = { type = "rectangle", size = [10.0, 2.0], divisions = [10, 2] }

[[bcs]]
body = "block"
set = "left"
ux = 0.0
uy = 0.0

[[loads]]
body = "block"
set = "right"
traction = [0.0, -1.0]
"#;

/// A perfectly plastic thick cylinder pressed beyond its limit load (Hill: p_L = 2 sigma_y /
/// sqrt(3) ln(b/a) = 200.1 MPa): steps 1-3 (p <= 195 MPa) converge, step 4 (260 MPa) cannot.
const BEYOND_LIMIT: &str = r#"
[problem]
hypothesis = "plane_strain"
[[materials]]
name = "steel"
model = "j2_plastic"
young = 210000.0
poisson = 0.3
yield_stress = 250.0
[[bodies]]
name = "cyl"
material = "steel"
mesh = { type = "annulus_sector", inner_radius = 1.0, outer_radius = 2.0, angles = [0.0, 90.0], divisions = [8, 4] }
[[bcs]]
body = "cyl"
set = "start"
uy = 0.0
[[bcs]]
body = "cyl"
set = "end"
ux = 0.0
[[loads]]
body = "cyl"
set = "inner"
pressure = 1.0
[steps]
path = [[0.0, 0.0], [1.0, 260.0]]
increments = 4
[solver.newton]
max_cutbacks = 4
"#;

/// Runs `mortex <args>` and returns (exit success, stderr + stdout).
fn run(args: &[&str], dir: &Path) -> (bool, String) {
    let out = bin().args(args).current_dir(dir).output().unwrap();
    let text = format!("{}{}", String::from_utf8_lossy(&out.stderr), String::from_utf8_lossy(&out.stdout));
    (out.status.success(), text)
}

fn expect_error(dir: &Path, name: &str, case: &str, needles: &[&str]) {
    let p = dir.join(format!("{name}.toml"));
    std::fs::write(&p, case).unwrap();
    for cmd in ["check", "run"] {
        let (ok, text) = run(
            &[cmd, p.to_str().unwrap(), "--quiet"]
                .into_iter()
                .filter(|a| cmd == "run" || *a != "--quiet")
                .collect::<Vec<_>>(),
            dir,
        );
        assert!(!ok, "{name}: '{cmd}' should fail:\n{text}");
        assert!(!text.contains("panicked"), "{name}: panic:\n{text}");
        for n in needles {
            assert!(text.contains(n), "{name}: '{cmd}' message should contain '{n}':\n{text}");
        }
    }
}

#[test]
fn good_case_checks_and_runs() {
    let d = tmpdir("good");
    std::fs::write(d.join("good.toml"), GOOD).unwrap();
    let (ok, text) = run(&["check", "good.toml"], &d);
    assert!(ok, "{text}");
    assert!(text.contains("33 nodes, 20 cells") && text.contains("edge set 'right'"), "{text}");
    let (ok, text) = run(&["run", "good.toml", "--quiet"], &d);
    assert!(ok, "{text}");
    assert!(d.join("results/good.h5").exists() && d.join("results/good.xdmf").exists());
}

#[test]
fn bad_inputs_give_clear_errors() {
    let d = tmpdir("bad");
    expect_error(&d, "malformed", "[problem\nhypothesis = 1", &["malformed.toml", "invalid TOML"]);
    expect_error(
        &d,
        "unknown_key",
        &GOOD.replace("poisson = 0.3", "poisson = 0.3\ndensity = 7.8"),
        &["unknown_key.toml", "not a valid case", "unknown field `density`"],
    );
    // A negative wear coefficient quoted as written (-5e-8), not as -0.00000005.
    let worn = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("wear_cases/uniform_wear.toml"))
        .unwrap()
        .replace("coefficient = ", "coefficient = -5e-8 # ");
    expect_error(&d, "negative_k", &worn, &["negative_k.toml", "coefficient", "got -5e-8"]);
    expect_error(&d, "nu_half", &GOOD.replace("poisson = 0.3", "poisson = 0.5"), &["materials[0].poisson", "nu < 0.5"]);
    expect_error(
        &d,
        "negative_e",
        &GOOD.replace("young = 210000.0", "young = -1.0"),
        &["materials[0].young", "positive"],
    );
    expect_error(
        &d,
        "bad_tag",
        &GOOD.replace("set = \"left\"", "set = \"clamped\""),
        &["bcs[0].set", "no set named 'clamped'", "available: "],
    );
    expect_error(
        &d,
        "missing_mesh",
        &GOOD.replace(
            "{ type = \"rectangle\", size = [10.0, 2.0], divisions = [10, 2] }",
            "{ type = \"gmsh\", file = \"nowhere.msh\" }",
        ),
        &["bodies[0].mesh", "nowhere.msh", "cannot read"],
    );
    expect_error(
        &d,
        "unknown_material",
        &GOOD.replace("material = \"steel\"", "material = \"titanium\""),
        &["bodies[0].material", "titanium"],
    );
    expect_error(&d, "no_load_kind", &GOOD.replace("traction = [0.0, -1.0]", ""), &["loads[0]", "exactly one of"]);
    expect_error(
        &d,
        "gradient_alone",
        &GOOD.replace("traction = [0.0, -1.0]", "pressure = 1.0\ntraction_gradient = [[0.0, 1.0], [0.0, 0.0]]"),
        &["loads[0].traction_gradient", "needs traction"],
    );
    expect_error(
        &d,
        "gradient_nan",
        &GOOD.replace("traction = [0.0, -1.0]", "traction = [0.0, -1.0]\ntraction_gradient = [[0.0, nan], [0.0, 0.0]]"),
        &["loads[0].traction_gradient"],
    );
    // Gmsh files: an inverted (bow-tie) quad and an unsupported second-order triangle.
    let msh_head = "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n1 5 1 5\n2 1 0 5\n1\n2\n3\n4\n5\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n2 0 0\n$EndNodes\n";
    std::fs::write(
        d.join("bowtie.msh"),
        format!("{msh_head}$Elements\n1 2 1 2\n2 1 3 2\n1 1 2 3 4\n2 2 5 4 3\n$EndElements\n"),
    )
    .unwrap();
    expect_error(
        &d,
        "inverted",
        &GOOD.replace(
            "{ type = \"rectangle\", size = [10.0, 2.0], divisions = [10, 2] }",
            "{ type = \"gmsh\", file = \"bowtie.msh\" }",
        ),
        &["bowtie.msh", "cell 1", "inverted or degenerate"],
    );
    std::fs::write(d.join("t6.msh"), format!("{msh_head}$Elements\n1 1 1 1\n2 1 9 1\n7 1 2 3 4 5 1\n$EndElements\n"))
        .unwrap();
    expect_error(
        &d,
        "t6",
        &GOOD.replace(
            "{ type = \"rectangle\", size = [10.0, 2.0], divisions = [10, 2] }",
            "{ type = \"gmsh\", file = \"t6.msh\" }",
        ),
        &["t6.msh", "element 7", "unsupported Gmsh type 9"],
    );
    // Ties: unknown body, boundary sets that do not close, a patch reaching outside the host.
    let tie = |patch_mesh: &str, boundary: &str, host: &str| {
        format!(
            "{GOOD}\n[[bodies]]\nname = \"patch\"\nmaterial = \"steel\"\nmesh = {patch_mesh}\n\n[[ties]]\nhost = \"{host}\"\npatch = \"patch\"\nboundary = {boundary}\n"
        )
    };
    let inside = "{ type = \"rectangle\", origin = [2.0, 0.5], size = [1.0, 1.0], divisions = [4, 4] }";
    expect_error(
        &d,
        "tie_body",
        &tie(inside, "[\"bottom\", \"right\", \"top\", \"left\"]", "hull"),
        &["ties[0].host", "no body named 'hull'"],
    );
    expect_error(
        &d,
        "tie_open",
        &tie(inside, "[\"bottom\", \"right\"]", "block"),
        &["ties[0]", "open surface ends inside the host"],
    );
    let outside = "{ type = \"rectangle\", origin = [9.5, 0.5], size = [1.0, 1.0], divisions = [4, 4] }";
    expect_error(
        &d,
        "tie_outside",
        &tie(outside, "[\"bottom\", \"right\", \"top\", \"left\"]", "block"),
        &["ties[0]", "leaves the host mesh"],
    );
    // A missing case file.
    let (ok, text) = run(&["check", "absent.toml"], &d);
    assert!(!ok && text.contains("absent.toml") && text.contains("cannot read"), "{text}");
}

#[test]
fn a_failed_run_never_damages_an_earlier_result() {
    let d = tmpdir("keep");
    std::fs::write(d.join("good.toml"), GOOD).unwrap();
    let (ok, _) = run(&["run", "good.toml", "--quiet", "-o", "out.h5"], &d);
    assert!(ok);
    let before = std::fs::read(d.join("out.h5")).unwrap();
    std::fs::write(d.join("bad.toml"), GOOD.replace("poisson = 0.3", "poisson = 0.7")).unwrap();
    let (ok, _) = run(&["run", "bad.toml", "--quiet", "-o", "out.h5"], &d);
    assert!(!ok);
    assert_eq!(before, std::fs::read(d.join("out.h5")).unwrap(), "the earlier result must be untouched");
}

/// Beyond the limit load of a perfectly plastic cylinder (Hill: p_L = 2 sigma_y/sqrt(3) ln(b/a)
/// = 200.1 MPa), Newton cannot converge: a typed error naming the step, a non-zero exit, and
/// the converged steps kept in the output with `completed = 0`.
#[test]
fn newton_failure_beyond_limit_load_is_reported() {
    let d = tmpdir("limit");
    let case = BEYOND_LIMIT;
    std::fs::write(d.join("limit.toml"), case).unwrap();
    let (ok, text) = run(&["run", "limit.toml", "--quiet"], &d);
    assert!(!ok, "{text}");
    assert!(!text.contains("panicked"), "{text}");
    assert!(text.contains("did not converge in step 4") && text.contains("kept in"), "{text}");
    let f = hdf5::File::open(d.join("results/limit.h5")).unwrap();
    let completed: u8 = f.attr("completed").unwrap().read_scalar().unwrap();
    let steps: u64 = f.attr("num_steps").unwrap().read_scalar().unwrap();
    assert_eq!((completed, steps), (0, 3), "steps 1-3 (p <= 195 MPa < 200.1) converge, step 4 (260) cannot");
}

/// `run --restart`: the continuation goes to a new file (`<name>_from<k>.h5`) holding the steps
/// after the checkpoint, bit for bit those of the uninterrupted run (compared as raw bytes of
/// the displacement datasets); it refuses to overwrite the file it resumes from, a missing
/// checkpoint step and a checkpoint at the case's last step are clear errors, and the earlier
/// result is never touched.
#[test]
fn restart_from_a_checkpoint() {
    let d = tmpdir("restart");
    let case = GOOD.to_string() + "\n[steps]\npath = [[0.0, 0.0], [1.0, 1.0]]\nincrements = 4\n";
    std::fs::write(d.join("good.toml"), case).unwrap();
    let (ok, text) = run(&["run", "good.toml", "--quiet", "-o", "full.h5"], &d);
    assert!(ok, "{text}");
    let before = std::fs::read(d.join("full.h5")).unwrap();
    let (ok, text) = run(&["run", "good.toml", "--quiet", "--restart", "full.h5", "--from-step", "2"], &d);
    assert!(ok, "{text}");
    let a = hdf5::File::open(d.join("full.h5")).unwrap();
    let b = hdf5::File::open(d.join("full_from2.h5")).unwrap();
    assert_eq!(b.group("steps").unwrap().member_names().unwrap(), vec!["000003", "000004"]);
    for k in ["000003", "000004"] {
        let x: Vec<f64> = a.dataset(&format!("steps/{k}/block/displacement")).unwrap().read_raw().unwrap();
        let y: Vec<f64> = b.dataset(&format!("steps/{k}/block/displacement")).unwrap().read_raw().unwrap();
        assert!(x.iter().zip(&y).all(|(p, q)| p.to_bits() == q.to_bits()) && x.len() == y.len(), "step {k}");
    }
    drop((a, b));
    for (args, needle) in [
        (vec!["--restart", "full.h5", "-o", "full.h5"], "overwrite the file it resumes from"),
        (vec!["--restart", "full.h5", "--from-step", "7"], "no checkpoint at step 7"),
        (vec!["--restart", "full.h5"], "nothing to run"),
        (vec!["--restart", "missing.h5"], "missing.h5"),
    ] {
        let mut all = vec!["run", "good.toml", "--quiet"];
        all.extend(args);
        let (ok, text) = run(&all, &d);
        assert!(!ok && text.contains(needle) && !text.contains("panicked"), "{all:?}:\n{text}");
    }
    assert_eq!(before, std::fs::read(d.join("full.h5")).unwrap(), "the earlier result must be untouched");
}

/// A wear run's checkpoint records the path it was written on: a restart under a case whose
/// `[steps] increments` (or `cycle`, a curve, a load) changed is refused with the key named,
/// the earlier result untouched; `[steps] cycles` may change (a run extended). Two
/// continuations of one file and step without `--output` are both kept, under two names.
#[test]
fn wear_restart_refuses_a_changed_path_and_keeps_every_continuation() {
    let d = tmpdir("wear_restart");
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(root.join("wear_cases/uniform_wear.toml")).unwrap();
    assert!(text.contains("cycles = 20") && text.contains("increments = 4"));
    let case = text.replace("cycles = 20", "cycles = 3") + "\n[output]\ncheckpoint_every = 1\nkeep_checkpoints = 0\n";
    std::fs::write(d.join("wear.toml"), &case).unwrap();
    let (ok, out) = run(&["run", "wear.toml", "--quiet", "-o", "full.h5"], &d);
    assert!(ok, "{out}");
    let before = std::fs::read(d.join("full.h5")).unwrap();
    std::fs::write(d.join("changed.toml"), case.replace("increments = 4", "increments = 8")).unwrap();
    let (ok, out) = run(&["run", "changed.toml", "--quiet", "--restart", "full.h5", "--from-step", "3"], &d);
    assert!(!ok && out.contains("[steps] increments") && !out.contains("panicked"), "{out}");
    assert!(!d.join("full_from3.h5").exists(), "a refused restart writes nothing");
    // One more cycle: the path is the same.
    std::fs::write(d.join("longer.toml"), case.replace("cycles = 3", "cycles = 4")).unwrap();
    for name in ["full_from3.h5", "full_from3_2.h5"] {
        let (ok, out) = run(&["run", "longer.toml", "--quiet", "--restart", "full.h5", "--from-step", "3"], &d);
        assert!(ok && d.join(name).exists(), "{name}: {out}");
    }
    let steps = |f: &str| hdf5::File::open(d.join(f)).unwrap().group("steps").unwrap().member_names().unwrap();
    assert_eq!(steps("full_from3.h5"), steps("full_from3_2.h5"));
    assert_eq!(before, std::fs::read(d.join("full.h5")).unwrap(), "the earlier result must be untouched");
}

/// `plot`: a PNG of the contact profile (1000 x 700 pixels, read from the PNG header) for the
/// last or a chosen step of the shipped Cattaneo-Mindlin case; bad requests (no contact in the
/// result, unknown pair, missing step, bad x range) are clear errors.
#[test]
fn plot_contact_profile_png() {
    let d = tmpdir("plot");
    let case = Path::new(env!("CARGO_MANIFEST_DIR")).join("wear_cases/cattaneo_mindlin.toml");
    let (ok, text) = run(&["run", case.to_str().unwrap(), "--quiet", "-o", "cm.h5"], &d);
    assert!(ok, "{text}");
    for (args, png) in
        [(vec!["plot", "cm.h5"], "cm_pair_step2.png"), (vec!["plot", "cm.h5", "--step", "1", "-o", "n.png"], "n.png")]
    {
        let (ok, text) = run(&args, &d);
        assert!(ok, "{args:?}: {text}");
        assert_eq!(png_size(&d.join(png)), (1000, 700), "{png}: IHDR size");
        // The case's [reference]: p0 and a of its header, c = a sqrt(1 - Q / (mu P)).
        assert!(text.contains("against Cattaneo-Mindlin (p0 = 857.06") && text.contains("a = 0.0742"), "{text}");
        assert!(text.contains("c = 0.0525"), "{text}");
    }
    let (_, text) = run(&["plot", "cm.h5"], &d);
    let figure = |label: &str| -> f64 {
        let at = text.find(label).unwrap_or_else(|| panic!("{label}: {text}")) + label.len();
        text[at..].trim_start().split('%').next().unwrap().parse().unwrap()
    };
    // Half-space theory against the finite cylinders' discretisation: 2% for the pressure
    // (the Hertz case meets 1%), 5% for the shear, whose stick-zone edge carries its kink
    // between two nodes (tests/cases.rs checks the stick zone's width to 3%).
    let (p, q) = (figure("pressure L2 over |x - x0| < a"), figure("shear L2"));
    assert!(p < 2.0 && q < 5.0, "pressure {p}%, shear {q}%");
    std::fs::write(d.join("good.toml"), GOOD).unwrap();
    assert!(run(&["run", "good.toml", "--quiet", "-o", "plain.h5"], &d).0);
    for (args, needle) in [
        (vec!["plot", "plain.h5"], "no contact pair"),
        (vec!["plot", "cm.h5", "--pair", "nope"], "no contact pair 'nope'"),
        (vec!["plot", "cm.h5", "--step", "9"], "no output step 9"),
        (vec!["plot", "cm.h5", "--xlim", "1", "-1"], "X_MIN < X_MAX"),
        (vec!["plot", "missing.h5"], "missing.h5"),
    ] {
        let (ok, text) = run(&args, &d);
        assert!(!ok && text.contains(needle) && !text.contains("panicked"), "{args:?}:\n{text}");
    }
}

/// `mortex plot --cycle`: the pressure at every increment of the recorded cycle nearest to the
/// one asked, one 900 x 380 panel per increment (uniform_wear: 4 increments per cycle), with a
/// reference run drawn beside it; a run without cycles or without contact is a clear error.
/// `mortex plot --wear` of the same run: one 1000 x 350 panel of scar profiles per wearing
/// surface (one here), then the largest depth and the worn area against the cycles; a run
/// without wear is a clear error.
#[test]
fn plot_pressure_over_a_cycle_png() {
    let d = tmpdir("plot_cycle");
    let case = Path::new(env!("CARGO_MANIFEST_DIR")).join("wear_cases/uniform_wear.toml");
    let (ok, text) = run(&["run", case.to_str().unwrap(), "--quiet", "-o", "uw.h5"], &d);
    assert!(ok, "{text}");
    let (ok, text) = run(&["plot", "uw.h5", "--cycle", "7", "--reference", "uw.h5"], &d);
    assert!(ok && text.contains("cycle 7: 4 increments"), "{text}");
    assert_eq!(png_size(&d.join("uw_cycle7.png")), (900, 4 * 380), "IHDR size");
    // The same chart as SVG beside it, its text in the shipped font's family.
    let svg = std::fs::read_to_string(d.join("uw_cycle7.svg")).unwrap();
    assert!(svg.contains("<svg") && svg.contains("width=\"900\"") && svg.contains("height=\"1520\""), "SVG header");
    assert!(svg.contains("sans-serif") && svg.contains("cycle 7"), "SVG labels");
    let (ok, text) = run(&["plot", "uw.h5", "--wear"], &d);
    assert!(ok, "{text}");
    assert_eq!(png_size(&d.join("uw_wear.png")), (1000, (1 + 2) * 350), "IHDR size");
    std::fs::write(d.join("good.toml"), GOOD).unwrap();
    assert!(run(&["run", "good.toml", "--quiet", "-o", "plain.h5"], &d).0);
    for (args, needle) in [
        (vec!["plot", "plain.h5", "--cycle", "1"], "no contact pair"),
        (vec!["plot", "uw.h5", "--cycle", "1", "--pair", "nope"], "no contact pair 'nope'"),
        (vec!["plot", "uw.h5", "--cycle", "1", "--reference", "missing.h5"], "missing.h5"),
        (vec!["plot", "plain.h5", "--wear"], "not a wear run"),
    ] {
        let (ok, text) = run(&args, &d);
        assert!(!ok && text.contains(needle) && !text.contains("panicked"), "{args:?}:\n{text}");
    }
}

/// A contact step that cannot converge (two Newton and two active-set iterations allowed, no
/// cut-back) is a typed error naming the step, iteration, residual and the size of the active
/// contact set.
#[test]
fn contact_newton_failure_reports_the_active_set() {
    let d = tmpdir("contact-fail");
    let case = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("wear_cases/cattaneo_mindlin.toml"))
        .unwrap()
        + "\n[solver.newton]\nmax_iterations = 2\nmax_set_iterations = 2\nmax_cutbacks = 0\n";
    std::fs::write(d.join("fail.toml"), case).unwrap();
    let (ok, text) = run(&["run", "fail.toml", "--quiet", "-o", "fail.h5"], &d);
    assert!(!ok && !text.contains("panicked"), "{text}");
    assert!(text.contains("step 1") && text.contains("iteration 2"), "{text}");
    let active: usize = text
        .split(" active contact nodes")
        .next()
        .and_then(|h| h.rsplit(' ').next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no active-set size in: {text}"));
    assert!(active > 0, "{text}");
}

/// Bad input found by trying the engine as a new user (each: a message naming file and key,
/// non-zero exit, no panic, nothing written).
#[test]
fn more_bad_inputs_give_clear_errors() {
    let d = tmpdir("bad2");
    let mesh = "{ type = \"rectangle\", size = [10.0, 2.0], divisions = [10, 2] }";
    expect_error(
        &d,
        "rotation_nan",
        &GOOD.replace(mesh, "{ type = \"rectangle\", size = [10.0, 2.0], divisions = [10, 2], rotation = nan }"),
        &["rotation_nan.toml", "bodies[0].mesh", "finite"],
    );
    expect_error(
        &d,
        "no_set_iterations",
        &format!("{GOOD}\n[solver.newton]\nmax_set_iterations = 0\n"),
        &["no_set_iterations.toml", "solver.newton.max_set_iterations", "at least 1"],
    );
    expect_error(
        &d,
        "huge_mesh",
        &GOOD.replace(mesh, "{ type = \"rectangle\", size = [10.0, 2.0], divisions = [100000, 100000] }"),
        &["huge_mesh.toml", "bodies[0].mesh", "exceed"],
    );
    expect_error(
        &d,
        "huge_increments",
        &format!("{GOOD}\n[steps]\nincrements = 1000000000000\n"),
        &["huge_increments.toml", "steps.increments", "more than"],
    );
    expect_error(
        &d,
        "many_increments",
        &format!("{GOOD}\n[steps]\nincrements = 100000000\n"),
        &["many_increments.toml", "steps.increments", "more than"],
    );
    let cut = "\n[[cuts]]\nbody = \"block\"\npoints = [[-1.0, 1.0], [11.0, 1.5]]\nkeep = \"right\"\n";
    expect_error(
        &d,
        "motion_both",
        &format!("{GOOD}{cut}motion = {{ offset = 0.1, translation = [0.0, 1.0] }}\n"),
        &["motion_both.toml", "cuts[0].motion", "exactly one of"],
    );
    expect_error(
        &d,
        "motion_nan",
        &format!("{GOOD}{cut}motion = {{ offset = nan }}\n"),
        &["motion_nan.toml", "cuts[0].motion.offset", "finite"],
    );
    expect_error(
        &d,
        "motion_curve",
        &format!("{GOOD}{cut}motion = {{ offset = 0.1, curve = \"wear\" }}\n"),
        &["motion_curve.toml", "cuts[0].motion.curve", "no curve named 'wear'"],
    );
    expect_error(
        &d,
        "cycle_open",
        &format!("{GOOD}\n[steps]\npath = [[0.0, 0.0], [1.0, 1.0], [2.0, 0.5]]\ncycle = [1.0, 2.0]\ncycles = 3\n"),
        &["cycle_open.toml", "steps.cycle", "does not close"],
    );
    expect_error(
        &d,
        "cycle_outside",
        &format!("{GOOD}\n[steps]\npath = [[0.0, 0.0], [1.0, 1.0]]\ncycle = [0.5, 3.0]\ncycles = 3\n"),
        &["cycle_outside.toml", "steps.cycle", "inside the load history"],
    );
    expect_error(
        &d,
        "cycles_huge",
        &format!("{GOOD}\n[steps]\npath = [[0.0, 0.0], [1.0, 1.0], [2.0, 1.0]]\ncycle = [1.0, 2.0]\ncycles = 100000000\nincrements = 8\n"),
        &["cycles_huge.toml", "steps.cycles", "more than"],
    );
    expect_error(&d, "fields_zero", &format!("{GOOD}\n[output]\nfields_every = 0\n"), &["output.fields_every"]);
    // A self-intersecting cut: the segments are numbered as the user gave them, whichever side
    // is kept.
    expect_error(
        &d,
        "self_cross",
        &format!("{GOOD}\n[[cuts]]\nbody = \"block\"\npoints = [[-1.0, 0.5], [11.0, 0.5], [11.0, 1.5], [5.0, -1.0]]\nkeep = \"right\"\n"),
        &["self_cross.toml", "cuts[0]", "segments 0 and 2"],
    );
    for name in ["rotation_nan", "huge_increments", "motion_both", "cycle_open"] {
        assert!(!d.join(format!("results/{name}.h5")).exists(), "{name}: nothing may be written");
    }
}

/// A valid run whose bodies have void cells writes zeros (not 0/0) for their cell fields, and
/// every value of every dataset is finite.
#[test]
fn void_cells_write_finite_fields() {
    let d = tmpdir("void");
    let case = format!("{GOOD}\n[[cuts]]\nbody = \"block\"\npoints = [[-1.0, 0.7], [11.0, 0.7]]\nkeep = \"right\"\n");
    std::fs::write(d.join("void.toml"), case).unwrap();
    let (ok, text) = run(&["run", "void.toml", "--quiet"], &d);
    assert!(ok, "{text}");
    let f = hdf5::File::open(d.join("results/void.h5")).unwrap();
    for name in ["cell_stress", "cell_eqps", "stress", "displacement", "von_mises"] {
        let v = f.dataset(&format!("steps/000001/block/{name}")).unwrap().read_raw::<f64>().unwrap();
        assert!(v.iter().all(|x| x.is_finite()), "{name} has non-finite values");
    }
    let cs = f.dataset("steps/000001/block/cell_stress").unwrap().read_2d::<f64>().unwrap();
    // Row 19 (top right cell, y in [1, 2]) is void: zeros.
    assert!(cs.row(19).iter().all(|v| *v == 0.0), "void cell: {:?}", cs.row(19));
}

/// A run that stops on a Newton failure keeps its converged steps in `<out>.h5.partial` when
/// `<out>.h5` already holds an earlier result, which stays untouched (as does its XDMF).
#[test]
fn a_failed_run_keeps_its_steps_beside_an_earlier_result() {
    let d = tmpdir("fail_keep");
    std::fs::write(d.join("good.toml"), GOOD).unwrap();
    let (ok, _) = run(&["run", "good.toml", "--quiet", "-o", "out.h5"], &d);
    assert!(ok);
    let before = std::fs::read(d.join("out.h5")).unwrap();
    let xdmf_before = std::fs::read(d.join("out.xdmf")).unwrap();
    // A plastic cylinder beyond its limit load, two cut-backs allowed.
    let case = BEYOND_LIMIT.replace("max_cutbacks = 4", "max_cutbacks = 2");
    std::fs::write(d.join("limit.toml"), case).unwrap();
    let (ok, text) = run(&["run", "limit.toml", "--quiet", "-o", "out.h5"], &d);
    assert!(!ok && text.contains("out.h5.partial"), "{text}");
    assert_eq!(before, std::fs::read(d.join("out.h5")).unwrap(), "the earlier result must be untouched");
    assert_eq!(xdmf_before, std::fs::read(d.join("out.xdmf")).unwrap(), "its XDMF too");
    let f = hdf5::File::open(d.join("out.h5.partial")).unwrap();
    let steps: u64 = f.attr("num_steps").unwrap().read_scalar().unwrap();
    assert_eq!(steps, 3);
}

/// Output selection: with `fields_every = 4` and `checkpoint_every = 5` over 10 steps, step
/// groups exist only at steps with a snapshot (4, 5, 8, 10: full fields at 4, 8 and the last,
/// checkpoints at 5 and 10), the per-step series holds all 10 rows, and the XDMF lists every
/// step, the bodies with the fields of the latest full-field step (none before step 4).
#[test]
fn output_selection_writes_series_every_step_and_fields_every_k() {
    let d = tmpdir("select");
    let case = format!("{GOOD}\n[steps]\nincrements = 10\n[output]\nfields_every = 4\ncheckpoint_every = 5\n");
    std::fs::write(d.join("sel.toml"), case).unwrap();
    let (ok, text) = run(&["run", "sel.toml", "--quiet"], &d);
    assert!(ok, "{text}");
    let f = hdf5::File::open(d.join("results/sel.h5")).unwrap();
    let mut groups: Vec<String> = f.group("steps").unwrap().member_names().unwrap();
    groups.sort();
    assert_eq!(groups, ["000004", "000005", "000008", "000010"]);
    let steps: Vec<u64> = f.dataset("series/step").unwrap().read_raw().unwrap();
    assert_eq!(steps, (1..=10).collect::<Vec<u64>>());
    assert!(f.group("steps/000005").unwrap().link_exists("checkpoint"));
    assert!(!f.group("steps/000005").unwrap().link_exists("block"), "step 5 has no full fields");
    let xdmf = std::fs::read_to_string(d.join("results/sel.xdmf")).unwrap();
    // Every step is a time; the bodies show the fields of the latest step that holds them.
    let listed: Vec<&str> = xdmf.split("<Grid Name=\"step_").skip(1).collect();
    assert_eq!(listed.len(), 10, "{xdmf}");
    for (k, grid) in listed.iter().enumerate() {
        let fields = grid.find("/steps/").map(|i| &grid[i + 7..i + 13]);
        let expected = match k + 1 {
            1..=3 => None,
            4..=7 => Some("000004"),
            8 | 9 => Some("000008"),
            _ => Some("000010"),
        };
        assert_eq!(fields, expected, "step {}: {grid}", k + 1);
    }
}

/// A tie whose closed boundary loop has an edge on the host's own boundary (a fine patch over a
/// contact zone, its top edge on the host's top face) is an error naming the tie and the edge;
/// the open loop (`["left", "bottom", "right"]`) is the right input and runs.
#[test]
fn tie_loop_with_an_edge_on_the_host_boundary_is_an_error() {
    let d = tmpdir("tieloop");
    let case = |boundary: &str| {
        format!(
            r#"
[problem]
hypothesis = "plane_strain"
[[materials]]
name = "steel"
model = "elastic"
young = 210000.0
poisson = 0.3
[[bodies]]
name = "host"
material = "steel"
mesh = {{ type = "rectangle", size = [10.0, 4.0], divisions = [10, 4] }}
[[bodies]]
name = "patch"
material = "steel"
mesh = {{ type = "rectangle", origin = [3.0, 2.0], size = [4.0, 2.0], divisions = [12, 6] }}
[[ties]]
name = "fine_zone"
host = "host"
patch = "patch"
boundary = {boundary}
[[bcs]]
body = "host"
set = "bottom"
ux = 0.0
uy = 0.0
[[loads]]
body = "patch"
set = "top"
pressure = 10.0
"#
        )
    };
    expect_error(
        &d,
        "closed_on_boundary",
        &case(r#"["bottom", "right", "top", "left"]"#),
        &["closed_on_boundary.toml", "ties[0]", "fine_zone", "outer boundary", "couples nothing"],
    );
    std::fs::write(d.join("open.toml"), case(r#"["left", "bottom", "right"]"#)).unwrap();
    let (ok, text) = run(&["run", "open.toml", "--quiet"], &d);
    assert!(ok, "{text}");
}

/// `[reference]` errors: a tangential force at or above `mu P` (no stick zone), an unknown
/// contact, a tangential force on a Hertz reference, a negative radius, a bulk stress whose
/// stick-zone offset leaves the contact, a bulk stress on a Hertz reference. Each a clear error
/// naming the file and key, before anything runs.
#[test]
fn reference_bad_inputs_give_clear_errors() {
    let d = tmpdir("reference_bad");
    let good = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("wear_cases/cattaneo_mindlin.toml"))
        .unwrap();
    let sub = |from: &str, to: &str| {
        assert!(good.contains(from), "{from}");
        good.replace(from, to)
    };
    expect_error(
        &d,
        "gross",
        &sub("tangential = 15.0", "tangential = 30.0"),
        &["gross.toml", "reference.tangential", "gross slip"],
    );
    expect_error(
        &d,
        "nope",
        &sub("kind = \"cattaneo_mindlin\"", "kind = \"cattaneo_mindlin\"\ncontact = \"nope\""),
        &["nope.toml", "reference.contact", "nope"],
    );
    expect_error(
        &d,
        "hertz_q",
        &sub("kind = \"cattaneo_mindlin\"", "kind = \"hertz\""),
        &["hertz_q.toml", "reference.tangential"],
    );
    expect_error(&d, "neg_r", &sub("radius = 5.0", "radius = -5.0"), &["neg_r.toml", "reference.radius"]);
    // A bulk stress that would push the stick zone (c = 0.0525 of a = 0.0743) past the edge:
    // e = sigma a / (4 mu p0) = 0.0289 at 400 MPa, beyond a - c = 0.0218.
    expect_error(
        &d,
        "bulk",
        &sub("tangential = 15.0", "tangential = 15.0\nbulk = 400.0"),
        &["bulk.toml", "reference.bulk", "|e| + c <= a"],
    );
    expect_error(
        &d,
        "hertz_bulk",
        &sub("kind = \"cattaneo_mindlin\"", "kind = \"hertz\"").replace("tangential = 15.0", "bulk = 10.0"),
        &["hertz_bulk.toml", "reference.bulk"],
    );
}

/// Wear input errors: negative or NaN coefficient, a wearing cut in contact with nothing, an
/// unknown cut, one increment per cycle, a wearing body surface in contact with nothing (named
/// by its `surface` key), zero stroke (nothing ever wears), wear deeper than the prepared band; restarts
/// from a checkpoint of another case or a damaged file. Each a clear error naming the file and
/// key (or what is wrong), non-zero exit, no panic, and the earlier result untouched.
#[test]
fn wear_bad_inputs_give_clear_errors() {
    let d = tmpdir("wear_bad");
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let good = std::fs::read_to_string(root.join("wear_cases/uniform_wear.toml")).unwrap();
    let sub = |from: &str, to: &str| {
        assert!(good.contains(from), "{from}");
        good.replace(from, to)
    };
    expect_error(
        &d,
        "neg_k",
        &sub("coefficient = 4e-3", "coefficient = -4e-3"),
        &["neg_k.toml", "wear[0].coefficient", ">= 0"],
    );
    expect_error(&d, "nan_k", &sub("coefficient = 4e-3", "coefficient = nan"), &["nan_k.toml", "wear[0].coefficient"]);
    expect_error(
        &d,
        "no_cut",
        &sub("cut = \"surface\"\ncoefficient", "cut = \"nowhere\"\ncoefficient"),
        &["no_cut.toml", "wear[0].cut", "nowhere"],
    );
    let lonely = sub(
        "[[contacts]]",
        "[[cuts]]\nname = \"lonely\"\nbody = \"host\"\npoints = [[-1.0, 1.0], [5.0, 1.0]]\nkeep = \"right\"\n\n[[wear]]\ncut = \"lonely\"\ncoefficient = 1e-3\nmax_depth = 0.1\n\n[[contacts]]",
    );
    expect_error(&d, "lonely", &lonely, &["lonely.toml", "wear[0].cut", "lonely", "not in contact with anything"]);
    expect_error(
        &d,
        "no_cycle",
        &sub("cycle = [1.0, 2.0]\ncycles = 20\n", ""),
        &["no_cycle.toml", "wear", "steps.cycle"],
    );
    expect_error(
        &d,
        "one_increment",
        &sub("increments = 4", "increments = 1"),
        &["one_increment.toml", "steps.increments", "only the cycle's end"],
    );
    // A wearing surface given by body and surface is named by those keys.
    let mccoll = std::fs::read_to_string(root.join("wear_cases/mccoll_fretting.toml")).unwrap();
    let from = "body = \"cylinder\"\nsurface = [\"arc\"]\ncoefficient";
    assert!(mccoll.contains(from));
    expect_error(
        &d,
        "by_surface",
        &mccoll.replace(from, "body = \"cylinder\"\nsurface = [\"top\"]\ncoefficient"),
        &["by_surface.toml", "wear[1].surface", "not in contact"],
    );
    expect_error(
        &d,
        "bad_change",
        &sub("[cycle_jump]\nfixed = 1", "[cycle_jump]\npressure_change = -0.2"),
        &["bad_change.toml", "cycle_jump.pressure_change", "> 0"],
    );
    expect_error(
        &d,
        "bad_tolerance",
        &sub("[cycle_jump]\nfixed = 1", "[cycle_jump]\nprediction_tolerance = nan"),
        &["bad_tolerance.toml", "cycle_jump.prediction_tolerance", "> 0"],
    );
    expect_error(
        &d,
        "fixed_and_tolerance",
        &sub("[cycle_jump]\nfixed = 1", "[cycle_jump]\nfixed = 1\nprediction_tolerance = 0.01"),
        &["fixed_and_tolerance.toml", "cycle_jump", "cannot be combined"],
    );
    expect_error(
        &d,
        "bad_scheme",
        &sub("[cycle_jump]\nfixed = 1", "[cycle_jump]\nscheme = \"sideways\""),
        &["bad_scheme.toml", "scheme"],
    );

    // Failing runs (the case itself is valid): zero stroke, a zero coefficient (named as the
    // cause, not the stroke), a band too shallow.
    for (name, text, needle) in [
        ("zero_stroke", sub("ux = 0.1", "ux = 0.0"), "no wear in the first cycle"),
        ("zero_k", sub("coefficient = 4e-3", "coefficient = 0.0"), "every [[wear]] coefficient is 0"),
        ("shallow", sub("max_depth = 2.0", "max_depth = 0.5"), "raise [[wear]] max_depth"),
    ] {
        std::fs::write(d.join(format!("{name}.toml")), text).unwrap();
        let (ok, text) = run(&["run", &format!("{name}.toml"), "--quiet", "-o", &format!("{name}.h5")], &d);
        assert!(!ok && text.contains(needle) && !text.contains("panicked"), "{name}:\n{text}");
    }

    // Restarts: a checkpoint of another case, a damaged file; the earlier result untouched.
    std::fs::write(d.join("wear.toml"), &good).unwrap();
    std::fs::write(d.join("good.toml"), GOOD).unwrap();
    let (ok, text) = run(&["run", "good.toml", "--quiet", "-o", "other.h5"], &d);
    assert!(ok, "{text}");
    let (ok, text) = run(&["run", "wear.toml", "--quiet", "-o", "wear.h5"], &d);
    assert!(ok, "{text}");
    let bytes = std::fs::read(d.join("wear.h5")).unwrap();
    std::fs::write(d.join("damaged.h5"), &bytes[..bytes.len() / 3]).unwrap();
    for (from, needle) in [("other.h5", "other.h5"), ("damaged.h5", "damaged.h5")] {
        let (ok, text) = run(&["run", "wear.toml", "--quiet", "--restart", from, "-o", "cont.h5"], &d);
        assert!(!ok && text.contains(needle) && !text.contains("panicked"), "{from}:\n{text}");
    }
    // A run killed before its first checkpoint: its partial file holds only the start of an HDF5
    // file (no side copy), its contact CSV three steps. The message says what happened.
    std::fs::write(d.join("early.h5.partial"), &bytes[..512]).unwrap();
    std::fs::write(d.join("early_contact.csv.partial"), "step,time,pair\n1,1,c\n2,2,c\n3,3,c\n").unwrap();
    let (ok, text) = run(&["run", "wear.toml", "--quiet", "--restart", "early.h5.partial", "-o", "cont.h5"], &d);
    assert!(!ok && !text.contains("panicked"), "{text}");
    for needle in ["early.h5.partial", "stopped before its first checkpoint, at output step 3", "start it again"] {
        assert!(text.contains(needle), "message should contain '{needle}':\n{text}");
    }
    assert_eq!(bytes, std::fs::read(d.join("wear.h5")).unwrap(), "the earlier result must be untouched");
}

/// A stroke that slides the flat off from under the cylinder (McColl scene, +-2 mm on a 3 mm
/// flat in steps of 2 mm, 4 increments per cycle, finite sliding): a typed error naming the contact and the end of the counter-surface
/// once the contact rests on the flat's corner, a non-zero exit, no panic, the converged steps
/// kept, and an earlier result beside it untouched.
#[test]
fn a_stroke_off_the_counter_surface_is_a_clear_error() {
    let d = tmpdir("off_surface");
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let case = std::fs::read_to_string(root.join("wear_cases/mccoll_fretting.toml"))
        .unwrap()
        .replace("ux = 0.025", "ux = 2.0")
        .replace("cycles = 18000", "cycles = 2")
        .replace("increments = 8", "increments = 4");
    assert!(case.contains("ux = 2.0") && case.contains("increments = 4"));
    run_fails_clearly(&d, &case, &["contact 'pair'", "end of the counter-surface", "[[bcs]]", "kept in"]);
}

/// Runs `case` in `d` over an earlier result `out.h5`: the run must fail with a message holding
/// every one of `needles`, without a panic, and leave the earlier result as it was.
fn run_fails_clearly(d: &Path, case: &str, needles: &[&str]) {
    std::fs::write(d.join("failing.toml"), case).unwrap();
    std::fs::write(d.join("out.h5"), b"an earlier result").unwrap();
    let (ok, text) = run(&["run", "failing.toml", "--quiet", "-o", "out.h5"], d);
    assert!(!ok, "{text}");
    assert!(!text.contains("panicked"), "{text}");
    for needle in needles {
        assert!(text.contains(needle), "message should contain '{needle}':\n{text}");
    }
    assert_eq!(std::fs::read(d.join("out.h5")).unwrap(), b"an earlier result", "the earlier result must be untouched");
}

/// A body held along y by contact alone whose load pulls it away from the contact (the
/// pressure-loaded punch of `free_punch_wear`, its top's ux prescribed, with its pressure
/// reversed): a typed error naming the body, the axis and that its load pulls it off, a
/// non-zero exit, no panic, an earlier result untouched. The same punch pushed onto the block
/// runs (tests/cases.rs `free_punch_wear_case`).
#[test]
fn a_body_pulled_off_its_only_support_is_a_clear_error() {
    let d = tmpdir("pulled_off");
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let case = std::fs::read_to_string(root.join("wear_cases/free_punch_wear.toml"))
        .unwrap()
        .replace("pressure = 50.0", "pressure = -50.0");
    assert!(case.contains("pressure = -50.0"));
    run_fails_clearly(&d, &case, &["body 'punch'", "along y by contact alone", "pulls it away", "kept in"]);
}

/// Rigid-body modes that no boundary condition fixes, named: `check` lists every one (the
/// pressure-loaded punch of `free_punch_wear`, its top's ux prescribed: a turn about a point of
/// its top edge, and y); `run` warns of those beyond the contact normal (the turn, held only by
/// friction and by how the pressure spreads; y is held by the contact pressure, as for any
/// force-loaded punch), and a rigid platen's punch (`sliding_wear`: its top moves as one
/// translation) is not free to turn.
#[test]
fn free_rigid_modes_are_named() {
    let d = tmpdir("free_modes");
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let case = std::fs::read_to_string(root.join("wear_cases/free_punch_wear.toml"))
        .unwrap()
        .replace("cycles = 20", "cycles = 1");
    std::fs::write(d.join("free.toml"), case).unwrap();
    let (ok, text) = run(&["check", "free.toml"], &d);
    assert!(ok && text.contains("body 'punch': free to turn about (0, 0.5) and along (0, 1)"), "{text}");
    let (ok, text) = run(&["run", "free.toml", "--quiet"], &d);
    assert!(ok && text.contains("body 'punch': free to turn about (0, 0.5):"), "{text}");
    let (ok, text) = run(&["check", root.join("wear_cases/sliding_wear.toml").to_str().unwrap()], &d);
    assert!(ok && text.contains("body 'punch': free along (0, 1):") && !text.contains("turn about"), "{text}");
    // Where a pair's sliding comes from: the case (sliding_wear sets it) or the default.
    assert!(text.contains("Finite sliding (set by the case's contacts.sliding)"), "{text}");
    let (ok, text) = run(&["check", root.join("wear_cases/mccoll_fretting.toml").to_str().unwrap()], &d);
    assert!(ok && text.contains("Finite sliding (the default: "), "{text}");
}

/// `[output] keep_checkpoints`: only the last checkpoints stay (older ones are removed as new
/// ones are written, and HDF5 reuses their space), a restart from a kept one runs and from a
/// removed one is refused naming the steps that have one; with `0` every one stays. A run with
/// a checkpoint every step, the last 2 kept, writes a smaller file than keeping all.
#[test]
fn only_the_last_checkpoints_are_kept() {
    let d = tmpdir("keep_checkpoints");
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(root.join("wear_cases/uniform_wear.toml"))
        .unwrap()
        .replace("cycles = 20", "cycles = 3");
    assert!(text.contains("cycles = 3") && !text.contains("[output]"));
    let mut sizes = vec![];
    for keep in [0, 2] {
        let name = format!("keep{keep}");
        let case = format!("{text}\n[output]\ncheckpoint_every = 1\nkeep_checkpoints = {keep}\n");
        std::fs::write(d.join(format!("{name}.toml")), case).unwrap();
        let (ok, out) = run(&["run", &format!("{name}.toml"), "--quiet", "-o", &format!("{name}.h5")], &d);
        assert!(ok, "{out}");
        let steps = mortex::io::checkpoint::available_steps(&d.join(format!("{name}.h5"))).unwrap();
        let all = hdf5::File::open(d.join(format!("{name}.h5")))
            .unwrap()
            .group("steps")
            .unwrap()
            .member_names()
            .unwrap()
            .len();
        if keep == 0 {
            assert_eq!(steps.len(), all, "keep all: {steps:?}");
        } else {
            assert_eq!(steps, vec![all - 1, all], "keep the last 2 of {all}");
        }
        sizes.push(std::fs::metadata(d.join(format!("{name}.h5"))).unwrap().len());
    }
    assert!(sizes[1] < sizes[0], "file sizes keeping all / 2 checkpoints: {sizes:?}");
    let (ok, out) = run(&["run", "keep2.toml", "--quiet", "--restart", "keep2.h5", "--from-step", "3"], &d);
    assert!(!ok && out.contains("no checkpoint at step 3") && !out.contains("panicked"), "{out}");
}

/// A rigid platen whose displacement is prescribed on every node of its set (a user's natural
/// reading of "the top moves by u") instead of on its master: the rows of the set whose DOFs are
/// all prescribed are dropped (kept, they were empty rows on the unknowns: a singular interface
/// system and 8 cut-backs in the first step), and the run equals the one prescribing the master
/// (`sliding_wear`, 2 cycles): the worn area within 1e-9 relative (the same equations; the
/// multipliers of the dropped rows no longer in the system reorder sums at round-off). Different
/// values on two nodes of one set are a contradiction: a clear error naming the set, the nodes
/// and the values, before anything is written.
#[test]
fn a_rigid_set_prescribed_on_every_node_runs_as_on_its_master() {
    let d = tmpdir("rigid_all_nodes");
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let master = std::fs::read_to_string(root.join("wear_cases/sliding_wear.toml"))
        .unwrap()
        .replace("cycles = 20", "cycles = 2");
    let every = master.replace("set = \"top_left\"                # the rigid master", "set = \"top\"");
    assert!(master.contains("cycles = 2") && every != master);
    let mut areas = vec![];
    for (name, case) in [("master", &master), ("every", &every)] {
        std::fs::write(d.join(format!("{name}.toml")), case).unwrap();
        let (ok, text) = run(&["run", &format!("{name}.toml"), "--quiet", "-o", &format!("{name}.h5")], &d);
        assert!(ok && !text.contains("cutting"), "{text}");
        let f = hdf5::File::open(d.join(format!("{name}.h5"))).unwrap();
        let area = f.dataset("wear/track/worn_area").unwrap().read_raw::<f64>().unwrap();
        areas.push(*area.last().unwrap());
    }
    assert!(areas[0] > 0.0 && ((areas[1] - areas[0]) / areas[0]).abs() < 1e-9, "{areas:?}");
    let conflicting = format!("{every}\n[[bcs]]\nbody = \"punch\"\nset = \"top_right\"\nux = 1.0\n");
    run_fails_clearly(
        &d,
        &conflicting,
        &["rigid set 'top' of body 'punch'", "ux = 1", "ux = 1.5", "prescribe it on one node"],
    );
}

/// `bench` runs one benchmark: two of its modes at once are a usage error (clap's exit code 2,
/// both flags named), never the silent choice of one of them.
#[test]
fn bench_refuses_two_modes_at_once() {
    let dir = tmpdir("bench_modes");
    let out = bin().args(["bench", "--hertz", "--wear"]).current_dir(&dir).output().unwrap();
    let text = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "usage error expected:\n{text}");
    assert!(text.contains("--hertz") && text.contains("--wear"), "both modes named:\n{text}");
}
