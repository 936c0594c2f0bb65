"""`geardyn run` on fmpy's container FMU (issue 4, acceptance 2, second third-party FMU).

fmpy 0.3.32 ships a compiled FMI 2.0/3.0 container (`container_fmu.so`); `make_container.py`
wraps the shipped spur_pair FMU in it. The container's binary is not ours: it instantiates the
inner FMU itself and steps it with its own internal step. geardyn and fmpy must produce the
same CSV from it, and the container's result must agree with the inner FMU run directly.
"""

import subprocess
import sys

import numpy as np

from conftest import run_geardyn
from test_host_geardyn_fmus import shipped
from test_host_thirdparty import MODELS, assert_same, fmpy_cli, read


def test_container_fmu_matches_fmpy_and_the_inner_fmu(tmp_path, report):
    inner = shipped("spur_pair")
    container = tmp_path / "GearContainer.fmu"
    subprocess.run([sys.executable, str(MODELS / "make_container.py"), str(inner), str(container)],
                   check=True, capture_output=True, text=True)
    info = run_geardyn("info", container).stdout
    assert "modelIdentifier                         container_fmu" in info
    assert run_geardyn("validate", container).returncode == 0

    g = tmp_path / "g.csv"
    r = run_geardyn("run", container, "--out", g, "--start", "operating.input_torque=130", check=False)
    assert r.returncode == 0, r.stderr
    f = fmpy_cli(container, tmp_path / "f.csv", "--start-values", "operating.input_torque", "130")
    rel = assert_same(g, f)
    assert g.read_text() == f.read_text()

    # The same experiment on the inner FMU directly: equal up to the container's own step
    # arithmetic (it accumulates its internal time, so steps differ in the last bits).
    d = tmp_path / "d.csv"
    r = run_geardyn("run", inner, "--out", d, "--outputs", "mesh.dte,mesh.force", "--start", "operating.input_torque=130",
                    "--stop-time", "0.005", "--output-interval", "1e-5", check=False)
    assert r.returncode == 0, r.stderr
    _, a = read(g)
    _, b = read(d)
    assert a.shape == b.shape
    dev = float(np.max(np.abs(a[:, 1:] - b[:, 1:]) / np.abs(b[:, 1:]).max(axis=0)))
    assert dev < 1e-9, dev
    report(f"fmpy container FMU, geardyn run vs fmpy simulate: max rel diff {rel:.3g} (byte-identical); vs inner FMU {dev:.2e}")
