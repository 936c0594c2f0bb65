"""Cross-tool validation of one real drivetrain system (issue 18 point 5, acceptance 1–3):
examples/systems/drivetrain (emotor → shaft_in → spur_stage → shaft_out → vehicle_load, five
geardyn FMUs, one SystemStructure.ssd).

* geardyn's master (Jacobi, zero-order hold) against libcosim (libcosimpy
  `CosimExecution.from_ssp_file` on the same SSD): libcosim's fixed-step algorithm is Jacobi
  with zero-order hold, so both compute the same numbers and must agree to rounding (1e-11 of
  each signal's largest value: a shaft torque is k times a difference of angles of about 1 rad,
  whose rounding k·ulp(θ) is 1.4e-13 of the output shaft's torque at the cruise point).
* Every coupling of geardyn's master against the monolithic native run of the same drivetrain
  (`geardyn simulate examples/drivetrain_monolithic.toml`, same grid): a convergence table
  over the communication steps T_mesh/5 … T_mesh/80 with observed orders (printed in the
  measurements summary), at the shipped operating point (cruise at 3000 rpm, the teeth in
  contact) and at the rattling one of the first version (4500 rpm, contact lost a third of
  the time; the SSD's bindings overridden with `--start`, the monolithic scene moved alike).
  The native run is itself checked against the independent scipy model
  `drivetrain_reference.py` (one ODE system, DOP853 rtol 1e-12, stiffness knots and contact
  changes as events).
* Acceptance 2's bound at T_mesh/20 (docs/cosimulation.md says which reading is met).
* The speed ratio of the gear stage in the coupled run against the tooth ratio z1/z2.

GEARDYN_LONG=1 runs the long variants (more steps in the table, a longer ratio run).
"""

from __future__ import annotations

import math
import os
import shutil
import tomllib
import xml.etree.ElementTree as ET

import numpy as np
import pytest

import drivetrain_reference as dr
import ports_reference as pr
from conftest import FMU_DIR, REPO, run_geardyn

SYSTEM = REPO / "examples" / "systems" / "drivetrain"
FMUS = ("emotor", "shaft_in", "spur_stage", "shaft_out", "vehicle_load")
LONG = os.environ.get("GEARDYN_LONG") == "1"
SSV = "{http://ssp-standard.org/SSP1/SystemStructureParameterValues}"
SSD = "{http://ssp-standard.org/SSP1/SystemStructureDescription}"
COLS = ["gear.mesh1.dte", "gear.input.speed", "gear.output.speed", "motor.flange.speed",
        "load.flange.speed", "shaft1.shaft.torque", "shaft2.shaft.torque"]


@pytest.fixture(scope="module")
def fmus(shipped_fmus):
    for f in FMUS:
        assert (FMU_DIR / f"{f}.fmu").exists(), f
    return FMU_DIR


def bindings():
    """The SSD's parameter values per component (name -> value)."""
    root = ET.parse(SYSTEM / "SystemStructure.ssd").getroot()
    out = {}
    for comp in root.iter(f"{SSD}Component"):
        vals = {}
        for p in comp.iter(f"{SSV}Parameter"):
            vals[p.get("name")] = float(p.find(f"{SSV}Real").get("value"))
        out[comp.get("name")] = vals
    return out


def scene(name):
    with open(REPO / "fmu" / name / "scene.toml", "rb") as fh:
        return tomllib.load(fh)


def reference_model():
    """The monolithic model's data: the shipped scenes with the SSD's bindings applied."""
    b = bindings()
    s = pr.load(REPO / "fmu" / "spur_stage" / "scene.toml")
    s.t_in, s.t_out = b["gear"]["input.torque"], b["gear"]["output.torque"]
    s.omega = b["gear"]["operating.input_speed"]
    m, sh1, sh2, ld = (scene(n)["element"] for n in ("emotor", "shaft_in", "shaft_out", "vehicle_load"))
    assert b["motor"]["controller.ki"] == 0.0  # the reference is a P controller
    el = dr.Elements(
        j_m=m["inertia"], d_m=m["damping"], kp=m["controller"]["kp"], omega_ref=b["motor"]["controller.speed_reference"],
        ripple=[(r["order"], r["amplitude"], r.get("phase", 0.0)) for r in m["ripple"]],
        t_max=(m["curve"]["speed"], m["curve"]["torque"]),
        k1=sh1["stiffness"], c1=sh1["damping"], k2=sh2["stiffness"], c2=sh2["damping"],
        j_l=ld["inertia"], t0=ld["torque"], c_v=ld["viscous"], c_d=ld["drag"],
        theta_m0=b["motor"]["initial.angle"], omega_m0=b["motor"]["initial.speed"],
        theta_l0=b["load"]["initial.angle"], omega_l0=b["load"]["initial.speed"])
    return s, el


