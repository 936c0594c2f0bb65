"""The Python module (`import geardyn`, python/) against the CLI on the same scene.

Tables are compared exactly: the CLI writes every float in its shortest round-trip form, so
parsing its CSV gives back the very doubles it computed, and the extension must return the
same ones. Text outputs are compared line for line and their numbers parsed back. Errors
must carry the CLI's message (the part after `error: ` on stderr).
"""

import math
import pathlib
import pickle
import re
import shutil
import threading
import warnings

import numpy as np
import pytest

import geardyn
from conftest import REPO, run_geardyn

SPUR = REPO / "fmu" / "spur_pair"
IDLER = REPO / "fmu" / "idler_gearset"
GEARS = REPO / "fmu" / "geometry_pair" / "gears.toml"


@pytest.fixture(autouse=True)
def _binary(geardyn_bin):
    """Every test here runs the CLI."""


def read_csv(path):
    """The CLI's CSV as (header, rows of exact floats)."""
    lines = pathlib.Path(path).read_text().splitlines()
    header = lines[0].split(",")
    rows = np.array([[float(v) for v in line.split(",")] for line in lines[1:]])
    return header, rows


def cli_error(*args):
    p = run_geardyn(*args, check=False)
    assert p.returncode != 0, f"CLI accepted {args}"
    assert p.stderr.startswith("error: "), p.stderr
    return p.stderr[len("error: "):].rstrip("\n")


