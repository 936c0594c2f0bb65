"""The drivetrain element FMUs (`docs/elements.md`) through fmpy and the raw C ABI.

Oracles, all independent of the FMU's code:
- the motor with torque ripple (open loop on the constant-torque plateau, and the shipped
  `emotor` with its PI controller, curve and anti-windup) against scipy `solve_ivp` (DOP853,
  rtol 1e-12) of the equations written out here;
- `fmi2SetRealInputDerivatives` with a torque ramp T(t) = T0 + T1 t over one big step on an
  inertia: the closed-form cubic; without derivatives the zero-order-hold parabola;
- output derivatives against the closed form (d/dt angle = speed, d/dt speed = T/J);
- the shipped element FMUs under fmpy against their `reference.csv` (written by the Rust run of
  the same model, `tests/element_fmus.rs`), and `geardyn run` against fmpy.
"""

import ctypes as C
import math

import fmpy
import numpy as np
import pytest
from conftest import FMU_DIR, REPO, run_geardyn
from fmi_host import ERROR, OK, Host, reals, vrs
from fmpy import extract
from scipy.integrate import solve_ivp

ELEMENTS = ["emotor", "shaft_in", "shaft_out", "vehicle_load"]


def build(tmp_path, name, text):
    folder = tmp_path / name
    folder.mkdir()
    (folder / "scene.toml").write_text(text)
    run_geardyn("fmu", "build", folder, "--out", tmp_path / "fmus")
    return tmp_path / "fmus" / f"{name}.fmu"


def shipped(name):
    fmu = FMU_DIR / f"{name}.fmu"
    if not fmu.exists():
        pytest.fail(f"{fmu} missing: run `bash scripts/build-fmus.sh`")
    return fmu


RIPPLE = [(6.0, 3.0, 0.0), (12.0, 1.5, 0.5)]

MOTOR_OPEN = """
[element]
kind = "motor"
name = "motor_open"
inertia = 0.01
damping = 1.0e-4
torque_fraction = 0.8
[element.curve]
speed = [0.0, 400.0, 1000.0]
torque = [150.0, 150.0, 60.0]
[[element.ripple]]
order = 6.0
amplitude = 3.0
[[element.ripple]]
order = 12.0
amplitude = 1.5
phase = 0.5
[initial]
speed = 50.0
[solver]
rtol = 1e-12
atol = 1e-12
stop_time = 0.03
output_interval = 1e-3
"""


def ripple(theta):
    return sum(a * math.cos(o * theta + p) for o, a, p in RIPPLE)


def test_open_loop_motor_with_ripple_matches_scipy(tmp_path, report):
    fmu = build(tmp_path, "motor_open", MOTOR_OPEN)
    load = -20.0
    r = fmpy.simulate_fmu(str(fmu), start_values={"flange.torque": load},
                          output=["flange.angle", "flange.speed"])
    J, d = 0.01, 1.0e-4

    def rhs(t, y):
        return [y[1], (0.8 * 150.0 + ripple(y[0]) + load - d * y[1]) / J]

    sol = solve_ivp(rhs, (0.0, 0.03), [0.0, 50.0], method="DOP853", rtol=1e-12, atol=1e-12,
                    t_eval=r["time"])
    assert sol.success
    assert r["flange.speed"].max() < 400.0, "stays on the constant-torque plateau"
    err_w = np.abs(r["flange.speed"] - sol.y[1]).max() / np.abs(sol.y[1]).max()
    err_a = np.abs(r["flange.angle"] - sol.y[0]).max() / np.abs(sol.y[0]).max()
    report(f"open-loop motor with ripple vs scipy DOP853: max rel speed error {err_w:.2e}, angle {err_a:.2e}")
    assert err_w < 1e-9 and err_a < 1e-9
    # The ripple is in the solution: the speed is not a straight line.
    lin = np.polyval(np.polyfit(r["time"], r["flange.speed"], 1), r["time"])
    assert np.abs(r["flange.speed"] - lin).max() > 1e-3


def t_max(w):
    return float(np.interp(w, [0.0, 400.0, 500.0, 600.0, 800.0, 1000.0],
                           [150.0, 150.0, 120.0, 100.0, 75.0, 60.0]))


