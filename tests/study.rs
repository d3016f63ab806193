//! `mortex study sweep`: a case run over a grid of its inputs, each run a process of its own,
//! gathered into one table, resumed without running again what finished.
//!
//! The scene is `wear_cases/uniform_wear.toml` (a block pressed with p = 50 MPa and slid
//! +-0.1 mm over a virtual surface that wears by Archard's law), whose wear is exact: after N
//! cycles the surface has sunk by w = k p S N (S = 0.4 mm of slip per cycle) over its 4 mm, so
//! the worn area is 4 w. The sweep varies the coefficient k and the cycles N.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

const P: f64 = 50.0;
const SLIP_PER_CYCLE: f64 = 0.4;
const WIDTH: f64 = 4.0;

fn case() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("wear_cases/uniform_wear.toml")
}

/// This test's scratch directory, removed when it passes.
fn scratch(name: &str) -> common::ScratchDir {
    common::ScratchDir::new("study", name)
}

/// A sweep file over `uniform_wear`: the wear coefficient and, when given, the cycles.
fn uniform_sweep(dir: &Path, k: &str, cycles: Option<&str>) -> PathBuf {
    let file = dir.join("sweep.toml");
    let mut text = format!(
        "case = {:?}\noutput = \"out\"\n[[vary]]\nkey = \"wear[0].coefficient\"\nvalues = [{k}]\n",
        case().display().to_string()
    );
    if let Some(n) = cycles {
        text.push_str(&format!("[[vary]]\nkey = \"steps.cycles\"\nvalues = [{n}]\n"));
    }
    std::fs::write(&file, text).unwrap();
    file
}

fn sweep(file: &Path) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_mortex"))
        .args(["study", "sweep"])
        .arg(file)
        .arg("--parallel")
        .arg("2")
        .output()
        .unwrap()
}

/// Four runs (k = 1e-3, 2e-3 /MPa; N = 5, 10 cycles): the table holds each run's depth and worn
/// area, equal to `k p S N` and `4 k p S N` (tolerance 1e-8 relative, that of the case's own
/// test in tests/wear.rs: the wear is exact up to round-off over the cut cells). Started again,
/// the sweep runs nothing and leaves every run's figures as they were.
#[test]
fn sweep_gathers_exact_wear_and_resumes_without_running_again() {
    let dir = scratch("grid");
    let file = uniform_sweep(&dir, "1e-3, 2e-3", Some("5, 10"));
    let out = sweep(&file);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(String::from_utf8_lossy(&out.stdout).contains("4 runs: 4 run now, 0 done before, 0 failed"));
    let csv = std::fs::read_to_string(dir.join("out/sweep.csv")).unwrap();
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col =
        |name: &str| header.iter().position(|h| *h == name).unwrap_or_else(|| panic!("no column {name}: {header:?}"));
    let (ck, cn, cd, ca, cs) = (
        col("wear[0].coefficient"),
        col("steps.cycles"),
        col("surface max_depth"),
        col("surface worn_area"),
        col("status"),
    );
    let mut rows = 0;
    for line in lines {
        let r: Vec<&str> = line.split(',').collect();
        let (k, n): (f64, f64) = (r[ck].parse().unwrap(), r[cn].parse().unwrap());
        let (depth, area): (f64, f64) = (r[cd].parse().unwrap(), r[ca].parse().unwrap());
        let w = k * P * SLIP_PER_CYCLE * n;
        assert_eq!(r[cs], "ok");
        assert!((depth / w - 1.0).abs() < 1e-8, "k {k}, N {n}: depth {depth} against {w}");
        assert!((area / (WIDTH * w) - 1.0).abs() < 1e-8, "k {k}, N {n}: worn area {area} against {}", WIDTH * w);
        rows += 1;
    }
    assert_eq!(rows, 4);
    let figures = dir.join("out/run_0003/figures.csv");
    let before = (std::fs::metadata(&figures).unwrap().modified().unwrap(), std::fs::read_to_string(&figures).unwrap());
    let again = sweep(&file);
    assert!(again.status.success());
    assert!(String::from_utf8_lossy(&again.stdout).contains("4 runs: 0 run now, 4 done before, 0 failed"));
    let after = (std::fs::metadata(&figures).unwrap().modified().unwrap(), std::fs::read_to_string(&figures).unwrap());
    assert_eq!(before, after);
    assert_eq!(std::fs::read_to_string(dir.join("out/sweep.csv")).unwrap(), csv);
    let _ = std::fs::remove_dir_all(&dir);
}

