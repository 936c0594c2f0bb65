"""Issue 31, acceptance 4: `geardyn hb` and `geardyn periodic` agree on the stability of
`fmu/idler_gearset` at every 1 rad/s over 385–395 rad/s, across its Neimark–Sacker interval,
and both agree with the independent 8-DOF scipy shooting of `idler8_reference.py` (its own
Newton shooting and finite-difference monodromy, ~1e-7 in |μ|): the verdicts wherever |μ|
differs from 1 by more than 1e-4, the spectral radii to 1e-6. `hb` runs with the issue's 40
harmonics; its radius within 2e-3 of 1 is checked by shooting from the HB state
(`shooting_check` = 1), the others are the HB orbit's own."""

import csv
import re

import numpy as np

from idler8_reference import SCENE, Idler8

SPEEDS = [float(s) for s in range(385, 396)]


def periodic(geardyn_bin, speed):
    """`geardyn periodic` at `speed`: spectral radius and verdict."""
    import subprocess

    out = subprocess.run([str(geardyn_bin), "periodic", str(SCENE.parent), "--speed", repr(speed)],
                         capture_output=True, text=True, check=True).stdout
    moduli = [float(m) for m in re.findall(r"\|μ\| = ([0-9.eE+-]+)", out)]
    verdict = re.search(r"stability: (\w+)", out).group(1)
    return max(moduli), verdict


def hb(geardyn_bin, speed, tmp_path):
    """The first point (at `speed`) of `geardyn hb --harmonics 40` started there."""
    import subprocess

    table = tmp_path / f"hb_{speed}.csv"
    subprocess.run([str(geardyn_bin), "hb", str(SCENE.parent), "--speed", f"{speed}:{speed + 0.25}",
                    "--harmonics", "40", "--out", str(table)], capture_output=True, check=True)
    row = next(csv.DictReader(table.open()))
    assert float(row["speed"]) == speed
    return {k: float(row[k]) for k in ("spectral_radius", "stable", "neutral", "shooting_check")}


def test_hb_periodic_and_reference_agree_across_the_neimark_sacker_interval(geardyn_bin, tmp_path):
    y = None
    verdicts = []
    for speed in SPEEDS:
        ref = Idler8(speed=speed)
        if y is None:
            y, _ = ref.integrate(ref.start_state(), 0.0, 20 * ref.period)
        # Warm start from the previous speed's orbit (the branch is continuous here).
        y, multipliers, _ = ref.periodic_orbit(y)
        rho_ref = float(np.max(np.abs(multipliers)))
        rho_p, verdict_p = periodic(geardyn_bin, speed)
        point = hb(geardyn_bin, speed, tmp_path)
        print(f"{speed:.0f} rad/s: |μ| reference {rho_ref:.7f}, periodic {rho_p:.7f} ({verdict_p}), "
              f"hb {point['spectral_radius']:.7f} (stable {point['stable']:.0f}, "
              f"shooting_check {point['shooting_check']:.0f})")
        assert abs(rho_p - rho_ref) <= 1e-6
        if point["shooting_check"] == 1:
            assert abs(point["spectral_radius"] - rho_ref) <= 1e-6
        if abs(rho_ref - 1) > 1e-4:
            stable = rho_ref < 1
            assert (verdict_p == "Stable") == stable
            assert point["stable"] == float(stable) and point["neutral"] == 0
            verdicts.append(stable)
    # The interval is crossed: stable points on both sides of unstable ones.
    assert verdicts[0] and verdicts[-1] and not all(verdicts)
