"""A diverging co-simulation stops early and says where (issue 32, acceptance 3).

examples/systems/drivetrain with Jacobi and a zero-order hold at T_mesh/10 is unstable: the
coupling pumps energy into the train until the motor turns at about 4e8 rad/s, and before the
divergence check the run ground on for about 5 CPU-minutes until the gear FMU refused a step
at t = 0.26 s. The master's bound (docs/systems.md: a connected speed, torque or force growing
more than 1000-fold within the second half of the run so far) stops it at t ≈ 0.164 s, while
the run is still cheap, naming the element and the signal. The stable couplings at the same
step run to the stop time (the negative control).
"""

import resource

import pytest

from conftest import FMU_DIR, REPO, run_geardyn

SYSTEM = REPO / "examples" / "systems" / "drivetrain"
DIVERGING = ["--algorithm", "jacobi", "--extrapolation", "none",
             "--output-interval", "5.2631578947368424e-05", "--stop-time", "0.3"]


@pytest.fixture(scope="module")
def fmus(shipped_fmus):
    return FMU_DIR


def last_time(csv):
    return float(csv.read_text().splitlines()[-1].split(",")[0])


def test_the_diverging_configuration_stops_early_naming_element_and_signal(fmus, tmp_path, report):
    out = tmp_path / "d.csv"
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    r = run_geardyn("run", SYSTEM, "--out", out, *DIVERGING, check=False)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    assert r.returncode == 1, r.stderr
    error = [line for line in r.stderr.splitlines() if line.startswith("error: ")]
    assert len(error) == 1, r.stderr
    assert error[0].startswith("error: the system diverges: element \""), error[0]
    assert " output \"" in error[0] and "more than 1000 times the largest" in error[0], error[0]
    t = last_time(out)
    # Well before the speeds run away (the motor is still below 1e4 rad/s at 0.17 s) and the
    # FMUs' cost with them.
    assert 0.1 < t < 0.17, t
    report(f"diverging drivetrain (Jacobi, hold, T_mesh/10): stopped at t = {t:.4f} s after {cpu:.2f} s CPU: {error[0][7:120]}…")


@pytest.mark.parametrize("algorithm,extrapolation", [("jacobi", "linear"), ("gauss-seidel", "none"), ("gauss-seidel", "linear")])
def test_stable_couplings_at_the_same_step_run_to_the_end(fmus, tmp_path, algorithm, extrapolation):
    out = tmp_path / "d.csv"
    args = list(DIVERGING)
    args[1], args[3] = algorithm, extrapolation
    r = run_geardyn("run", SYSTEM, "--out", out, *args, check=False)
    assert r.returncode == 0, r.stderr
    assert last_time(out) == 0.3
