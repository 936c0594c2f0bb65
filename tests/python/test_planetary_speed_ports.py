"""Speed causality on a planetary stage (issue 33: `fmu build` with shaft ports on the sun,
carrier and ring "(torque or speed causality)"; docs/ports.md "Speed causality").

`fmu/planetary_stage` (3 planets, ring held, contact-loss law) with its sun port turned to speed
causality: the sun is tied to its neighbour's flange by a compliant coupling (k, c), the
neighbour turning at the nominal sun speed; the carrier keeps its torque port with the balanced
load. Built with `geardyn fmu build` and run in fmpy with no inputs set (the neighbour turns on
at its start speed, as natively), on the grid of `geardyn simulate` of the same scene:

- fmpy validation finds no problem; the speed port's variables have their causalities;
- every mesh's DTE and contact state, the sun port's coupling torque and the carrier port's
  speed equal `geardyn simulate` to 1e-10 of each signal's largest value (the neighbour's
  angle is accumulated per step in the FMU, in one product natively: rounding, see BOUND);
- the physics holds (independent of the code): the imposed speed drives the stage, so over
  the last 2 ms the carrier's mean speed is the neighbour's speed over Willis' ratio
  1 + Z_r/Z_s (to the change of the coupling's twist over the window, bound 1e-4), and the
  coupling's mean torque balances the carrier's load through the torque ratio (bound 1e-3:
  the stage still settles).
"""

from __future__ import annotations

import re

import numpy as np
import pytest

from conftest import REPO, native_run, run_geardyn

K_COUPLING, C_COUPLING = 2.0e4, 2.0
H, STOP = 1e-5, 0.02
# The FMU advances the neighbour's angle step by step (φ_c + ω h per communication step),
# `simulate` as φ_0 + ω t: their roundings differ by ~1e-16 of ~20 rad per step, a random walk
# of ~1e-13 rad over 2000 steps, times k = 2e4 N·m/rad: ~1e-11 of the coupling torque. Bound:
BOUND = 1e-10


def scene_text():
    text = (REPO / "fmu" / "planetary_stage" / "scene.toml").read_text()
    text = text.replace('name = "planetary_stage"', 'name = "planetary_stage_speed"', 1)
    old = 'gear = "sun"\ncausality = "torque"\ntorque = 150.0\n'
    assert old in text
    new = (f'gear = "sun"\ncausality = "speed"\nstiffness = {K_COUPLING!r}\n'
           f'damping = {C_COUPLING!r}\ntorque = 150.0\n')
    return text.replace(old, new, 1)


def test_speed_port_stage_fmu_matches_simulate(tmp_path, geardyn_bin):
    import fmpy
    import fmpy.validation

    scene = tmp_path / "planetary_stage_speed.toml"
    scene.write_text(scene_text())
    run_geardyn("fmu", "build", scene, "--out", tmp_path)
    fmu = tmp_path / "planetary_stage_speed.fmu"
    assert fmpy.validation.validate_fmu(str(fmu)) == []
    md = fmpy.read_model_description(str(fmu))
    by = {v.name: v for v in md.modelVariables}
    assert by["input.angle"].causality == "input" and by["input.speed"].causality == "input"
    assert by["input.torque"].causality == "output"
    assert by["output.torque"].causality == "input" and by["output.speed"].causality == "output"

    native = native_run(scene, tmp_path / "native.csv", H, STOP)
    meshes = sorted({m.group(1) for m in re.finditer(r'\nname = "((?:sp|rp)\d)"', scene_text())})
    assert len(meshes) == 6
    cont = [f"{m}.dte" for m in meshes] + ["input.torque", "output.speed", "sun.speed"]
    cont = [c for c in cont if c in native.dtype.names]
    assert {"input.torque", "output.speed"} <= set(cont)
    discrete = [f"{m}.contact_state" for m in meshes]
    r = fmpy.simulate_fmu(str(fmu), fmi_type="CoSimulation", output_interval=H, stop_time=STOP,
                          output=cont + discrete)
    assert len(r) == len(native)
    for c in cont:
        amp = np.abs(native[c]).max()
        err = np.abs(r[c] - native[c]).max()
        print(f"{c}: fmpy vs simulate {err / amp:.2e} of its largest value")
        assert err <= BOUND * amp, c
    for c in discrete:
        assert np.array_equal(r[c], native[c]), c

    # The imposed speed drives the stage (Willis, P1) and the torques balance (P9).
    doc_speed = float(re.search(r"input_speed = ([0-9.e+-]+)", scene_text()).group(1))
    z = {k: int(v) for k, v in re.findall(r'name = "(sun|ring)"\nteeth = (\d+)', scene_text())}
    ratio = 1 + z["ring"] / z["sun"]
    window = native["time"] >= STOP - 0.002
    carrier = native["output.speed"][window].mean()
    print(f"carrier mean speed {carrier:.9f} rad/s, neighbour/ratio {doc_speed / ratio:.9f}")
    assert carrier == pytest.approx(doc_speed / ratio, rel=1e-4)
    torque_in = -native["input.torque"][window].mean()  # the coupling's torque on the sun
    load = float(re.search(r"torque = (-[0-9.e+-]+)", scene_text()).group(1))
    print(f"coupling torque on the sun {torque_in:.4f} N·m, load/ratio {-load / ratio:.4f} N·m")
    assert torque_in == pytest.approx(-load / ratio, rel=1e-3)