def identical(a, b):
    """Bitwise equality of float arrays (NaN equal to NaN in the same place)."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    assert a.shape == b.shape, (a.shape, b.shape)
    same = (a == b) | (np.isnan(a) & np.isnan(b))
    assert same.all(), f"{(~same).sum()} values differ, first at {np.argwhere(~same)[0]}"


def scene_copy(tmp_path, source, name="scene.toml"):
    path = tmp_path / name
    shutil.copy(source / "scene.toml", path)
    return path


def test_simulate_pair_matches_cli(tmp_path):
    path = scene_copy(tmp_path, SPUR)
    scene = geardyn.Scene.from_file(path)
    scene["solver.stop_time"] = 0.004
    run = geardyn.simulate(scene)
    # The CLI's `--stop-time` is the scene's `solver.stop_time` in Python.
    run_geardyn("simulate", path, "--stop-time", "0.004", "--out", tmp_path / "cli.csv", "--quiet")
    header, rows = read_csv(tmp_path / "cli.csv")
    assert header == ["time", *run.names]
    identical(run.time, rows[:, 0])
    identical(run.data, rows[:, 1:])
    assert run.method == "exact"


def test_simulate_rk_and_changed_parameter_match_cli(tmp_path):
    """A changed parameter and RK settings, written to a file for the CLI."""
    scene = geardyn.Scene.example("spur_pair")
    scene.update({"solver.method": "rk", "solver.rtol": 1e-7, "solver.stop_time": 0.003,
                  "mesh.stiffness.mean": 2.5e8})
    path = tmp_path / "changed.toml"
    path.write_text(scene.to_toml())
    run_geardyn("simulate", path, "--out", tmp_path / "cli.csv", "--quiet")
    _, rows = read_csv(tmp_path / "cli.csv")
    run = geardyn.simulate(scene)
    assert run.method != "exact"
    identical(np.column_stack([run.time, run.data]), rows)


def test_simulate_train_matches_cli(tmp_path):
    path = scene_copy(tmp_path, IDLER)
    scene = geardyn.Scene.from_file(path)
    assert scene.is_train
    run = geardyn.simulate(scene)
    run_geardyn("simulate", path, "--out", tmp_path / "cli.csv", "--quiet")
    header, rows = read_csv(tmp_path / "cli.csv")
    assert header == ["time", *run.names]
    identical(np.column_stack([run.time, run.data]), rows)


NUMBER = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"


def test_periodic_matches_cli():
    scene = geardyn.Scene.example("spur_pair")
    orbit = geardyn.periodic(scene, periods=1, warmup=20)
    out = run_geardyn("periodic", "--example", "spur_pair").stdout
    assert orbit.report == out
    # The numbers of the text, parsed back, are the orbit's at the printed precision.
    mult = re.findall(rf"multiplier ({NUMBER}) ({NUMBER})i  \|μ\| = ({NUMBER})", out)
    assert len(mult) == len(orbit.multipliers) == 2
    for (re_, im, norm), m in zip(mult, orbit.multipliers):
        assert float(re_) == float(f"{m.real:+.12f}")
        assert float(im) == float(f"{m.imag:+.12f}")
        assert float(norm) == float(f"{abs(m):.12f}")
    x, v = re.search(rf"y0 = \[x = ({NUMBER}) m, x' = ({NUMBER}) m/s\]", out).groups()
    assert (float(x), float(v)) == (orbit.y0[0], orbit.y0[1])  # `{:e}` is exact
    assert f"stability: {orbit.stability}" in out
    residuals = [float(r) for r in re.findall(rf"scaled residual ({NUMBER})", out)]
    assert residuals == [float(f"{r:.3e}") for r in orbit.residuals]


def test_periodic_speed_is_the_scene_parameter():
    """`geardyn periodic --speed W` and `scene["operating.pinion_speed"] = W` agree."""
    scene = geardyn.Scene.example("spur_pair")
    scene["operating.pinion_speed"] = 430.0
    orbit = geardyn.periodic(scene)
    out = run_geardyn("periodic", "--example", "spur_pair", "--speed", "430").stdout
    assert orbit.report == out


def test_speeds_take_units_like_the_cli(tmp_path):
    """`speed` takes "4500rpm", "471.24rad/s" or rad/s, as `--speed` does; equal speeds give
    identical results; the orbit carries each mesh's force with the report's numbers."""
    scene = geardyn.Scene.example("spur_pair")
    w = 4500 * 2 * math.pi / 60
    out = run_geardyn("periodic", "--example", "spur_pair", "--speed", "4500rpm").stdout
    for speed in ["4500rpm", f"{w!r}rad/s", w]:
        orbit = geardyn.periodic(scene, speed=speed)
        assert orbit.report == out
    assert orbit.speed == w and orbit.speed_rpm == pytest.approx(4500, rel=1e-15)
    (mesh,) = orbit.meshes
    for key, unit in [("mesh_frequency", "Hz"), ("peak_force", "N"), ("force_rms", "N")]:
        assert f"{key} = {float(re.search(rf'{key} = ({NUMBER}) {unit}', out).group(1))!r}" \
            == f"{key} = {mesh[key]!r}"
    assert mesh["dynamic_factor"] > 1
    assert geardyn.parse_speed("4500rpm") == w and geardyn.parse_speed(430) == 430.0
    table = geardyn.sweep(scene, "4000rpm:4100rpm:3", direction="up")
    run_geardyn("sweep", "--example", "spur_pair", "--speed", "4000rpm:4100rpm:3", "--direction", "up",
                "--out", tmp_path / "s.csv", "--units")
    header, rows = read_csv(tmp_path / "s.csv")
    assert header == [f"{c} [{table.units[c]}]" for c in table.columns]
    identical(table.data, rows)
    np.testing.assert_allclose(table["speed_rpm"], [4000, 4050, 4100], rtol=1e-15)
    for bad in ["1000rpn:2000rpm:5", "1000:2000rpm:5"]:
        with pytest.raises(geardyn.GeardynError) as e:
            geardyn.sweep(scene, bad)
        assert str(e.value) == in_python(cli_error("sweep", "--example", "spur_pair", "--speed", bad,
                                                   "--out", tmp_path / "s.csv"))
    with pytest.raises(geardyn.GeardynError, match="'4500rpn': unknown unit"):
        geardyn.periodic(scene, speed="4500rpn")


def test_sweep_matches_cli(tmp_path):
    scene = geardyn.Scene.example("spur_pair")
    table = geardyn.sweep(scene, "400:500:6", direction="both", tolerance=1e-7)
    run_geardyn("sweep", "--example", "spur_pair", "--speed", "400:500:6", "--out", tmp_path / "s.csv")
    header, rows = read_csv(tmp_path / "s.csv")
    assert header == table.columns
    identical(table.data, rows)
    assert len(table) == 12


def test_hb_matches_cli(tmp_path):
    scene = geardyn.Scene.example("spur_pair")
    table = geardyn.hb(scene, "400:500", harmonics=8)
    run_geardyn("hb", "--example", "spur_pair", "--speed", "400:500", "--harmonics", "8",
                "--out", tmp_path / "h.csv")
    header, rows = read_csv(tmp_path / "h.csv")
    assert header == table.columns
    identical(table.data, rows)


def test_hb_caveats_are_warnings_with_the_cli_summary_text(tmp_path):
    """The countershaft's H = 20 branch from 385 rad/s ends at its first point that H does not
    resolve (just past the 394 rad/s fold): the CLI says so in its summary, and Python must
    raise the same sentence as a RuntimeWarning, not return the shortened table silently."""
    shaft = REPO / "fmu" / "countershaft_gearset"
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        table = geardyn.hb(geardyn.Scene.from_file(shaft), "385:400")
    said = [str(w.message) for w in caught if issubclass(w.category, RuntimeWarning)]
    out = run_geardyn("hb", shaft, "--speed", "385:400", "--out", tmp_path / "h.csv").stdout
    ends = [line.strip() for line in out.splitlines() if "the branch ends at" in line]
    assert len(ends) == 1, out
    assert f"hb: {ends[0]}" in said, said
    header, rows = read_csv(tmp_path / "h.csv")
    identical(table.data, rows)
    last = float(re.search(r"ends at ([0-9.]+) rad/s", ends[0]).group(1))
    assert abs(table.data[-1][header.index("speed")] - last) < 1e-4
    assert last < 400.0


def test_modes_matches_cli():
    scene = geardyn.Scene.from_file(IDLER)
    m = geardyn.modes(scene)
    out = run_geardyn("modes", IDLER).stdout
    assert m.report == out
    lines = out.splitlines()
    assert lines[1].split()[4:] == m.labels  # mode, f, [Hz], kind
    table = [line.split() for line in lines[2:2 + len(m.frequencies)]]
    for row, f, shape in zip(table, m.frequencies, m.shapes):
        assert float(row[1]) == float(f"{f:.3f}")
        assert [float(v) for v in row[-len(m.labels):]] == [float(f"{v:.5f}") for v in shape]
    rigid = geardyn.modes(scene, rigid_bearings=True)
    assert rigid.report == run_geardyn("modes", IDLER, "--rigid-bearings").stdout


def test_stiffness_matches_cli(tmp_path):
    st = geardyn.stiffness(GEARS, torque=100.0, etc=True, harmonics=4)
    p = run_geardyn("stiffness", GEARS, "--torque", "100", "--out", tmp_path / "k.csv")
    header, rows = read_csv(tmp_path / "k.csv")
    assert header == st.columns
    identical(st.data, rows)
    assert p.stdout == st.summary + f"curve → {tmp_path / 'k.csv'}\n"
    off = geardyn.stiffness(GEARS, torque=50.0, etc=False)
    run_geardyn("stiffness", GEARS, "--torque", "50", "--etc", "off", "--out", tmp_path / "o.csv")
    identical(off.data, read_csv(tmp_path / "o.csv")[1])


def test_build_fmu_matches_cli(tmp_path):
    lib = REPO / "target" / "release" / "libgeardyn.so"
    fmu = geardyn.build_fmu(SPUR, tmp_path / "py", cdylib=lib)
    cli = run_geardyn("fmu", "build", SPUR, "--out", tmp_path / "cli", "--cdylib", lib).stdout.strip()
    assert fmu.name == pathlib.Path(cli).name == "spur_pair.fmu"
    assert fmu.read_bytes() == pathlib.Path(cli).read_bytes()
    # An unchanged scene read from its folder ships the folder (README included).
    from_scene = geardyn.build_fmu(geardyn.Scene.from_file(SPUR), tmp_path / "scene", cdylib=lib)
    assert from_scene.read_bytes() == fmu.read_bytes()


def test_bad_scene_file_raises_the_cli_message(tmp_path):
    path = scene_copy(tmp_path, SPUR)
    text = path.read_text()
    path.write_text(text.replace("inertia = 0.01091", "inertia = -0.01091"))
    with pytest.raises(geardyn.GeardynError) as e:
        geardyn.Scene.from_file(path)
    assert str(e.value) == cli_error("simulate", path, "--out", tmp_path / "x.csv")
    assert "gear[1].inertia" in str(e.value)
    missing = tmp_path / "missing.toml"
    with pytest.raises(geardyn.GeardynError) as e:
        geardyn.Scene.from_file(missing)
    assert str(e.value) == cli_error("simulate", missing, "--out", tmp_path / "x.csv")


def test_bad_parameter_raises_the_cli_message_and_leaves_the_scene(tmp_path):
    path = scene_copy(tmp_path, SPUR)
    scene = geardyn.Scene.from_file(path)
    with pytest.raises(geardyn.GeardynError) as e:
        scene["mesh.stiffness.mean"] = -2.9831e8
    # The CLI on the same file with the same value.
    path.write_text(path.read_text().replace("mean = 2.9831e8", "mean = -2.9831e8"))
    assert str(e.value) == cli_error("simulate", path, "--out", tmp_path / "x.csv")
    assert scene["mesh.stiffness.mean"] == 2.9831e8
    with pytest.raises(geardyn.GeardynError) as e:
        scene["mesh.stiffness.contact_ratio"] = float("nan")
    assert "mesh.stiffness.contact_ratio" in str(e.value) and "NaN" in str(e.value)
    with pytest.raises(geardyn.GeardynError, match="scene path 'mesh.nope.mean': no key 'nope'"):
        scene["mesh.nope.mean"]
    with pytest.raises(geardyn.GeardynError, match=r"index 2 out of range \('gear' has 2 elements\)"):
        scene["gear[2].inertia"] = 1.0


def in_python(cli_message):
    """The CLI's message as Python says it: the options are the functions' arguments."""
    for option in ("speed", "direction", "torque"):
        cli_message = cli_message.replace(f"--{option}", option)
    return cli_message


def test_bad_option_raises_the_cli_message(tmp_path):
    """The CLI's messages, with the options named as this module's arguments."""
    scene = geardyn.Scene.example("spur_pair")
    for speed in ["500:400:5", "400:500", "400:500:1"]:
        with pytest.raises(geardyn.GeardynError) as e:
            geardyn.sweep(scene, speed)
        cli = cli_error("sweep", "--example", "spur_pair", "--speed", speed, "--out", tmp_path / "s.csv")
        assert "--speed" in cli and "--" not in str(e.value)
        assert str(e.value) == in_python(cli)
    with pytest.raises(geardyn.GeardynError) as e:
        geardyn.sweep(scene, "400:500:3", direction="sideways")
    assert str(e.value) == in_python(cli_error("sweep", "--example", "spur_pair", "--speed", "400:500:3",
                                               "--direction", "sideways", "--out", tmp_path / "s.csv"))
    with pytest.raises(geardyn.GeardynError) as e:
        geardyn.hb(scene, "-400:500")
    assert str(e.value) == in_python(cli_error("hb", "--example", "spur_pair", "--speed", "-400:500",
                                               "--out", tmp_path / "h.csv"))
    # A limit's message says how to raise it in Python.
    with pytest.raises(geardyn.GeardynError) as e:
        geardyn.simulate(scene, max_rows=10)
    assert "max_rows=" in str(e.value) and "--" not in str(e.value), str(e.value)
    with pytest.raises(geardyn.GeardynError) as e:
        geardyn.stiffness(GEARS, torque=-1.0)
    assert str(e.value) == in_python(cli_error("stiffness", GEARS, "--torque", "-1", "--out", tmp_path / "k.csv"))
    # Every command takes every scene: the pair's modes are its one-mesh drivetrain's, the
    # rigid rotation and sqrt(k̄/m_e)/2π (k̄ = 2.9831e8 N/m, m_e of docs/model.md).
    pair = geardyn.modes(scene)
    m_e = 1.0 / (0.04535**2 / 0.002621 + 0.06564**2 / 0.01091)
    assert list(pair.rigid) == [True, False]
    assert pair.frequencies[1] == pytest.approx(math.sqrt(2.9831e8 / m_e) / (2 * math.pi), rel=1e-12)


def test_the_aliasing_warning_reaches_python(tmp_path):
    """`runup_spur` (a speed profile: its summary is of the output rows) sampled every 1e-4 s
    while its mesh frequency reaches 38·8000/60 = 5067 Hz: the CLI warns on stderr, Python
    with the same text as a RuntimeWarning."""
    scene = geardyn.Scene.example("runup_spur")
    scene.update({"solver.output_interval": 1e-4})
    with pytest.warns(RuntimeWarning) as caught:
        geardyn.simulate(scene)
    path = tmp_path / "runup.toml"
    path.write_text(scene.to_toml())
    p = run_geardyn("simulate", path, "--out", tmp_path / "r.csv")
    warning = str(caught[0].message)
    assert "alias" in warning and warning in p.stderr
    # With the summary off there is nothing to alias, as with --quiet.
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        geardyn.simulate(scene, statistics=False)


def test_two_threads_solving_at_once_give_the_serial_results():
    a = geardyn.Scene.example("spur_pair")
    a.update({"solver.method": "rk", "solver.stop_time": 0.02})
    b = geardyn.Scene.example("idler_gearset")
    serial = [geardyn.simulate(a), geardyn.simulate(b)]
    results = [None, None]
    barrier = threading.Barrier(2)

    def work(i, scene):
        barrier.wait()
        results[i] = geardyn.simulate(scene)

    threads = [threading.Thread(target=work, args=(i, s)) for i, s in enumerate([a, b])]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for s, r in zip(serial, results):
        assert s.names == r.names
        identical(s.time, r.time)
        identical(s.data, r.data)


def test_scene_paths_dicts_and_pickling():
    scene = geardyn.Scene.example("spur_pair")
    assert "mesh.stiffness.mean" in scene.paths()
    assert scene["gear[0].name"] == "pinion"
    scene["mesh.ste.cos[0]"] = 2e-6  # an element of an array of values
    assert scene["mesh.ste.cos"] == [2e-6]
    assert "mesh.stiffness.mean" in scene and "mesh.nope" not in scene
    same = geardyn.Scene.from_dict(scene.to_dict())
    assert same.to_dict() == scene.to_dict()
    identical(geardyn.simulate(same).data, geardyn.simulate(scene).data)
    text = geardyn.Scene.from_toml(scene.to_toml(), origin="text")
    assert text.origin == "text" and text.name == "spur_pair"
    scene["mesh.stiffness.mean"] = np.float64(2.5e8)
    back = pickle.loads(pickle.dumps(scene))
    assert back.to_toml() == scene.to_toml() and back["mesh.stiffness.mean"] == 2.5e8
    with pytest.raises(TypeError, match="cannot put a object"):
        scene["mesh.stiffness.mean"] = object()


def test_every_output_has_a_unit_and_the_views_carry_them():
    for name in geardyn.Scene.examples():
        scene = geardyn.Scene.example(name)
        scene["solver.stop_time"] = 10 * scene["solver.output_interval"]
        run = geardyn.simulate(scene)
        unknown = [n for n in run.names if run.units[n] is None]
        assert not unknown, f"{name}: outputs without a unit: {unknown}"
    run = geardyn.simulate(geardyn.Scene.example("spur_pair"))
    assert run.data.flags.writeable and run.data.dtype == np.float64 and run.data.shape == (2001, 7)
    df = run.to_pandas()
    assert df.attrs["units"]["mesh.force"] == "N"
    identical(df["mesh.dte"].to_numpy(), run["mesh.dte"])
    ds = run.to_xarray()
    assert ds["mesh.dte_rate"].attrs["units"] == "m/s" and ds["time"].attrs["units"] == "s"


def test_a_parameter_in_a_table_the_file_does_not_have():
    """`solver.stop_time` on a scene file without `[solver]` creates the table (as writing it
    into the file would); a table the format does not know is refused by the scene reader with
    its name, and the scene is left unchanged."""
    scene = geardyn.Scene.from_file(REPO / "examples" / "planetary" / "ev_reducer_3p.toml")
    assert "solver" not in scene.to_dict()
    scene["solver.stop_time"] = 0.002
    assert scene["solver.stop_time"] == 0.002
    assert geardyn.simulate(scene).time[-1] == pytest.approx(0.002, rel=1e-12)
    before = scene.to_toml()
    with pytest.raises(geardyn.GeardynError, match="nonsense"):
        scene["nonsense.value"] = 1.0
    assert scene.to_toml() == before
