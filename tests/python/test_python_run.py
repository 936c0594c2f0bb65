"""`geardyn.run` (issue 35, "The whole CLI in Python": FMU and SSP runs with inputs from arrays,
fmpy's conventions): the rows of `geardyn run` bit for bit, for a single FMU with start values
and an input array, and for an SSP system with the master's options; a refused step raises
with the reason the FMU logged, in Python's terms.

The CLI's CSV is parsed with the csv module: it writes shortest round-trip floats, so parsing
gives back its doubles.
"""

import csv
import warnings

import numpy as np
import pytest

import geardyn
from conftest import REPO, run_geardyn


def cli_rows(path):
    """The header and rows of a CSV `geardyn run` wrote (flags True/False as 1/0)."""
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    flag = {"True": 1.0, "False": 0.0}
    return rows[0], np.array([[flag[v] if v in flag else float(v) for v in r] for r in rows[1:]])


def identical(a, b):
    assert a.shape == b.shape
    assert np.array_equal(a, b), f"largest difference {np.max(np.abs(a - b))}"


def torque_ramp():
    """An input table in fmpy's convention: a structured array, `time` and one field per input."""
    t = np.linspace(0.0, 2e-3, 11)
    signals = np.zeros(len(t), dtype=[("time", float), ("operating.input_torque", float)])
    signals["time"] = t
    signals["operating.input_torque"] = 100.0 + 5e4 * t + 0.1 / 3.0
    return signals


def test_single_fmu_with_start_values_and_input_matches_cli(spur_fmu, tmp_path):
    signals = torque_ramp()
    got = geardyn.run(spur_fmu, stop_time=2e-3, output_interval=1e-5,
                      start_values={"mesh.backlash": 2e-4, "initial.static_dte": True},
                      input=signals, output=["mesh.dte", "mesh.force", "mesh.contact_state"])
    # The same input as a CSV (17 significant digits reach the run exactly, as from Python).
    with open(tmp_path / "in.csv", "w") as f:
        f.write("time,operating.input_torque\n")
        for t, q in signals:
            f.write(f"{float(t)!r},{float(q)!r}\n")
    run_geardyn("run", spur_fmu, "--stop-time", "2e-3", "--output-interval", "1e-5",
                "--start", "mesh.backlash=0.0002", "--start", "initial.static_dte=1",
                "--input", tmp_path / "in.csv", "--outputs", "mesh.dte,mesh.force,mesh.contact_state",
                "--out", tmp_path / "cli.csv")
    header, rows = cli_rows(tmp_path / "cli.csv")
    assert ["time", *got.names] == header
    identical(np.column_stack([got.time, got.data]), rows)
    assert got.units["mesh.force"] == "N" and got.units["time"] == "s"
    # fmpy's result layout, and the input reached the run: without it the force differs.
    structured = got.to_structured()
    assert structured.dtype.names == ("time", "mesh.dte", "mesh.force", "mesh.contact_state")
    identical(structured["mesh.force"], got["mesh.force"])
    plain = geardyn.run(spur_fmu, stop_time=2e-3, output_interval=1e-5,
                        start_values={"mesh.backlash": 2e-4}, output=["mesh.force"])
    assert np.max(np.abs(plain["mesh.force"] - got["mesh.force"])) > 1.0


def test_input_as_dict_of_arrays_equals_the_structured_array(spur_fmu):
    signals = torque_ramp()
    a = geardyn.run(spur_fmu, stop_time=1e-3, output_interval=1e-5, input=signals)
    b = geardyn.run(spur_fmu, stop_time=1e-3, output_interval=1e-5,
                    input={n: signals[n] for n in signals.dtype.names})
    identical(a.data, b.data)


def test_input_without_time_is_refused_naming_it(spur_fmu):
    with pytest.raises(geardyn.GeardynError, match="input: no 'time' field"):
        geardyn.run(spur_fmu, input={"operating.input_torque": np.ones(3)})


def test_system_matches_cli(tmp_path):
    system = REPO / "examples" / "systems" / "drivetrain3"
    got = geardyn.run(system, stop_time=2e-3, algorithm="jacobi", extrapolation="none")
    run_geardyn("run", system, "--stop-time", "2e-3", "--algorithm", "jacobi",
                "--extrapolation", "none", "--out", tmp_path / "cli.csv")
    header, rows = cli_rows(tmp_path / "cli.csv")
    assert ["time", *got.names] == header
    identical(np.column_stack([got.time, got.data]), rows)
    assert got.steps is None


def test_error_controlled_system_returns_its_steps(tmp_path):
    system = REPO / "examples" / "systems" / "drivetrain3"
    # 1e-5: at 1e-4 the master's steps that end at the stage's knots leave no step undone in
    # the first 2 ms.
    got = geardyn.run(system, stop_time=2e-3, tolerance=1e-5)
    run_geardyn("run", system, "--stop-time", "2e-3", "--tolerance", "1e-5", "--out", tmp_path / "cli.csv")
    header, rows = cli_rows(tmp_path / "cli.csv")
    identical(np.column_stack([got.time, got.data]), rows)
    s_header, s_rows = cli_rows(tmp_path / "cli.csv.steps.csv")
    assert got.steps.columns == s_header
    identical(got.steps.data, s_rows)
    assert got.steps["accepted"].min() == 0.0  # some steps were undone and redone smaller
    assert any("tolerance=" in n or "tolerance " in n for n in got.notes), got.notes
    assert not any("--" in n or "/tmp" in n for n in got.notes), got.notes


def test_refused_step_raises_with_the_fmus_reason(spur_fmu):
    """The FMU refuses a step at an absurd speed and logs why: the exception carries that
    reason, in Python's terms (no CLI flag)."""
    with pytest.raises(geardyn.GeardynError) as e:
        geardyn.run(spur_fmu, start_values={"operating.pinion_speed": 1e11},
                    output_interval=2e-4, stop_time=4e-4)
    message = str(e.value)
    cli = run_geardyn("run", spur_fmu, "--start", "operating.pinion_speed=1e11", "--output-interval",
                      "2e-4", "--stop-time", "4e-4", check=False)
    assert cli.returncode == 1
    cli_error = cli.stderr.strip().splitlines()[0].removeprefix("error: ")
    assert cli_error.split(" (")[0] in message
    assert "pinion_speed" in message and "--" not in message


def test_bad_option_names_the_argument(spur_fmu):
    with pytest.raises(geardyn.GeardynError, match="output_interval") as e:
        geardyn.run(spur_fmu, output_interval=-1.0)
    assert "--" not in str(e.value)
    with pytest.raises(geardyn.GeardynError, match="algorithm"):
        geardyn.run(spur_fmu, algorithm="jacobi")


def test_notes_become_warnings():
    """`two_stage` holds a connection its consumer cannot interpolate, and the run says so in a
    note: here a RuntimeWarning, and in `notes`."""
    system = REPO / "examples" / "systems" / "two_stage"
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        got = geardyn.run(system, stop_time=1e-3)
    raised = [str(w.message) for w in caught if w.category is RuntimeWarning]
    assert raised == [n.removeprefix("warning: ") for n in got.notes]
    assert any("zero-order hold" in n and "stage2" in n for n in raised), raised
