//! kill -9 during a run, then resume: a run resumes from any checkpoint, bit for bit, and
//! checkpoints must survive the process being killed at any moment.
//!
//! In a file of its own: the killed runs are child processes, and a child inherits the HDF5
//! file descriptors (and their locks) of whatever the test process has open at that moment.

use mortex::io::checkpoint;
use std::path::{Path, PathBuf};

/// The running test's scratch directory (the harness names each test's thread after the test).
fn scratch_dir() -> PathBuf {
    let test = std::thread::current().name().unwrap_or("main").replace("::", "_");
    std::env::temp_dir().join(format!("mortex-kill-{}-{test}", std::process::id()))
}

fn tmpfile(name: &str) -> PathBuf {
    let d = scratch_dir();
    std::fs::create_dir_all(&d).unwrap();
    d.join(name)
}

/// Removes the running test's scratch files once its checks passed (a failing test keeps
/// them): each test writes about a gigabyte of checkpoints.
fn clean_scratch() {
    let _ = std::fs::remove_dir_all(scratch_dir());
}

/// Starts `mortex run case -o <name>.h5`, kills it (SIGKILL) after `delay`, then resumes with
/// `--restart` from what it left; with `damage`, the left `.h5.partial` is first made unreadable
/// (its first 8 KiB zeroed, the superblock with them), as a kill during an HDF5 metadata update
/// can leave it, so the resume must come from the side copy of the last checkpoint. Returns the step it resumed from and the continuation's file,
/// or `None` if the run finished first, was killed before its first checkpoint or after its
/// last one. A killed run
/// must never leave an XDMF beside a file it does not describe.
fn kill_then_resume(
    case: &Path,
    name: &str,
    delay: std::time::Duration,
    damage: bool,
    last_step: usize,
) -> Option<(usize, PathBuf)> {
    use std::process::{Command, Stdio};
    let exe = env!("CARGO_BIN_EXE_mortex");
    let out = tmpfile(&format!("{name}.h5"));
    let mut child = Command::new(exe)
        .args(["run", case.to_str().unwrap(), "--quiet", "-o", out.to_str().unwrap()])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    std::thread::sleep(delay);
    child.kill().unwrap(); // SIGKILL
    child.wait().unwrap();
    let xdmf = out.with_extension("xdmf");
    let partial = PathBuf::from(format!("{}.partial", out.display()));
    if out.exists() {
        // The run finished before the kill: its XDMF describes it.
        assert!(xdmf.exists());
        return None;
    }
    assert!(!xdmf.exists(), "a killed run must not leave an XDMF beside a file it does not describe");
    if !partial.exists() {
        // Killed while still reading the case and building the model: nothing to resume.
        return None;
    }
    if damage {
        let side = checkpoint::side_path(&partial);
        if !side.exists() {
            return None; // killed before the first checkpoint
        }
        let mut bytes = std::fs::read(&partial).unwrap();
        let n = bytes.len().min(8192);
        bytes[..n].fill(0);
        std::fs::write(&partial, bytes).unwrap();
        assert!(hdf5::File::open(&partial).is_err(), "{name}: the damaged file must not open");
    }
    if !damage && !checkpoint::side_path(&partial).exists() {
        // Killed before the first checkpoint (possibly while the file's header was written).
        return None;
    }
    let k = *checkpoint::available_steps(&partial).unwrap().last()?;
    if k == last_step {
        // Killed after the last step's checkpoint, while the run was finishing its files: the
        // restart rightly refuses ("nothing to run").
        return None;
    }
    let cont = tmpfile(&format!("{name}_resumed.h5"));
    let status = Command::new(exe)
        .args([
            "run",
            case.to_str().unwrap(),
            "--quiet",
            "--restart",
            partial.to_str().unwrap(),
            "-o",
            cont.to_str().unwrap(),
        ])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .unwrap();
    assert!(status.success(), "{name}: the resume failed");
    Some((k, cont))
}

