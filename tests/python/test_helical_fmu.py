"""The helical pair with sliding friction as an FMU (issue 6 part A): the shipped
`helical_pair_friction` scene (He & Singh 2007 NASA-ART pair, piecewise-linear K_e(t) with
μ = 0.2) runs under fmpy and gives the DTE and K_e(t) of `geardyn simulate` on the same grid."""

from conftest import FMU_DIR, fmpy_matches_native

H = 2e-6
STOP = 0.0048  # two mesh periods at 1000 rpm


def test_helical_fmu_matches_native(shipped_fmus, tmp_path, report):
    assert FMU_DIR / "helical_pair_friction.fmu" in shipped_fmus
    k = fmpy_matches_native("helical_pair_friction", H, STOP, tmp_path, report)
    # K_e(t) is the paper's trapezoid-like wave: ~10–20 % peak to peak, always positive.
    ratio = (k.max() - k.min()) / k.mean()
    report(f"helical_pair_friction K_e(t): mean {k.mean():.6e} N/m, peak-to-peak/mean {ratio:.4f}")
    assert 0.1 < ratio < 0.25 and k.min() > 0
