"""The helical pair with sliding friction as an FMU (issue 6 part A): the shipped
`helical_pair_friction` scene (He & Singh 2007 NASA-ART pair, piecewise-linear K_e(t) with
μ = 0.2) runs under fmpy and gives the DTE and K_e(t) of `geardyn simulate` on the same grid."""

import numpy as np
from conftest import FMU_DIR, REPO, native_run

import fmpy

SCENE = REPO / "fmu" / "helical_pair_friction"
H = 2e-6
STOP = 0.0048  # two mesh periods at 1000 rpm


def test_helical_fmu_matches_native(shipped_fmus, tmp_path, report):
    fmu = FMU_DIR / "helical_pair_friction.fmu"
    assert fmu in shipped_fmus
    native = native_run(SCENE, tmp_path / "dte.csv", H, STOP)
    r = fmpy.simulate_fmu(str(fmu), fmi_type="CoSimulation", output_interval=H, stop_time=STOP,
                          output=["dte", "mesh_stiffness"])
    assert len(r) == len(native)
    amp = np.abs(native["dte"]).max()
    err = np.abs(r["dte"] - native["dte"]).max()
    report(f"helical_pair_friction fmpy vs native: max|dDTE| = {err:.3e} m = {err / amp:.3e} of max|DTE|")
    assert err <= 1e-12 * amp
    k = r["mesh_stiffness"]
    assert np.abs(k - native["mesh_stiffness"]).max() <= 1e-12 * k.max()
    # K_e(t) is the paper's trapezoid-like wave: ~10–20 % peak to peak, always positive.
    ratio = (k.max() - k.min()) / k.mean()
    report(f"helical_pair_friction K_e(t): mean {k.mean():.6e} N/m, peak-to-peak/mean {ratio:.4f}")
    assert 0.1 < ratio < 0.25 and k.min() > 0