/// kill -9 at five moments of a many-step CLI run (the moving_contact case with 40 cycles:
/// 161 steps, a surface re-cut every step, a checkpoint every step), then `--restart` from what
/// the killed run left: every resume must end in exactly the uninterrupted run's final state
/// (every f64 of its checkpoint by its bits) and its later contact pressures; the killed run
/// must not leave an XDMF that describes another file. Kill moments: fractions 0.15 .. 0.85 of
/// the uninterrupted run's wall time (deterministic, spread over the run).
#[test]
fn kill_minus_nine_then_resume_is_bit_identical() {
    use std::process::{Command, Stdio};
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(root.join("wear_cases/moving_contact.toml"))
        .unwrap()
        .replace("cycles = 3", "cycles = 40")
        .replace("[[0.0, 0.0], [1.0, 0.0], [7.0, 1.0]]", "[[0.0, 0.0], [1.0, 0.0], [81.0, 1.0]]");
    let case = tmpfile("kill_case.toml");
    std::fs::write(&case, text).unwrap();
    let exe = env!("CARGO_BIN_EXE_mortex");
    let run =
        |args: &[&str]| Command::new(exe).args(args).stdout(Stdio::null()).stderr(Stdio::null()).status().unwrap();
    let reference = tmpfile("kill_ref.h5");
    let started = std::time::Instant::now();
    assert!(run(&["run", case.to_str().unwrap(), "--quiet", "-o", reference.to_str().unwrap()]).success());
    let wall = started.elapsed();
    let last = |file: &Path| -> (usize, Vec<u64>) {
        let steps = checkpoint::available_steps(file).unwrap();
        let k = *steps.last().unwrap();
        let f = hdf5::File::open(file).unwrap();
        let c = f.group(&format!("steps/{k:06}/checkpoint")).unwrap();
        let mut b = vec![];
        for name in ["u", "f_int", "multipliers", "stress"] {
            b.extend(c.dataset(name).unwrap().read_raw::<f64>().unwrap().iter().map(|v| v.to_bits()));
        }
        let p = f.dataset(&format!("steps/{k:06}/contacts/interface/pressure")).unwrap().read_raw::<f64>().unwrap();
        b.extend(p.iter().map(|v| v.to_bits()));
        (k, b)
    };
    let (k_ref, bits_ref) = last(&reference);
    assert_eq!(k_ref, 161);
    let mut resumed_from = vec![];
    for (i, fraction) in [0.15, 0.32, 0.5, 0.67, 0.85].into_iter().enumerate() {
        // The third kill also damages what the run left (resume from the side checkpoint).
        let damage = i == 2;
        let Some((k, cont)) = kill_then_resume(&case, &format!("kill_{i}"), wall.mul_f64(fraction), damage, k_ref)
        else {
            continue;
        };
        let (k_end, b) = last(&cont);
        assert_eq!(k_end, k_ref);
        assert!(b == bits_ref, "kill {i}: resumed from step {k}: final state differs from the uninterrupted run");
        resumed_from.push(k);
    }
    eprintln!("resumed from steps {resumed_from:?} of {k_ref}");
    assert!(resumed_from.len() >= 3, "most kills must land mid-run (resumed from {resumed_from:?})");
    clean_scratch();
}

/// Every f64 and integer of a checkpoint group (the wear state included), by its bits.
/// The bits of every dataset under `g` (subgroups too, such as the implicit jump's increment
/// linearisations), in name order (integers read as f64: exact below 2^53).
fn group_bits(g: &hdf5::Group, b: &mut Vec<u64>) {
    let mut names = g.member_names().unwrap();
    names.sort();
    for name in names {
        match g.dataset(&name) {
            Ok(d) => b.extend(d.read_raw::<f64>().unwrap().iter().map(|v| v.to_bits())),
            Err(_) => group_bits(&g.group(&name).unwrap(), b),
        }
    }
}

