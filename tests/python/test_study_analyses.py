"""`hb`, `modes` and `spectrum` as study analyses (issue 35, "Any output"), on spur_pair,
idler_gearset and countershaft_gearset: each stored result equals the number taken from the
same point run through the plain API (`Scene.update` + `geardyn.hb/modes/spectrum`), and the
results carry their units. Bad options are refused naming the field."""

import numpy as np
import pytest

import geardyn
from geardyn import study as gs
from conftest import REPO


def study_file(tmp_path, scene, parameter, analysis, results):
    path = tmp_path / f"{scene}_{analysis.split()[0]}.toml"
    path.write_text(f"""
scene = "{REPO / 'fmu' / scene}"
results = {results!r}
[[parameter]]
{parameter}
[analysis]
{analysis}
""".replace("'", '"'))
    return path


def plain(scene, point):
    s = geardyn.Scene.from_file(REPO / "fmu" / scene)
    s.update(point)
    return s


def test_modes_study(client, tmp_path):
    for scene, n in [("spur_pair", 1), ("idler_gearset", 4), ("countershaft_gearset", 2)]:
        path = study_file(tmp_path, scene, 'path = "gear[0].inertia"\nvalues = [1.0e-3, 2.0e-3]'
                          if scene == "spur_pair" else
                          'path = "model.modal_damping_ratio"\nvalues = [0.02, 0.05]',
                          'kind = "modes"', [f"f{k}" for k in range(1, n + 1)])
        study = gs.load(path)
        gs.run(study, client=client, progress=False)
        ds = gs.to_xarray(study)
        for i, point in enumerate(study.points()):
            f = np.sort(geardyn.modes(plain(scene, point)).frequencies)
            f = f[f > 1e-9 * f.max()]
            for k in range(1, n + 1):
                assert ds[f"f{k}"].values[i] == f[k - 1], (scene, point, k)
        assert ds["f1"].attrs["units"] == "Hz"
    # A fourth mode the pair does not have: the point fails with the reason.
    path = study_file(tmp_path, "spur_pair", 'path = "gear[0].inertia"\nvalues = [1.0e-3]',
                      'kind = "modes"', ["f1", "f2"])
    study = gs.load(path)
    gs.run(study, client=client, progress=False)
    assert "1 elastic mode" in gs.results(study)["error"][0]


def mesh_frequency(scene, mesh):
    """Teeth × shaft speed of the mesh's pinion, the speed carried from the input gear
    through the meshes before it (and rigid shafts: coaxial gears share a speed)."""
    d = scene.to_dict()
    teeth = {g["name"]: g["teeth"] for g in d["gear"]}
    omega = d["operating"].get("input_speed", d["operating"].get("pinion_speed"))
    meshes = d["mesh"] if isinstance(d["mesh"], list) else [dict(d["mesh"], name="mesh")]
    first = meshes[0]["pinion"] if not scene.is_train else d["operating"].get("input_gear", meshes[0]["pinion"])
    speed = {first: omega}
    shafts = [tuple(s["gears"]) for s in d.get("shaft", [])]
    for _ in range(len(meshes) + len(shafts)):
        for a, b in shafts:
            for x, y in ((a, b), (b, a)):
                if x in speed and y not in speed:
                    speed[y] = speed[x]
        for m in meshes:
            p, g = m["pinion"], m["gear"]
            if p in speed and g not in speed:
                speed[g] = speed[p] * teeth[p] / teeth[g]
            if g in speed and p not in speed:
                speed[p] = speed[g] * teeth[g] / teeth[p]
    m = next(x for x in meshes if x.get("name", "mesh") == mesh)
    return teeth[m["pinion"]] * speed[m["pinion"]] / (2 * np.pi)


def test_spectrum_study(client, tmp_path):
    for scene in ["spur_pair", "idler_gearset", "countershaft_gearset"]:
        path = study_file(tmp_path, scene, 'path = "operating.input_torque"\nvalues = [80.0, 120.0]'
                          if scene != "spur_pair" else
                          'path = "operating.pinion_speed"\nvalues = [350.0, 450.0]',
                          'kind = "spectrum"\nsamples = 64', ["mesh_order_1", "mesh_order_2"])
        study = gs.load(path)
        gs.run(study, client=client, progress=False)
        ds = gs.to_xarray(study)
        base = geardyn.Scene.from_file(REPO / "fmu" / scene)
        meshes = [m["name"] for m in base.to_dict()["mesh"]] if base.is_train else ["mesh"]
        for i, point in enumerate(study.points()):
            s = plain(scene, point)
            spectrum = geardyn.spectrum(s, samples=64)
            for m in meshes:
                # The mesh frequency from the teeth and the speed ratio, independently.
                fm = mesh_frequency(s, m)
                for k in (1, 2):
                    column = f"{m}.mesh_order_{k}" if base.is_train else f"mesh_order_{k}"
                    [j] = np.flatnonzero(np.isclose(spectrum["frequency_Hz"], k * fm, rtol=1e-9))
                    want = spectrum[f"{m}.dte_amplitude_m"][j]
                    assert ds[column].values[i] == want, (scene, column)
                    assert ds[column].attrs["units"] == "m"
                    assert ds["error"].values[i] == ""


