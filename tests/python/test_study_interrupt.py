"""Ctrl-C on `geardyn-study run` gives one line (issue 35, "Ergonomics"): SIGINT while the
study runs on its LocalCluster stops it with exit status 130 and exactly one line on stderr,
with no traceback from Dask's event loop or its workers; the points that arrived are stored."""

import signal
import subprocess
import sys
import time
from pathlib import Path

from geardyn import study as gs
from conftest import REPO

SCRIPT = Path(sys.executable).parent / "geardyn-study"


def test_ctrl_c_is_one_line_and_loses_nothing(tmp_path):
    path = tmp_path / "long.toml"
    path.write_text(f"""
scene = "{REPO / 'fmu' / 'spur_pair'}"
results = ["dte_rms"]
[[parameter]]
path = "operating.pinion_speed"
from = 300.0
to = 520.0
points = 300
[[parameter]]
path = "solver.stop_time"
values = [0.2]
[analysis]
kind = "simulate"
""")
    study = gs.load(path)
    # SIGINT as a terminal sends it; a child of a non-interactive shell would ignore it.
    p = subprocess.Popen([str(SCRIPT), "run", str(path), "--no-progress", "--workers", "2"],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                         preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    start = time.time()
    while not list(study.store.glob("part-*.parquet")) and time.time() - start < 120:
        if p.poll() is not None:
            break
        time.sleep(0.2)
    assert p.poll() is None, "the study ended before it could be interrupted"
    p.send_signal(signal.SIGINT)
    out, err = p.communicate(timeout=120)
    assert p.returncode == 130, (out, err)
    assert err.splitlines() == ["interrupted: the points that arrived are stored; run again to continue"], err
    df = gs.results(study)
    assert 0 < len(df) < 300 and df["error"].isna().all()
    # Running it again computes only the others: test_study.py's
    # test_rerun_after_an_interrupt_computes_only_the_missing_points.
