"""The rest of the CLI from Python (issue 35, "The whole CLI in Python"): `spectrum`,
`waterfall` (with order cuts), `floquet` and `band` give the CLI's numbers bit for bit, on
spur_pair, idler_gearset and countershaft_gearset where the command applies (the spectrum),
on the run-up example (waterfall), and on the linear helical pair (floquet, band: the other
scenes have contact loss or backlash, which both refuse with the same message as the CLI).

The CLI's CSVs are parsed here with the csv module: it writes shortest round-trip floats, so
parsing gives back its doubles.
"""

import csv
import json

import numpy as np
import pytest

import geardyn
from conftest import REPO, run_geardyn
from test_api import cli_error, identical, in_python

SCENES = {
    "spur_pair": REPO / "fmu" / "spur_pair",
    "idler_gearset": REPO / "fmu" / "idler_gearset",
    "countershaft_gearset": REPO / "fmu" / "countershaft_gearset",
}


@pytest.fixture(autouse=True)
def _binary(geardyn_bin):
    """Every test here runs the CLI."""


def cli_csv(path):
    """(numeric header, numeric rows, text columns) of a CSV the CLI wrote."""
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    header, body = rows[0], rows[1:]
    numeric = [j for j, _ in enumerate(header) if all(_is_float(r[j]) for r in body)]
    text = {header[j]: [r[j] for r in body] for j in range(len(header)) if j not in numeric}
    return [header[j] for j in numeric], np.array([[float(r[j]) for j in numeric] for r in body]), text


def _is_float(v):
    try:
        float(v)
        return True
    except ValueError:
        return False


@pytest.mark.parametrize("name", SCENES)
def test_spectrum_matches_cli(name, tmp_path):
    scene = geardyn.Scene.from_file(SCENES[name])
    got = geardyn.spectrum(scene, samples=128)
    out = run_geardyn("spectrum", SCENES[name], "--samples", "128", "--out", tmp_path / "s.csv").stdout
    header, rows, text = cli_csv(tmp_path / "s.csv")
    assert got.columns == header and got.labels == text["order"]
    identical(got.data, rows)
    # The report names the CSV the CLI wrote; the rest is the same text.
    assert got.report.split("\n", 1)[1] == out.split("\n", 1)[1]
    assert len(got) > 10 and "1×" in " ".join(got.labels)


def test_spectrum_of_chosen_signals_and_a_plot(tmp_path):
    scene = geardyn.Scene.from_file(SCENES["idler_gearset"])
    got = geardyn.spectrum(scene, signals=["mesh1.force", "mesh2.dte"], periods=2, plot=tmp_path / "s.png")
    run_geardyn("spectrum", SCENES["idler_gearset"], "--signal", "mesh1.force,mesh2.dte", "--periods", "2",
                "--out", tmp_path / "s.csv")
    header, rows, _ = cli_csv(tmp_path / "s.csv")
    assert got.columns == header
    identical(got.data, rows)
    assert (tmp_path / "s.png").stat().st_size > 10_000


def test_waterfall_and_order_cuts_match_cli(tmp_path):
    scene = geardyn.Scene.example("runup_spur")
    got = geardyn.waterfall(scene, order_cuts=True, shaft_orders=[37.0, 39.0])
    run_geardyn("waterfall", "--example", "runup_spur", "--shaft-orders", "37,39", "--out", tmp_path / "w.csv",
                "--order-cuts", tmp_path / "c.csv")
    header, rows, _ = cli_csv(tmp_path / "w.csv")
    assert got.map.columns == header
    identical(got.map.data, rows)
    header, rows, _ = cli_csv(tmp_path / "c.csv")
    assert got.order_cuts.columns == header and "order_37_amplitude_m" in header
    identical(got.order_cuts.data, rows)
    assert geardyn.waterfall(scene, segment=500).order_cuts is None


def test_floquet_and_band_match_cli(tmp_path):
    scene = geardyn.Scene.example("helical_pair_friction")
    got = geardyn.floquet(scene, speed="19000rpm")
    assert got == json.loads(run_geardyn("floquet", "--example", "helical_pair_friction", "--speed", "19000rpm",
                                         "--json").stdout)
    assert got  # a monodromy with its multipliers
    report = geardyn.band(scene, "1000rpm:30000rpm", points=200)
    assert report == run_geardyn("band", "--example", "helical_pair_friction", "--speed", "1000rpm:30000rpm",
                                 "--points", "200").stdout
    assert "unstable 18582" in report
    # A scene with backlash is refused as on the CLI, in the file's spelling.
    with pytest.raises(geardyn.GeardynError) as e:
        geardyn.floquet(geardyn.Scene.example("spur_pair"))
    assert str(e.value) == in_python(cli_error("floquet", "--example", "spur_pair"))
    assert 'mesh.contact = "backlash"' in str(e.value)
