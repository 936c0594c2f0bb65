"""Speed-causality ports on a planetary stage (issue 33, item 2: `fmu build` with shaft ports on
the sun, carrier and ring, torque or speed causality; docs/ports.md "Speed causality").

The shipped `fmu/planetary_stage` has torque ports. Here the same stage gets speed ports —
compliant couplings to the neighbours' flanges — in both arrangements that put a port on each
central member:
- ring held: the sun in, the carrier out (the shipped arrangement);
- carrier held (the star arrangement): the sun in, the ring out.

A third arrangement mixes the causalities: the sun's port speed, the carrier's torque (the
shipped stage with only its input port turned), so the stage turns freely under the load
(`test_speed_in_torque_out_matches_simulate_and_willis`, below).

Checked on each of the first two:
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

import re
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


# The mixed arrangement.
K_COUPLING, C_COUPLING = 2.0e4, 2.0
H_MIXED, STOP_MIXED = 1e-5, 0.02
# The FMU advances the neighbour's angle step by step (φ_c + ω h per communication step),
# `simulate` as φ_0 + ω t: their roundings differ by ~1e-16 of ~20 rad per step, a random walk
# of ~1e-13 rad over 2000 steps, times k = 2e4 N·m/rad: ~1e-11 of the coupling torque. Bound:
BOUND = 1e-10


def speed_in_torque_out():
    text = (REPO / "fmu" / "planetary_stage" / "scene.toml").read_text()
    text = text.replace('name = "planetary_stage"', 'name = "planetary_stage_speed"', 1)
    old = 'gear = "sun"\ncausality = "torque"\ntorque = 150.0\n'
    assert old in text
    new = (f'gear = "sun"\ncausality = "speed"\nstiffness = {K_COUPLING!r}\n'
           f'damping = {C_COUPLING!r}\ntorque = 150.0\n')
    return text.replace(old, new, 1)


def test_speed_in_torque_out_matches_simulate_and_willis(tmp_path, geardyn_bin):
    """The sun's port speed, the carrier's torque, the ring held: fmpy validation, every
    mesh's DTE and contact state, the sun port's coupling torque and the carrier port's speed
    equal `geardyn simulate` to BOUND of each signal's largest value (the neighbour's angle is
    accumulated per step in the FMU, in one product natively: rounding); the imposed speed
    drives the stage, so over the last 2 ms the carrier's mean speed is the neighbour's speed
    over Willis' ratio 1 + Z_r/Z_s (to the change of the coupling's twist over the window,
    bound 1e-4), and the coupling's mean torque balances the carrier's load through the torque
    ratio (bound 1e-3: the stage still settles)."""
    scene = tmp_path / "planetary_stage_speed.toml"
    scene.write_text(speed_in_torque_out())
    run_geardyn("fmu", "build", scene, "--out", tmp_path)
    fmu = tmp_path / "planetary_stage_speed.fmu"
    assert fmpy.validation.validate_fmu(str(fmu)) == []
    md = fmpy.read_model_description(str(fmu))
    by = {v.name: v for v in md.modelVariables}
    assert by["input.angle"].causality == "input" and by["input.speed"].causality == "input"
    assert by["input.torque"].causality == "output"
    assert by["output.torque"].causality == "input" and by["output.speed"].causality == "output"

    native = native_run(scene, tmp_path / "native.csv", H_MIXED, STOP_MIXED)
    meshes = sorted({m.group(1) for m in re.finditer(r'\nname = "((?:sp|rp)\d)"', speed_in_torque_out())})
    assert len(meshes) == 6
    cont = [f"{m}.dte" for m in meshes] + ["input.torque", "output.speed", "sun.speed"]
    cont = [c for c in cont if c in native.dtype.names]
    assert {"input.torque", "output.speed"} <= set(cont)
    discrete = [f"{m}.contact_state" for m in meshes]
    r = fmpy.simulate_fmu(str(fmu), fmi_type="CoSimulation", output_interval=H_MIXED, stop_time=STOP_MIXED,
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
    doc_speed = float(re.search(r"input_speed = ([0-9.e+-]+)", speed_in_torque_out()).group(1))
    z = {k: int(v) for k, v in re.findall(r'name = "(sun|ring)"\nteeth = (\d+)', speed_in_torque_out())}
    ratio = 1 + z["ring"] / z["sun"]
    window = native["time"] >= STOP_MIXED - 0.002
    carrier = native["output.speed"][window].mean()
    print(f"carrier mean speed {carrier:.9f} rad/s, neighbour/ratio {doc_speed / ratio:.9f}")
    assert carrier == pytest.approx(doc_speed / ratio, rel=1e-4)
    torque_in = -native["input.torque"][window].mean()  # the coupling's torque on the sun
    load = float(re.search(r"torque = (-[0-9.e+-]+)", speed_in_torque_out()).group(1))
    print(f"coupling torque on the sun {torque_in:.4f} N·m, load/ratio {-load / ratio:.4f} N·m")
    assert torque_in == pytest.approx(-load / ratio, rel=1e-3)
