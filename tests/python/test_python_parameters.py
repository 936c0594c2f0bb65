"""Any parameter from Python (issue 35, "Any parameter" and "Ergonomics"), on spur_pair,
idler_gearset and countershaft_gearset:

- whole-number parameters (`gear[0].teeth`) take NumPy's whole floats exactly and refuse a
  fraction with the path; a value of the wrong type is refused naming the path and value;
- a study over `gear[0].teeth` ∈ {36, 38, 40} × the input torque gives the numbers of the
  separate scenes, and stores the teeth as integers. The teeth are linked to the base radius
  (`path = ["gear[0].teeth", "gear[0].base_radius"]`, one row of values per step): the scene
  reader refuses gears whose base pitches differ, so a gear with other teeth has another
  radius. A study over a string parameter (a mesh's `contact` law on idler_gearset, linear | contact_loss) does the same;
- `Scene.example` of an unknown name lists every example that `Scene.examples()` returns;
- a script that starts a study at its top level, without `if __name__ == "__main__":`, gets
  one message and no worker errors;
- a user output, a callable on each point's result (given to `load` or named in the file as
  `module:function`), is stored as a column and equals the callable on the serial run; a
  callable that returns something other than a number fails its points with the reason.

The reference for every study point is the same scene edited as text (the value written into
the TOML file as an integer or string) and run through `geardyn.simulate`.
"""

import re
import subprocess
import sys

import numpy as np
import pytest

import geardyn
from geardyn import study as gs
from conftest import REPO

SCENES = {
    "spur_pair": REPO / "fmu" / "spur_pair" / "scene.toml",
    "idler_gearset": REPO / "fmu" / "idler_gearset" / "scene.toml",
    "countershaft_gearset": REPO / "fmu" / "countershaft_gearset" / "scene.toml",
}
# The torque each scene's operating point names (single pair: input_torque as well).
TORQUE = "operating.input_torque"


def short_scene(tmp_path, name):
    """The scene with a 5 ms run (its own `[solver]` kept, stop time replaced)."""
    scene = geardyn.Scene.from_file(SCENES[name])
    scene["solver.stop_time"] = 0.005
    path = tmp_path / f"{name}.toml"
    path.write_text(scene.to_toml())
    return path


def first_gear(text, teeth, base_radius):
    """The scene text with the first gear's teeth (an integer) and base radius set, as a user
    edits the file."""
    new, n = re.subn(r"(?m)^teeth = \d+$", f"teeth = {teeth}", text, count=1)
    new, m = re.subn(r"(?m)^base_radius = [0-9.e-]+", f"base_radius = {base_radius!r}", new, count=1)
    assert n == m == 1
    return new


def pitch(path):
    scene = geardyn.Scene.from_file(path)
    return scene["gear[0].base_radius"] / scene["gear[0].teeth"]


@pytest.mark.parametrize("name", SCENES)
def test_whole_floats_set_integers_and_fractions_are_refused(name):
    scene = geardyn.Scene.from_file(SCENES[name])
    radius = 36 * pitch(SCENES[name])
    scene.update({"gear[0].teeth": np.float64(36.0), "gear[0].base_radius": radius})
    assert scene["gear[0].teeth"] == 36 and isinstance(scene["gear[0].teeth"], int)
    by_text = geardyn.Scene.from_toml(first_gear(SCENES[name].read_text(), 36, radius))
    assert scene.to_dict() == by_text.to_dict()
    with pytest.raises(geardyn.GeardynError, match=r"scene path 'gear\[0\].teeth' = 36.5: must be a whole number"):
        scene["gear[0].teeth"] = 36.5
    assert scene["gear[0].teeth"] == 36
    with pytest.raises(geardyn.GeardynError, match=r"scene path 'operating.input_torque' = \"a lot\""):
        scene[TORQUE] = "a lot"


