//! Every shipped case in `wear_cases/` runs through the `mortex` binary, and its HDF5 result,
//! read back both with the `hdf5` crate and with h5py (Python), matches the case's reference.

mod common;
use common::ResultFiles;
use std::path::Path;
use std::process::Command;

fn run_case(name: &str) -> ResultFiles {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let out = ResultFiles::in_scratch("cases", &format!("{name}.h5"));
    let status = Command::new(env!("CARGO_BIN_EXE_mortex"))
        .args([
            "run",
            root.join("wear_cases").join(format!("{name}.toml")).to_str().unwrap(),
            "--quiet",
            "-o",
            out.to_str().unwrap(),
        ])
        .status()
        .unwrap();
    assert!(status.success(), "case {name} failed");
    out
}

fn read2(f: &hdf5::File, path: &str) -> ndarray::Array2<f64> {
    f.dataset(path).unwrap().read_2d::<f64>().unwrap()
}

/// Lamé: inner-wall radial displacement `u_r(a) = ((1+nu)/E)[(1-2nu) A a + B/a]` = 9.1429e-4 mm.
/// Tolerance 0.5%: 16 x 24 bilinear mesh (L2 error 1.2e-3 in tests/lame_convergence.rs).
#[test]
fn lame_cylinder_case() {
    let out = run_case("lame_cylinder");
    let f = hdf5::File::open(&out).unwrap();
    let x = read2(&f, "mesh/cylinder/nodes");
    let u = read2(&f, "steps/000001/cylinder/displacement");
    let (e, nu, p, a, b) = (210000.0, 0.3, 100.0, 1.0f64, 2.0f64);
    let ca = p * a * a / (b * b - a * a);
    let cb = p * a * a * b * b / (b * b - a * a);
    let ur_exact = (1.0 + nu) / e * ((1.0 - 2.0 * nu) * ca * a + cb / a);
    let mut n_inner = 0;
    for i in 0..x.nrows() {
        let r = x[[i, 0]].hypot(x[[i, 1]]);
        if (r - a).abs() < 1e-9 {
            let ur = (u[[i, 0]] * x[[i, 0]] + u[[i, 1]] * x[[i, 1]]) / r;
            assert!((ur - ur_exact).abs() / ur_exact < 5e-3, "node {i}: u_r = {ur}, Lame {ur_exact}");
            n_inner += 1;
        }
    }
    assert_eq!(n_inner, 25);
    let completed: u8 = f.attr("completed").unwrap().read_scalar().unwrap();
    assert_eq!(completed, 1);
}

/// Kirsch: hoop stress at the top of the hole = 3 x remote stress (infinite plate); with
/// d/W = 0.1 Howland's finite-width factor gives 3.03. Tolerance 5%: nodal values are recovered
/// from the Gauss points of a 0.05 mm mesh, which misses a steep peak by a few percent (each
/// cell's Gauss values extrapolated to its nodes: 3.120, +3.0%; the lumped projection used
/// before: 2.963, -2.2%).
#[test]
fn plate_hole_case() {
    let out = run_case("plate_hole");
    let f = hdf5::File::open(&out).unwrap();
    let x = read2(&f, "mesh/plate/nodes");
    let s = read2(&f, "steps/000001/plate/stress");
    let i = (0..x.nrows()).min_by(|&i, &j| {
        let d = |k: usize| x[[k, 0]].hypot(x[[k, 1]] - 1.0);
        d(i).total_cmp(&d(j))
    });
    let i = i.unwrap();
    let scf = s[[i, 0]] / 100.0;
    eprintln!("plate with hole: stress concentration {scf:.4} (Howland 3.03)");
    assert!((scf - 3.03).abs() / 3.03 < 0.05, "SCF {scf}");
}

/// Hill cylinder loaded to p = 187.64 MPa (c = 1.6) and unloaded: residual hoop stress in the
/// plastic zone `sigma_t = -p + 2k (1 + ln(r/a)) - p a^2/(b^2 - a^2) (1 + b^2/r^2)`, `k = sigma_y/sqrt 3`
/// (Hill 1950 ch. V; elastic unloading, no reverse yield since p < 2 p_e). Compared at the
/// innermost ring of integration points. Tolerance 2% of 2k (target: 2% for the plastic solution).
#[test]
fn plastic_cylinder_residual_stress() {
    let out = run_case("plastic_cylinder");
    let f = hdf5::File::open(&out).unwrap();
    let pts = read2(&f, "mesh/points");
    let last: u64 = f.attr("num_steps").unwrap().read_scalar().unwrap();
    assert_eq!(last, 40);
    let s = read2(&f, "steps/000040/points/stress");
    let (p, a, b, k) = (187.64, 1.0f64, 2.0f64, 250.0 / 3f64.sqrt());
    let rmin = (0..pts.nrows()).map(|q| pts[[q, 0]].hypot(pts[[q, 1]])).fold(f64::INFINITY, f64::min);
    let mut checked = 0;
    for q in 0..pts.nrows() {
        let (x, y) = (pts[[q, 0]], pts[[q, 1]]);
        let r = x.hypot(y);
        if r > rmin + 1e-3 {
            continue;
        }
        let (c, sn) = (x / r, y / r);
        let st = s[[q, 0]] * sn * sn + s[[q, 1]] * c * c - 2.0 * s[[q, 3]] * sn * c;
        let exact = -p + 2.0 * k * (1.0 + (r / a).ln()) - p * a * a / (b * b - a * a) * (1.0 + b * b / (r * r));
        assert!((st - exact).abs() < 0.02 * 2.0 * k, "point {q} at r = {r}: residual hoop {st} vs {exact}");
        checked += 1;
    }
    assert!(checked >= 20);
    // h5py must read the same file (ParaView/h5py users). Required when CI is set.
    let py = Command::new("python3")
        .args([
            "-c",
            "import sys, h5py; f = h5py.File(sys.argv[1], 'r'); s = f['steps/000040/points/stress']; \
             print(s.shape[0], s.shape[1], int(f.attrs['completed']), f['time'].shape[0])",
            out.to_str().unwrap(),
        ])
        .output();
    match py {
        Ok(o) if o.status.success() => {
            let text = String::from_utf8_lossy(&o.stdout).trim().to_string();
            assert_eq!(text, format!("{} 4 1 40", s.nrows()), "h5py view of the file");
        }
        other => {
            assert!(std::env::var_os("CI").is_none(), "h5py could not read the result: {other:?}");
            eprintln!("h5py not available: skipped the Python read-back");
        }
    }
}

/// MorteX tying case: patch test through the whole tool chain (case file -> HDF5). Uniform
/// sigma_xx = 100 MPa at every integration point of both meshes and interface traction
/// `t = sigma . n` at every multiplier node; 1e-8 relative (the patch-test target tolerance).
#[test]
fn tied_patch_case() {
    let out = run_case("tied_patch");
    let f = hdf5::File::open(&out).unwrap();
    let s = read2(&f, "steps/000001/points/stress");
    for q in 0..s.nrows() {
        let e = [(s[[q, 0]] - 100.0).abs(), s[[q, 1]].abs(), s[[q, 3]].abs()].into_iter().fold(0.0, f64::max);
        assert!(e < 1e-8 * 100.0, "point {q}: stress {:?}", s.row(q));
    }
    let t = read2(&f, "steps/000001/ties/patch_in_host/traction");
    let n = read2(&f, "mesh/ties/patch_in_host/normals");
    assert_eq!(t.nrows(), 12, "coarse-grained: 3 interior multiplier nodes per side");
    for l in 0..t.nrows() {
        assert!(
            (t[[l, 0]] - 100.0 * n[[l, 0]]).abs() < 1e-6 && t[[l, 1]].abs() < 1e-6,
            "node {l}: traction {:?}",
            t.row(l)
        );
    }
    let frac = f.dataset("mesh/host/material_fraction").unwrap().read_raw::<f64>().unwrap();
    let removed: f64 = frac.iter().map(|v| 1.0 - v).sum();
    // The host loses exactly the patch area (16 mm^2 over unit cells), to round-off.
    assert!((removed - 16.0).abs() < 1e-9, "removed host area {removed}");
}

/// Contact case (frictionless, virtual host surface): uniform sigma_yy = -50 MPa everywhere and
/// contact pressure 50 MPa at every multiplier node, 1e-8 relative (contact patch test).
#[test]
fn block_contact_case() {
    let out = run_case("block_contact");
    let f = hdf5::File::open(&out).unwrap();
    let s = read2(&f, "steps/000001/points/stress");
    for q in 0..s.nrows() {
        let e = [s[[q, 0]].abs(), (s[[q, 1]] + 50.0).abs(), s[[q, 3]].abs()].into_iter().fold(0.0, f64::max);
        assert!(e < 1e-8 * 50.0, "point {q}: stress {:?}", s.row(q));
    }
    let p = f.dataset("steps/000001/contacts/interface/pressure").unwrap().read_raw::<f64>().unwrap();
    assert!(!p.is_empty());
    for (l, v) in p.iter().enumerate() {
        assert!((v - 50.0).abs() < 1e-8 * 50.0, "node {l}: pressure {v}");
    }
    // The same profile in the CSV beside the HDF5 file (one row per multiplier node and step).
    let csv = std::fs::read_to_string(format!("{}_contact.csv", out.with_extension("").display())).unwrap();
    let mut lines = csv.lines();
    assert_eq!(
        lines.next(),
        Some(
            "step,time,pair,x,y,pressure,shear,slip,accumulated_slip,status,cycle,increment,nodal_pressure,nodal_shear"
        )
    );
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), p.len());
    // The nodal traction (force over hat) of a uniform pressure is that pressure (the hats
    // sum to one), in the CSV and the HDF5 file alike.
    for r in &rows {
        let (pressure, nodal): (f64, f64) = (r[5].parse().unwrap(), r[12].parse().unwrap());
        assert!((pressure - 50.0).abs() < 1e-8 * 50.0 && r[2] == "interface" && r[9] == "0", "CSV row {r:?}");
        assert!((nodal - 50.0).abs() < 1e-8 * 50.0, "CSV row {r:?}");
    }
    let nodal = f.dataset("steps/000001/contacts/interface/nodal_pressure").unwrap().read_raw::<f64>().unwrap();
    assert!(nodal.len() == p.len() && nodal.iter().all(|v| (v - 50.0).abs() < 1e-8 * 50.0), "{nodal:?}");
}

