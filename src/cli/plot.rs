//! `mortex plot`: the contact profile of a result's step against its reference.

use std::path::PathBuf;

pub(crate) fn plot(
    result: PathBuf,
    step: Option<usize>,
    pair: Option<String>,
    output: Option<PathBuf>,
    xlim: Option<Vec<f64>>,
) -> anyhow::Result<()> {
    use mortex::io::plot;
    let profile = plot::read_profile(&result, step, pair.as_deref())?;
    let xlim = match xlim.as_deref() {
        Some(&[a, b]) if a.is_finite() && b.is_finite() && b > a => (a, b),
        Some(v) => return Err(anyhow::anyhow!("--xlim {v:?}: give two finite values, X_MIN < X_MAX")),
        None => plot::default_xlim(&profile),
    };
    let out = output.unwrap_or_else(|| {
        let name = result.file_name().map(|n| n.to_string_lossy().to_string()).unwrap_or_default();
        let stem = name.trim_end_matches(".partial").trim_end_matches(".h5");
        result.with_file_name(format!("{stem}_{}_step{}.png", profile.pair, profile.step))
    });
    plot::write_png(&profile, xlim, &out)?;
    println!("contact '{}', step {}: {}", profile.pair, profile.step, out.display());
    if let Some(r) = &profile.reference {
        let (p, q) = plot::reference_errors(&profile, r);
        let name = match (r.c, r.e) {
            (None, _) => "Hertz",
            (Some(_), e) if e == 0.0 => "Cattaneo-Mindlin",
            _ => "Cattaneo-Mindlin with Nowell-Hills' offset",
        };
        let centre = if r.centre_from_profile { "the computed contact's centre" } else { "the case's" };
        println!(
            "  against {name} (p0 = {:.4}, a = {:.5}{}{}, x0 = {:.5}, {centre}): pressure L2 over |x - x0| < a {:.2}%{}",
            r.p0,
            r.a,
            r.c.map_or(String::new(), |c| format!(", c = {c:.5}")),
            if r.e != 0.0 { format!(", e = {:.5}", r.e) } else { String::new() },
            r.x0,
            100.0 * p,
            q.map_or(String::new(), |q| format!(", shear L2 {:.2}%", 100.0 * q))
        );
    }
    Ok(())
}