def test_emotor_pi_with_anti_windup_matches_scipy(report):
    """The shipped emotor, free rotor from rest to the speed reference (saturated start,
    anti-windup), against scipy at rtol 1e-12; the saturation switches make the right-hand
    side non-smooth, so the agreement is that of two adaptive integrators across kinks."""
    r = fmpy.simulate_fmu(str(shipped("emotor")), output=["flange.speed", "motor.electric_torque"])
    J, d, kp, ki, wref = 0.01, 1.0e-4, 5.0, 50.0, 471.238898038469

    def drive(y):
        e = wref - y[1]
        cmd = kp * e + ki * y[2]
        tm = t_max(y[1])
        if cmd > tm:
            return tm, (0.0 if e > 0 else e)
        if cmd < -tm:
            return -tm, (0.0 if e < 0 else e)
        return cmd, e

    def rhs(t, y):
        te, di = drive(y)
        return [y[1], (te + ripple(y[0]) - d * y[1]) / J, di]

    sol = solve_ivp(rhs, (0.0, 0.5), [0.0, 0.0, 0.0], method="DOP853", rtol=1e-12, atol=1e-12,
                    t_eval=r["time"])
    assert sol.success
    err = np.abs(r["flange.speed"] - sol.y[1]).max() / wref
    report(f"emotor PI run-up vs scipy DOP853: max speed error {err:.2e} of the reference speed")
    assert err < 1e-6
    assert r["motor.electric_torque"][0] == 150.0, "saturated at the start"
    assert abs(r["flange.speed"][-1] - wref) < 0.05 * wref


INERTIA = """
[element]
kind = "inertia"
name = "wheel"
inertia = 0.25
[initial]
angle = 0.3
speed = 12.0
"""


@pytest.fixture
def inertia(tmp_path):
    fmu = build(tmp_path, "wheel", INERTIA)
    h = Host(fmu, extract(str(fmu), str(tmp_path / "x")))
    c = h.instantiate(logging_on=1)
    assert c
    yield h, c
    h.fmi2FreeInstance(c)


def start(h, c, torque):
    assert h.fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0) == OK
    assert h.fmi2EnterInitializationMode(c) == OK
    assert h.fmi2SetReal(c, vrs(h.vr("flange_a.torque")), 1, reals(torque)) == OK
    assert h.fmi2ExitInitializationMode(c) == OK


def get(h, c, *names):
    out = (C.c_double * len(names))()
    assert h.fmi2GetReal(c, vrs(*[h.vr(n) for n in names]), len(names), out) == OK
    return list(out)


@pytest.mark.parametrize("ramp", [True, False])
def test_ramp_input_derivative_is_exact(inertia, ramp, report):
    """T(t) = T0 + T1 t over one step of h = 0.75 s: θ = θ0 + ω0 h + (T0 h²/2 + T1 h³/6)/J
    with the derivative (second-order coupling is exact for a linear input), the ZOH parabola
    without."""
    h, c = inertia
    J, T0, T1, step = 0.25, 2.0, 8.0, 0.75
    start(h, c, T0)
    if ramp:
        order = (C.c_int * 1)(1)
        assert h.fmi2SetRealInputDerivatives(c, vrs(h.vr("flange_a.torque")), 1, order, reals(T1)) == OK
    assert h.fmi2DoStep(c, 0.0, step, 1) == OK
    theta, w = get(h, c, "flange_a.angle", "flange_a.speed")
    T1e = T1 if ramp else 0.0
    want_theta = 0.3 + 12.0 * step + (T0 * step**2 / 2 + T1e * step**3 / 6) / J
    want_w = 12.0 + (T0 * step + T1e * step**2 / 2) / J
    report(f"inertia, one step with {'a ramp input' if ramp else 'zero-order hold'}: angle error {abs(theta - want_theta):.1e} rad")
    assert abs(theta - want_theta) <= 1e-14 * want_theta
    assert abs(w - want_w) <= 1e-14 * want_w
    # The two answers differ by T1 h³/(6J): the test can tell them apart.
    assert T1 * step**3 / 6 / J > 1e6 * 1e-14 * want_theta


def test_input_derivative_orders_and_targets_are_checked(inertia):
    h, c = inertia
    start(h, c, 1.0)
    h.messages.clear()
    # Orders 1 to 3 are taken (the element follows the input's Taylor polynomial), 4 is not.
    order = (C.c_int * 1)(4)
    assert h.fmi2SetRealInputDerivatives(c, vrs(h.vr("flange_a.torque")), 1, order, reals(1.0)) == ERROR
    assert any("order 4" in m[3] for m in h.messages), h.messages
    # Only continuous Real inputs take a rate: an output or a parameter is refused, naming it.
    for name in ("flange_a.speed", "inertia"):
        assert h.fmi2Reset(c) == OK
        start(h, c, 1.0)
        h.messages.clear()
        order = (C.c_int * 1)(1)
        assert h.fmi2SetRealInputDerivatives(c, vrs(h.vr(name)), 1, order, reals(1.0)) == ERROR
        assert any(f"'{name}'" in m[3] and "not a continuous Real input" in m[3] for m in h.messages), h.messages