fn checkpoint_bits(file: &Path, step: usize) -> Vec<u64> {
    let f = hdf5::File::open(file).unwrap();
    let c = f.group(&format!("steps/{step:06}/checkpoint")).unwrap();
    let mut b = vec![];
    for name in ["u", "f_int", "multipliers", "stress", "history", "slip_increment", "accumulated_slip"] {
        b.extend(c.dataset(name).unwrap().read_raw::<f64>().unwrap().iter().map(|v| v.to_bits()));
    }
    if let Ok(d) = c.dataset("ghost_forces") {
        b.extend(d.read_raw::<f64>().unwrap().iter().map(|v| v.to_bits()));
    }
    let w = c.group("wear").unwrap();
    group_bits(&w, &mut b);
    for a in ["cycle", "computed_cycles", "increment", "cycle_steps", "jump", "last_jump", "jump_before"] {
        b.push(w.attr(a).unwrap().read_scalar::<u64>().unwrap());
    }
    for a in ["decay", "last_fraction", "cycle_fraction"] {
        b.push(w.attr(a).unwrap().read_scalar::<f64>().unwrap().to_bits());
    }
    b
}

/// The part of a cycle's wear applied so far at the checkpoint of `step` (0 between cycles), or
/// `None` where the killed run's file cannot be read there: a kill during an HDF5 metadata
/// update may damage it, and the resume then came from the side copy of its last checkpoint.
fn checkpoint_cycle_fraction(file: &Path, step: usize) -> Option<f64> {
    let f = hdf5::File::open(file).ok()?;
    let w = f.group(&format!("steps/{step:06}/checkpoint/wear")).ok()?;
    w.attr("cycle_fraction").ok()?.read_scalar::<f64>().ok()
}

/// kill -9 at five moments of a wear run with adaptive cycle jumps (the McColl fretting case
/// on coarser meshes, 400 cycles, its own 4 increments per cycle, a checkpoint every step), then
/// `--restart`: every resume must end in the uninterrupted run's final state, wear state
/// (surfaces, depths, sums, counters, jump controller) and scar, bit for bit.
#[test]
fn kill_minus_nine_during_wear_with_jumps_then_resume_is_bit_identical() {
    kill_during_wear(
        "mccoll_fretting",
        "cycles = 18000",
        400,
        &[("friction = 0.9", "friction = 0.9\nsliding = \"small\"")],
    );
}

/// The same with fatigue followed on the flat (`[fatigue]` under the contact): the cycle's
/// stress-strain history so far, the damage and the retired points are part of the bits.
#[test]
fn kill_minus_nine_during_wear_with_fatigue_then_resume_is_bit_identical() {
    let fatigue = "[fatigue]\nbody = \"flat\"\nregion = [[-0.4, -0.2], [0.4, 0.0]]\nsigma_f = 1225.0\nb = -0.095\neps_f = 1.0\nc = -0.66\n\n[output]";
    kill_during_wear(
        "mccoll_fretting",
        "cycles = 18000",
        400,
        &[("friction = 0.9", "friction = 0.9\nsliding = \"small\""), ("[output]", fatigue)],
    );
}

/// The same with finite sliding: every step paired in its own end configuration (a fixed point
/// of solves from the step's start), wear swept along the stroke; a restart builds its solver
/// afresh where the run kept its factorisation between re-pairings.
#[test]
fn kill_minus_nine_during_finite_sliding_wear_then_resume_is_bit_identical() {
    kill_during_wear(
        "mccoll_fretting",
        "cycles = 18000",
        400,
        &[("friction = 0.9", "friction = 0.9\nsliding = \"finite\"")],
    );
}

/// The same with a yielding flat (`mccoll_j2`, J2 with isotropic hardening, finite sliding,
/// 60 cycles): the plastic history of every point and the birth forces of the ghost-penalty
/// faces the wear updates bring into the yielded layer are part of the bits compared.
#[test]
fn kill_minus_nine_during_elastic_plastic_wear_then_resume_is_bit_identical() {
    kill_during_wear("mccoll_j2", "cycles = 1000", 60, &[]);
}