def t_mesh():
    s = pr.load(REPO / "fmu" / "spur_stage" / "scene.toml")
    return 2 * math.pi / (s.base.z1 * bindings()["gear"]["operating.input_speed"])


def geardyn(out, h, stop, algorithm, extrapolation, cols=COLS, starts=()):
    r = run_geardyn("run", SYSTEM, "--out", out, "--stop-time", repr(stop), "--output-interval", repr(h),
                    "--algorithm", algorithm, "--extrapolation", extrapolation, "--outputs", ",".join(cols),
                    *starts, check=False)
    assert r.returncode == 0, r.stderr
    return np.genfromtxt(out, delimiter=",", names=True, deletechars="")


MONOLITHIC = REPO / "examples" / "drivetrain_monolithic.toml"
NATIVE = {"dte": "mesh1.dte", "pinion.speed": "pinion.speed", "gear.speed": "gear.speed",
          "motor.speed": "motor.speed", "load.speed": "load.speed", "tau1": "shaft1.torque",
          "tau2": "shaft2.torque"}


def native(out, h, stop, scene=MONOLITHIC):
    """The monolithic native run (`geardyn simulate`, the oracle of issue 18 point 5) on the
    grid of a co-simulation with step h, in the reference's keys."""
    run_geardyn("simulate", scene, "--out", out, "--stop-time", repr(stop), "--output-interval", repr(h),
                "--rtol", "1e-12", "--atol", "1e-18", "--quiet")
    d = np.genfromtxt(out, delimiter=",", names=True, deletechars="")
    res = {k: d[c] for k, c in NATIVE.items()}
    res["time"] = d["time"]
    return res


def col(data, name):
    return data[name]


# The shipped operating point (the SSD's bindings) and the rattling one of the first version.
CRUISE_RPM, RATTLING_RPM, ROAD_LOAD_T0 = 3000.0, 4500.0, 10.0


class Case:
    """An operating point of the system: `--start` overrides of the SSD's bindings (none for
    the shipped one) and the monolithic scene moved to the same point."""

    def __init__(self, name, rpm, tmp_path):
        self.name, self.point = name, dr.SteadyPoint(rpm, ROAD_LOAD_T0)
        self.t_mesh = self.point.t_mesh
        if rpm == CRUISE_RPM:
            self.starts, self.scene = (), MONOLITHIC
        else:
            self.starts = [a for k, v in self.point.bindings().items() for a in ("--start", f"{k}={v!r}")]
            self.scene = tmp_path / f"monolithic_{rpm:g}.toml"
            self.scene.write_text(self.point.monolithic_scene(MONOLITHIC.read_text()))

    def run(self, out, h, stop, algorithm, extrapolation):
        return geardyn(out, h, stop, algorithm, extrapolation, starts=self.starts)

    def oracle(self, out, h, stop):
        return native(out, h, stop, self.scene)