/// Cattaneo-Mindlin case (two cylinders, rigid platen, normal then tangential force; see its
/// header): from the contact CSV of the last step, the stick zone (halfway between the outermost
/// stick node and the next slip node) within 3% of a sqrt(1 - Q/(mu P)) (target tolerance;
/// measured -1.8% on this graded mesh), and the Coulomb law at every node in contact: slip
/// |q| = mu p, stick |q| <= mu p (round-off, 1e-9 mu p0).
#[test]
fn cattaneo_mindlin_case() {
    let out = run_case("cattaneo_mindlin");
    let csv = std::fs::read_to_string(format!("{}_contact.csv", out.with_extension("").display())).unwrap();
    let mut nodes: Vec<(f64, f64, f64, u8)> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect::<Vec<_>>())
        .filter(|r| r[0] == "2")
        .map(|r| (r[3].parse().unwrap(), r[5].parse().unwrap(), r[6].parse().unwrap(), r[9].parse().unwrap()))
        .collect();
    nodes.sort_by(|a, b| a.0.total_cmp(&b.0));
    let (e_star, p, mu, q, r_eff) = (210_000.0 / (2.0 * (1.0 - 0.09)), 100.0, 0.3, 15.0, 5.0);
    let a: f64 = (4.0 * p * r_eff / (std::f64::consts::PI * e_star)).sqrt();
    let p0 = 2.0 * p / (std::f64::consts::PI * a);
    let c = a * (1.0f64 - q / (mu * p)).sqrt();
    let stick: Vec<usize> = (0..nodes.len()).filter(|&i| nodes[i].3 == 1).collect();
    let (lo, hi) = (stick[0], stick[stick.len() - 1]);
    assert!(stick.len() == hi - lo + 1, "one stick interval");
    let c_num = 0.25 * (nodes[hi].0 + nodes[hi + 1].0 - nodes[lo].0 - nodes[lo - 1].0);
    assert!((c_num / c - 1.0).abs() < 0.03, "stick zone {c_num} vs {c}");
    for n in &nodes {
        let bound = mu * n.1;
        match n.3 {
            2 => assert!((n.2.abs() - bound).abs() < 1e-9 * mu * p0, "slip node {n:?}"),
            1 => assert!(n.2.abs() <= bound + 1e-9 * mu * p0, "stick node {n:?}"),
            _ => assert!(n.1 == 0.0 && n.2 == 0.0, "open node {n:?}"),
        }
    }
}

/// Fretting-loop case (the cattaneo_mindlin scene cycled between +-Q*, Q* = 0.5 mu P; see its
/// header): the dissipation written per step in the HDF5 file, over the second cycle (t = 6 to
/// 10), within 5% (target tolerance) of Mindlin-Deresiewicz, W = 4 mu^2 int_{c<|x|<a} p g_c dx
/// (measured +0.97% on this graded mesh).
#[test]
fn fretting_loop_case() {
    let out = run_case("fretting_loop");
    let f = hdf5::File::open(&out).unwrap();
    let times = f.dataset("time").unwrap().read_raw::<f64>().unwrap();
    let step_at = |t: f64| times.iter().position(|&x| (x - t).abs() < 1e-12).unwrap() + 1;
    let diss =
        |s: usize| f.dataset(&format!("steps/{s:06}/contacts/dissipation")).unwrap().read_raw::<f64>().unwrap()[0];
    let w = diss(step_at(10.0)) - diss(step_at(6.0));
    let (e_star, p, mu, q_star, r_eff) = (210_000.0 / (2.0 * (1.0 - 0.09)), 100.0, 0.3, 15.0, 5.0);
    let a: f64 = (4.0 * p * r_eff / (std::f64::consts::PI * e_star)).sqrt();
    let p0 = 2.0 * p / (std::f64::consts::PI * a);
    let c = a * (1.0f64 - q_star / (mu * p)).sqrt();
    let n = 20_000;
    let w_exact: f64 = (0..n)
        .map(|i| {
            let x = c + (a - c) * (i as f64 + 0.5) / n as f64;
            let xi = x / c;
            let g = c * c / (2.0 * r_eff) * (xi * (xi * xi - 1.0).sqrt() - (xi + (xi * xi - 1.0).sqrt()).ln());
            // Both sides of the centre.
            2.0 * 4.0 * mu * mu * p0 * (1.0 - x * x / (a * a)).sqrt() * g * (a - c) / n as f64
        })
        .sum();
    assert!((w / w_exact - 1.0).abs() < 0.05, "dissipation per cycle {w:.4e} vs {w_exact:.4e}");
}

/// Finite sliding (`sliding_block`): after the 3 mm drag the tangential reaction on the block is
/// mu P = 15 N/mm (Coulomb and equilibrium; tolerance 1e-3: each step is paired in its own end
/// configuration, re-paired until the estimated pressure change is below 1e-3 of the largest,
/// and Coulomb's law holds in the frame of the deformed, slightly tilted segments,
/// tests/sliding.rs), every node carrying pressure slips, the
/// multiplier nodes sit on the block's new footprint x in [2.5, 3.5] (current positions), and
/// their accumulated slip is the stroke less the elastic shear of the first increments (1%).
#[test]
fn sliding_block_case() {
    let out = run_case("sliding_block");
    let f = hdf5::File::open(&out).unwrap();
    let last = f.group("steps").unwrap().member_names().unwrap().into_iter().max().unwrap();
    let r = read2(&f, &format!("steps/{last}/upper/reaction"));
    let q: f64 = r.column(0).sum();
    assert!((q.abs() / 15.0 - 1.0).abs() < 1e-3, "tangential reaction {q}");
    let c = format!("steps/{last}/contacts/drag");
    let p = f.dataset(&format!("{c}/pressure")).unwrap().read_raw::<f64>().unwrap();
    let status = f.dataset(&format!("{c}/status")).unwrap().read_raw::<u8>().unwrap();
    let acc = f.dataset(&format!("{c}/accumulated_slip")).unwrap().read_raw::<f64>().unwrap();
    let pos = read2(&f, &format!("{c}/position"));
    for l in 0..p.len() {
        assert!(pos[[l, 0]] > 2.5 - 1e-9 && pos[[l, 0]] < 3.5 + 1e-9, "node {l} at {}", pos[[l, 0]]);
        if p[l] > 1e-6 {
            assert_eq!(status[l], 2, "node {l} carries pressure {} but does not slip", p[l]);
            assert!((acc[l] / 3.0 - 1.0).abs() < 0.01, "node {l}: accumulated slip {}", acc[l]);
        }
    }
}

/// Moving contact surface under a cyclic load (see the case header): at every step the contact
/// pressure is `p(t) = 50 MPa x path factor` at every multiplier node and the stress uniform at
/// every point with material (round-off, 1e-8); steps carry their cycle and increment; the
/// surface moved 1 mm and the host's material fraction is written per step.
#[test]
fn moving_contact_case() {
    let out = run_case("moving_contact");
    let f = hdf5::File::open(&out).unwrap();
    let factor = |t: f64| {
        // steps.path [[0, 0], [1, 1], [2, 0.5], [3, 1]], window [1, 3] repeated.
        let local = if t <= 1.0 { t } else { 1.0 + (t - 1.0).rem_euclid(2.0) };
        let local = if t > 1.0 && local == 1.0 { 3.0 } else { local };
        if local <= 1.0 {
            local
        } else if local <= 2.0 {
            1.0 - 0.5 * (local - 1.0)
        } else {
            0.5 + 0.5 * (local - 2.0)
        }
    };
    let steps: u64 = f.attr("num_steps").unwrap().read_scalar().unwrap();
    assert_eq!(steps, 13);
    for k in 1..=steps {
        let g = f.group(&format!("steps/{k:06}")).unwrap();
        let t: f64 = g.attr("time").unwrap().read_scalar().unwrap();
        let (cycle, inc): (u64, u64) =
            (g.attr("cycle").unwrap().read_scalar().unwrap(), g.attr("increment").unwrap().read_scalar().unwrap());
        let expected_label = if k == 1 { (0, 1) } else { ((k - 2) / 4 + 1, (k - 2) % 4 + 1) };
        assert_eq!((cycle, inc), expected_label, "step {k}");
        let p = 50.0 * factor(t);
        let pressure = g.dataset("contacts/interface/pressure").unwrap().read_raw::<f64>().unwrap();
        for (l, v) in pressure.iter().enumerate() {
            assert!((v - p).abs() < 1e-8 * 50.0, "step {k} (t = {t}): node {l}: pressure {v} vs {p}");
        }
        let fraction = g.dataset("host/material_fraction").unwrap().read_raw::<f64>().unwrap();
        assert_eq!(fraction.len(), 48);
    }
    // The surface ends 1 mm lower: y = 1.63 (vertices in the order the case gives them).
    let v = read2(&f, &format!("steps/{steps:06}/surfaces/surface/vertices"));
    assert!((v[[0, 0]] + 1.0).abs() < 1e-12 && (v[[0, 1]] - 1.63).abs() < 1e-12, "{v:?}");
}