/// The same during wear in fractions of a cycle (`sliding_wear`, k = 1e-4, 4 cycles, its own
/// 16 increments, `min_fraction = 1/256`: the first cycles' wear, 8 um against the contact's
/// compliance, is applied in 1/32 to 1/2 parts, each cycle recomputed on the worn geometry):
/// resumes from checkpoints between two parts (the part applied so far and the last part's size
/// and predicted pressure are in the state), bit for bit.
#[test]
fn kill_minus_nine_during_wear_in_fractions_of_a_cycle_then_resume_is_bit_identical() {
    kill_during_wear(
        "sliding_wear",
        "cycles = 20",
        4,
        &[("[steps]", "[cycle_jump]\nmin_fraction = 0.00390625\n\n[steps]")],
    );
}

/// kill -9 at five moments of the wear case `name` (its `cycles` line replaced to run
/// `cycles`, on coarser meshes, a checkpoint every step, `edits` applied), then `--restart`.
fn kill_during_wear(name: &str, cycles_line: &str, cycles: u64, edits: &[(&str, &str)]) {
    use std::process::{Command, Stdio};
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let finite = if edits.iter().any(|e| e.1.contains("finite")) { "_finite" } else { "" };
    let fatigue = if edits.iter().any(|e| e.1.contains("[fatigue]")) { "_fatigue" } else { "" };
    let tag = format!("_{name}{finite}{fatigue}");
    let mut text = std::fs::read_to_string(root.join(format!("wear_cases/{name}.toml")))
        .unwrap()
        .replace("divisions = [30, 160]", "divisions = [14, 60]")
        .replace("divisions = [120, 30]", "divisions = [50, 12]")
        .replace(cycles_line, &format!("cycles = {cycles}"))
        .replace("checkpoint_every = 100", "checkpoint_every = 1")
        .replace("checkpoint_every = 80", "checkpoint_every = 1");
    for (from, to) in edits {
        text = text.replace(from, to);
    }
    assert!(text.contains(&format!("cycles = {cycles}")) && text.contains("checkpoint_every = 1\n"));
    assert!(name != "mccoll_fretting" || text.contains("divisions = [14, 60]"));
    let case = tmpfile(&format!("kill_wear{tag}.toml"));
    std::fs::write(&case, text).unwrap();
    let exe = env!("CARGO_BIN_EXE_mortex");
    let run =
        |args: &[&str]| Command::new(exe).args(args).stdout(Stdio::null()).stderr(Stdio::null()).status().unwrap();
    let reference = tmpfile(&format!("kill_wear{tag}_ref.h5"));
    let started = std::time::Instant::now();
    assert!(run(&["run", case.to_str().unwrap(), "--quiet", "-o", reference.to_str().unwrap()]).success());
    let wall = started.elapsed();
    let k_ref = *checkpoint::available_steps(&reference).unwrap().last().unwrap();
    let bits_ref = checkpoint_bits(&reference, k_ref);
    let computed = {
        let f = hdf5::File::open(&reference).unwrap();
        let jumps = f.dataset("wear/jump").unwrap().read_raw::<u64>().unwrap();
        // The elastic scene must jump; the yielding one ratchets, and is refused jumps at first.
        assert!(
            name != "mccoll_fretting" || jumps.iter().any(|&j| j > 1),
            "{tag}: the run must jump cycles: {jumps:?}"
        );
        jumps.len()
    };
    let (mut resumed_from, mut fractions_at_resume) = (vec![], vec![]);
    for (i, fraction) in [0.15, 0.32, 0.5, 0.67, 0.85].into_iter().enumerate() {
        let Some((k, cont)) =
            kill_then_resume(&case, &format!("kill_wear{tag}_{i}"), wall.mul_f64(fraction), i == 1, k_ref)
        else {
            continue;
        };
        let k_end = *checkpoint::available_steps(&cont).unwrap().last().unwrap();
        assert_eq!(k_end, k_ref);
        assert!(
            checkpoint_bits(&cont, k_end) == bits_ref,
            "kill {i}: resumed from step {k}: final state differs from the uninterrupted run"
        );
        // The same active-set iterations too: each step starts from the sets the last computed
        // cycle converged to at its increment, which the checkpoint carries.
        let iterations =
            |f: &Path| hdf5::File::open(f).unwrap().dataset("series/iterations").unwrap().read_raw::<f64>().unwrap();
        let (a, b) = (iterations(&reference), iterations(&cont));
        let n = k_ref - k;
        assert_eq!(a[a.len() - n..], b[b.len() - n..], "kill {i}: resumed from step {k}: iterations differ");
        resumed_from.push(k);
        if i != 1 {
            // The killed run's file (the damaged one excepted) holds the checkpoint resumed from.
            let partial = PathBuf::from(format!("{}.partial", tmpfile(&format!("kill_wear{tag}_{i}.h5")).display()));
            fractions_at_resume.extend(checkpoint_cycle_fraction(&partial, k));
        }
    }
    eprintln!("wear run{tag} ({computed} wear updates, {k_ref} steps, {wall:?}): resumed from steps {resumed_from:?}");
    assert!(resumed_from.len() >= 3, "most kills must land mid-run (resumed from {resumed_from:?})");
    if edits.iter().any(|e| e.1.contains("min_fraction")) {
        assert!(
            fractions_at_resume.iter().filter(|&&f| f > 0.0).count() >= 2,
            "resumes must start between two fractions of a cycle's wear: fractions applied {fractions_at_resume:?}"
        );
    }
    clean_scratch();
}

