//! `geardyn stiffness`: mesh stiffness from gear geometry (docs/stiffness.md).

use std::path::PathBuf;

use clap::Args;

use geardyn::output;

#[derive(Args)]
pub struct StiffnessArgs {
    /// Gears file (TOML: module, pressure_angle, face_width, [pinion], [gear], [model]).
    gears: PathBuf,
    /// Pinion torque, N·m.
    #[arg(long, allow_negative_numbers = true)]
    torque: f64,
    /// Extended tooth contact.
    #[arg(long, value_parser = ["on", "off"], default_value = "on")]
    etc: String,
    /// Output CSV file (one row per knot of the curve).
    #[arg(long)]
    out: PathBuf,
    /// Also write an SVG plot of the curve (with ETC on, the ETC-off curve is drawn too).
    #[arg(long)]
    plot: Option<PathBuf>,
    /// Number of Fourier harmonics in the summary.
    #[arg(long, default_value_t = 4)]
    harmonics: usize,
    /// Do not print the summary.
    #[arg(long)]
    quiet: bool,
}

pub fn run(args: StiffnessArgs) -> Result<(), String> {
    use geardyn::mesh::geometry::{report, spec, CurveOptions, MeshModel};
    let origin = args.gears.display().to_string();
    let text = std::fs::read_to_string(&args.gears)
        .map_err(|e| format!("cannot read gears file '{origin}': {e}"))?;
    let spec = spec::parse_gears_file(&text, &origin)?;
    let model = MeshModel::new(&spec, "").map_err(|e| format!("{origin}: {e}"))?;
    let etc = args.etc == "on";
    let curve = model
        .curve(CurveOptions {
            torque: args.torque,
            etc,
        })
        .map_err(|e| format!("--torque {}: {e}", args.torque))?;
    let names = report::csv_names(curve.low_pairs + 1);
    let names: Vec<&str> = names.iter().map(String::as_str).collect();
    let rows = report::csv_rows(&curve);
    output::write_table(&args.out, &names, rows.iter().map(|r| r.iter().copied()))?;
    if let Some(path) = &args.plot {
        let title = format!("Mesh stiffness, T = {} N·m", args.torque);
        let svg = if etc {
            let off = model.curve(CurveOptions {
                etc: false,
                ..curve.options
            })?;
            report::svg(&[("ETC on", &curve), ("ETC off", &off)], &title)
        } else {
            report::svg(&[("ETC off", &curve)], &title)
        };
        output::write_text(path, &svg)?;
    }
    if !args.quiet {
        print!("{}", report::summary(&model, &curve, args.harmonics));
        println!("curve → {}", args.out.display());
    }
    Ok(())
}