def test_paths_are_the_scene_formats_paths():
    """`scene[...]` reads and writes the paths the messages and `describe` write: a pair's
    component by position or by name (`[1]`, `[y]`), and refuses a malformed path with the
    scene format's own wording."""
    scene = geardyn.Scene.from_file(SCENES["idler_gearset"])
    assert scene["gear[0].bearing_stiffness[y]"] == scene["gear[0].bearing_stiffness[1]"] == 1.27e8
    scene["gear[0].bearing_stiffness[x]"] = 1.5e8
    assert scene["gear[0].bearing_stiffness"] == [1.5e8, 1.27e8]
    assert scene.describe("gear[0].bearing_stiffness[x]").value == 1.5e8
    for path, why in [("gear[0]x", "an index must be written [n]"),
                      ("gear[a].teeth", "index 'a' is not a whole number >= 0"),
                      ("gear[9].teeth", "index 9 out of range ('gear' has 3 elements)"),
                      ("mesh..x", "an empty key")]:
        with pytest.raises(geardyn.GeardynError, match=re.escape(f"scene path '{path}': {why}")):
            scene[path]


@pytest.mark.parametrize("name", SCENES)
def test_a_study_over_teeth_and_torque_is_the_separate_scenes(client, tmp_path, name):
    base = short_scene(tmp_path, name)
    study_file = tmp_path / "teeth.toml"
    study_file.write_text(f'''scene = "{base}"
results = ["dte_rms", "peak_force"]
[[parameter]]
path = ["gear[0].teeth", "gear[0].base_radius"]
values = {[[t, t * pitch(base)] for t in (36, 38, 40)]!r}
[[parameter]]
path = "{TORQUE}"
values = [80.0, 120.0]
[analysis]
kind = "simulate"
''')
    study = gs.load(study_file)
    summary = gs.run(study, client=client, progress=False)
    assert (summary.total, summary.failed) == (6, 0)
    df = gs.results(study)
    assert str(df["gear[0].teeth"].dtype) == "int64"
    assert list(df["gear[0].teeth"]) == [36, 36, 38, 38, 40, 40]
    for row in df.to_dict("records"):
        text = first_gear(base.read_text(), row["gear[0].teeth"], row["gear[0].base_radius"])
        scene = geardyn.Scene.from_toml(text)
        scene[TORQUE] = row[TORQUE]
        stats = geardyn.simulate(scene).statistics
        prefix = [f"{m['name']}." for m in stats] if len(stats) > 1 else [""]
        for p, m in zip(prefix, stats):
            assert (row[f"{p}dte_rms"], row[f"{p}peak_force"]) == (m["dte_rms"], m["peak_force"])
    # The teeth reach the model: the mesh frequency changes, and so do the answers.
    first = df.columns[df.columns.str.endswith("dte_rms")][0]
    assert df[first].nunique() == 6


def test_a_study_over_a_string_parameter(client, tmp_path):
    base = short_scene(tmp_path, "idler_gearset")
    assert base.read_text().count('contact = "contact_loss"') == 2
    study_file = tmp_path / "contact.toml"
    study_file.write_text(f'''scene = "{base}"
results = ["dte_rms", "contact_loss_fraction"]
[[parameter]]
path = "mesh[1].contact"
values = ["linear", "contact_loss"]
[analysis]
kind = "simulate"
''')
    study = gs.load(study_file)
    gs.run(study, client=client, progress=False)
    df = gs.results(study)
    assert list(df["mesh[1].contact"]) == ["linear", "contact_loss"]
    for row in df.to_dict("records"):
        text = base.read_text()
        second = text.index('contact = "contact_loss"', text.index('contact = "contact_loss"') + 1)
        text = text[:second] + f'contact = "{row["mesh[1].contact"]}"' + text[second + len('contact = "contact_loss"'):]
        for m in geardyn.simulate(geardyn.Scene.from_toml(text)).statistics:
            for r in ("dte_rms", "contact_loss_fraction"):
                assert row[f"{m['name']}.{r}"] == m[r]
    with pytest.raises(gs.StudyError, match=r"parameter\[0\].values = \['linear', 2.0\]: mixes numbers and strings"):
        study_file.write_text(study_file.read_text().replace('["linear", "contact_loss"]', '["linear", 2.0]'))
        gs.load(study_file)


def test_an_unknown_example_lists_every_example():
    with pytest.raises(geardyn.GeardynError) as e:
        geardyn.Scene.example("nope")
    for name in geardyn.Scene.examples():
        assert name in str(e.value)