def test_the_ssd_binds_the_cruise_point(report):
    """The shipped SSD and monolithic scene are the steady start of `SteadyPoint` at 3000 rpm on
    the road load (so the rattling case, built by the same rule at 4500 rpm, is the same
    system at another point), and the motor's command stays inside its full-load curve."""
    point = dr.SteadyPoint(CRUISE_RPM, ROAD_LOAD_T0)
    flat = {f"{el}.{k}": v for el, vals in bindings().items() for k, v in vals.items()}
    expected = point.bindings()
    assert expected.pop("load.torque") == scene("vehicle_load")["element"]["torque"]
    assert flat.keys() == expected.keys()
    for k, v in expected.items():
        assert flat[k] == pytest.approx(v, rel=1e-15, abs=1e-18), k
    assert point.monolithic_scene(MONOLITHIC.read_text()) == MONOLITHIC.read_text()
    assert t_mesh() == pytest.approx(point.t_mesh, rel=1e-15)
    for rpm in (CRUISE_RPM, RATTLING_RPM):
        p = dr.SteadyPoint(rpm, ROAD_LOAD_T0)
        m = scene("emotor")["element"]
        assert p.motor_torque < np.interp(p.omega, m["curve"]["speed"], m["curve"]["torque"])


def test_the_system_starts_in_its_steady_operating_point(fmus, tmp_path):
    """The bound start values are consistent: at t = 0 the shafts carry the steady torques
    (the load's resistance at the wheel speed, times z1/z2 at the pinion), the bodies turn at
    the tooth ratio, and the motor's P controller asks for exactly that torque."""
    d = geardyn(tmp_path / "c.csv", 1e-5, 1e-5, "jacobi", "none", COLS + ["motor.motor.electric_torque"])
    w1, w2 = col(d, "gear.input.speed")[0], col(d, "gear.output.speed")[0]
    ld = scene("vehicle_load")["element"]
    t_load = ld["torque"] + ld["viscous"] * w2 + ld["drag"] * w2 * w2
    assert w2 / w1 == pytest.approx(38 / 55, rel=1e-15)
    assert col(d, "shaft2.shaft.torque")[0] == pytest.approx(t_load, rel=1e-12)
    assert col(d, "shaft1.shaft.torque")[0] == pytest.approx(t_load * 38 / 55, rel=1e-12)
    m = scene("emotor")["element"]
    assert col(d, "motor.motor.electric_torque")[0] == pytest.approx(t_load * 38 / 55 + m["damping"] * w1, rel=1e-12)


def libcosim(folder, h, n, cols):
    """libcosimpy's fixed-step algorithm (Jacobi, zero-order hold) on the packed system in
    `folder`: the values of `cols` (`element.variable`) after each of n steps of h."""
    import fmpy
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimObserver import CosimObserver

    log_output_level(CosimLogLevel.WARNING)
    root = ET.parse(folder / "SystemStructure.ssd").getroot()
    files = {c.get("name"): folder / c.get("source") for c in root.iter(f"{SSD}Component")}
    vrs = {}
    for el, fmu in files.items():
        md = fmpy.read_model_description(str(fmu))
        vrs[el] = {v.name: v.valueReference for v in md.modelVariables}
    ex = CosimExecution.from_ssp_file(str(folder), step_size=int(round(h * 1e9)))
    assert ex.num_slaves() == len(files)
    obs = CosimObserver.create_last_value()
    ex.add_observer(observer=obs)
    idx = {el: ex.slave_index_from_instance_name(el) for el in files}
    rows = []
    for _ in range(n):
        assert ex.step()
        row = []
        for c in cols:
            el, var = c.split(".", 1)
            row += obs.last_real_values(slave_index=idx[el], variable_references=[vrs[el][var]])
        rows.append(row)
    return np.array(rows)


def libcosim_agreement(system, fmus, cols, run, col, tmp_path, tol):
    """geardyn's master (Jacobi, zero-order hold: `run(out, h, stop, algorithm, extrapolation)`)
    against libcosim on the same SSD, packed with its FMUs into `tmp_path`: the largest
    difference relative to each signal's largest value, asserted ≤ tol; and Gauss-Seidel
    differs visibly, so the agreement identifies the algorithm."""
    folder = tmp_path / system.name
    (folder / "resources").mkdir(parents=True)
    ssd = (system / "SystemStructure.ssd").read_text()
    for f in fmus:
        shutil.copy(FMU_DIR / f"{f}.fmu", folder / "resources" / f"{f}.fmu")
        assert f"../../../out/fmus/{f}.fmu" in ssd
        ssd = ssd.replace(f"../../../out/fmus/{f}.fmu", f"resources/{f}.fmu")
    (folder / "SystemStructure.ssd").write_text(ssd)
    h, n = 2e-5, 250  # libcosim counts time in integer ns; 5 ms, 14 mesh periods at 4500 rpm
    ours = run(tmp_path / "g.csv", h, n * h, "jacobi", "none")
    theirs = libcosim(folder, h, n, cols)
    assert len(ours) == n + 1
    worst = 0.0
    for j, c in enumerate(cols):
        a, b = col(ours, c)[1:], theirs[:, j]
        d = float(np.abs(a - b).max() / np.abs(b).max())
        worst = max(worst, d)
        assert d <= tol, (c, d)
    gs = run(tmp_path / "gs.csv", h, n * h, "gauss-seidel", "none")
    d_gs = np.abs(col(gs, "gear.mesh1.dte")[1:] - theirs[:, 0]).max() / np.abs(theirs[:, 0]).max()
    assert d_gs > 1e-3, d_gs
    return h, n, worst