/// Sliding wear of a punch track (`sliding_wear`, see its header), accelerated (k = 1e-4: one
/// cycle wears 10 um, far more than the contact's compliance) against the same scene at a
/// realistic coefficient (k = 1e-7 over 20,000 cycles, same k N, implicit jumps):
/// - realistic, first cycle: the middle of the track has worn 2 k P (exact for Archard's law
///   while a cycle's wear leaves the pressure as it was; 0.5%: measured 0.25%, the rate filter
///   rounds the plateau's shoulders). The accelerated first cycle is a large time step: taken
///   at its end pressure (the punch then rests on the groove's shallower ends) it wears 0.80 of
///   that in the middle; taken as computed (explicit, before) 2 k P, but the later cycles grew
///   a wavy groove (149.5-158.0 um where the realistic run is flat at 151.6);
/// - accelerated: the scar within 1% of the realistic run's deepest over |x| <= 1.8 mm
///   (measured 0.15%); the worn area k P 6 mm per cycle (0.5%: the slip is the stroke less the
///   elastic shear); between cycles 10 and 20 the middle wears at 1.5 k P per cycle, the area
///   rate over the punch's reach once the groove is flat under it (5%); the groove ends at
///   least two and a half element layers deep.
#[test]
fn sliding_wear_case() {
    const K: f64 = 1e-4;
    const K_REAL: f64 = 1e-7;
    const P: f64 = 50.0;
    const LAYER: f64 = 1.037 / 20.0;
    let out = run_case("sliding_wear");
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(root.join("wear_cases/sliding_wear.toml")).unwrap();
    assert!(text.contains("coefficient = 1e-4") && text.contains("cycles = 20\n"));
    let realistic = run_text(
        "sliding_wear_realistic",
        &text.replace("coefficient = 1e-4", "coefficient = 1e-7").replace("cycles = 20\n", "cycles = 20000\n"),
    );
    let read = |file: &Path| {
        let f = hdf5::File::open(file).unwrap();
        let cycles = f.dataset("wear/cycle").unwrap().read_raw::<u64>().unwrap();
        let depth = read2(&f, "wear/track/depth");
        let x: Vec<f64> =
            f.dataset("wear/track/vertices").unwrap().read_dyn::<f64>().unwrap().slice(ndarray::s![0, .., 0]).to_vec();
        let area = f.dataset("wear/track/worn_area").unwrap().read_raw::<f64>().unwrap();
        (cycles, depth, x, area)
    };
    let (cycles, depth, x, area) = read(&out);
    let (real_cycles, real_depth, real_x, _) = read(&realistic);
    let row = |cycles: &[u64], c: u64| {
        cycles.iter().position(|&v| v == c).unwrap_or_else(|| panic!("no wear update at cycle {c}"))
    };
    let first = row(&real_cycles, 1);
    for (xi, d) in real_x.iter().zip(real_depth.row(first)).filter(|(x, _)| x.abs() <= 0.5) {
        assert!(
            (d / (2.0 * K_REAL * P) - 1.0).abs() < 5e-3,
            "realistic first cycle, x = {xi}: depth {d} against 2 k P"
        );
    }
    let last = cycles.len() - 1;
    assert_eq!(cycles[last], 20);
    let real_last = real_depth.nrows() - 1;
    let deepest_real = real_depth.row(real_last).iter().fold(0.0_f64, |a, &b| a.max(b));
    for ((xi, d), d_real) in x.iter().zip(depth.row(last)).zip(real_depth.row(real_last)) {
        if xi.abs() <= 1.8 {
            assert!((d - d_real).abs() < 0.01 * deepest_real, "x = {xi}: depth {d} against the realistic {d_real}");
        }
    }
    assert!((area[last] / (K * P * 6.0 * 20.0) - 1.0).abs() < 5e-3, "worn area {}", area[last]);
    let middle = |r: usize, half: f64| -> Vec<f64> {
        x.iter().zip(depth.row(r)).filter(|(x, _)| x.abs() <= half).map(|(_, d)| *d).collect()
    };
    let mean = |v: Vec<f64>| v.iter().sum::<f64>() / v.len() as f64;
    let rate = (mean(middle(last, 0.9)) - mean(middle(row(&cycles, 10), 0.9))) / 10.0;
    assert!((rate / (1.5 * K * P) - 1.0).abs() < 0.05, "late wear rate {rate} against 1.5 k P");
    let deepest = depth.row(last).iter().fold(0.0_f64, |a, &b| a.max(b));
    assert!(deepest > 2.5 * LAYER, "groove {deepest} mm deep: less than 2.5 layers of {LAYER}");
    assert_fields_every(&out, 80);
}

/// Full fields are written every `every` recorded steps of the schedule and at the last step,
/// however many steps a wear run computes: fractions of a cycle compute a cycle again and
/// jumps skip cycles. Once, every step past the schedule's count wrote its fields (10 MB a step
/// on the rounded punch), then every `every` computed steps (884 MB for the free rounded punch
/// at 32 increments, 60 computed cycles for 6). The schedule position of a step is the ramp's
/// steps, plus `increments` per cycle before its cycle, plus its increment; fields go where the
/// furthest position reached passes a multiple of `every` at least `every` computed steps after
/// the last fields (exact; a jump leaps over many multiples, and McColl's 92 computed cycles of
/// 18,000 would write 75 field sets at `fields_every = 1000` where its 737 computed steps ask
/// for none before the last), and never twice at one position.
fn assert_fields_every(out: &Path, every: usize) {
    let f = hdf5::File::open(out).unwrap();
    let read = |name: &str| f.dataset(&format!("series/{name}")).unwrap().read_raw::<f64>().unwrap();
    let (step, cycle, increment) = (read("step"), read("cycle"), read("increment"));
    let ramp = cycle.iter().filter(|&&c| c == 0.0).count();
    let increments = increment.iter().zip(&cycle).filter(|(_, &c)| c > 0.0).fold(0.0_f64, |a, (&i, _)| a.max(i));
    let position = |k: usize| {
        if cycle[k] == 0.0 {
            step[k] as usize
        } else {
            ramp + ((cycle[k] - 1.0) * increments + increment[k]) as usize
        }
    };
    let (mut reached, mut last_fields) = (0, 0);
    let mut expected = vec![];
    for k in 0..step.len() {
        let s = step[k] as usize;
        if (position(k) / every > reached / every && s - last_fields >= every) || k + 1 == step.len() {
            expected.push(s);
            last_fields = s;
        }
        reached = reached.max(position(k));
    }
    let mut with_fields: Vec<usize> = f
        .group("steps")
        .unwrap()
        .member_names()
        .unwrap()
        .iter()
        .filter(|g| {
            // A body's displacement: checkpoint steps hold the contact fields too.
            let members = f.group(&format!("steps/{g}")).unwrap().member_names().unwrap();
            members.iter().any(|m| f.link_exists(&format!("steps/{g}/{m}/displacement")))
        })
        .map(|g| g.parse().unwrap())
        .collect();
    with_fields.sort_unstable();
    assert_eq!(with_fields, expected, "{} steps, {} recorded", step.len(), reached);
    let positions: std::collections::BTreeSet<usize> =
        with_fields.iter().map(|s| position(step.iter().position(|&v| v as usize == *s).unwrap())).collect();
    assert_eq!(positions.len(), with_fields.len(), "fields written twice at one schedule position");
}

/// Reciprocating sliding of a pin on a plate (`pin_on_plate`, see its header), a stroke eight
/// contact widths per increment: every track point with |x| <= 0.7 mm is passed by the whole
/// contact twice per cycle and wears 2 k P per cycle (exact for Archard's law), 4.8 um after 3
/// cycles; 1%: 64 increments per cycle give 4.778-4.785 um there, the sweep of a field riding
/// along is exact to the trapezoid rule of the sub-positions. Swept from the increments' ends
/// alone (the pressure field interpolated across the pin's entry into its groove's end) the
/// track stepped down 4.5% beyond the increment position |x| = 0.5. The worn area is k P 4 mm
/// per cycle (0.5%: the slip is the stroke less the elastic shear).
#[test]
fn pin_on_plate_case() {
    const K: f64 = 4e-5;
    const P: f64 = 20.0;
    const CYCLES: f64 = 3.0;
    let out = run_case("pin_on_plate");
    let f = hdf5::File::open(&out).unwrap();
    let depth = read2(&f, "wear/plate.top/depth");
    let x: Vec<f64> =
        f.dataset("wear/plate.top/vertices").unwrap().read_dyn::<f64>().unwrap().slice(ndarray::s![0, .., 0]).to_vec();
    let area = f.dataset("wear/plate.top/worn_area").unwrap().read_raw::<f64>().unwrap();
    let last = depth.nrows() - 1;
    let expected = 2.0 * K * P * CYCLES;
    let mut checked = 0;
    for (xi, d) in x.iter().zip(depth.row(last)).filter(|(x, _)| x.abs() <= 0.7) {
        assert!((d / expected - 1.0).abs() < 1e-2, "x = {xi}: depth {d} against 2 k P N = {expected}");
        checked += 1;
    }
    assert!(checked > 60, "{checked} track vertices checked (20 um apart)");
    assert!((area[last] / (K * P * 4.0 * CYCLES) - 1.0).abs() < 5e-3, "worn area {}", area[last]);
}

