//! Rows of a run at switching instants and on the output grid (issue 31 item 4,
//! `docs/reference.md`): a row that falls on a stiffness switch reports the state after the
//! switch, whichever way the switching time rounds; the mesh phase is printed rounded to its
//! resolution; no row falls off the requested grid.

use geardyn::scene::{PairScene, Scene};
use geardyn::simulation::{output_grid, run};

/// The shipped spur pair with contact ratio 1.5: the stiffness switches at mesh phases 0 and
/// 0.5, which rows every 1/20 mesh period hit.
fn pair_with_switches_on_the_grid() -> PairScene {
    let text = std::fs::read_to_string("fmu/spur_pair/scene.toml")
        .unwrap()
        .replace("contact_ratio = 1.504", "contact_ratio = 1.5");
    assert!(text.contains("contact_ratio = 1.5\n"));
    PairScene::from_toml_str(&text, "spur_pair (contact ratio 1.5)").unwrap()
}

/// Over 40 mesh periods at 20 rows per period every row at phase 0 or 0.5 (80 rows, each on a
/// switch) shows the stiffness of the piece after it (that of the next row, 1/20 period
/// later, in the same piece), and every phase reads exactly k/20.
#[test]
fn a_row_on_a_stiffness_switch_reports_the_state_after_it() {
    let scene = pair_with_switches_on_the_grid();
    let f_m = 38.0 * scene.operating.pinion_speed / std::f64::consts::TAU;
    let h = 1.0 / (20.0 * f_m);
    let run = run(&scene, 40.0 / f_m, h).unwrap();
    let (phase, stiffness) = (4, 5);
    let mut on_switch = 0;
    let mut high_low = [0usize; 2];
    for (k, row) in run.rows.iter().enumerate() {
        let expected = (k % 20) as f64 / 20.0;
        assert_eq!(row[phase], expected, "row {k}: phase {}", row[phase]);
        if k % 10 == 0 && k + 1 < run.rows.len() {
            on_switch += 1;
            assert_eq!(
                row[stiffness],
                run.rows[k + 1][stiffness],
                "row {k} (phase {expected}) on a switch: stiffness {} before the switch, \
                 {} after it",
                row[stiffness],
                run.rows[k + 1][stiffness]
            );
            if k > 0 {
                let before = run.rows[k - 1][stiffness];
                assert_ne!(before, row[stiffness], "row {k}: the previous piece");
                high_low[usize::from(row[stiffness] > before)] += 1;
            }
        }
    }
    assert_eq!(on_switch, 80);
    // Both kinds of switch (low → high and high → low) are among them.
    assert!(high_low[0] > 0 && high_low[1] > 0, "{high_low:?}");
}

/// A stop time that is not a multiple of the interval ends the rows at the last multiple
/// (200 mesh periods of the spur pair at 3e-5 s: 2339 intervals, not 2339.18).
#[test]
fn no_row_falls_off_the_grid() {
    let stop = 200.0 / 2850.0;
    let grid = output_grid(stop, 3e-5);
    assert_eq!(grid.len(), 2340);
    for (k, t) in grid.iter().enumerate() {
        assert_eq!(*t, k as f64 * 3e-5, "row {k}");
    }
    // A multiple within rounding is the stop time itself.
    let grid = output_grid(0.02, 1e-5);
    assert_eq!((grid.len(), *grid.last().unwrap()), (2001, 0.02));
    let scene = Scene::from_path(std::path::Path::new("fmu/spur_pair")).unwrap();
    let pair = scene.pair().unwrap();
    let run = run(&pair, stop, 3e-5).unwrap();
    assert_eq!(run.times.len(), 2340);
    assert_eq!(*run.times.last().unwrap(), 2339.0 * 3e-5);
}
