"""The independent 8-DOF idler reference (`idler8_reference.py`, Liu 2007 Ch. 2 from the notes)
against geardyn on the shipped `fmu/idler_gearset`: its mean-stiffness modes against
`geardyn modes`, and its time series against `geardyn simulate` from the same start:
- at the shipped speed and load (no contact loss);
- at 620 rad/s (mesh 1 in total contact loss 18 % of the time; its tooth pairs hand over with
  short dips of one pair's elastic deflection below zero and back, which scipy's step-end
  event check alone would miss);
- at half the load and f_m = 1400 Hz (Liu's Fig. 2.13b setting: with relief A at 50 N·m the
  pairs separate again; here mesh 1 goes through patterns II, III and IV of §1.3 every
  period and into total contact loss in single contact).
"""

import math
import subprocess

import numpy as np
import pytest

from idler8_reference import N, SCENE, Idler8, scene_text

PERIODS = 100
SAMPLES_PER_PERIOD = 37  # incommensurate with the knots


def test_reference_modes_match_geardyn_modes():
    """Natural frequencies and mode shapes of the mean system (K_b + Σ k̂ d dᵀ, M) against
    the Python module's `modes` (full precision; the CLI prints 3 decimals)."""
    import geardyn

    ours = geardyn.modes(geardyn.Scene.from_file(str(SCENE)))
    ref = Idler8()
    assert ours.labels == ["pinion.x", "pinion.u", "idler.x", "idler.y", "idler.u",
                           "follower.x", "follower.y", "follower.u"]
    df = np.max(np.abs(ours.frequencies / ref.natural_frequencies - 1))
    shapes = [p / p[np.argmax(np.abs(p))] for p in ref.mode_shapes.T]
    ds = max(np.max(np.abs(s - p)) for s, p in zip(ours.shapes, shapes))
    print(f"reference {np.round(ref.natural_frequencies, 3)} Hz; frequencies {df:.2e} "
          f"relative, shapes {ds:.2e}")
    assert df <= 1e-12 and ds <= 1e-12


@pytest.mark.parametrize("speed, torque, mesh1_loses", [(330.6939635357677, 100.0, False),
                                                        (620.0, 100.0, True),
                                                        (2 * math.pi * 1400 / 38, 50.0, True)])
def test_reference_time_series_match_geardyn_simulate(tmp_path, geardyn_bin, speed, torque,
                                                      mesh1_loses):
    """Both meshes' DTE and deflection over 100 mesh periods from the static start, to 1e-10
    of the static mesh deflection F/k̂."""
    scene = tmp_path / "scene.toml"
    scene.write_text(scene_text(speed, torque))
    ref = Idler8(scene)
    csv = tmp_path / "run.csv"
    subprocess.run([str(geardyn_bin), "simulate", str(scene), "--out", str(csv), "--stop-time",
                    repr(PERIODS * ref.period), "--output-interval",
                    repr(ref.period / SAMPLES_PER_PERIOD), "--quiet"], check=True)
    data = np.genfromtxt(csv, delimiter=",", names=True, deletechars="")
    times = data["time"]
    y0 = ref.start_state()
    states, lost = ref.sample(y0, times)
    worst = 0.0
    for j, m in enumerate(ref.meshes):
        scale = ref.static_force / m.mean
        for q, v in (("dte", m.e), ("deflection", m.d)):
            d = np.max(np.abs(data[f"mesh{j + 1}.{q}"] - states[:, :N] @ v)) / scale
            print(f"{speed:.2f} rad/s, {torque} N·m, mesh{j + 1}.{q}: {d:.2e} of F/k̂")
            worst = max(worst, d)
        assert lost[j] == bool((data[f"mesh{j + 1}.contact_state"] == 0).any())
    assert worst <= 1e-10, worst
    assert lost[0] == mesh1_loses


@pytest.mark.parametrize("speed, stable", [(385.0, True), (390.0, False)])
def test_reference_orbit_and_multipliers_match_geardyn_periodic(speed, stable):
    """The period-1 orbit by the reference's own Newton shooting, and the eigenvalues of its
    finite-difference monodromy (Floquet multipliers, ~1e-7), against `geardyn periodic`
    (Python module): at 385 rad/s stable (|μ| = 0.99747), at 390 rad/s past the
    Neimark-Sacker point of issue 31 (|μ| = 1.000198), so the verdict there is independent of
    either program's stability code."""
    import geardyn

    ref = Idler8(speed=speed)
    y, _ = ref.integrate(ref.start_state(), 0.0, 20 * ref.period)
    y0, multipliers, _ = ref.periodic_orbit(y)
    orbit = geardyn.periodic(geardyn.Scene.from_toml(scene_text(speed)))
    dy = np.max(np.abs(orbit.y0 - y0) / ref.state_scale())
    ours, theirs = np.sort(np.abs(orbit.multipliers)), np.sort(np.abs(multipliers))
    dmu = np.max(np.abs(ours - theirs))
    print(f"{speed} rad/s: start state {dy:.2e} of the scale; |μ| {dmu:.2e}; spectral radius "
          f"{theirs[-1]:.9f} (reference) vs {ours[-1]:.9f}, {orbit.stability}")
    assert dy <= 1e-11 and dmu <= 1e-6
    assert (theirs[-1] < 1 - 1e-4) == stable and (theirs[-1] > 1 + 1e-4) == (not stable)
    assert (orbit.stability == "Stable") == stable