def test_an_unguarded_script_gets_one_message(tmp_path):
    study_file = tmp_path / "s.toml"
    study_file.write_text(f'scene = "{SCENES["spur_pair"]}"\nresults = ["dte_rms"]\n'
                          '[[parameter]]\npath = "mesh.damping_ratio"\nvalues = [0.03, 0.05]\n'
                          '[analysis]\nkind = "simulate"\n')
    script = tmp_path / "script.py"
    script.write_text(f"from geardyn import study\nstudy.run({str(study_file)!r}, workers=2, progress=False)\n")
    p = subprocess.run([sys.executable, script], capture_output=True, text=True, timeout=120, cwd=tmp_path)
    assert p.returncode != 0
    assert p.stderr.count("Traceback") == 1 and "Nanny" not in p.stderr, p.stderr
    assert f'{script}, line 2: a study with its own worker processes must be started under ' \
           '`if __name__ == "__main__":`' in p.stderr
    # The guarded script runs.
    script.write_text("from geardyn import study\nif __name__ == '__main__':\n"
                      f"    print(study.run({str(study_file)!r}, workers=2, progress=False).computed)\n")
    p = subprocess.run([sys.executable, script], capture_output=True, text=True, timeout=180, cwd=tmp_path)
    assert p.returncode == 0, p.stderr
    assert p.stdout.strip() == "2"


def largest_dte(run):
    """A user output: the largest DTE of the run over every mesh (a module-level function,
    shipped to the workers by reference)."""
    return max(float(np.abs(run[n]).max()) for n in run.names if n.endswith("dte"))


@pytest.mark.parametrize("name", SCENES)
def test_a_callable_output(client, tmp_path, name):
    base = short_scene(tmp_path, name)
    study_file = tmp_path / "out.toml"
    study_file.write_text(f'''scene = "{base}"
results = ["dte_rms"]
[[parameter]]
path = "{TORQUE}"
values = [80.0, 120.0]
[analysis]
kind = "simulate"
''')
    # A module-level function and a lambda (shipped by value).
    study = gs.load(study_file, outputs={"largest_dte": largest_dte,
                                         "rows": lambda run: len(run.time)})
    summary = gs.run(study, client=client, progress=False)
    assert summary.failed == 0
    df = gs.results(study)
    for row in df.to_dict("records"):
        scene = geardyn.Scene.from_file(base)
        scene[TORQUE] = row[TORQUE]
        run = geardyn.simulate(scene)
        assert row["largest_dte"] == largest_dte(run) and row["rows"] == len(run.time)
    assert df["largest_dte"].nunique() == 2
    # Another output is another study: its points are computed, not taken from the store.
    again = gs.load(study_file, outputs={"largest_dte": lambda run: 0.0})
    assert {again.key(p) for p in again.points()}.isdisjoint(df["key"])


def test_an_output_named_in_the_file_and_its_errors(tmp_path, monkeypatch):
    module = tmp_path / "my_outputs.py"
    module.write_text("import numpy as np\n\ndef dte_span(run):\n    return float(np.ptp(run['mesh.dte']))\n\n"
                      "def not_a_number(run):\n    return 'big'\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    base = short_scene(tmp_path, "spur_pair")
    text = (f'scene = "{base}"\nresults = ["dte_rms"]\n[[parameter]]\npath = "mesh.damping_ratio"\n'
            'values = [0.03, 0.06]\n[analysis]\nkind = "simulate"\n')
    study_file = tmp_path / "file_output.toml"
    study_file.write_text(text + '[[output]]\nname = "span"\nfunction = "my_outputs:dte_span"\n'
                          '[[output]]\nname = "word"\nfunction = "my_outputs:not_a_number"\n')
    study = gs.load(study_file)
    # A new cluster, whose workers start with the module's folder on their path.
    summary = gs.run(study, workers=1, progress=False)
    assert summary.failed == 2  # `word` fails every point, and the point is stored with why
    df = gs.results(study)
    assert all("output 'word' returned 'big' (str): must be a number" in e for e in df["error"])
    with pytest.raises(gs.StudyError, match=r"output\[0\].function = 'my_outputs:nope'"):
        study_file.write_text(text + '[[output]]\nname = "x"\nfunction = "my_outputs:nope"\n')
        gs.load(study_file)
    with pytest.raises(gs.StudyError, match=r"output 'dte_rms': the name of a result or parameter column"):
        gs.load(_write(tmp_path / "plain.toml", text), outputs={"dte_rms": largest_dte})


def _write(path, text):
    path.write_text(text)
    return path