/// kill -9 during reciprocating sliding whose increments are solved in sub-steps (the shipped
/// `pin_on_plate`, 2 cycles, a checkpoint every step: every increment reaching a stroke end is
/// cut into about 15 pieces), then `--restart`: the cycle's wear summed over the pieces, the
/// count of its steps and their linearisations are part of the state, bit for bit.
#[test]
fn kill_minus_nine_during_sub_stepped_sliding_wear_then_resume_is_bit_identical() {
    use std::process::{Command, Stdio};
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(root.join("wear_cases/pin_on_plate.toml"))
        .unwrap()
        .replace("cycles = 3", "cycles = 2")
        .replace("checkpoint_every = 100", "checkpoint_every = 1");
    assert!(text.contains("cycles = 2") && text.contains("checkpoint_every = 1"));
    let case = tmpfile("kill_pin.toml");
    std::fs::write(&case, text).unwrap();
    let reference = tmpfile("kill_pin_ref.h5");
    let started = std::time::Instant::now();
    let status = Command::new(env!("CARGO_BIN_EXE_mortex"))
        .args(["run", case.to_str().unwrap(), "--quiet", "-o", reference.to_str().unwrap()])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .unwrap();
    assert!(status.success());
    let wall = started.elapsed();
    let f = hdf5::File::open(&reference).unwrap();
    let sub_steps = f.dataset("series/sub_steps").unwrap().read_raw::<u64>().unwrap();
    assert!(sub_steps.iter().filter(|&&n| n > 1).count() >= 4, "increments must be cut: {sub_steps:?}");
    drop(f);
    let k_ref = *checkpoint::available_steps(&reference).unwrap().last().unwrap();
    let bits_ref = checkpoint_bits(&reference, k_ref);
    let mut resumed_from = vec![];
    for (i, fraction) in [0.4, 0.7].into_iter().enumerate() {
        let Some((k, cont)) = kill_then_resume(&case, &format!("kill_pin_{i}"), wall.mul_f64(fraction), false, k_ref)
        else {
            continue;
        };
        assert!(checkpoint_bits(&cont, k_ref) == bits_ref, "kill {i}: resumed from step {k}: final state differs");
        resumed_from.push(k);
    }
    assert!(!resumed_from.is_empty(), "a kill must land mid-run");
    clean_scratch();
}
