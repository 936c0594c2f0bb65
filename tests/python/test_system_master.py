"""geardyn's multi-FMU master (`geardyn run system.ssp`) against libcosim's (issue 18, point 4;
acceptance 3 for the master itself).

The system is examples/systems/two_stage: two instances of the shipped spur_pair FMU; the first
stage's dynamic mesh force times its gear's base radius (ssc:LinearTransformation, N -> N.m)
drives the second stage's pinion. Both masters read the same SystemStructure.ssd (libcosimpy's
`CosimExecution.from_ssp_file`, which applies the LinearTransformation and the parameter
bindings itself).

libcosim's fixed-step algorithm (`cosim::fixed_step_algorithm`) steps all simulators in
parallel from t to t+h, then transfers every output to the connected inputs: that is Jacobi
with zero-order hold. geardyn runs with `--algorithm jacobi --extrapolation none` (spur_pair
has canInterpolateInputs="false" anyway), so both must agree to rounding. The test also checks
that the connection matters (an uncoupled second stage differs) and that Gauss-Seidel gives a
visibly different result (so the agreement identifies the algorithm).
"""

import pathlib
import shutil
import zipfile

import numpy as np
import pytest

from conftest import REPO, run_geardyn

EXAMPLE = REPO / "examples" / "systems" / "two_stage"
STEP = 2e-5
N = 500  # 10 ms, about 30 mesh periods
COLS = ["stage1.mesh.force", "stage1.mesh.dte", "stage2.operating.input_torque", "stage2.mesh.dte"]


@pytest.fixture(scope="module")
def system(spur_fmu, tmp_path_factory):
    """The example as a folder (for libcosim) and as an .ssp archive (for geardyn), with the
    FMU inside, as the SSP standard lays it out."""
    d = tmp_path_factory.mktemp("two_stage")
    folder = d / "folder"
    (folder / "resources").mkdir(parents=True)
    shutil.copy(spur_fmu, folder / "resources" / "spur_pair.fmu")
    ssd = (EXAMPLE / "SystemStructure.ssd").read_text()
    assert ssd.count("../../../out/fmus/spur_pair.fmu") == 2
    (folder / "SystemStructure.ssd").write_text(ssd.replace("../../../out/fmus/spur_pair.fmu", "resources/spur_pair.fmu"))
    shutil.copy(EXAMPLE / "stage1.ssv", folder / "stage1.ssv")
    ssp = d / "two_stage.ssp"
    with zipfile.ZipFile(ssp, "w", zipfile.ZIP_DEFLATED) as z:
        for f in folder.rglob("*"):
            if f.is_file():
                z.write(f, f.relative_to(folder).as_posix())
    return folder, ssp


def geardyn(ssp, out, *args):
    r = run_geardyn("run", ssp, "--out", out, "--stop-time", repr(N * STEP), "--output-interval", repr(STEP),
                    "--outputs", ",".join(COLS), *args, check=False)
    assert r.returncode == 0, r.stderr
    data = np.genfromtxt(out, delimiter=",", names=True, deletechars="")
    return r, data


def libcosim(folder):
    import fmpy
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimObserver import CosimObserver

    log_output_level(CosimLogLevel.WARNING)
    md = fmpy.read_model_description(str(folder / "resources" / "spur_pair.fmu"))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    ex = CosimExecution.from_ssp_file(str(folder), step_size=int(round(STEP * 1e9)))
    assert ex.num_slaves() == 2
    obs = CosimObserver.create_last_value()
    ex.add_observer(observer=obs)
    idx = {n: ex.slave_index_from_instance_name(n) for n in ("stage1", "stage2")}
    rows = []
    for _ in range(N):
        assert ex.step()
        row = []
        for col in COLS:
            el, var = col.split(".", 1)
            row += obs.last_real_values(slave_index=idx[el], variable_references=[vr[var]])
        rows.append(row)
    return np.array(rows)


def test_jacobi_matches_libcosim(system, tmp_path, report):
    folder, ssp = system
    r, ours = geardyn(ssp, tmp_path / "g.csv", "--algorithm", "jacobi", "--extrapolation", "none")
    header = (tmp_path / "g.csv").read_text().splitlines()[0]
    assert header == '"time",' + ",".join(f'"{c}"' for c in COLS)
    theirs = libcosim(folder)
    assert len(ours) == N + 1
    worst = 0.0
    for j, col in enumerate(COLS):
        a = ours[ours.dtype.names[j + 1]][1:]
        b = theirs[:, j]
        scale = np.abs(b).max()
        d = float(np.abs(a - b).max() / scale)
        worst = max(worst, d)
        assert d <= 1e-12, (col, d)
    report(f"two_stage system, geardyn Jacobi vs libcosim fixed-step, h = {STEP}, {N} steps: "
           f"max |diff| / max|value| = {worst:.2e} over {', '.join(COLS)}")

    # The connection matters: stage2 with its input torque held at the bound 144.74 N.m
    # (no connection) differs from the coupled run by far more than the tolerance.
    free = tmp_path / "free.csv"
    rr = run_geardyn("run", folder / "resources" / "spur_pair.fmu", "--out", free, "--stop-time", repr(N * STEP),
                     "--output-interval", repr(STEP), "--outputs", "mesh.dte", "--start", "operating.pinion_speed=%r" % (350 * 38 / 55),
                     "--start", "operating.load_torque=209.49341379910638", "--start", "operating.input_torque=144.74090407938257", check=False)
    assert rr.returncode == 0, rr.stderr
    uncoupled = np.genfromtxt(free, delimiter=",", names=True, deletechars="")["mesh.dte"]
    coupled = ours[ours.dtype.names[4]]
    assert np.abs(coupled - uncoupled).max() > 1e-3 * np.abs(coupled).max()

    # Gauss-Seidel (stage2 sees stage1's force at the end of the step) is another algorithm:
    # it does not reproduce libcosim's result.
    _, gs = geardyn(ssp, tmp_path / "gs.csv", "--algorithm", "gauss-seidel", "--extrapolation", "none")
    d_gs = np.abs(gs[gs.dtype.names[4]][1:] - theirs[:, 3]).max() / np.abs(theirs[:, 3]).max()
    assert d_gs > 1e-6, d_gs
    report(f"two_stage system, geardyn Gauss-Seidel vs libcosim: {d_gs:.2e} (a different algorithm)")


def test_linear_extrapolation_falls_back_with_a_note(system, tmp_path):
    """spur_pair declares canInterpolateInputs="false": the default (linear) falls back to the
    hold for the connection, says so, and gives the zero-order-hold result."""
    folder, ssp = system
    r, lin = geardyn(ssp, tmp_path / "l.csv", "--algorithm", "jacobi")
    assert 'connection stage1.mesh.force → stage2.operating.input_torque (line' in r.stderr
    assert 'zero-order hold: stage1 declares maxOutputDerivativeOrder="0" and stage2 does not declare canInterpolateInputs="true"' in r.stderr
    _, hold = geardyn(ssp, tmp_path / "h.csv", "--algorithm", "jacobi", "--extrapolation", "none")
    assert (tmp_path / "l.csv").read_text() == (tmp_path / "h.csv").read_text()