/// Coarse-grained multipliers by one rule whether or not the other side wears: the pin of
/// `pin_on_plate` on a twice finer arc (241 vertices), pressed on a plate whose top cells are
/// 20 um wide and much thinner. A wearing plate's top becomes a virtual surface in its host
/// cells: its spacing must be the cell's extent along the surface (the edge's length of the
/// unworn plate), not the cell's square-root area, which coarse-grained less and left a
/// two-node checkerboard (multipliers 933 / 220 MPa alternating against p0 = 432). After the
/// unworn ramp the multipliers fall from the middle outward, and the peak nodal traction is
/// within 6% of Hertz's p0 (three multiplier rows span the contact's 59 um, 22 um apart).
#[test]
fn coarse_grained_multipliers_follow_one_rule_whether_or_not_a_side_wears() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(root.join("wear_cases/pin_on_plate.toml"))
        .unwrap()
        .replace("grading = [1.0, 0.1]", "grading = [1.0, 0.02]")
        .replace("divisions = [20, 120]", "divisions = [20, 240]")
        .replace("cycles = 3", "cycles = 1");
    assert!(text.contains("[1.0, 0.02]") && text.contains("[20, 240]") && text.contains("cycles = 1"));
    let (i, j) = (text.find("[[wear]]").unwrap(), text.find("[steps]").unwrap());
    let unworn = format!("{}{}", &text[..i], &text[j..]);
    let nodes = |t: &str| {
        let case = mortex::case::parse(t, "pin", &root.join("wear_cases"), "pin").unwrap_or_else(|e| panic!("{e}"));
        let disc = case.model.initial();
        assert_eq!(disc.contact.pairs.len(), 1);
        disc.contact.pairs[0].multipliers.num_nodes
    };
    let (wearing, not_wearing) = (nodes(&text), nodes(&unworn));
    assert_eq!(wearing, not_wearing, "multiplier nodes with and without wear");
    assert!(wearing < 200, "{wearing} multiplier nodes: the 241-vertex arc is not coarse-grained");
    let out = run_text("pin_fine", &text);
    let PinContact { pressed, peak, nodal_peak } = pin_contact_after_ramp(&out);
    for k in 1..pressed.len() {
        let rising = pressed[k].1 > pressed[k - 1].1;
        assert_eq!(rising, k <= peak, "multipliers not single-peaked (a checkerboard): {pressed:?}");
    }
    let p0 = pin_hertz_p0();
    assert!((nodal_peak / p0 - 1.0).abs() < 0.06, "peak nodal traction {nodal_peak} against p0 = {p0}");
}

/// The unworn Hertz contact of the `pin_on_plate` scene, wear declared on the plate (so the
/// plate's top is a virtual surface and the multipliers coarse-grained by its cells), on
/// contact meshes fine enough to resolve it: plate cells 5 um along the track (12 multiplier
/// rows over the contact's 59 um), pin arc of 481 vertices graded toward the contact.
/// Reference: Hertz (plane strain, E* from both bodies), p0 = 431.9 MPa. The peak nodal
/// traction within 2% of p0 (the discrete peak converges from above: +5.5% at 20 um cells,
/// +3.6% at 10 um, +1.6% at 5 um); the multipliers rise to one peak and fall (no
/// checkerboard; at 10 um cells they still alternate 485 / 370 MPa while the nodal traction
/// does not), the largest within 3% of p0 (measured +2.0%).
#[test]
fn pin_hertz_pressure_within_two_percent_on_a_resolved_contact() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(root.join("wear_cases/pin_on_plate.toml"))
        .unwrap()
        .replace("divisions = [250, 20], grading = [1.0, 0.1]", "divisions = [1000, 20], grading = [1.0, 0.02]")
        .replace("divisions = [20, 120]", "divisions = [20, 480]")
        .replace("cycles = 3", "cycles = 1");
    assert!(text.contains("[1000, 20]") && text.contains("[20, 480]") && text.contains("cycles = 1"));
    let out = run_text("pin_resolved", &text);
    let PinContact { pressed, peak, nodal_peak } = pin_contact_after_ramp(&out);
    assert!(pressed.len() >= 10, "{} multiplier rows pressed", pressed.len());
    for k in 1..pressed.len() {
        // Equal neighbours (the symmetric pair about the middle) count as the peak.
        let step = pressed[k].1 - pressed[k - 1].1;
        assert!(
            if k <= peak { step >= -1e-9 * pressed[peak].1 } else { step <= 1e-9 * pressed[peak].1 },
            "multipliers not single-peaked (a checkerboard): {pressed:?}"
        );
    }
    let p0 = pin_hertz_p0();
    assert!((nodal_peak / p0 - 1.0).abs() < 0.02, "peak nodal traction {nodal_peak} against p0 = {p0}");
    assert!((pressed[peak].1 / p0 - 1.0).abs() < 0.03, "peak multiplier {} against p0 = {p0}", pressed[peak].1);
}

/// Hertz's p0 of the `pin_on_plate` scene (plane strain, steel pin R = 2 mm on aluminium,
/// P = 20 N/mm): E* from both bodies, `a = sqrt(4 P R / (pi E*))`, `p0 = 2 P / (pi a)`.
fn pin_hertz_p0() -> f64 {
    let e_star = 1.0 / ((1.0 - 0.3f64.powi(2)) / 210000.0 + (1.0 - 0.33f64.powi(2)) / 70000.0);
    let a = (4.0 * 20.0 * 2.0 / (std::f64::consts::PI * e_star)).sqrt();
    2.0 * 20.0 / (std::f64::consts::PI * a)
}

/// The pin's contact at the end of the ramp (the first output step): the pressed multiplier
/// rows `(x, lambda)` sorted along x, the index of the largest, and the peak nodal traction.
struct PinContact {
    pressed: Vec<(f64, f64)>,
    peak: usize,
    nodal_peak: f64,
}

fn pin_contact_after_ramp(out: &Path) -> PinContact {
    let f = hdf5::File::open(out).unwrap();
    let lambda = read2(&f, "series/contacts/track/pressure");
    let nodal = read2(&f, "series/contacts/track/nodal_pressure");
    let x = f.dataset("series/contacts/track/position").unwrap().read_dyn::<f64>().unwrap();
    let mut pressed: Vec<(f64, f64)> =
        (0..lambda.ncols()).filter(|&k| lambda[[0, k]] > 0.0).map(|k| (x[[0, k, 0]], lambda[[0, k]])).collect();
    pressed.sort_by(|a, b| a.0.total_cmp(&b.0));
    let peak = (0..pressed.len()).max_by(|&a, &b| pressed[a].1.total_cmp(&pressed[b].1)).unwrap();
    let nodal_peak = nodal.row(0).iter().fold(0.0_f64, |m, &v| m.max(v));
    PinContact { pressed, peak, nodal_peak }
}

/// Sliding wear under a free punch (`free_punch_wear`, see its header): pressure-loaded, its top
/// held in x only, held in y by the contact alone, mu = 0.3. Every step's slip is the
/// prescribed stroke's doing, so no failure may be blamed on a tangential load (it once
/// stopped at step 63 with a false "gross sliding" error); the run completes its 20 cycles.
/// The worn area is `k int p |ds|` to 1e-10 (the wear balance, exact by construction); the
/// first cycle's middle within 5% of 2 k P (measured 3.8%: the punch rocks at each stroke's
/// start within an increment; 1.2% at 64 increments).
#[test]
fn free_punch_wear_case() {
    const K: f64 = 1e-4;
    const P: f64 = 50.0;
    let out = run_case("free_punch_wear");
    let f = hdf5::File::open(&out).unwrap();
    let cycles = f.dataset("wear/cycle").unwrap().read_raw::<u64>().unwrap();
    assert_eq!(*cycles.last().unwrap(), 20);
    let area = f.dataset("wear/track/worn_area").unwrap().read_raw::<f64>().unwrap();
    let work = f.dataset("wear/track/work").unwrap().read_raw::<f64>().unwrap();
    let last = area.len() - 1;
    assert!((area[last] / (K * work[last]) - 1.0).abs() < 1e-10, "worn area {} against k work", area[last]);
    let depth = read2(&f, "wear/track/depth");
    let x: Vec<f64> =
        f.dataset("wear/track/vertices").unwrap().read_dyn::<f64>().unwrap().slice(ndarray::s![0, .., 0]).to_vec();
    let first = cycles.iter().position(|&c| c == 1).unwrap();
    for (xi, d) in x.iter().zip(depth.row(first)).filter(|(x, _)| x.abs() <= 0.5) {
        assert!((d / (2.0 * K * P) - 1.0).abs() < 0.05, "first cycle, x = {xi}: depth {d} against 2 k P");
    }
}

