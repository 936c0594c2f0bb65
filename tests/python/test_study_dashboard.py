"""The Dask dashboard of a study (issue 35, "Ergonomics"): on request the LocalCluster serves
it, the study prints its address on stderr, and the address answers; without bokeh the request
is refused naming the option. By default there is none and nothing is printed."""

import sys
import urllib.request

import pytest

from geardyn import study as gs
from conftest import REPO

STUDY = f"""
scene = "{REPO / 'fmu' / 'spur_pair'}"
results = ["dte_rms"]
[[parameter]]
path = "operating.pinion_speed"
values = [350.0, 400.0]
[analysis]
kind = "simulate"
"""


def test_the_dashboard_address_is_printed_and_served(tmp_path, capfd):
    pytest.importorskip("bokeh")
    path = tmp_path / "study.toml"
    path.write_text(STUDY)
    seen = []

    def fetch(record):
        # While the study runs: the printed address serves the dashboard's status page.
        if not seen:
            printed = [line for line in capfd.readouterr().err.splitlines()
                       if line.startswith("Dask dashboard: ")]
            assert len(printed) == 1, printed
            link = printed[0].removeprefix("Dask dashboard: ")
            with urllib.request.urlopen(link, timeout=30) as page:
                seen.append((link, page.status, page.read()))

    gs.run(gs.load(path), workers=1, progress=False, dashboard=":0", on_result=fetch)
    [(link, status, body)] = seen
    assert link.startswith("http://") and link.endswith("/status"), link
    assert status == 200 and b"bokeh" in body.lower()


def test_no_dashboard_by_default_and_a_clear_error_without_bokeh(tmp_path, capfd, monkeypatch):
    from distributed import Client

    path = tmp_path / "study.toml"
    path.write_text(STUDY)
    with gs.local_cluster(1) as cluster, Client(cluster) as client:
        gs.run(gs.load(path), client=client, progress=False)
    assert "dashboard" not in capfd.readouterr().err
    monkeypatch.setitem(sys.modules, "bokeh", None)
    with pytest.raises(gs.StudyError, match=r"dashboard = ':8787': .*needs bokeh"):
        gs.local_cluster(1, dashboard=":8787")