def test_hb_study(client, tmp_path):
    for scene, speeds in [("spur_pair", "400:420"), ("idler_gearset", "300:310")]:
        path = study_file(tmp_path, scene, 'path = "mesh.damping_ratio"\nvalues = [0.03, 0.06]'
                          if scene == "spur_pair" else
                          'path = "model.modal_damping_ratio"\nvalues = [0.02, 0.04]',
                          f'kind = "hb"\nspeed = "{speeds}"\nharmonics = 10',
                          ["peak_dte_rms", "peak_mesh_frequency", "folds", "unstable_points"])
        study = gs.load(path)
        gs.run(study, client=client, progress=False)
        ds = gs.to_xarray(study)
        for i, point in enumerate(study.points()):
            table = geardyn.hb(plain(scene, point), speeds, 10)
            rms = np.max([table[c] for c in table.columns if c.endswith("dte_rms")], axis=0)
            j = int(np.argmax(rms))
            assert ds["peak_dte_rms"].values[i] == rms[j]
            assert ds["peak_mesh_frequency"].values[i] == table["mesh_frequency"][j]
            assert ds["folds"].values[i] == np.count_nonzero(table["fold"])
            assert ds["unstable_points"].values[i] == np.count_nonzero(table["stable"] == 0)
        assert ds["peak_dte_rms"].attrs["units"] == "m"


def test_analysis_options_are_checked(tmp_path):
    for analysis, needle in [('kind = "hb"', "hb needs speed"),
                             ('kind = "modes"\ntimeout = 5.0', "analysis.timeout: not an option of modes"),
                             ('kind = "spectrum"\nspeed = "1:2"', "analysis.speed: not an option of spectrum")]:
        path = study_file(tmp_path, "spur_pair", 'path = "gear[0].inertia"\nvalues = [1.0e-3]',
                          analysis, ["f1"] if "modes" in analysis else ["mesh_order_1"]
                          if "spectrum" in analysis else ["peak_dte_rms"])
        with pytest.raises(gs.StudyError, match=needle):
            gs.load(path)


def test_sweep_and_periodic_studies_on_drivetrains(client, tmp_path):
    """A drivetrain's sweep results are per mesh, each from its own columns; `unconverged`
    is the branch's. A periodic study gives the orbit's stability; `dte0` (one pair's DTE)
    is refused for a drivetrain."""
    for scene, speeds in [("idler_gearset", "300:310:3"), ("countershaft_gearset", "240:242:2")]:
        results = ["peak_dte_rms", "peak_mesh_frequency", "hysteresis", "max_contact_loss_fraction",
                   "unconverged"]
        path = study_file(tmp_path, scene, 'path = "operating.input_torque"\nvalues = [90.0, 110.0]',
                          f'kind = "sweep"\nspeed = "{speeds}"', results)
        study = gs.load(path)
        gs.run(study, client=client, progress=False)
        ds = gs.to_xarray(study)
        meshes = [m["name"] for m in geardyn.Scene.from_file(REPO / "fmu" / scene).to_dict()["mesh"]]
        for i, point in enumerate(study.points()):
            table = geardyn.sweep(plain(scene, point), speeds)
            assert ds["unconverged"].values[i] == np.count_nonzero(table["converged"] == 0)
            for m in meshes:
                rms = table[f"{m}.dte_rms"]
                j = int(np.argmax(rms))
                assert ds[f"{m}.peak_dte_rms"].values[i] == rms[j]
                assert ds[f"{m}.peak_mesh_frequency"].values[i] == table[f"{m}.mesh_frequency"][j]
                assert ds[f"{m}.max_contact_loss_fraction"].values[i] == \
                    table[f"{m}.contact_loss_fraction"].max()
                assert ds[f"{m}.peak_dte_rms"].attrs["units"] == "m"
            assert (ds["error"].values == "").all()

        path = study_file(tmp_path, scene, 'path = "operating.input_torque"\nvalues = [90.0]',
                          'kind = "periodic"', ["floquet_max", "stable", "period"])
        study = gs.load(path)
        gs.run(study, client=client, progress=False)
        orbit = geardyn.periodic(plain(scene, study.points()[0]))
        df = gs.results(study)
        assert df["floquet_max"][0] == orbit.spectral_radius and df["period"][0] == orbit.period
        with pytest.raises(gs.StudyError, match="dte0"):
            gs.load(study_file(tmp_path, scene, 'path = "operating.input_torque"\nvalues = [90.0]',
                               'kind = "periodic"', ["dte0"]))
