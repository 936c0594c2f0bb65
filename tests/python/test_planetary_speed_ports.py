"""Speed-causality ports on a planetary stage (issue 33, item 2: `fmu build` with shaft ports on
the sun, carrier and ring, torque or speed causality; docs/ports.md "Speed causality").

The shipped `fmu/planetary_stage` has torque ports. Here the same stage gets speed ports —
compliant couplings to the neighbours' flanges — in both arrangements that put a port on each
central member:
- ring held: the sun in, the carrier out (the shipped arrangement);
- carrier held (the star arrangement): the sun in, the ring out.

Checked on each:
- fmpy validates the FMU, and the ports are declared with speed causality (angle and speed
  inputs, torque output that depends on them);
- fmpy standalone (the neighbours turn at their start speeds) gives the numbers of
  `geardyn simulate` on the same grid to 1e-10 of the largest value (every mesh's DTE and both
  port torques). Not bit for bit as the torque-port stage: a speed coupling is not a row of the
  exact propagator, so both run DOP853 (rtol 1e-9), which the FMU restarts at each
  communication point while `simulate` steps across the grid; measured 4.4e-12;
- at every communication point the port torque is the coupling law of docs/ports.md,
  −[k(φ − θ) + c(ω − ω_g)], formed here from the FMU's inputs and its gear outputs;
- the stage's kinematics hold through the couplings: with the neighbours at the Willis speeds
  (sun/output speed ratio 1 + Z_r/Z_s with the ring held, −Z_r/Z_s with the carrier held),
  the port torques settle to the ratio of the stage (carrier/sun −(1 + Z_r/Z_s), ring/sun −Z_r/Z_s in each shaft's own
  sense) to 1e-4 (measured 3.2e-6 and 1.6e-6: what is left is the mesh ripple, ±1.1 N·m, over a
  window that is not a whole number of mesh periods, ≤ 1.1/(π·116 periods) = 3e-3 N·m = 2e-5),
  and the two halves of the window agree to 1e-5 of the torque. A carried rotation off by a
  relative δ twists a coupling by δ·ω·t and moves its torque without bound: δ = 1e-8 moves
  the sun coupling's torque by 4e-3 N·m between the halves (k = 2e4 N·m/rad, ω = 1047 rad/s,
  20 ms), which the halves' comparison sees.
"""

from __future__ import annotations

import tomllib

import fmpy
import fmpy.validation
import numpy as np
import pytest

from conftest import REPO, native_run, run_geardyn

H = 1e-5
STOP = 0.01
ZS, ZR = 23, 73
SHIPPED = (REPO / "fmu" / "planetary_stage" / "scene.toml").read_text()
TORQUE_IN = 'gear = "sun"\ncausality = "torque"\ntorque = 150.0'
TORQUE_OUT = 'gear = "carrier"\ncausality = "torque"\ntorque = -626.0869565217391'


def ring_held() -> str:
    text = SHIPPED.replace('name = "planetary_stage"', 'name = "planetary_stage_speed"')
    assert TORQUE_IN in text and TORQUE_OUT in text
    return text.replace(TORQUE_IN, 'gear = "sun"\ncausality = "speed"\nstiffness = 2.0e4\ndamping = 1.0\n'
                        'torque = 150.0').replace(
        TORQUE_OUT, 'gear = "carrier"\ncausality = "speed"\nstiffness = 5.0e4\ndamping = 2.0\n'
        'torque = -626.0869565217391')


def carrier_held() -> str:
    """The star arrangement: the carrier on the torsional support, the ring the output, turning
    against the sun at Z_s/Z_r; the balanced load −150·73/23 N·m."""
    support = "ground_stiffness = 5000000.0   # N·m/rad: the ring's torsional support (held)\nground_damping = 50.0\n"
    text = ring_held().replace('name = "planetary_stage_speed"', 'name = "planetary_star_speed"')
    assert support in text
    text = text.replace(support, "").replace(
        'fixed = "ring"', 'fixed = "carrier"\nground_stiffness = 5000000.0\nground_damping = 50.0').replace(
        'output_gear = "carrier"', 'output_gear = "ring"').replace(
        'gear = "carrier"\ncausality = "speed"\nstiffness = 5.0e4\ndamping = 2.0\ntorque = -626.0869565217391',
        'gear = "ring"\ncausality = "speed"\nstiffness = 5.0e4\ndamping = 2.0\ntorque = -476.0869565217391')
    assert 'fixed = "carrier"' in text and "torque = -476.08" in text
    return text