/// Runs the case text `text` (a variant of a shipped case) under `name` in the scratch folder.
fn run_text(name: &str, text: &str) -> ResultFiles {
    let case = ResultFiles::in_scratch("cases", &format!("{name}.toml"));
    std::fs::write(&*case, text).unwrap();
    let out = ResultFiles::in_scratch("cases", &format!("{name}.h5"));
    let status = Command::new(env!("CARGO_BIN_EXE_mortex"))
        .args(["run", case.to_str().unwrap(), "--quiet", "-o", out.to_str().unwrap()])
        .status()
        .unwrap();
    assert!(status.success(), "case {name} failed");
    out
}

/// The final depth profile of surface `s` (vertex x, depth) and, per step of the last cycle,
/// the pressed multiplier rows of pair `pair` and the runs ("islands") they form along x.
fn scar_and_islands(out: &Path, s: &str, pair: &str) -> (Vec<(f64, f64)>, Vec<(usize, usize)>) {
    let f = hdf5::File::open(out).unwrap();
    let depth = read2(&f, &format!("wear/{s}/depth"));
    let x = f.dataset(&format!("wear/{s}/vertices")).unwrap().read_dyn::<f64>().unwrap();
    let last = depth.nrows() - 1;
    let profile = (0..depth.ncols()).map(|i| (x[[0, i, 0]], depth[[last, i]])).collect();
    let p = read2(&f, &format!("series/contacts/{pair}/pressure"));
    let pos = f.dataset(&format!("series/contacts/{pair}/position")).unwrap().read_dyn::<f64>().unwrap();
    let cycle = f.dataset("series/cycle").unwrap().read_raw::<u64>().unwrap();
    let c_last = *cycle.last().unwrap();
    let islands = (0..p.nrows())
        .filter(|&k| cycle[k] == c_last)
        .map(|k| {
            let mut row: Vec<(f64, bool)> = (0..p.ncols()).map(|j| (pos[[k, j, 0]], p[[k, j]] > 0.0)).collect();
            row.sort_by(|a, b| a.0.total_cmp(&b.0));
            let pressed = row.iter().filter(|r| r.1).count();
            let runs = (0..row.len()).filter(|&j| row[j].1 && (j == 0 || !row[j - 1].1)).count();
            (pressed, runs)
        })
        .collect();
    (profile, islands)
}

/// Wear at any rate gives the scar of its `k N` (`punch_on_bronze`, see its header): a flat
/// punch on a rigid platen slid +-0.5 mm on bronze, realistic k = 2e-8 over 20,000 cycles
/// (implicit jumps) against the same scene accelerated 1,000 times (k = 2e-5, 20 cycles, each
/// computed) and 10,000 times (k = 2e-4, 2 cycles). The element-scale roughness mode of one
/// computed cycle's wear has `a = (E*/h) k S` of about 200 and 2,000 there (E*/h = 4e6 MPa/mm,
/// S = 2 mm): applied as computed (explicit) it grew ripples and the punch rested on 3-9
/// islands at up to 2,470 MPa against 83 nominal; taken at the cycle's end pressure (implicit,
/// amplification 1 / (1 + a)) the contact under the punch mid-stroke stays whole, one island
/// of all 29 rows as in the realistic run. Depths: 1,000 times, the middle (abs(x) <= 0.5)
/// within 1% and the profile over abs(x) <= 0.9 within 2% of the largest depth (measured
/// 0.04% and 0.3%); 10,000 times (two updates of 12.7 um each: the groove's ends not yet run
/// in), the middle within 1% (measured 0.3%).
#[test]
fn punch_on_bronze_case_wears_the_scar_of_its_k_n() {
    let realistic = run_case("punch_on_bronze");
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(root.join("wear_cases/punch_on_bronze.toml")).unwrap();
    assert!(text.contains("coefficient = 2e-8") && text.contains("cycles = 20000"));
    let faster = |k: &str, n: &str| {
        text.replace("coefficient = 2e-8", &format!("coefficient = {k}"))
            .replace("cycles = 20000", &format!("cycles = {n}"))
    };
    let (reference, _) = scar_and_islands(&realistic, "plate.top", "track");
    let deepest = reference.iter().fold(0.0_f64, |a, b| a.max(b.1));
    assert!(deepest > 0.02, "the realistic run wears {deepest} mm");
    for (k, n, whole_profile) in [("2e-5", "20", true), ("2e-4", "2", false)] {
        let out = run_text(&format!("punch_on_bronze_k{k}"), &faster(k, n));
        let (profile, islands) = scar_and_islands(&out, "plate.top", "track");
        for (&(x, d), &(_, d_ref)) in profile.iter().zip(&reference) {
            if x.abs() <= 0.5 {
                assert!((d / d_ref - 1.0).abs() < 0.01, "k = {k}, x = {x}: depth {d} against {d_ref}");
            }
            if whole_profile && x.abs() <= 0.9 {
                assert!((d - d_ref).abs() < 0.02 * deepest, "k = {k}, x = {x}: depth {d} against {d_ref}");
            }
        }
        // Mid-stroke (the punch over the groove's flat middle: increments 7-8 and 15-16 of 16,
        // at or next to x = 0), the contact is one island of the punch's whole face.
        for inc in [7, 8, 15, 16] {
            let (pressed, runs) = islands[inc - 1];
            assert!(runs == 1 && pressed >= 28, "k = {k}, increment {inc}: {pressed} rows pressed in {runs} islands");
        }
    }
}

/// Hertz line contact (`hertz`, see its header): the peak pressure and the contact half-width
/// (from the load and the peak, `a = 2 P / (pi p_max)`) against Johnson's `p0` and `a`, 1% each
/// (the block is a finite 40 x 20 mm body, about 0.2% stiffer than the half-space at this `a`;
/// the contact has about 20 multiplier nodes); and the pressure integrates to P (0.5%).
#[test]
fn hertz_case() {
    const P: f64 = 100.0;
    const R: f64 = 10.0;
    let e_star = 210_000.0 / (2.0 * (1.0 - 0.3 * 0.3));
    let a = (4.0 * P * R / (std::f64::consts::PI * e_star)).sqrt();
    let p0 = 2.0 * P / (std::f64::consts::PI * a);
    let out = run_case("hertz");
    let f = hdf5::File::open(&out).unwrap();
    let last = f.group("steps").unwrap().member_names().unwrap().into_iter().max().unwrap();
    let c = format!("steps/{last}/contacts/hertz");
    let p = f.dataset(&format!("{c}/pressure")).unwrap().read_raw::<f64>().unwrap();
    let pos = read2(&f, &format!("{c}/position"));
    let mut prof: Vec<(f64, f64)> = (0..p.len()).map(|l| (pos[[l, 0]], p[l])).collect();
    prof.sort_by(|u, v| u.0.total_cmp(&v.0));
    let load: f64 = prof.windows(2).map(|w| 0.5 * (w[0].1 + w[1].1) * (w[1].0 - w[0].0)).sum();
    let peak = prof.iter().map(|q| q.1).fold(0.0, f64::max);
    let a_fit = 2.0 * load / (std::f64::consts::PI * peak);
    assert!((load / P - 1.0).abs() < 5e-3, "load {load}");
    assert!((peak / p0 - 1.0).abs() < 0.01, "p_max {peak} against p0 {p0}");
    assert!((a_fit / a - 1.0).abs() < 0.01, "a {a_fit} against {a}");
}

/// Shipped `tied_bending_contrast` (a 10x finer, 10x stiffer patch tied along a straight
/// interface through the host's cells, pure bending; Akula, Vignollet & Yastrebov, arXiv
/// 1902.04003, sec. 4): the exact interface traction is `sigma . n` with `sigma_xx = 50 (y - 2)`.
/// The shipped coarse-grained multipliers keep the largest traction error within the paper's 1%
/// of the mean traction (measured 0.47%: the host's bending discretisation error at h = 0.125
/// mm, first order in h); the same case with the classical space misses it (measured 1.45%:
/// its multipliers, ten per host cell, over-constrain the cut host cells) and does worse than
/// the coarse-grained.
#[test]
fn tied_bending_contrast_case() {
    let traction_error = |out: &Path| {
        let f = hdf5::File::open(out).unwrap();
        let t = read2(&f, "steps/000001/ties/interface/traction");
        let p = read2(&f, "mesh/ties/interface/points");
        let n = read2(&f, "mesh/ties/interface/normals");
        let (mut worst, mut mean) = (0.0_f64, 0.0);
        for l in 0..t.nrows() {
            let s = 50.0 * (p[[l, 1]] - 2.0);
            let (ex, ey) = (s * n[[l, 0]], s * n[[l, 1]]);
            worst = worst.max(((t[[l, 0]] - ex).powi(2) + (t[[l, 1]] - ey).powi(2)).sqrt());
            mean += ex.abs() / t.nrows() as f64;
        }
        (worst / mean, t.nrows())
    };
    let out = run_case("tied_bending_contrast");
    let (coarse, nodes) = traction_error(&out);
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(root.join("wear_cases/tied_bending_contrast.toml"))
        .unwrap()
        .replace("multipliers = \"coarse_grained\"", "multipliers = \"classical\"");
    let classical_case = ResultFiles::in_scratch("cases", "classical.toml");
    std::fs::write(&*classical_case, text).unwrap();
    let classical_out = ResultFiles(classical_case.with_extension("h5"));
    let status = Command::new(env!("CARGO_BIN_EXE_mortex"))
        .args(["run", classical_case.to_str().unwrap(), "--quiet", "-o", classical_out.to_str().unwrap()])
        .status()
        .unwrap();
    assert!(status.success());
    let (classical, classical_nodes) = traction_error(&classical_out);
    eprintln!("traction error: coarse-grained {coarse:.4} ({nodes} nodes), classical {classical:.4} ({classical_nodes} nodes)");
    assert!(coarse <= 0.01, "coarse-grained traction error {coarse:.3e}");
    assert!(classical > 0.01 && classical > coarse, "classical {classical:.3e}, coarse-grained {coarse:.3e}");
}