def test_geardyn_jacobi_matches_libcosim(fmus, tmp_path, report):
    """Same SSD, same algorithm (Jacobi, zero-order hold): agreement to rounding."""
    h, n, worst = libcosim_agreement(SYSTEM, FMUS, COLS, geardyn, col, tmp_path, 1e-11)
    report(f"drivetrain, geardyn Jacobi/hold vs libcosim fixed-step, h = {h}, {n} steps: "
           f"max |diff| / max|value| = {worst:.2e} over {', '.join(COLS)}")


COUPLINGS = [("gauss-seidel", "none", "GS hold"), ("gauss-seidel", "linear", "GS linear"),
             ("jacobi", "none", "Jacobi hold"), ("jacobi", "linear", "Jacobi linear")]
SIGNALS = [("gear.mesh1.dte", "dte"), ("gear.input.speed", "pinion.speed"), ("load.flange.speed", "load.speed"),
           ("shaft1.shaft.torque", "tau1"), ("shaft2.shaft.torque", "tau2")]


def convergence_table(case, tmp_path, stop, divisors):
    """Max errors against the monolithic native run of the case's point, per coupling and h =
    T_mesh/n, and the DTE's RMS (plain and about its mean) from the oracle."""
    table = {}
    for alg, ex, label in COUPLINGS:
        errs = []
        for n in divisors:
            h = case.t_mesh / n
            d = case.run(tmp_path / "c.csv", h, stop, alg, ex)
            r = case.oracle(tmp_path / "n.csv", h, stop)
            # `simulate` writes only rows on the grid (issue 31 item 4); the master also writes
            # the stop time where it is off the grid: compare the common rows.
            d = d[: len(r["time"])]
            assert np.abs(r["time"] - d["time"]).max() <= 1e-12 * stop  # same grid
            e = {k: float(np.abs(col(d, c) - r[k]).max()) for c, k in SIGNALS}
            e["dte_rms_err"] = float(np.sqrt(np.mean((col(d, "gear.mesh1.dte") - r["dte"]) ** 2)))
            e["rms_ac"] = float(np.sqrt(np.mean((r["dte"] - r["dte"].mean()) ** 2)))
            e["rms"] = float(np.sqrt(np.mean(r["dte"] ** 2)))
            errs.append(e)
        table[label] = errs
    return table


def orders(e):
    return [math.log2(a / b) for a, b in zip(e, e[1:])]