ARRANGEMENTS = {
    # name: (scene text, output gear, the port torque ratio output/input of the stage)
    "planetary_stage_speed": (ring_held, "carrier", -(1 + ZR / ZS)),
    "planetary_star_speed": (carrier_held, "ring", -ZR / ZS),
}


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    """name -> (scene path, scene document, FMU)."""
    out = tmp_path_factory.mktemp("planetary_speed")
    result = {}
    for name, (text, _, _) in ARRANGEMENTS.items():
        path = out / f"{name}.toml"
        path.write_text(text())
        run_geardyn("fmu", "build", path, "--out", out)
        result[name] = (path, tomllib.loads(path.read_text()), out / f"{name}.fmu")
    return result


@pytest.mark.parametrize("name", ARRANGEMENTS)
def test_the_fmu_declares_speed_ports(name, built, report):
    _, doc, fmu = built[name]
    assert fmpy.validation.validate_fmu(str(fmu)) == []
    md = fmpy.read_model_description(str(fmu))
    by = {v.name: v for v in md.modelVariables}
    for port in ("input", "output"):
        assert by[f"{port}.angle"].causality == "input" and by[f"{port}.speed"].causality == "input"
        assert by[f"{port}.torque"].causality == "output"
        deps = next(u.dependencies for u in md.outputs if u.variable.name == f"{port}.torque")
        assert sorted(d.name for d in deps) == [f"{port}.angle", f"{port}.speed"]
    assert [p["gear"] for p in doc["port"]] == ["sun", ARRANGEMENTS[name][1]]
    report(f"{name}.fmu: fmpy validate, no problem; speed ports on sun and {ARRANGEMENTS[name][1]}")


@pytest.mark.parametrize("name", ARRANGEMENTS)
def test_fmpy_matches_simulate_and_the_torque_is_the_coupling_law(name, built, tmp_path, report):
    path, doc, fmu = built[name]
    output_gear = ARRANGEMENTS[name][1]
    native = native_run(path, tmp_path / "native.csv", H, STOP)
    dte = [f"{m['name']}.dte" for m in doc["mesh"]]
    torques = ["input.torque", "output.torque"]
    motion = ["input.angle", "input.speed", "output.angle", "output.speed",
              "sun.angle", "sun.speed", f"{output_gear}.angle", f"{output_gear}.speed"]
    r = fmpy.simulate_fmu(str(fmu), fmi_type="CoSimulation", output_interval=H, stop_time=STOP,
                          output=dte + torques + motion)
    assert len(r) == len(native)
    for c in dte + torques:
        amp = np.abs(native[c]).max()
        err = np.abs(r[c] - native[c]).max()
        report(f"{name} fmpy vs simulate: {c} max|d| = {err:.3e} = {err / amp:.3e} of max")
        assert err <= 1e-10 * amp, (c, err / amp)
    ports = {p["name"]: p for p in doc["port"]}
    for port, gear in (("input", "sun"), ("output", output_gear)):
        k, c = ports[port]["stiffness"], ports[port]["damping"]
        law = -(k * (r[f"{port}.angle"] - r[f"{gear}.angle"]) + c * (r[f"{port}.speed"] - r[f"{gear}.speed"]))
        err = np.abs(r[f"{port}.torque"] - law).max()
        amp = np.abs(law).max()
        report(f"{name}: {port}.torque against the coupling law, max|d| = {err:.3e} N.m = {err / amp:.3e} of max")
        # The law is formed from rounded outputs: an angle of ~10 rad carries 2e-15 rad of
        # rounding, times k = 5e4.
        assert err <= 1e-9 * amp
        # The couplings carry the load and the stage vibrates through them.
        assert np.ptp(r[f"{port}.torque"]) > 1e-3 * amp


@pytest.mark.parametrize("name", ARRANGEMENTS)
def test_the_port_torques_settle_to_the_stage_ratio(name, built, tmp_path, report):
    path, _, _ = built[name]
    ratio = ARRANGEMENTS[name][2]
    stop = 0.1
    run = native_run(path, tmp_path / "long.csv", 1e-5, stop)
    t = run["time"]
    window = t >= 0.06
    # The torques the couplings apply to the neighbours: their means over the last 40 ms.
    t_in, t_out = run["input.torque"][window].mean(), run["output.torque"][window].mean()
    got = t_out / t_in
    report(f"{name}: mean port torques {t_in:.6f} / {t_out:.6f} N.m over 60-100 ms; ratio {got:.9f}, "
           f"stage {ratio:.9f}, relative difference {got / ratio - 1:.3e}")
    assert abs(got / ratio - 1) <= 1e-4
    # No drift: the two halves of the window agree as closely (a ratio error of the carried
    # rotation would twist the couplings steadily).
    halves = [run["input.torque"][(t >= a) & (t < b)].mean() for a, b in ((0.06, 0.08), (0.08, stop + 1))]
    assert abs(halves[1] - halves[0]) <= 1e-5 * abs(t_in)