/// `fine_zone` on the generated meshes: a uniform zone of the given width and divisions in the
/// middle of the rectangle's x lines and of the half disc's arc (the contact zone of a fretting
/// scar resolved evenly), the rest graded away; bad zones are errors naming the key. Exact
/// up to round-off: the zone's lines are `width / divisions` apart by construction (1e-9 of the
/// spacing allows for the subtraction of coordinates of order 1 mm).
#[test]
fn fine_zone_meshes_resolve_the_contact_zone_evenly() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(root.join("wear_cases/mccoll_fretting.toml")).unwrap();
    let with = |cylinder: &str, flat: &str| {
        text.replace("angular_grading = 200.0 }", &format!("fine_zone = {cylinder} }}")).replace(
            "divisions = [120, 30], grading = [30.0, 0.01], refine_to_centre = [true, false] }",
            &format!("divisions = [160, 30], grading = [1.0, 0.01], fine_zone = {flat} }}"),
        )
    };
    let good = with("{ width = 0.6, divisions = 120 }", "{ width = 0.7, divisions = 120 }");
    let case = mortex::case::parse(&good, "fine_zone", &root.join("wear_cases"), "fine_zone").unwrap();
    let coords = &case.model.coords;
    // Flat top: y = 0 (the cylinder's lowest node coincides with one of them).
    let mut xs: Vec<f64> = coords.iter().filter(|p| p.y == 0.0 && p.x.abs() <= 0.35 + 1e-12).map(|p| p.x).collect();
    xs.sort_by(f64::total_cmp);
    xs.dedup_by(|a, b| (*a - *b).abs() < 1e-12);
    assert_eq!(xs.len(), 121, "120 divisions over the flat's fine zone");
    let h = 0.7 / 120.0;
    assert!(xs.windows(2).all(|w| ((w[1] - w[0]) - h).abs() < 1e-9 * h), "uniform flat zone");
    // Cylinder arc (radius 6 about (0, 6)): angles of the rim nodes within the zone.
    let half_angle = 0.3 / 6.0;
    let mut angles: Vec<f64> = coords
        .iter()
        .filter(|p| ((p.x.powi(2) + (p.y - 6.0).powi(2)).sqrt() - 6.0).abs() < 1e-9 && p.y < 6.0)
        .map(|p| p.x.atan2(6.0 - p.y))
        .filter(|a| a.abs() <= half_angle + 1e-12)
        .collect();
    angles.sort_by(f64::total_cmp);
    angles.dedup_by(|a, b| (*a - *b).abs() < 1e-12);
    assert_eq!(angles.len(), 121, "120 divisions over the arc's fine zone");
    let dt = 2.0 * half_angle / 120.0;
    assert!(angles.windows(2).all(|w| ((w[1] - w[0]) - dt).abs() < 1e-9 * dt), "uniform arc zone");
    // Bad zones: odd on a half disc, no division left outside, wider than the body.
    for (cylinder, flat, what) in [
        ("{ width = 0.6, divisions = 121 }", "{ width = 0.7, divisions = 120 }", "even"),
        ("{ width = 0.6, divisions = 120 }", "{ width = 0.7, divisions = 160 }", "fine_zone.divisions"),
        ("{ width = 0.6, divisions = 120 }", "{ width = 3.5, divisions = 120 }", "fine_zone.width"),
    ] {
        let err = mortex::case::parse(&with(cylinder, flat), "bad", &root.join("wear_cases"), "bad")
            .err()
            .unwrap_or_else(|| panic!("{cylinder} / {flat} accepted"))
            .to_string();
        assert!(err.contains(what) && err.contains("mesh"), "{err}");
    }
}

/// Reciprocating sliding wear of a punch with rounded edges ten element layers deep
/// (`rounded_punch_wear`, see its header): the run completes with default settings, its wear
/// applied in fractions of a cycle (25 passes for 8 cycles), and default step control (its
/// first version stopped in the first cycle on a singular interface system, then at 68 um on a
/// pairing that flipped between two states: a rounding's near-vertical flank paired with the
/// plate across a third of a millimetre of open space), the groove is deeper than the plate's
/// top ten element layers, and the worn area equals k times the wear work `int p |ds|` (1e-10:
/// the two are one sum, split between the vertices; a round-off margin); full fields every 32
/// recorded steps however often a cycle is computed again (see `assert_fields_every`).
#[test]
fn rounded_punch_wears_ten_layers_deep() {
    const K: f64 = 2e-4;
    // Top ten of 40 layers over 1 mm graded 0.1 (last/first) toward the top.
    let ratio = 0.1_f64.powf(1.0 / 39.0);
    let first = 1.0 / (0..40).map(|i| ratio.powi(i)).sum::<f64>();
    let ten_layers: f64 = (0..10).map(|i| first * ratio.powi(39 - i)).sum();
    let out = run_case("rounded_punch_wear");
    let f = hdf5::File::open(&out).unwrap();
    let depth = read2(&f, "wear/plate.top/depth");
    let area = f.dataset("wear/plate.top/worn_area").unwrap().read_raw::<f64>().unwrap();
    let work = f.dataset("wear/plate.top/work").unwrap().read_raw::<f64>().unwrap();
    let cycles = f.dataset("wear/cycle").unwrap().read_raw::<u64>().unwrap();
    let last = depth.nrows() - 1;
    assert_eq!(cycles[last], 8);
    let deepest = depth.row(last).iter().fold(0.0_f64, |a, &b| a.max(b));
    assert!(deepest > ten_layers, "groove {deepest} mm deep, ten layers {ten_layers}");
    assert!(((area[last] - K * work[last]) / area[last]).abs() < 1e-10, "area {} work {}", area[last], work[last]);
    assert_fields_every(&out, 32);
}

/// The rounded punch of `rounded_punch_wear` with wear applied in fractions of a cycle
/// (`[cycle_jump] min_fraction = 1/256`, the default, written out so the scene stays this one): one cycle's wear (12 um) is twenty times the
/// contact's elastic approach (0.6 um), so applied whole it changes the pressure beyond the
/// controller's bound and the groove grows pits (whole cycles at 32 increments: 96-113 um over
/// |x| <= 0.5, 17% of the depth); in fractions each update changes the pressure by at most
/// `pressure_change` (widened where the last fraction's predicted pressure held) and the run
/// follows the path of a realistic coefficient. Checks: the groove's bottom over |x| <= 0.5
/// flat within 1% of its depth (measured 0.5%: the bottom follows the punch's flat, whose ends
/// sit on the roundings' tangent points), and 16 against 32 recorded increments within 2% (L2
/// over the track |x| <= 1.1, and the deepest point; measured 0.25% and 0.1%). About 110 s +
/// 250 s (25 and 36 passes for 8 cycles): a study, `cargo test --release -- --ignored`.
#[test]
#[ignore]
fn rounded_punch_in_fractions_of_a_cycle_wears_a_flat_groove_at_any_increment_count() {
    const FLAT_BOTTOM: f64 = 0.01;
    const INCREMENTS_AGREE: f64 = 0.02;
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let meshes = root.join("wear_cases/meshes/");
    let text = std::fs::read_to_string(root.join("wear_cases/rounded_punch_wear.toml"))
        .unwrap()
        .replace("file = \"meshes/", &format!("file = \"{}", meshes.display()))
        .replace("[steps]", "[cycle_jump]\nmin_fraction = 0.00390625\n\n[steps]");
    assert!(text.contains("min_fraction") && text.contains("increments = 16"));
    let profile = |increments: usize| {
        let t = text.replace("increments = 16", &format!("increments = {increments}"));
        let out = run_text(&format!("rounded_punch_fractions_{increments}"), &t);
        let f = hdf5::File::open(&*out).unwrap();
        let depth = read2(&f, "wear/plate.top/depth");
        let x = f.dataset("wear/plate.top/vertices").unwrap().read_raw::<f64>().unwrap();
        let cycles = f.dataset("wear/cycle").unwrap().read_raw::<u64>().unwrap();
        let last = depth.nrows() - 1;
        assert_eq!(cycles[last], 8);
        let xs: Vec<f64> = (0..depth.ncols()).map(|i| x[2 * i]).collect();
        (xs, depth.row(last).to_vec())
    };
    let (x, d16) = profile(16);
    let (_, d32) = profile(32);
    let deepest = |d: &[f64]| d.iter().fold(0.0_f64, |a, &b| a.max(b));
    let bottom: Vec<f64> = x.iter().zip(&d32).filter(|(x, _)| x.abs() <= 0.5).map(|(_, &d)| d).collect();
    let lowest = bottom.iter().fold(f64::INFINITY, |a, &b| a.min(b));
    assert!((deepest(&d32) - lowest) / deepest(&d32) < FLAT_BOTTOM, "bottom {lowest}..{}", deepest(&d32));
    let (mut num, mut den) = (0.0, 0.0);
    for i in (0..x.len()).filter(|&i| x[i].abs() <= 1.1) {
        num += (d16[i] - d32[i]).powi(2);
        den += d32[i].powi(2);
    }
    assert!((num / den).sqrt() < INCREMENTS_AGREE, "16 against 32 increments: L2 {}", (num / den).sqrt());
    assert!(
        (deepest(&d16) / deepest(&d32) - 1.0).abs() < INCREMENTS_AGREE,
        "deepest {} {}",
        deepest(&d16),
        deepest(&d32)
    );
}