def test_output_derivatives(tmp_path, inertia):
    h, c = inertia
    start(h, c, 5.0)
    names = ["flange_a.angle", "flange_a.speed"]
    out = (C.c_double * 2)()
    order = (C.c_int * 2)(1, 1)
    assert h.fmi2GetRealOutputDerivatives(c, vrs(*[h.vr(n) for n in names]), 2, order, out) == OK
    assert list(out) == [12.0, 5.0 / 0.25]
    md = fmpy.read_model_description(str(tmp_path / "fmus" / "wheel.fmu"))
    assert md.coSimulation.canInterpolateInputs and md.coSimulation.maxOutputDerivativeOrder == 1
    h.messages.clear()
    order = (C.c_int * 1)(2)
    assert h.fmi2GetRealOutputDerivatives(c, vrs(h.vr("flange_a.speed")), 1, order, out) == ERROR
    assert any("order 2" in m[3] for m in h.messages), h.messages


def test_negative_inertia_is_refused_with_a_log(inertia):
    h, c = inertia
    h.messages.clear()
    assert h.fmi2SetReal(c, vrs(h.vr("inertia")), 1, reals(-0.5)) == ERROR
    (_, status, _, msg), = h.messages
    assert "'inertia'" in msg and "-0.5" in msg, msg


@pytest.mark.parametrize("name", ["emotor", "vehicle_load"])
def test_fmpy_reproduces_the_reference(name, report):
    ref = np.genfromtxt(REPO / "fmu" / name / "reference.csv", delimiter=",", names=True, deletechars="")
    r = fmpy.simulate_fmu(str(shipped(name)))
    assert len(r) == len(ref)
    worst = 0.0
    for col in r.dtype.names[1:]:
        # The reference's header is the FMU's output names: no mapping between them.
        scale = max(np.abs(ref[col]).max(), 1e-300)
        worst = max(worst, np.abs(r[col] - ref[col]).max() / scale)
    report(f"{name}.fmu under fmpy vs reference.csv: max rel diff {worst:.2e}")
    # fmpy rounds its communication points its own way, so the adaptive steps differ in the
    # last bits: agreement to the integrator's tolerance (rtol 1e-10), not bit for bit.
    assert worst <= 1e-9


@pytest.mark.parametrize("name", ELEMENTS)
def test_geardyn_run_matches_fmpy(name, tmp_path):
    from test_host_thirdparty import assert_same, fmpy_cli

    fmu = shipped(name)
    g = tmp_path / "g.csv"
    r = run_geardyn("run", fmu, "--out", g, check=False)
    assert r.returncode == 0, r.stderr
    f = fmpy_cli(fmu, tmp_path / "f.csv")
    assert_same(g, f)


def test_coupling_order_zoh_one_ramp_two(inertia, report):
    """An inertia driven by T(t) = e^t known only at the communication points: the speed error
    at t = 1 s falls with the step at order 1 under zero-order hold and at order 2 with
    first-order input derivatives. Oracle: ω(1) = ω0 + (e − 1)/J."""
    h, c = inertia
    J, w0 = 0.25, 12.0
    vr, order = vrs(h.vr("flange_a.torque")), (C.c_int * 1)(1)
    want = w0 + (math.e - 1.0) / J
    rows = []
    for ramp in (False, True):
        errs = []
        for n in (25, 50, 100, 200):
            assert h.fmi2Reset(c) == OK
            start(h, c, 1.0)
            step = 1.0 / n
            for i in range(n):
                tc = i * step
                assert h.fmi2SetReal(c, vr, 1, reals(math.exp(tc))) == OK
                if ramp:
                    assert h.fmi2SetRealInputDerivatives(c, vr, 1, order, reals(math.exp(tc))) == OK
                assert h.fmi2DoStep(c, tc, step, 1) == OK
            errs.append(abs(get(h, c, "flange_a.speed")[0] - want))
        orders = [math.log2(errs[k] / errs[k + 1]) for k in range(3)]
        rows.append(orders)
        report(f"{'ramp' if ramp else 'ZOH '}: speed errors {', '.join(f'{e:.2e}' for e in errs)} for h = 1/25..1/200; observed orders {', '.join(f'{o:.2f}' for o in orders)}")
    zoh, lin = rows
    assert all(0.9 < o < 1.1 for o in zoh), zoh
    assert all(1.9 < o < 2.1 for o in lin), lin


LIGHT_LOAD = """
[element]
kind = "load"
name = "light_load"
inertia = 0.5
torque = 5.0
drag = 2.0e-4
[initial]
speed = 471.238898038469
[solver]
rtol = 1e-12
atol = 1e-12
"""


