//! `mortex study stability`: where the classical multipliers fail and the coarse-grained ones
//! hold, at growing mesh-density contrast (see [`mortex::scenes`]):
//!
//! - a circular patch tied into a host, 1 to 20 times finer, same or 10x stiffer, under tension
//!   and bending: the traction oscillation along the tie over its mean;
//! - Hertz contact with the cylinder (which carries the multipliers) 1 to 12 times finer than
//!   the block: the largest pressure deviation from Hertz over `abs(x) <= 0.9 a`, over p0.
//!
//! Writes `<output>/stability.csv` and `.md`, and the charts `tying.png` and
//! `curved_contact.png` (each with an SVG copy). Default output: `results/stability`.

use super::study::{io_err, StudyError};
use mortex::mortar::MultiplierSpace;
use mortex::scenes::{
    hertz_density_deviation, tied_inclusion_oscillation, InclusionLoad, MultiplierFigure, STABILITY_E,
};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Patch refinement ratios of the tied inclusion and cylinder refinements of the contact.
const TIE_RATIOS: [usize; 4] = [1, 5, 10, 20];
const CONTACT_REFINEMENTS: [f64; 5] = [1.0, 2.0, 4.0, 8.0, 12.0];

/// One row: the scene, its variant, the contrast, and each space's figure and multiplier count.
struct Row {
    scene: &'static str,
    variant: String,
    contrast: f64,
    classical: MultiplierFigure,
    coarse: MultiplierFigure,
}

/// Runs the study into `output`; returns the Markdown table's path.
pub fn stability(output: &Path) -> Result<PathBuf, StudyError> {
    std::fs::create_dir_all(output).map_err(io_err(output))?;
    let scene_err =
        |e: mortex::scenes::SceneError| StudyError::Io { path: output.display().to_string(), msg: e.to_string() };
    let total = 4 * TIE_RATIOS.len() + CONTACT_REFINEMENTS.len();
    let bar = indicatif::ProgressBar::new(total as u64);
    if let Ok(style) =
        indicatif::ProgressStyle::with_template("{spinner} [{elapsed_precise}] {bar:40} {pos}/{len} {msg}")
    {
        bar.set_style(style);
    }
    let mut rows = vec![];
    for load in [InclusionLoad::Tension, InclusionLoad::Bending] {
        for stiffness in [1.0, 10.0] {
            let variant = format!(
                "{}, E_patch = {stiffness} E_host",
                if load == InclusionLoad::Tension { "tension" } else { "bending" }
            );
            for ratio in TIE_RATIOS {
                bar.set_message(format!("tied inclusion, {variant}, 1:{ratio}"));
                let run =
                    |space| tied_inclusion_oscillation(ratio, space, stiffness * STABILITY_E, load).map_err(scene_err);
                let classical = run(MultiplierSpace::Classical)?;
                let coarse = run(MultiplierSpace::CoarseGrained)?;
                rows.push(Row {
                    scene: "tied inclusion",
                    variant: variant.clone(),
                    contrast: ratio as f64,
                    classical,
                    coarse,
                });
                bar.inc(1);
            }
        }
    }
    for refine in CONTACT_REFINEMENTS {
        bar.set_message(format!("Hertz contact, cylinder {refine}x finer"));
        let run = |space| hertz_density_deviation(0.005, refine, false, space, 0.9).map_err(scene_err);
        let classical = run(MultiplierSpace::Classical)?;
        let coarse = run(MultiplierSpace::CoarseGrained)?;
        rows.push(Row {
            scene: "Hertz contact",
            variant: "block h = 0.005 mm".into(),
            contrast: refine,
            classical,
            coarse,
        });
        bar.inc(1);
    }
    bar.finish_and_clear();
    let mut csv = String::from(
        "scene,variant,contrast,classical,classical_multipliers,coarse_grained,coarse_grained_multipliers\n",
    );
    for r in &rows {
        let _ = writeln!(
            csv,
            "{},{},{},{:.6e},{},{:.6e},{}",
            r.scene,
            r.variant,
            r.contrast,
            r.classical.deviation,
            r.classical.multipliers,
            r.coarse.deviation,
            r.coarse.multipliers
        );
    }
    let path = output.join("stability.csv");
    std::fs::write(&path, csv).map_err(io_err(&path))?;
    charts(output, &rows);
    write_summary(output, &rows)
}