/// Reciprocating sliding wear under a free rounded punch, pressure-loaded with no platen
/// (`rounded_punch_free`, see its header), its first 3 of 6 cycles (the whole case, ten layers
/// deep, is run by `free_rounded_punch_grooves_agree_at_16_and_32_increments`: 6 minutes):
/// held in y by the contact alone and free to turn about a point of its top, it runs with
/// default step control (before, a total force put on one corner of its top tipped it and the
/// first step failed) through the plate's top five element layers (52 um after 3 cycles); the
/// worn area equals k times the wear work (1e-10: one sum split between the vertices, a
/// round-off margin); the first cycle wears `k P S` (Archard's global balance: `S` = 2 mm of
/// stroke; 2%: the punch, free to turn, rocks at the stroke reversals and its bottom slides
/// further than its top, more as it sinks into the groove its first cycle's passes wear;
/// measured +1.5%, and +1.58% and +1.43% at 32 and 64 increments; the +0.5% once measured here
/// came from a groove pitted by a failed wear update); full fields every 32 recorded steps.
#[test]
fn free_rounded_punch_wears_five_layers_deep_in_three_cycles() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(root.join("wear_cases/rounded_punch_free.toml"))
        .unwrap()
        .replace("meshes/rounded_punch.msh", &root.join("wear_cases/meshes/rounded_punch.msh").to_string_lossy());
    assert!(text.contains("cycles = 6\n") && text.contains("fields_every = 32"));
    let out = run_text("rounded_punch_free_3", &text.replace("cycles = 6\n", "cycles = 3\n"));
    assert_free_punch_groove(&out, 0.02, 3, 5);
    assert_fields_every(&out, 32);
}

/// The checks of the free rounded punch's groove (`rounded_punch_free` and its variants):
/// `cycles` completed, deeper than the plate's top `layers` element layers (of 40 over 1 mm
/// graded 0.1, last over first, toward the top), worn area `k int p |ds|` to 1e-10, and the
/// first cycle's worn area `k P S` within `first_cycle` (relative).
fn assert_free_punch_groove(out: &Path, first_cycle: f64, cycles_done: u64, layers: i32) {
    const K: f64 = 2e-4;
    const P: f64 = 50.0;
    const STROKE_PER_CYCLE: f64 = 2.0;
    let ratio = 0.1_f64.powf(1.0 / 39.0);
    let first = 1.0 / (0..40).map(|i| ratio.powi(i)).sum::<f64>();
    let top_layers: f64 = (0..layers).map(|i| first * ratio.powi(39 - i)).sum();
    let f = hdf5::File::open(out).unwrap();
    let depth = read2(&f, "wear/plate.top/depth");
    let area = f.dataset("wear/plate.top/worn_area").unwrap().read_raw::<f64>().unwrap();
    let work = f.dataset("wear/plate.top/work").unwrap().read_raw::<f64>().unwrap();
    let cycles = f.dataset("wear/cycle").unwrap().read_raw::<u64>().unwrap();
    let last = depth.nrows() - 1;
    assert_eq!(cycles[last], cycles_done);
    let deepest = depth.row(last).iter().fold(0.0_f64, |a, &b| a.max(b));
    assert!(deepest > top_layers, "groove {deepest} mm deep, {layers} layers {top_layers}");
    assert!(((area[last] - K * work[last]) / area[last]).abs() < 1e-10, "area {} work {}", area[last], work[last]);
    let one = cycles.iter().position(|&c| c == 1).unwrap();
    let archard = K * P * STROKE_PER_CYCLE;
    let worn = area[one];
    assert!((worn / archard - 1.0).abs() < first_cycle, "first cycle's worn area {worn} against k P S {archard}");
}

/// The free rounded punch of `rounded_punch_free` (no friction) at 16 and 32 recorded
/// increments per cycle: the grooves agree within 2% (the target; L2 over the track |x| <= 1.1
/// mm and the deepest point). Measured 0.53% L2, 0.91% at the worst point, 101.3 against 101.45
/// um; 64 increments give 100.97 um, 0.58% L2 from 32. Before, a wear update whose linearised
/// system failed for the whole cycle (contact sets that cycled, or a singular system) applied
/// the whole cycle's wear as computed: at one cycle's wear twenty times the contact's elastic
/// approach that grew pits 20% of the depth at 16 increments (114.8 um, 7.7% L2 from 32); such
/// an update now halves its part of the cycle until the system solves. Both runs also pass the
/// checks of the shipped case through ten element layers. About 6 + 6 minutes: a study,
/// `cargo test --release -- --ignored`.
#[test]
#[ignore]
fn free_rounded_punch_grooves_agree_at_16_and_32_increments() {
    const INCREMENTS_AGREE: f64 = 0.02;
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(root.join("wear_cases/rounded_punch_free.toml"))
        .unwrap()
        .replace("meshes/rounded_punch.msh", &root.join("wear_cases/meshes/rounded_punch.msh").to_string_lossy());
    assert!(text.contains("friction = 0.0") && text.contains("increments = 16"));
    let groove = |increments: usize| {
        let t = text.replace("increments = 16", &format!("increments = {increments}"));
        let out = run_text(&format!("rounded_punch_free_{increments}"), &t);
        assert_free_punch_groove(&out, 0.02, 6, 10);
        scar_and_islands(&out, "plate.top", "track").0
    };
    let (d16, d32) = (groove(16), groove(32));
    let (mut num, mut den) = (0.0, 0.0);
    for (&(x, a), &(x32, b)) in d16.iter().zip(&d32) {
        assert_eq!(x, x32, "one plate");
        if x.abs() <= 1.1 {
            num += (a - b).powi(2);
            den += b * b;
        }
    }
    assert!((num / den).sqrt() < INCREMENTS_AGREE, "16 against 32 increments: L2 {}", (num / den).sqrt());
    let deepest = |d: &[(f64, f64)]| d.iter().fold(0.0_f64, |m, p| m.max(p.1));
    assert!(
        (deepest(&d16) / deepest(&d32) - 1.0).abs() < INCREMENTS_AGREE,
        "deepest {} {}",
        deepest(&d16),
        deepest(&d32)
    );
}

/// The free rounded punch of `rounded_punch_free` with friction 0.3, the regime that stopped in
/// its seventh cycle (104 um) before: the punch, free to turn about a point of its top, rests on
/// one to three nodes of a rounding near the stroke's ends, where the predicted active sets went
/// round a cycle of a dozen sets at every increment size, and later a pairing fixed point
/// alternated between two rests. Reference: the run completes its 6 cycles with default
/// settings and wears deeper than the plate's top ten element layers (computed from the
/// grading); the worn area equals `k int p |ds|` to 1e-10 (one sum split between the
/// vertices: round-off); the first cycle's worn area `k P S` within 3% (Archard's global
/// balance; the friction moment tilts the punch at each reversal so its bottom slides beyond
/// the top's stroke: measured +2.0% with whole cycles of wear, +0.6% without friction in
/// fractions of a cycle, the default; in fractions with friction: 97.1 um, +1.4%, 6 minutes).
/// A long study. **Fails at present**: since a failed wear update halves its part of the cycle
/// (before, it applied the whole cycle's wear as computed), the run stops in its sixth cycle
/// (step 1014, 85.6 um): at a stroke reversal the punch rests on one node of a rounding and
/// Newton's active set still changes after 8 cut-backs (one slipping node leaves the punch a
/// mechanism and the sets cycle between its edges; see docs/limits.md). A last start that
/// sticks such a set's slipping rows lets the run, restarted at step 1008, complete (97.18
/// um); the whole run from the start still stops, at step 942 (cycle 6, a stroke reversal).
#[test]
#[ignore]
fn free_rounded_punch_with_friction_wears_ten_layers_deep() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(root.join("wear_cases/rounded_punch_free.toml"))
        .unwrap()
        .replace("friction = 0.0", "friction = 0.3")
        .replace("meshes/rounded_punch.msh", &root.join("wear_cases/meshes/rounded_punch.msh").to_string_lossy());
    assert!(text.contains("friction = 0.3") && text.contains("cycles = 6\n"));
    let out = run_text("rounded_punch_friction", &text);
    assert_free_punch_groove(&out, 0.03, 6, 10);
}

