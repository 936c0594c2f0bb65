//! Every command's plot opens as a PNG of the documented size (`src/plot`), for a single pair
//! and a drivetrain; a plot path with an unknown extension is refused before anything is
//! written.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn geardyn(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_geardyn"))
        .args(args)
        .output()
        .expect("run geardyn")
}

fn workdir(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("plots-{name}"));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The width and height of the PNG at `path` (its IHDR chunk), after checking the signature.
fn png_size(path: &Path) -> (u32, u32) {
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    assert_eq!(
        &bytes[..8],
        b"\x89PNG\r\n\x1a\n",
        "{} is a PNG",
        path.display()
    );
    assert_eq!(&bytes[12..16], b"IHDR");
    let be = |i: usize| u32::from_be_bytes(bytes[i..i + 4].try_into().unwrap());
    (be(16), be(20))
}

fn run_ok(args: &[&str]) {
    let o = geardyn(args);
    assert!(
        o.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
}

#[test]
fn simulate_plots_dte_and_force_of_every_scene() {
    let dir = workdir("simulate");
    for example in ["spur_pair", "idler_gearset"] {
        let (csv, png) = (
            dir.join(format!("{example}.csv")),
            dir.join(format!("{example}.png")),
        );
        run_ok(&[
            "simulate",
            "--example",
            example,
            "--stop-time",
            "0.005",
            "--out",
            csv.to_str().unwrap(),
            "--plot",
            png.to_str().unwrap(),
            "--quiet",
        ]);
        // Two stacked panels (DTE, force), each three quarters of a single plot's height.
        assert_eq!(png_size(&png), (960, 900), "{example}");
    }
}

#[test]
fn sweep_plot_is_a_png() {
    let dir = workdir("sweep");
    let (csv, png) = (dir.join("frf.csv"), dir.join("frf.png"));
    run_ok(&[
        "sweep",
        "--example",
        "spur_pair",
        "--speed",
        "380:520:15",
        "--out",
        csv.to_str().unwrap(),
        "--plot",
        png.to_str().unwrap(),
    ]);
    assert_eq!(png_size(&png), (960, 600));
}

#[test]
fn an_unknown_plot_extension_is_refused_before_any_output() {
    let dir = workdir("bad-extension");
    let (csv, pdf) = (dir.join("run.csv"), dir.join("run.pdf"));
    for args in [
        vec!["simulate", "--example", "spur_pair", "--stop-time", "0.001"],
        vec!["sweep", "--example", "spur_pair", "--speed", "400:500:3"],
    ] {
        let mut args = args;
        args.extend([
            "--out",
            csv.to_str().unwrap(),
            "--plot",
            pdf.to_str().unwrap(),
        ]);
        let o = geardyn(&args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{args:?} accepted a .pdf plot");
        assert!(err.contains("run.pdf") && err.contains(".png"), "{err}");
        assert!(
            !csv.exists() && !pdf.exists(),
            "{args:?} left output behind"
        );
    }
}

/// Issue 31 item 6: the spectrum's stem plot (over frequency and over order, in dB), the
/// waterfall with its colour bar (over frequency and over order), the order cuts and the
/// Campbell diagram all render as PNGs of the plot size. `scripts/plots.sh` draws the same
/// plots into `docs/img/` (where they were looked at).
#[test]
fn spectrum_waterfall_order_cut_and_campbell_plots_are_pngs() {
    let dir = workdir("issue31");
    let p = |name: &str| dir.join(name).to_str().unwrap().to_string();
    run_ok(&[
        "spectrum",
        "--example",
        "spur_pair",
        "--signal",
        "mesh.dte,mesh.force",
        "--out",
        &p("s.csv"),
        "--plot",
        &p("s.png"),
    ]);
    run_ok(&[
        "spectrum",
        "--example",
        "idler_gearset",
        "--out",
        &p("s2.csv"),
        "--plot",
        &p("s2.png"),
        "--db",
        "--order-range",
        "0:200",
    ]);
    run_ok(&[
        "waterfall",
        "--example",
        "runup_spur",
        "--out",
        &p("w.csv"),
        "--plot",
        &p("w.png"),
        "--frequency-range",
        "0:6000",
        "--order-cuts",
        &p("o.csv"),
        "--shaft-orders",
        "37,39",
        "--order-plot",
        &p("o.png"),
        "--db",
    ]);
    run_ok(&[
        "waterfall",
        "--example",
        "runup_spur",
        "--out",
        &p("w2.csv"),
        "--plot",
        &p("w2.png"),
        "--order-range",
        "0:120",
        "--dynamic-range",
        "80",
    ]);
    run_ok(&[
        "modes",
        "--example",
        "idler_gearset",
        "--campbell",
        &p("c.png"),
    ]);
    run_ok(&[
        "modes",
        "--example",
        "runup_spur",
        "--campbell",
        &p("c2.png"),
        "--rpm",
        "0:9000",
    ]);
    for name in [
        "s.png", "s2.png", "w.png", "o.png", "w2.png", "c.png", "c2.png",
    ] {
        assert_eq!(png_size(&dir.join(name)), (960, 600), "{name}");
    }
    // The order-range map keeps only the rows of its orders.
    let map = std::fs::read_to_string(dir.join("w2.csv")).unwrap();
    for line in map.lines().skip(1).take(2000) {
        let order: f64 = line.split(',').nth(3).unwrap().parse().unwrap();
        assert!((0.0..=120.0).contains(&order), "{line}");
    }
    let cuts = std::fs::read_to_string(dir.join("o.csv")).unwrap();
    assert!(
        cuts.starts_with(
            "time_s,revolutions,speed_rad_s,speed_rpm,order_38_amplitude_m,order_38_phase_rad,"
        ),
        "{}",
        cuts.lines().next().unwrap()
    );
}
