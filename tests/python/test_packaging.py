"""Installed geardyn builds FMUs without the source tree (issue 35, acceptance 2).

- The abi3 wheel of scripts/build-wheel.sh installs into a fresh venv with no Rust toolchain
  on PATH, and the README's Python example runs from it. The FMU it builds carries the
  cdylib of this build and runs in fmpy like one built from the source tree.
- The binary that `cargo install --path .` puts into a temporary root builds an FMU that fmpy
  runs: it carries the cdylib (build.rs), since the install copies only the executable.
"""

import os
import re
import shutil
import subprocess
import sys
import zipfile

import numpy as np
import pytest

from conftest import REPO

README_EXAMPLE = re.compile(
    r"<!-- tests/python/test_packaging.py runs this example from the installed wheel -->\n"
    r"```python\n(.*?)^```",
    re.S | re.M,
)


def no_cargo_path(venv):
    """PATH for the fresh venv: its own bin and the system's, without cargo or rustc."""
    path = os.pathsep.join([str(venv / "bin"), "/usr/local/bin", "/usr/bin", "/bin"])
    for tool in ("cargo", "rustc", "maturin"):
        found = shutil.which(tool, path=path)
        if found:
            pytest.skip(f"{tool} is installed system-wide ({found}): cannot test without it")
    return path


def fmpy_rows(fmu, stop_time=2e-3):
    fmpy = pytest.importorskip("fmpy")
    result = fmpy.simulate_fmu(
        str(fmu), fmi_type="CoSimulation", stop_time=stop_time, output_interval=1e-4,
        output=["mesh.dte", "mesh.force"],
    )
    return np.array([result["mesh.dte"], result["mesh.force"]])


def fmu_binary(fmu):
    with zipfile.ZipFile(fmu) as z:
        [name] = [n for n in z.namelist() if n.startswith("binaries/linux64/")]
        return z.read(name)


@pytest.fixture(scope="module")
def cdylib():
    lib = REPO / "target" / "release" / "libgeardyn.so"
    if not lib.is_file():
        pytest.fail(f"{lib} missing: run `cargo build --release` (scripts/test.sh does)")
    return lib.read_bytes()


def test_the_wheel_installs_without_rust_and_runs_the_readme_example(tmp_path, cdylib):
    wheels = tmp_path / "wheels"
    subprocess.run(["bash", str(REPO / "scripts" / "build-wheel.sh"), str(wheels)], check=True,
                   capture_output=True, text=True)
    [wheel] = wheels.glob("geardyn-*.whl")
    assert "-abi3-" in wheel.name, wheel.name
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True)
    env = {k: v for k, v in os.environ.items()
           if not k.startswith(("CARGO", "RUSTUP", "VIRTUAL_ENV", "GEARDYN", "PYTHON"))}
    env["PATH"] = no_cargo_path(venv)
    pip = [str(venv / "bin" / "python"), "-m", "pip", "install", "--quiet",
           "--disable-pip-version-check"]
    subprocess.run([*pip, str(wheel)], check=True, env=env, capture_output=True, text=True)

    example = README_EXAMPLE.search((REPO / "README.md").read_text()).group(1)
    work = tmp_path / "work"
    work.mkdir()
    (work / "example.py").write_text(example)
    where = subprocess.run([str(venv / "bin" / "python"), "-c",
                            "import geardyn; print(geardyn.__file__)"],
                           cwd=work, env=env, check=True, capture_output=True, text=True)
    assert str(venv) in where.stdout, where.stdout  # the wheel's module, not the source tree's
    ran = subprocess.run([str(venv / "bin" / "python"), "example.py"], cwd=work, env=env,
                         capture_output=True, text=True)
    assert ran.returncode == 0, ran.stderr

    # The same numbers as the source tree's module, printed as the example prints them.
    import geardyn

    scene = geardyn.Scene.example("spur_pair")
    scene["operating.pinion_speed"] = geardyn.parse_speed("4500rpm")
    mesh = geardyn.simulate(scene).statistics[0]
    printed = f"DTE RMS {mesh['dte_rms']:.4e} m, peak force {mesh['peak_force']:.1f} N"
    lines = ran.stdout.splitlines()
    assert lines[0] == printed, (lines, printed)
    fmu = work / lines[1]
    assert fmu_binary(fmu) == cdylib  # the wheel carries this build's FMU binary
    reference = geardyn.build_fmu(scene, tmp_path / "reference")
    assert np.array_equal(fmpy_rows(fmu), fmpy_rows(reference))


def test_the_cargo_installed_binary_builds_an_fmu_that_fmpy_runs(tmp_path, cdylib):
    root = tmp_path / "root"
    # --path uses the workspace's target/, so the install reuses the release build.
    subprocess.run(["cargo", "install", "--locked", "--path", str(REPO), "--root", str(root)],
                   check=True, capture_output=True, text=True)
    installed = root / "bin" / "geardyn"
    assert not (installed.parent / "libgeardyn.so").exists()
    env = dict(os.environ, XDG_CACHE_HOME=str(tmp_path / "cache"))
    built = subprocess.run([str(installed), "fmu", "build", str(REPO / "fmu" / "spur_pair"),
                            "--out", str(tmp_path / "fmus")], cwd=tmp_path, env=env,
                           capture_output=True, text=True)
    assert built.returncode == 0, built.stderr
    fmu = tmp_path / "fmus" / "spur_pair.fmu"
    assert fmu_binary(fmu) == cdylib  # the binary carries this build's cdylib, not a stale one
    # A second build reuses the cached copy.
    again = subprocess.run([str(installed), "fmu", "build", str(REPO / "fmu" / "spur_pair"),
                            "--out", str(tmp_path / "fmus2")], cwd=tmp_path, env=env,
                           capture_output=True, text=True)
    assert again.returncode == 0, again.stderr
    assert len(list((tmp_path / "cache" / "geardyn").iterdir())) == 1
    rows = fmpy_rows(fmu)
    assert np.all(np.isfinite(rows)) and rows[1].max() > 0
    tree = subprocess.run([str(REPO / "target" / "release" / "geardyn"), "fmu", "build",
                           str(REPO / "fmu" / "spur_pair"), "--out", str(tmp_path / "tree")],
                          check=True, capture_output=True, text=True)
    assert tree.returncode == 0
    assert np.array_equal(rows, fmpy_rows(tmp_path / "tree" / "spur_pair.fmu"))