@pytest.mark.parametrize("name,rpm", [("cruise", CRUISE_RPM), ("rattling", RATTLING_RPM)])
def test_convergence_against_the_monolithic_model(fmus, tmp_path, report, name, rpm):
    """Error against the monolithic native run (examples/drivetrain_monolithic.toml, checked
    against the scipy model below; at the rattling point moved there by the same rule) over the
    communication step h = T_mesh/n, every coupling; max error over the run (the system starts
    in its steady operating point). Observed order p = log2(e(h)/e(h/2))."""
    case = Case(name, rpm, tmp_path)
    stop = 5e-3 if not LONG else 2e-2
    divisors = (5, 10, 20, 40, 80) if not LONG else (5, 10, 20, 40, 80, 160, 320)
    table = convergence_table(case, tmp_path, stop, divisors)
    for label, errs in table.items():
        dte = [e["dte"] for e in errs]
        report(f"{name} ({rpm:g} rpm), {label}: max DTE error / DTE RMS about its mean ({errs[0]['rms_ac']:.3e} m) "
               f"at T_mesh/{divisors} = " + ", ".join(f"{e['dte'] / e['rms_ac']:.3g}" for e in errs)
               + f"; / DTE RMS ({errs[0]['rms']:.3e} m) " + ", ".join(f"{e['dte'] / e['rms']:.3g}" for e in errs)
               + "; RMS DTE error / DTE RMS " + ", ".join(f"{e['dte_rms_err'] / e['rms']:.3g}" for e in errs)
               + "; observed orders " + ", ".join(f"{p:.2f}" for p in orders(dte))
               + "; load speed errors (rad/s) " + ", ".join(f"{e['load.speed']:.2e}" for e in errs)
               + "; shaft1 torque errors (N.m) " + ", ".join(f"{e['tau1']:.2e}" for e in errs))
    # The orders are asserted on n = 5 … 80 (GEARDYN_LONG's finer steps are reported): at
    # n = 320 the load speed error, 1.4e-7 rad/s with Gauss-Seidel/linear, nears what the
    # element FMUs' own integrators resolve (rtol 1e-10 of 217 rad/s).
    table = {label: errs[:5] for label, errs in table.items()}
    divisors = divisors[:5]
    # Jacobi with zero-order hold is a first-order coupling: on the fine steps the DTE, speed
    # and torque errors fall at order 1 (±0.3), and they fall monotonically.
    jac = table["Jacobi hold"]
    for _, k in SIGNALS:
        e = [x[k] for x in jac]
        assert all(a > b for a, b in zip(e, e[1:])), (k, e)
        p = math.log2(e[-2] / e[-1])
        assert 0.7 <= p <= 1.3, (k, e, p)
    # Gauss-Seidel with hold mixes angles at t and t+h in each shaft: a torque error of
    # k·Ω·h (165 N.m at T_mesh/20 on the input shaft at any speed), first order.
    for k in ("tau1", "load.speed"):
        e = [x[k] for x in table["GS hold"]]
        assert 0.8 <= math.log2(e[-2] / e[-1]) <= 1.3, (k, e)
    tau_gs = table["GS hold"][2]["tau1"]
    h20 = case.t_mesh / 20
    assert tau_gs == pytest.approx(dr.SteadyPoint(rpm, ROAD_LOAD_T0).k1 * case.point.omega * h20, rel=0.05), tau_gs
    # With --extrapolation linear, every connection is extrapolated (Jacobi, cut connections)
    # or interpolated (Gauss-Seidel) with first-order derivatives: the angles and speeds of the
    # bodies and the gear stage, and the shafts' torques (whose rate k (ω_a − ω_b) + c (α_a − α_b)
    # needs the flange accelerations: the rates of the ramp that ended at the communication
    # point). A second-order coupling: on the fine steps the DTE, the load speed and the input
    # shaft torque fall at order 2 with Gauss-Seidel, and the DTE and the load speed with
    # Jacobi. (Jacobi's sampled shaft torque is not: at grid points just after a stiffness
    # knot or contact change, its value from the flange speeds extrapolated with the
    # acceleration from before the jump keeps an error c·Δα·h, first order, while the states
    # converge at order 2.)
    # (The load speed, an integral of the torque errors over the steps, converges somewhat
    # faster: 2.36–2.38 over 5 ms at cruise, 2.5–2.8 over GEARDYN_LONG's 20 ms at both points.)
    for k, top in (("dte", 2.4), ("tau1", 2.4), ("load.speed", 3.0)):
        e = [x[k] for x in table["GS linear"]]
        for p in orders(e)[-2:]:
            assert 1.7 <= p <= top, ("GS linear", k, e)
    for k in ("dte", "load.speed"):
        e = [x[k] for x in table["Jacobi linear"]]
        assert all(a > b for a, b in zip(e, e[1:])), ("Jacobi linear", k, e)
    e = [x["dte"] for x in table["Jacobi linear"]]
    for p in orders(e)[-2:]:
        assert 1.7 <= p <= 2.4, ("Jacobi linear", e)
    e = [x["load.speed"] for x in table["Jacobi linear"]]
    assert orders(e)[-2] >= 1.7, ("Jacobi linear", e)
    e = [x["tau1"] for x in table["Jacobi linear"]]
    assert all(a > b for a, b in zip(e, e[1:])), ("Jacobi linear", e)
    for n in range(len(divisors)):
        assert table["GS linear"][n]["tau1"] < table["GS hold"][n]["tau1"] / 100
        # (at T_mesh/5 the extrapolation over a fifth of the mesh period can overshoot more
        # than the hold: measured at the cruise point, 0.47 against 0.18 of the RMS)
        if divisors[n] >= 10:
            assert table["Jacobi linear"][n]["dte"] < table["Jacobi hold"][n]["dte"]


