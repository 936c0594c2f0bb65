"""`geardyn run` equals `fmpy simulate` on every shipped geardyn FMU (issue 4, acceptance 1 and 3).

The FMUs are `out/fmus/<name>.fmu`, one per `fmu/<name>/scene.toml`, built by
`scripts/build-fmus.sh` (scripts/test.sh runs it before pytest). For each: the default
experiment grid, an explicit grid with start values and a shortened last step, and an input
CSV (torque ramp with a jump, speed ramp) — same header, same time grid, values ≤ 1e-12
relative (in practice the CSV files are byte-identical).
"""

import pathlib
import tomllib

import pytest

from conftest import GEAR_SCENES as SCENES
from conftest import REPO
from test_host_thirdparty import assert_same, fmpy_cli, read
from conftest import run_geardyn

FMU_DIR = REPO / "out" / "fmus"


def names(scene: pathlib.Path):
    """(speed input, a damping parameter) of the scene's FMU: drivetrain FMUs name them
    `operating.input_speed` and `<first mesh>.damping` (`mesh1` unless the mesh is named),
    single-mesh FMUs `operating.pinion_speed` and `mesh.damping` (the scene's key paths)."""
    text = (scene / "scene.toml").read_text()
    if "[[mesh]]" in text:
        first = tomllib.loads(text)["mesh"][0].get("name", "mesh1")
        return "operating.input_speed", f"{first}.damping"
    return "operating.pinion_speed", "mesh.damping"


def driving_input(scene: pathlib.Path) -> tuple[str, str]:
    """The input that drives the stage and a start value for it: `operating.input_torque`, or
    `<port>.torque` of a scene with torque ports, or the neighbour's `<port>.speed` of a speed
    port (docs/ports.md; the port on the input gear is named `input` in fmu/spur_stage and
    fmu/spur_stage_speed)."""
    text = (scene / "scene.toml").read_text()
    if 'causality = "speed"' in text:
        return "input.speed", "480"
    return ("input.torque" if "[[port]]" in text else "operating.input_torque"), "150"


def shipped(name: str) -> pathlib.Path:
    fmu = FMU_DIR / f"{name}.fmu"
    if not fmu.exists():
        pytest.fail(f"{fmu} missing: run `bash scripts/build-fmus.sh`")
    return fmu


def geardyn_run(fmu, out, *args):
    r = run_geardyn("run", fmu, "--out", out, *args, check=False)
    assert r.returncode == 0, r.stderr
    return out


def test_every_scene_is_shipped():
    assert SCENES, "no fmu/*/scene.toml"


@pytest.mark.parametrize("scene", SCENES, ids=lambda p: p.name)
def test_default_experiment_matches_fmpy(scene, tmp_path, report):
    fmu = shipped(scene.name)
    g = geardyn_run(fmu, tmp_path / "g.csv")
    f = fmpy_cli(fmu, tmp_path / "f.csv")
    rel = assert_same(g, f)
    assert g.read_text() == f.read_text()
    report(f"{scene.name}.fmu, geardyn run vs fmpy simulate, default grid: {len(read(g)[1])} rows, max rel diff {rel:.3g}, byte-identical")


@pytest.mark.parametrize("scene", SCENES, ids=lambda p: p.name)
def test_start_values_and_last_step_match_fmpy(scene, tmp_path, report):
    fmu = shipped(scene.name)
    _, damping = names(scene)
    name, value = driving_input(scene)
    g = geardyn_run(fmu, tmp_path / "g.csv", "--stop-time", "0.0123", "--output-interval", "1e-4",
                    "--start", f"{name}={value}", "--start", f"{damping}=900")
    f = fmpy_cli(fmu, tmp_path / "f.csv", "--stop-time", "0.0123", "--output-interval", "1e-4",
                 "--start-values", name, value, damping, "900")
    rel = assert_same(g, f)
    assert read(g)[1][-1, 0] == 0.0123
    report(f"{scene.name}.fmu, geardyn run vs fmpy, start values + shortened last step: max rel diff {rel:.3g}")


@pytest.mark.parametrize("scene", SCENES, ids=lambda p: p.name)
def test_input_csv_matches_fmpy(scene, tmp_path, report):
    fmu = shipped(scene.name)
    speed, _ = names(scene)
    csv = tmp_path / "in.csv"
    csv.write_text(
        f'"time","operating.input_torque","{speed}"\n'
        "0,100,471.238898038469\n"
        "0.004,160,471.238898038469\n"
        "0.00655,160,480\n"
        "0.00655,40,480\n"
        "0.012,80,500\n"
    )
    g = geardyn_run(fmu, tmp_path / "g.csv", "--input", csv, "--stop-time", "0.015", "--output-interval", "1e-4")
    f = fmpy_cli(fmu, tmp_path / "f.csv", "--input-file", csv, "--stop-time", "0.015", "--output-interval", "1e-4")
    rel = assert_same(g, f)
    # The jump at 0.00655 is an input event: a row off the 1e-4 grid.
    assert 0.00655 in read(g)[1][:, 0]
    # The input changes the result.
    base = geardyn_run(fmu, tmp_path / "b.csv", "--stop-time", "0.015", "--output-interval", "1e-4")
    assert base.read_text() != g.read_text()
    report(f"{scene.name}.fmu, geardyn run --input vs fmpy --input-file: max rel diff {rel:.3g}")