/// A Latin hypercube of 8 runs over the wear coefficient (log scale, 1e-3 to 4e-3 /MPa) and the
/// pressure (40 to 60 MPa), seeded: each key's range cut into 8 strata holds exactly one run
/// (exact), the same seed gives the same values (bit for bit), and every run's depth is
/// `k p S N` (1e-8 relative, as above).
#[test]
fn latin_hypercube_puts_one_run_in_each_stratum() {
    let dir = scratch("lhs");
    let n = 8usize;
    let body = |out: &str| {
        format!(
            "case = {:?}\noutput = \"{out}\"\nsampling = \"latin_hypercube\"\nsamples = {n}\nseed = 3\n\
             [[vary]]\nkey = \"wear[0].coefficient\"\nrange = [1e-3, 4e-3]\nscale = \"log\"\n\
             [[vary]]\nkey = \"loads[0].pressure\"\nrange = [40.0, 60.0]\n",
            case().display().to_string()
        )
    };
    let mut tables = vec![];
    for out in ["a", "b"] {
        let file = dir.join(format!("{out}.toml"));
        std::fs::write(&file, body(out)).unwrap();
        let run = sweep(&file);
        assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
        tables.push(std::fs::read_to_string(dir.join(out).join("sweep.csv")).unwrap());
    }
    let rows: Vec<Vec<String>> =
        tables[0].lines().skip(1).map(|l| l.split(',').map(str::to_string).collect()).collect();
    let values = |t: &str| -> Vec<String> {
        t.lines().skip(1).map(|l| l.split(',').take(3).collect::<Vec<_>>().join(",")).collect()
    };
    assert_eq!(values(&tables[0]), values(&tables[1]), "the same seed must give the same sample");
    assert_eq!(rows.len(), n);
    let stratum = |x: f64, lo: f64, hi: f64| ((x - lo) / (hi - lo) * n as f64).floor() as usize;
    let mut k_strata: Vec<usize> =
        rows.iter().map(|r| stratum(r[1].parse::<f64>().unwrap().ln(), 1e-3f64.ln(), 4e-3f64.ln())).collect();
    let mut p_strata: Vec<usize> = rows.iter().map(|r| stratum(r[2].parse().unwrap(), 40.0, 60.0)).collect();
    k_strata.sort_unstable();
    p_strata.sort_unstable();
    assert_eq!(k_strata, (0..n).collect::<Vec<_>>());
    assert_eq!(p_strata, (0..n).collect::<Vec<_>>());
    let header: Vec<&str> = tables[0].lines().next().unwrap().split(',').collect();
    let cd = header.iter().position(|h| *h == "surface max_depth").unwrap();
    for r in &rows {
        let (k, p, depth): (f64, f64, f64) = (r[1].parse().unwrap(), r[2].parse().unwrap(), r[cd].parse().unwrap());
        let w = k * p * SLIP_PER_CYCLE * 20.0;
        assert!((depth / w - 1.0).abs() < 1e-8, "k {k}, p {p}: depth {depth} against {w}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// `mortex study convergence` of the uniform-wear case in its increments per cycle (4, 8,
/// 16): the wear and the (uniform) contact pressure are exact at any setting, so every error
/// against the finest run (largest depth, worn area, depth profile, pressure at the stroke
/// positions of the last cycle) is round-off (below 1e-12), the reference rows read 0, and the
/// table holds a row per value and figure. Knob values that do not refine (the step size growing) are an
/// error naming the knob.
#[test]
fn convergence_of_an_exact_case_is_round_off() {
    let dir = scratch("conv");
    let file = dir.join("conv.toml");
    let text = format!(
        "case = {:?}\noutput = \"out\"\n[[knob]]\nkey = \"steps.increments\"\nvalues = [4, 8, 16]\n",
        case().display().to_string()
    );
    std::fs::write(&file, text).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_mortex")).args(["study", "convergence"]).arg(&file).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let csv = std::fs::read_to_string(dir.join("out/convergence.csv")).unwrap();
    let rows: Vec<Vec<&str>> = csv.lines().skip(1).map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), 3 * 4, "3 values x (depth, worn area, depth profile, pressure profile): {csv}");
    for r in &rows {
        let error: f64 = r[5].parse().unwrap();
        assert!(error < 1e-12, "{r:?}");
        if r[1] == "16" {
            assert_eq!(error, 0.0);
        }
    }
    let bad = dir.join("bad.toml");
    std::fs::write(
        &bad,
        format!(
            "case = {:?}\noutput = \"bad\"\n[[knob]]\nkey = \"steps.increments\"\nvalues = [8, 4]\n",
            case().display().to_string()
        ),
    )
    .unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_mortex")).args(["study", "convergence"]).arg(&bad).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("bad.toml") && err.contains("knob[0].values"), "{err}");
    assert!(!dir.join("bad").exists());
    let _ = std::fs::remove_dir_all(&dir);
}

/// `mortex study pareto` measures each run's error against the reference run: on the uniform-wear
/// case with the wear coefficient as the "setting" (reference k = 2e-3 /MPa, runs at 1e-3,
/// 1.5e-3, 3e-3), the depth is `k p S N`, so each error is `|k / k_ref - 1|` (tolerance 1e-3:
/// the table prints the error to 4 significant digits; the wear itself is exact to 1e-8), and
/// some run is on the front.
#[test]
fn pareto_errors_are_against_the_reference_run() {
    let dir = scratch("pareto");
    let file = dir.join("pareto.toml");
    let text = format!(
        "case = {:?}\noutput = \"out\"\nreference = [{{ key = \"wear[0].coefficient\", value = 2e-3 }}]\n\
         [[vary]]\nkey = \"wear[0].coefficient\"\nvalues = [1e-3, 1.5e-3, 3e-3]\n",
        case().display().to_string()
    );
    std::fs::write(&file, text).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_mortex")).args(["study", "pareto"]).arg(&file).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let csv = std::fs::read_to_string(dir.join("out/pareto.csv")).unwrap();
    let rows: Vec<Vec<&str>> = csv.lines().skip(1).map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), 3);
    for (r, k) in rows.iter().zip([1e-3, 1.5e-3, 3e-3]) {
        let error: f64 = r[3].parse().unwrap();
        let exact = (k / 2e-3 - 1.0_f64).abs();
        assert!((error / exact - 1.0).abs() < 1e-3, "k {k}: error {error} against {exact}");
    }
    assert!(rows.iter().any(|r| r[4] == "yes"));
    let _ = std::fs::remove_dir_all(&dir);
}