class Part:
    """One element FMU under a hand-written fixed-step master (fmpy's FMU2Slave)."""

    def __init__(self, fmu, tmp_path, name, starts):
        from fmpy.fmi2 import FMU2Slave

        md = fmpy.read_model_description(str(fmu))
        self.vr = {v.name: v.valueReference for v in md.modelVariables}
        self.s = FMU2Slave(guid=md.guid, unzipDirectory=extract(str(fmu), str(tmp_path / name)),
                           modelIdentifier=md.coSimulation.modelIdentifier, instanceName=name)
        self.s.instantiate()
        self.s.setupExperiment(startTime=0.0)
        self.s.enterInitializationMode()
        for k, x in starts.items():
            self.s.setReal([self.vr[k]], [x])
        self.s.exitInitializationMode()

    def get(self, *names):
        return self.s.getReal([self.vr[n] for n in names])

    def rate(self, *names):
        return self.s.getRealOutputDerivatives([self.vr[n] for n in names], [1] * len(names))

    def set(self, values, rates=None):
        self.s.setReal([self.vr[n] for n in values], list(values.values()))
        if rates:
            self.s.setRealInputDerivatives([self.vr[n] for n in rates], [1] * len(rates), list(rates.values()))

    def free(self):
        self.s.terminate()
        self.s.freeInstance()


def test_motor_shaft_load_cosimulation_matches_the_monolithic_system(tmp_path, report):
    """emotor → shaft_out → a load, connected as docs/elements.md says (the shaft's torque
    outputs straight into the bodies' torque inputs), under a fixed-step master: the speeds
    converge to scipy's monolithic solution of the same equations (DOP853, rtol 1e-12) at
    order 1 with zero-order hold and order 2 when the master passes the shaft torque's
    output derivatives on as input derivatives."""
    load_fmu = build(tmp_path, "light_load", LIGHT_LOAD)
    w0, T_end = 471.238898038469, 0.05
    Jm, dm, kp, ki = 0.01, 1.0e-4, 5.0, 50.0
    k, c = 5.0e4, 2.0
    JL, T0, cd = 0.5, 5.0, 2.0e-4

    def rhs(t, y):
        th_m, w_m, integ, th_l, w_l = y
        tau = k * (th_m - th_l) + c * (w_m - w_l)
        e = w0 - w_m
        cmd = kp * e + ki * integ
        tm = t_max(w_m)
        te, di = (tm, 0.0 if e > 0 else e) if cmd > tm else ((-tm, 0.0 if e < 0 else e) if cmd < -tm else (cmd, e))
        return [w_m, (te + ripple(th_m) - tau - dm * w_m) / Jm, di,
                w_l, (tau - T0 - cd * w_l * abs(w_l)) / JL]

    ref = solve_ivp(rhs, (0.0, T_end), [0.0, w0, 0.0, 0.0, w0], method="DOP853", rtol=1e-12, atol=1e-12)
    assert ref.success
    want = ref.y[[1, 4], -1]

    def cosim(n, ramp):
        h = T_end / n
        motor = Part(shipped("emotor"), tmp_path, f"m{n}{ramp}", {"initial.speed": w0})
        shaft = Part(shipped("shaft_out"), tmp_path, f"s{n}{ramp}", {})
        load = Part(load_fmu, tmp_path, f"l{n}{ramp}", {})
        for i in range(n):
            tc = i * h
            am, wm, aam = motor.get("flange.angle", "flange.speed", "flange.acceleration")
            al, wl, aal = load.get("flange.angle", "flange.speed", "flange.acceleration")
            shaft.set({"flange_a.angle": am, "flange_a.speed": wm, "flange_b.angle": al, "flange_b.speed": wl},
                      {"flange_a.speed": aam, "flange_b.speed": aal} if ramp else None)
            ta, tb = shaft.get("flange_a.torque", "flange_b.torque")
            if ramp:
                ra, rb = shaft.rate("flange_a.torque", "flange_b.torque")
            motor.set({"flange.torque": ta}, {"flange.torque": ra} if ramp else None)
            load.set({"flange.torque": tb}, {"flange.torque": rb} if ramp else None)
            for p in (motor, shaft, load):
                p.s.doStep(tc, h)
        got = [motor.get("flange.speed")[0], load.get("flange.speed")[0]]
        for p in (motor, shaft, load):
            p.free()
        return np.abs(np.array(got) - want).max()

    ns = (1000, 2000, 4000, 8000)
    for ramp in (False, True):
        errs = [cosim(n, ramp) for n in ns]
        orders = [math.log2(errs[i] / errs[i + 1]) for i in range(3)]
        report(f"emotor+shaft_out+load, {'output→input derivatives' if ramp else 'zero-order hold'}: "
               f"max speed error at {T_end} s {', '.join(f'{e:.2e}' for e in errs)} rad/s for h = {T_end}/{ns}; "
               f"observed orders {', '.join(f'{o:.2f}' for o in orders)}")
        lo, hi = (1.8, 2.3) if ramp else (0.8, 1.3)
        assert all(lo < o < hi for o in orders), orders
