"""Shared pytest fixtures: repository paths and the release `geardyn` binary.

`scripts/test.sh` builds the binary before pytest runs; the fixture fails with a clear message
if it is missing rather than building behind the user's back.
"""

import contextlib
import pathlib
import shutil
import subprocess

import pytest

REPO = pathlib.Path(__file__).resolve().parents[2]
GEARDYN = REPO / "target" / "release" / "geardyn"


@pytest.fixture(scope="session")
def repo_root() -> pathlib.Path:
    return REPO


@pytest.fixture(scope="session")
def geardyn_bin() -> pathlib.Path:
    if not GEARDYN.exists():
        pytest.fail(f"{GEARDYN} missing: run `cargo build --release` (scripts/test.sh does)")
    return GEARDYN


def run_geardyn(*args, check=True):
    """Runs the binary, returning the CompletedProcess (text mode)."""
    return subprocess.run([str(GEARDYN), *map(str, args)], capture_output=True, text=True, check=check)


def build_stub_fmu(directory: pathlib.Path, model_description: str) -> pathlib.Path:
    """Compiles the project's C stub (`tests/fixtures/stub_fmu.c`) and packs it with
    `model_description` (modelIdentifier "stub") into `directory/stub.fmu`; skips the test
    where no C compiler is installed."""
    import zipfile

    cc = shutil.which("cc") or shutil.which("gcc")
    if cc is None:
        pytest.skip("no C compiler (cc) to build the stub FMU")
    so = directory / "stub.so"
    subprocess.run([cc, "-shared", "-fPIC", "-O1", "-o", str(so), str(REPO / "tests/fixtures/stub_fmu.c")], check=True)
    fmu = directory / "stub.fmu"
    with zipfile.ZipFile(fmu, "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr("modelDescription.xml", model_description)
        z.write(so, "binaries/linux64/stub.so")
    return fmu


FMU_DIR = REPO / "out" / "fmus"
SCENES = sorted(p.parent for p in (REPO / "fmu").glob("*/scene.toml"))
# The gear scenes (single mesh or drivetrain); the element scenes (`[element]`,
# docs/elements.md) have their own tests in test_element_fmus.py.
GEAR_SCENES = [s for s in SCENES if "\n[element]" not in "\n" + (s / "scene.toml").read_text()]


@pytest.fixture(scope="session")
def shipped_fmus() -> list:
    """Every FMU built by `scripts/build-fmus.sh` (one per `fmu/*/scene.toml`)."""
    fmus = [FMU_DIR / f"{s.name}.fmu" for s in SCENES]
    missing = [str(f) for f in fmus if not f.exists()]
    if not SCENES or missing:
        pytest.fail(f"FMUs missing: {missing or 'no fmu/*/scene.toml'}; run `bash scripts/build-fmus.sh`")
    return fmus


@pytest.fixture(scope="session")
def spur_fmu(shipped_fmus) -> pathlib.Path:
    return FMU_DIR / "spur_pair.fmu"


@contextlib.contextmanager
def initialized_slave(fmu, tmp_path):
    """An fmpy FMU2Slave of `fmu`, instantiated and initialized at t = 0 with its start values:
    yields (slave, value reference by name, model description); frees it afterwards."""
    import fmpy
    from fmpy.fmi2 import FMU2Slave

    if not pathlib.Path(fmu).exists():
        pytest.fail(f"{fmu} missing: run `bash scripts/build-fmus.sh`")
    md = fmpy.read_model_description(fmu)
    unzip = fmpy.extract(fmu, unzipdir=tmp_path / "x")
    s = FMU2Slave(guid=md.guid, unzipDirectory=unzip,
                  modelIdentifier=md.coSimulation.modelIdentifier, instanceName="stage")
    s.instantiate()
    s.setupExperiment(startTime=0.0)
    s.enterInitializationMode()
    s.exitInitializationMode()
    try:
        yield s, {v.name: v.valueReference for v in md.modelVariables}, md
    finally:
        try:
            s.terminate()
        except Exception:  # an instance in the error state (a refused call) cannot terminate
            pass
        s.freeInstance()
        shutil.rmtree(tmp_path / "x", ignore_errors=True)


def native_run(scene, out_csv, output_interval, stop_time):
    """`geardyn simulate` on a grid; returns the CSV as a numpy structured array."""
    import numpy as np

    run_geardyn("simulate", scene, "--out", out_csv, "--output-interval", repr(output_interval),
                "--stop-time", repr(stop_time), "--quiet")
    return np.genfromtxt(out_csv, delimiter=",", names=True, deletechars="")


def fmpy_matches_native(name, output_interval, stop_time, tmp_path, report):
    """Runs the shipped FMU `name` under fmpy and `geardyn simulate` on its scene on the same
    grid (same step partition), asserts that DTE and mesh stiffness agree to 1e-12 of their
    largest values, and returns fmpy's mesh-stiffness series."""
    import fmpy
    import numpy as np

    native = native_run(REPO / "fmu" / name, tmp_path / "dte.csv", output_interval, stop_time)
    r = fmpy.simulate_fmu(str(FMU_DIR / f"{name}.fmu"), fmi_type="CoSimulation",
                          output_interval=output_interval, stop_time=stop_time,
                          output=["mesh.dte", "mesh.stiffness"])
    assert len(r) == len(native)
    amp = np.abs(native["mesh.dte"]).max()
    err = np.abs(r["mesh.dte"] - native["mesh.dte"]).max()
    report(f"{name} fmpy vs native: max|dDTE| = {err:.3e} m = {err / amp:.3e} of max|DTE|")
    assert err <= 1e-12 * amp
    k = r["mesh.stiffness"]
    assert np.abs(k - native["mesh.stiffness"]).max() <= 1e-12 * k.max()
    return k


_MEASUREMENTS = []


@pytest.fixture
def report(request):
    """Records a measured number; all of them are printed in the summary of the run."""

    def add(text):
        _MEASUREMENTS.append(f"{request.node.name}: {text}")

    return add


def pytest_terminal_summary(terminalreporter):
    if _MEASUREMENTS:
        terminalreporter.section("measurements")
        for line in _MEASUREMENTS:
            terminalreporter.write_line(line)


@pytest.fixture(scope="module")
def client():
    """A Dask client on `geardyn.study.local_cluster(2)`: 2 single-threaded worker processes,
    one cluster per test module."""
    from distributed import Client

    from geardyn import study as gs

    cluster = gs.local_cluster(2)
    c = Client(cluster)
    yield c
    c.close()
    cluster.close()