@pytest.mark.parametrize("algorithm", ["jacobi", "gauss-seidel"])
def test_speed_ratio_is_the_tooth_ratio(fmus, tmp_path, report, algorithm):
    """Acceptance 1 in the coupled run: the mean speed ratio of the gear stage after the start
    (0.1 s) equals z1/z2 = 38/55 within 1e-6. The mean speeds are the angle increments over the
    window divided by its length (exact time means; sample means of ω at the output grid alias
    the mesh-frequency vibration). The elastic DTE is what remains: r1 Δθ1 − r2 Δθ2 = ΔS.
    Communication step T_mesh/20, the system's own: at T_mesh/10 (5.3e-5 s at 3000 rpm) Jacobi
    with hold is unstable, its error grows (0.05 of the DTE RMS over 20 ms, 6 over 80 ms) until
    the gear stage refuses a step at 0.26 s (docs/cosimulation.md)."""
    stop = 1.0 if not LONG else 5.0
    d = geardyn(tmp_path / "r.csv", t_mesh() / 20, stop, algorithm, "none", ["gear.mesh1.dte"])
    i = np.searchsorted(d["time"], 0.1)
    a1, a2 = col(d, "gear.input.angle"), col(d, "gear.output.angle")
    ratio = (a2[-1] - a2[i]) / (a1[-1] - a1[i])
    rel = ratio / (38 / 55) - 1
    w1, w2 = col(d, "gear.input.speed")[i:], col(d, "gear.output.speed")[i:]
    pointwise = np.mean(w2 / w1) / (38 / 55) - 1
    report(f"{algorithm}: mean(ω2)/mean(ω1) / (z1/z2) − 1 over 0.1–{stop} s = {rel:.2e} "
           f"(pointwise sample mean of ω2/ω1: {pointwise:.2e}, the vibration's correlation)")
    assert abs(rel) <= 1e-6
    # and the difference is the elastic DTE's change (spur_stage's base radii: r2/r1 = 55/38)
    s = pr.load(REPO / "fmu" / "spur_stage" / "scene.toml").base
    dte = col(d, "gear.mesh1.dte")
    assert s.r_b1 * (a1[-1] - a1[i]) - s.r_b2 * (a2[-1] - a2[i]) == pytest.approx(dte[-1] - dte[i], abs=1e-12)


def dte_error_at_a_twentieth_of_the_mesh_period(case, tmp_path, report):
    """Issue 18 acceptance 2's bound: the DTE error at h = T_mesh/20 with the best coupling the
    shipped FMUs allow (Gauss-Seidel with interpolation and extrapolation), against the
    monolithic native run, over the convergence table's 5 ms. Returns it three ways, each
    relative to a DTE RMS: the RMS of the error over the run / the DTE's RMS (the issue's
    words with one norm on both sides), its maximum / the DTE's RMS, its maximum / the DTE's
    RMS about its mean (the measure of the first version of this test, the strictest)."""
    stop, h = 5e-3, case.t_mesh / 20
    d = case.run(tmp_path / "c.csv", h, stop, "gauss-seidel", "linear")
    r = case.oracle(tmp_path / "n.csv", h, stop)
    err = col(d, "gear.mesh1.dte") - r["dte"]
    rms, rms_ac = np.sqrt(np.mean(r["dte"] ** 2)), np.sqrt(np.mean((r["dte"] - r["dte"].mean()) ** 2))
    ratios = (np.sqrt(np.mean(err ** 2)) / rms, np.abs(err).max() / rms, np.abs(err).max() / rms_ac)
    after_first_ms = np.abs(err[d["time"] > 1e-3]).max() / rms
    report(f"{case.name} ({case.point.rpm:g} rpm), GS linear at T_mesh/20: RMS DTE error / DTE RMS = {ratios[0]:.3g}, "
           f"max DTE error / DTE RMS = {ratios[1]:.3g} ({after_first_ms:.3g} after the first ms), "
           f"max DTE error / DTE RMS about its mean = {ratios[2]:.3g}")
    return ratios