fn write_summary(output: &Path, rows: &[Row]) -> Result<PathBuf, StudyError> {
    let mut md = String::from(
        "# Multiplier spaces under density contrast\n\n\
         Tied inclusion: largest traction deviation from its 4-harmonic fit over its mean, \
         classical / coarse-grained, against how much finer the patch is than the host.\n\n\
         | load, patch | 1:1 | 1:5 | 1:10 | 1:20 |\n|---|---|---|---|---|\n",
    );
    let mut variants: Vec<&str> =
        rows.iter().filter(|r| r.scene == "tied inclusion").map(|r| r.variant.as_str()).collect();
    variants.dedup();
    for v in variants {
        let cells: Vec<String> = rows
            .iter()
            .filter(|r| r.scene == "tied inclusion" && r.variant == v)
            .map(|r| format!("{:.5} / {:.5}", r.classical.deviation, r.coarse.deviation))
            .collect();
        let _ = writeln!(md, "| {v} | {} |", cells.join(" | "));
    }
    md.push_str(
        "\nHertz contact: largest deviation of the pressure from Hertz over abs(x) <= 0.9 a, over p0, \
         against how much finer the cylinder (the multiplier side) is than the block.\n\n\
         | cylinder finer by | classical | coarse-grained |\n|---|---|---|\n",
    );
    for r in rows.iter().filter(|r| r.scene == "Hertz contact") {
        let _ = writeln!(
            md,
            "| {} | {:.2}% | {:.2}% |",
            r.contrast,
            100.0 * r.classical.deviation,
            100.0 * r.coarse.deviation
        );
    }
    let path = output.join("stability.md");
    std::fs::write(&path, md).map_err(io_err(&path))?;
    Ok(path)
}

/// `tying.png` (one panel per load and patch material) and `curved_contact.png`.
fn charts(output: &Path, rows: &[Row]) {
    use mortex::io::plot::{write_xy_png, Series};
    let pair = |rows: Vec<&Row>, scale: f64| {
        vec![
            Series {
                label: "classical".into(),
                points: rows.iter().map(|r| (r.contrast, scale * r.classical.deviation)).collect(),
                joined: true,
            },
            Series {
                label: "coarse-grained".into(),
                points: rows.iter().map(|r| (r.contrast, scale * r.coarse.deviation)).collect(),
                joined: true,
            },
        ]
    };
    let mut variants: Vec<&str> =
        rows.iter().filter(|r| r.scene == "tied inclusion").map(|r| r.variant.as_str()).collect();
    variants.dedup();
    let tying: Vec<(String, String, String, Vec<Series>)> = variants
        .iter()
        .map(|v| {
            let of: Vec<&Row> = rows.iter().filter(|r| r.scene == "tied inclusion" && r.variant == *v).collect();
            (
                format!("tied inclusion, {v}"),
                "patch finer than the host by".to_string(),
                "traction oscillation / mean".to_string(),
                pair(of, 1.0),
            )
        })
        .collect();
    let contact: Vec<&Row> = rows.iter().filter(|r| r.scene == "Hertz contact").collect();
    let curved = vec![(
        "Hertz contact, cylinder finer than the block: pressure deviation".to_string(),
        "cylinder / block element size ratio".to_string(),
        "max |p - p_Hertz| / p0 (%)".to_string(),
        pair(contact, 100.0),
    )];
    for (panels, name) in [(tying, "tying.png"), (curved, "curved_contact.png")] {
        if let Err(e) = write_xy_png(&panels, &output.join(name)) {
            tracing::warn!(error = %e, "{name} not drawn");
        }
    }
}