/// Bad sweeps: a misspelt key, an array element the case does not have, no values, a value of the wrong type, a value the
/// case refuses (a negative wear coefficient), too many runs. Each is an error naming the
/// sweep file and the key, exit code 1, and nothing is run (no output directory).
#[test]
fn bad_sweeps_give_clear_errors_and_run_nothing() {
    let dir = scratch("bad");
    let cycles: Vec<String> = (1..=200).map(|n| n.to_string()).collect();
    let increments: Vec<String> = (4..=104).map(|n| n.to_string()).collect();
    let cases = [
        // Keys the case leaves out are added and checked by the case reader: a typo is its
        // unknown field, named with the run.
        ("key = \"wear[0].coef\"\nvalues = [1e-3]".to_string(), "wear[0].coef = 0.001"),
        ("key = \"wear[3].coefficient\"\nvalues = [1e-3]".to_string(), "vary[0].key"),
        ("key = \"wear[0].coefficient\"\nvalues = []".to_string(), "vary[0].values"),
        ("key = \"steps.cycles\"\nvalues = [2.5]".to_string(), "vary[0].key"),
        ("key = \"wear[0].coefficient\"\nvalues = [1e-3, -1e-3]".to_string(), "wear[0].coefficient"),
        (
            format!(
                "key = \"steps.cycles\"\nvalues = [{}]\n[[vary]]\nkey = \"steps.increments\"\nvalues = [{}]",
                cycles.join(", "),
                increments.join(", ")
            ),
            "20200 runs",
        ),
    ];
    for (i, (vary, expected)) in cases.iter().enumerate() {
        let file = dir.join(format!("bad{i}.toml"));
        let text = format!("case = {:?}\noutput = \"out{i}\"\n[[vary]]\n{vary}\n", case().display().to_string());
        std::fs::write(&file, text).unwrap();
        let out = sweep(&file);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{vary}: {err}");
        assert!(err.contains(&format!("bad{i}.toml")) && err.contains(expected), "{vary}: {err}");
        assert!(!dir.join(format!("out{i}")).exists(), "{vary}: something was run");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

fn mortex(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_mortex")).args(args).output().unwrap()
}

/// The same sweep handed to Slurm: `--slurm --no-submit` writes one job array (a task per
/// run, each `mortex study task <runs.txt> <index>`, extra `#SBATCH` options kept); running
/// each task as Slurm would and then `mortex study gather` gives the exact wear of every run
/// (1e-8, as the local sweep above). Gathering before the tasks ran names the runs missing; a
/// second `--slurm` after they ran has nothing left to submit.
#[test]
fn slurm_job_array_tasks_then_gather_give_the_local_table() {
    let dir = scratch("slurm");
    let file = uniform_sweep(&dir, "1e-3, 2e-3", Some("5"));
    let f = file.to_str().unwrap();
    let out = mortex(&["study", "sweep", f, "--slurm", "--no-submit", "--sbatch=--time=00:10:00"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(
        String::from_utf8_lossy(&out.stdout).contains("2 tasks written"),
        "{}",
        String::from_utf8_lossy(&out.stdout)
    );
    let script = std::fs::read_to_string(dir.join("out/slurm/array.sbatch")).unwrap();
    for line in ["#SBATCH --array=0-1", "#SBATCH --time=00:10:00", "study task", "$SLURM_ARRAY_TASK_ID"] {
        assert!(script.contains(line), "job script lacks {line:?}:\n{script}");
    }
    let early = mortex(&["study", "gather", f]);
    assert!(!early.status.success());
    assert!(String::from_utf8_lossy(&early.stderr).contains("2 of 2 runs not done yet"), "{early:?}");
    let runs = dir.join("out/slurm/runs.txt");
    for i in ["0", "1"] {
        let task = mortex(&["study", "task", runs.to_str().unwrap(), i]);
        assert!(task.status.success(), "task {i}: {}", String::from_utf8_lossy(&task.stderr));
    }
    let gathered = mortex(&["study", "gather", f]);
    assert!(gathered.status.success(), "{}", String::from_utf8_lossy(&gathered.stderr));
    let csv = std::fs::read_to_string(dir.join("out/sweep.csv")).unwrap();
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let (ck, cd, ca) = (col("wear[0].coefficient"), col("surface max_depth"), col("surface worn_area"));
    let mut rows = 0;
    for line in lines {
        let r: Vec<&str> = line.split(',').collect();
        let k: f64 = r[ck].parse().unwrap();
        let (depth, area): (f64, f64) = (r[cd].parse().unwrap(), r[ca].parse().unwrap());
        let w = k * P * SLIP_PER_CYCLE * 5.0;
        assert!((depth / w - 1.0).abs() < 1e-8, "k {k}: depth {depth} against {w}");
        assert!((area / (WIDTH * w) - 1.0).abs() < 1e-8, "k {k}: worn area {area}");
        rows += 1;
    }
    assert_eq!(rows, 2);
    let again = mortex(&["study", "sweep", f, "--slurm", "--no-submit"]);
    assert!(String::from_utf8_lossy(&again.stdout).contains("every run is done"), "{again:?}");
}

/// The same on a real Slurm cluster (`.ci/setup` starts a single-node one): `--slurm` submits the
/// job array with `sbatch`, its tasks run on the node, and `mortex study gather` gives the exact
/// wear of every run (1e-8). Without `sbatch` the test says so and passes, except on CI.
#[test]
fn slurm_cluster_runs_the_job_array() {
    let have_slurm = Command::new("sinfo").arg("-h").output().is_ok_and(|o| o.status.success());
    if !have_slurm {
        assert!(std::env::var_os("CI").is_none(), "no Slurm cluster on CI: .ci/setup should have started one");
        eprintln!("no Slurm here (sinfo failed): skipped");
        return;
    }
    let dir = scratch("slurm-cluster");
    let file = uniform_sweep(&dir, "1e-3, 3e-3", None);
    let f = file.to_str().unwrap();
    let out = mortex(&["study", "sweep", f, "--slurm", "--sbatch=--time=00:05:00"]);
    let stdout = String::from_utf8_lossy(&out.stdout).to_string();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let id = stdout.split("job array ").nth(1).and_then(|r| r.split_whitespace().next()).expect("job id").to_string();
    let started = std::time::Instant::now();
    loop {
        let q = Command::new("squeue").args(["-h", "-j", &id]).output().unwrap();
        if String::from_utf8_lossy(&q.stdout).trim().is_empty() {
            break;
        }
        assert!(started.elapsed().as_secs() < 300, "job array {id} still queued or running after 300 s");
        std::thread::sleep(std::time::Duration::from_millis(500));
    }
    let gathered = mortex(&["study", "gather", f]);
    assert!(gathered.status.success(), "{}", String::from_utf8_lossy(&gathered.stderr));
    let csv = std::fs::read_to_string(dir.join("out/sweep.csv")).unwrap();
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let (ck, cd, cn) = (col("wear[0].coefficient"), col("surface max_depth"), col("status"));
    let cycles: f64 = 20.0; // the case's own `steps.cycles`
    let mut rows = 0;
    for line in lines {
        let r: Vec<&str> = line.split(',').collect();
        assert_eq!(r[cn], "ok");
        let (k, depth): (f64, f64) = (r[ck].parse().unwrap(), r[cd].parse().unwrap());
        let w = k * P * SLIP_PER_CYCLE * cycles;
        assert!((depth / w - 1.0).abs() < 1e-8, "k {k}: depth {depth} against {w}");
        rows += 1;
    }
    assert_eq!(rows, 2);
}