def test_dte_error_at_a_twentieth_of_the_mesh_period(fmus, tmp_path, report):
    """Issue 18 acceptance 2 at the shipped (cruise) operating point, in the reading "the RMS
    DTE error is at most 1e-3 of the DTE RMS" (docs/cosimulation.md: the pointwise readings
    are not met; see the xfail below). The same check at the rattling point fails (next
    test), so it can fail."""
    rms_reading, _, _ = dte_error_at_a_twentieth_of_the_mesh_period(Case("cruise", CRUISE_RPM, tmp_path), tmp_path, report)
    assert rms_reading <= 1e-3


@pytest.mark.xfail(strict=True, reason="at the rattling point (4500 rpm, contact lost a third of the time) "
                   "the DTE error at T_mesh/20 is 7.2e-3 of the DTE RMS (RMS over the run), 2.4e-2 at its "
                   "maximum: docs/cosimulation.md")
def test_dte_error_at_a_twentieth_of_the_mesh_period_when_the_teeth_rattle(fmus, tmp_path, report):
    rms_reading, _, _ = dte_error_at_a_twentieth_of_the_mesh_period(Case("rattling", RATTLING_RPM, tmp_path), tmp_path, report)
    assert rms_reading <= 1e-3


@pytest.mark.xfail(strict=True, reason="pointwise, the cruise point's largest DTE error at T_mesh/20 is 2.5e-3 of "
                   "the DTE RMS (7.1e-3 of its RMS about the mean; 1.7e-3 after the first millisecond): even "
                   "fed the exact shaft torques at both ends of every step, the gear stage alone errs by 7e-4 of "
                   "the RMS through its linear input ramps, and the master's own errors add to that: "
                   "docs/cosimulation.md")
def test_largest_dte_error_at_a_twentieth_of_the_mesh_period(fmus, tmp_path, report):
    _, max_reading, _ = dte_error_at_a_twentieth_of_the_mesh_period(Case("cruise", CRUISE_RPM, tmp_path), tmp_path, report)
    assert max_reading <= 1e-3


def test_native_monolithic_run_matches_the_scipy_model(tmp_path, report):
    """The oracle is checked by an independent one: `geardyn simulate` of the monolithic scene
    against the scipy model of the same drivetrain (started from the SSD's values, so this
    also checks that the scene and the system describe the same drivetrain and start)."""
    s, el = reference_model()
    stop = 1e-2
    r_native = native(tmp_path / "n.csv", t_mesh() / 20, stop)
    r = dr.simulate(s, el, stop, r_native["time"])
    assert r["events"] > 20  # knots and contact changes were crossed
    tol = {"dte": 1e-8 * np.abs(r["dte"]).max(), "tau1": 1e-8, "tau2": 1e-8}
    worst = {}
    for k in NATIVE:
        e = float(np.abs(r_native[k] - r[k]).max())
        worst[k] = e
        assert e <= tol.get(k, 1e-9), (k, e)
    report("native monolithic vs scipy over 10 ms: " + ", ".join(f"{k} {v:.1e}" for k, v in worst.items())
           + " (DTE in m, speeds in rad/s, torques in N.m)")
    # and the comparison can fail: 1 % more load inertia in the reference is seen
    el.j_l *= 1.01
    r2 = dr.simulate(s, el, stop, r_native["time"])
    assert np.abs(r_native["load.speed"] - r2["load.speed"]).max() > 1e3 * tol.get("load.speed", 1e-9)
