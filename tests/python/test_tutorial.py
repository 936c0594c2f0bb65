"""The tutorial (docs/tutorial.md) runs end to end, exactly as printed (issue 19, acceptance 1).

Every fenced block of the tutorial is executed in order, in one fresh folder, so no command in
it can go stale:

- a ```toml block whose first line is `# file: NAME` is written to NAME (the reader saves it);
- a ```sh block runs in bash (`set -euo pipefail`), with the release `geardyn` first on PATH
  (the tutorial says to install it with `cargo install --path .`);
- a ```python block runs with this interpreter (the project's ./.venv, which has fmpy).

Other blocks (```text output excerpts) are not run. Afterwards the test checks the outputs the
tutorial promises, with numbers from closed forms where it states them.
"""

import csv
import math
import os
import re
import subprocess
import sys

from conftest import GEARDYN, REPO

TUTORIAL = REPO / "docs" / "tutorial.md"
BLOCK = re.compile(r"^```(\w+)\n(.*?)^```", re.S | re.M)


def blocks():
    return [(m.group(1), m.group(2)) for m in BLOCK.finditer(TUTORIAL.read_text())]


def run_tutorial(folder):
    env = dict(os.environ)
    env["PATH"] = f"{GEARDYN.parent}{os.pathsep}{env['PATH']}"
    env["MPLBACKEND"] = "Agg"
    ran = {"sh": 0, "python": 0, "file": 0}
    for lang, body in blocks():
        first = body.splitlines()[0] if body.strip() else ""
        if lang == "toml" and first.startswith("# file: "):
            (folder / first[len("# file: "):].strip()).write_text(body)
            ran["file"] += 1
        elif lang == "sh":
            r = subprocess.run(["bash", "-euo", "pipefail", "-c", body], cwd=folder, env=env,
                               capture_output=True, text=True)
            assert r.returncode == 0, f"tutorial block failed:\n{body}\n--- stderr\n{r.stderr}"
            ran["sh"] += 1
        elif lang == "python":
            r = subprocess.run([sys.executable, "-c", body], cwd=folder, env=env,
                               capture_output=True, text=True)
            assert r.returncode == 0, f"tutorial block failed:\n{body}\n--- stderr\n{r.stderr}"
            ran["python"] += 1
    return ran


def rows(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def is_png(path):
    return path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_tutorial_runs_end_to_end(tmp_path):
    ran = run_tutorial(tmp_path)
    assert ran["sh"] >= 7 and ran["python"] == 1 and ran["file"] == 3, ran
    for png in ["k.png", "run.png", "spectrum.png", "waterfall.png", "cuts.png", "frf.png"]:
        assert is_png(tmp_path / png), png

    # The mesh frequency at 3000 rpm is 25 teeth x 50 rev/s = 1250 Hz (closed form); the
    # periodic spectrum has its lines on multiples of it, labelled so, the first the largest.
    spectrum = rows(tmp_path / "spectrum.csv")
    lines = {float(r["frequency_Hz"]): r for r in spectrum}
    assert lines[1250.0]["order"] == "1×mesh" and lines[2500.0]["order"] == "2×mesh"
    ac = [r for r in spectrum if float(r["frequency_Hz"]) > 0]
    assert max(ac, key=lambda r: float(r["mesh.dte_amplitude_m"]))["order"] == "1×mesh"

    # The waterfall's strongest line in each window lies on a mesh order k·25·n/60 Hz.
    windows = {}
    for r in rows(tmp_path / "waterfall.csv"):
        f = float(r["frequency_Hz"])
        if f > 600:
            best = windows.get(r["time_s"])
            if best is None or float(r["amplitude_m"]) > best[2]:
                windows[r["time_s"]] = (float(r["rpm"]), f, float(r["amplitude_m"]))
    resolution = 50.0  # Hz: 1/(1000 samples x 20 us)
    for rpm, f, _ in windows.values():
        k = round(f / (25 * rpm / 60))
        assert k >= 1 and abs(f - k * 25 * rpm / 60) <= 2 * resolution, (rpm, f)

    # The sweep jumps: the up and down branches differ somewhere by more than a factor 2.
    frf = rows(tmp_path / "frf.csv")
    up = {r["speed"]: float(r["dte_rms"]) for r in frf if float(r["direction"]) > 0}
    down = {r["speed"]: float(r["dte_rms"]) for r in frf if float(r["direction"]) < 0}
    assert any(down[s] > 2 * up[s] for s in up), "no hysteresis between the branches"
    assert all(float(r["dynamic_factor"]) > 0 for r in frf)
