"""Parallel Jacobi on the shipped five-FMU drivetrain (issue 32, item 4): the FMUs' steps on
two threads give the bytes of the serial run, for both Jacobi couplings (the first 32 steps
are serial, the rest parallel)."""

import pytest

from conftest import FMU_DIR, REPO, run_geardyn

SYSTEM = REPO / "examples" / "systems" / "drivetrain"


@pytest.mark.parametrize("extrapolation", ["none", "linear"])
def test_two_threads_give_the_bytes_of_one(shipped_fmus, tmp_path, extrapolation, report):
    texts = []
    for threads in ("1", "2"):
        out = tmp_path / f"t{threads}.csv"
        r = run_geardyn("run", SYSTEM, "--out", out, "--algorithm", "jacobi", "--extrapolation", extrapolation,
                        "--output-interval", "2.631578947368421e-05", "--stop-time", "0.05",
                        "--threads", threads, check=False)
        assert r.returncode == 0, r.stderr
        texts.append(out.read_bytes())
    assert texts[0].count(b"\n") == 1902
    assert texts[0] == texts[1]
    report(f"drivetrain (5 FMUs), Jacobi/{extrapolation}, 1901 steps: --threads 2 byte-identical to --threads 1")