/// Partial slip under a bulk stress (`nowell_hills`, see its header): the stick zone's centre
/// sits `e = sigma a / (4 mu p0)` from the contact's centre (Nowell & Hills), within 3% of `a`
/// (each stick-zone edge is located to a node, 4 um = 1.9% of `a`, and the finite bodies offset
/// the stick zone by 1.5% of `a` without any bulk stress); the shear within 3% of the offset
/// Cattaneo-Mindlin solution in L2 over the contact (1.5% without bulk stress). Before the
/// reference was laid at the computed contact, the scene read as offset by 0.074 mm against
/// 0.041 with a shear 14-16% from the half-plane's: the bulk strain had carried the whole
/// contact 27 um along x in the current configuration the profiles are written in.
#[test]
fn nowell_hills_offset_of_the_stick_zone() {
    let out = run_case("nowell_hills");
    let profile = mortex::io::plot::read_profile(&out, None, None).unwrap();
    let r = profile.reference.expect("the case's [reference]");
    assert!(r.centre_from_profile && (r.e - 0.0412).abs() < 1e-4, "e = {}", r.e);
    let status = profile.status.as_ref().expect("a frictional pair's status");
    let stick: Vec<f64> = (0..profile.x.len()).filter(|&i| status[i] == 1).map(|i| profile.x[i]).collect();
    let (lo, hi) =
        (stick.iter().copied().fold(f64::INFINITY, f64::min), stick.iter().copied().fold(f64::NEG_INFINITY, f64::max));
    let offset = 0.5 * (lo + hi) - r.x0;
    assert!((offset - r.e).abs() < 0.03 * r.a, "stick zone centred {offset} from the contact's, e = {}", r.e);
    // The stick zone's half-width against Cattaneo-Mindlin's c = a sqrt(1 - Q / mu P), within
    // 3% of a (the target; the contact nodes are 2% of a apart, so the last stick node lies
    // within one spacing of the edge).
    let c = r.c.expect("a Cattaneo-Mindlin stick zone");
    let half_width = 0.5 * (hi - lo);
    assert!((half_width - c).abs() < 0.03 * r.a, "stick half-width {half_width} against c = {c} (a = {})", r.a);
    let (pressure, shear) = mortex::io::plot::reference_errors(&profile, &r);
    let shear = shear.expect("a Cattaneo-Mindlin shear");
    assert!(pressure < 0.03 && shear < 0.03, "pressure L2 {pressure}, shear L2 {shear}");
}

/// The surface stress `sigma_xx` of the Nowell-Hills scene (`nowell_hills`) against the
/// half-plane solution (Hills & Nowell, Mechanics of Fretting Fatigue, 1994, ch. 4: the surface
/// values of a Hertzian pressure, a full-slip shear `mu p`, the stick zone's correction of
/// half-width `c` centred at `e`, and the bulk stress):
/// `sigma_xx = -p(x) - 2 mu p0 g(x / a) + 2 mu p0 (c / a) g((x - e) / c) + sigma`, with
/// `g(t) = t` inside and `t - sgn(t) sqrt(t^2 - 1)` outside. Within 5% (the target) in L2 over
/// |x| < 1.5 a, measured 3.8%, read at the surface from the integration points of the
/// specimen's top element layer (its two rows of points, extrapolated linearly in depth: sigma_xx
/// varies at first order in depth there, 2 p0 / a per unit depth under the pressure alone);
/// and the output's nodal stress along the surface within the same 5%, measured 3.7% (each
/// cell's points fitted and extrapolated to its nodes; the lumped L2 projection it replaced
/// read 5.3%, a mean over the cells around a node, 25 MPa too tensile at the contact's centre).
#[test]
fn nowell_hills_surface_stress() {
    const BULK: f64 = 100.0;
    const TARGET: f64 = 0.05;
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(root.join("wear_cases/nowell_hills.toml")).unwrap();
    assert!(text.contains("traction = [100.0, 0.0]") && text.contains("bulk = 100.0"), "the case's bulk stress");
    let out = run_case("nowell_hills");
    let profile = mortex::io::plot::read_profile(&out, None, None).unwrap();
    let r = profile.reference.expect("the case's [reference]");
    let (a, c, e, mu, p0) = (r.a, r.c.expect("a stick zone"), r.e, r.mu, r.p0);
    let f = hdf5::File::open(&out).unwrap();
    let last = f.group("steps").unwrap().member_names().unwrap().into_iter().max().unwrap();
    // The specimen's surface moved by its displacement: the contact's centre in its reference frame.
    let nodes = read2(&f, "mesh/specimen/nodes");
    let u = read2(&f, &format!("steps/{last}/specimen/displacement"));
    let top = (0..nodes.nrows())
        .filter(|&i| nodes[[i, 1]].abs() < 1e-12)
        .min_by(|&i, &j| (nodes[[i, 0]] + u[[i, 0]] - r.x0).abs().total_cmp(&(nodes[[j, 0]] + u[[j, 0]] - r.x0).abs()))
        .unwrap();
    let x0 = r.x0 - u[[top, 0]];
    // The two shallowest rows of points under the contact (the top layer's).
    let points = read2(&f, "mesh/points");
    let stress = read2(&f, &format!("steps/{last}/points/stress"));
    let under: Vec<usize> =
        (0..points.nrows()).filter(|&q| points[[q, 1]] < 0.0 && (points[[q, 0]] - x0).abs() < 1.5 * a).collect();
    let mut depths: Vec<f64> = under.iter().map(|&q| points[[q, 1]]).collect();
    depths.sort_by(|p, q| q.total_cmp(p));
    depths.dedup_by(|p, q| (*p - *q).abs() < 1e-9);
    let (z1, z2) = (depths[0], depths[1]);
    let row = |z: f64| {
        let mut v: Vec<(f64, f64)> = under
            .iter()
            .filter(|&&q| (points[[q, 1]] - z).abs() < 1e-9)
            .map(|&q| (points[[q, 0]], stress[[q, 0]]))
            .collect();
        v.sort_by(|p, q| p.0.total_cmp(&q.0));
        v
    };
    let (shallow, deep) = (row(z1), row(z2));
    assert_eq!(shallow.len(), deep.len(), "one point below another");
    let g = |t: f64| if t.abs() <= 1.0 { t } else { t - t.signum() * (t * t - 1.0).sqrt() };
    let exact = |x: f64| {
        let s = x - x0;
        let p = if s.abs() < a { p0 * (1.0 - (s / a).powi(2)).sqrt() } else { 0.0 };
        -p - 2.0 * mu * p0 * g(s / a) + 2.0 * mu * p0 * (c / a) * g((s - e) / c) + BULK
    };
    let (mut num, mut den) = (0.0, 0.0);
    for (&(x, s1), &(x2, s2)) in shallow.iter().zip(&deep) {
        assert!((x - x2).abs() < 1e-9, "points at {x} and {x2}");
        let surface = s1 + (s1 - s2) * (0.0 - z1) / (z1 - z2);
        num += (surface - exact(x)).powi(2);
        den += exact(x).powi(2);
    }
    assert!((num / den).sqrt() < TARGET, "surface sigma_xx: L2 {} against the half-plane's", (num / den).sqrt());
    // The output's nodal stress along the surface, as a user reads it (in the current frame).
    let nodal = read2(&f, &format!("steps/{last}/specimen/stress"));
    let (mut num, mut den) = (0.0, 0.0);
    for i in (0..nodes.nrows()).filter(|&i| nodes[[i, 1]].abs() < 1e-12) {
        let x = nodes[[i, 0]] + u[[i, 0]];
        if (x - r.x0).abs() < 1.5 * a {
            num += (nodal[[i, 0]] - exact(x - r.x0 + x0)).powi(2);
            den += exact(x - r.x0 + x0).powi(2);
        }
    }
    assert!((num / den).sqrt() < TARGET, "nodal surface sigma_xx: L2 {} against the half-plane's", (num / den).sqrt());
}

/// Dissimilar materials, both bodies wearing (`pad_both_wear`, 500 of its 20,000 cycles, with
/// jumps): Archard's law on both surfaces of one contact gives each worn area as its own
/// coefficient times the same contact work `int p |ds|`. Reference: each area against `k_i W`
/// and their ratio against `k_pad / k_plate = 4`; tolerance 1e-10 relative (round-off: the
/// work and the volumes are sums of the same products).
#[test]
fn both_bodies_wear_in_the_ratio_of_their_coefficients() {
    const K_PAD: f64 = 4e-8;
    const K_PLATE: f64 = 1e-8;
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(root.join("wear_cases/pad_both_wear.toml")).unwrap();
    assert!(text.contains("cycles = 20000\n"));
    let out = run_text("pad_both_wear_500", &text.replace("cycles = 20000\n", "cycles = 500\n"));
    let f = hdf5::File::open(&out).unwrap();
    let last = |path: &str| *f.dataset(path).unwrap().read_raw::<f64>().unwrap().last().unwrap();
    let (pad, plate) = (last("wear/pad.arc/worn_area"), last("wear/plate.top/worn_area"));
    let (pad_work, plate_work) = (last("wear/pad.arc/work"), last("wear/plate.top/work"));
    assert!(pad > 0.0 && plate > 0.0, "worn areas {pad}, {plate}");
    assert!((pad / (K_PAD * pad_work) - 1.0).abs() < 1e-10, "pad: {pad} against k W = {}", K_PAD * pad_work);
    assert!(
        (plate / (K_PLATE * plate_work) - 1.0).abs() < 1e-10,
        "plate: {plate} against k W = {}",
        K_PLATE * plate_work
    );
    assert!((pad / plate / (K_PAD / K_PLATE) - 1.0).abs() < 1e-10, "ratio {} against 4", pad / plate);
}
