"""The shipped FMUs as files: validation by fmpy, ZIP rules, exported symbols and library
dependencies, checked-in model descriptions, and `geardyn fmu build` on a bad scene.

Oracles: fmpy's validator (XSD + semantic rules), the FMI 2.0.x §2.3 ZIP rules and the list
of the 34 Co-Simulation functions of §2.1/§4.2, written out here from the standard."""

import pathlib
import shutil
import subprocess
import zipfile

import fmpy
import fmpy.validation
import pytest
from conftest import REPO, run_geardyn

# FMI 2.0.x: 25 common functions (§2.1) and 9 Co-Simulation functions (§4.2).
FMI2_CS_FUNCTIONS = sorted("""
fmi2GetTypesPlatform fmi2GetVersion fmi2SetDebugLogging fmi2Instantiate fmi2FreeInstance
fmi2SetupExperiment fmi2EnterInitializationMode fmi2ExitInitializationMode fmi2Terminate fmi2Reset
fmi2GetReal fmi2GetInteger fmi2GetBoolean fmi2GetString fmi2SetReal fmi2SetInteger fmi2SetBoolean
fmi2SetString fmi2GetFMUstate fmi2SetFMUstate fmi2FreeFMUstate fmi2SerializedFMUstateSize
fmi2SerializeFMUstate fmi2DeSerializeFMUstate fmi2GetDirectionalDerivative
fmi2SetRealInputDerivatives fmi2GetRealOutputDerivatives fmi2DoStep fmi2CancelStep fmi2GetStatus
fmi2GetRealStatus fmi2GetIntegerStatus fmi2GetBooleanStatus fmi2GetStringStatus
""".split())


def test_function_list_is_complete():
    assert len(FMI2_CS_FUNCTIONS) == 34 == len(set(FMI2_CS_FUNCTIONS))


def test_fmpy_validate_reports_no_problem(shipped_fmus):
    for fmu in shipped_fmus:
        problems = fmpy.validation.validate_fmu(str(fmu))
        assert problems == [], f"{fmu.name}: {problems}"
        # The command line too: it exits with the number of problems.
        r = subprocess.run([str(REPO / ".venv" / "bin" / "fmpy"), "validate", str(fmu)],
                           capture_output=True, text=True)
        assert r.returncode == 0, r.stdout + r.stderr


def test_zip_follows_the_standard(shipped_fmus):
    for fmu in shipped_fmus:
        md = fmpy.read_model_description(str(fmu))
        ident = md.coSimulation.modelIdentifier
        with zipfile.ZipFile(fmu) as z:
            names = z.namelist()
            assert set(names) == {
                "modelDescription.xml",
                f"binaries/linux64/{ident}.so",
                "resources/scene.toml",
                "documentation/index.html",
            }
            for info in z.infolist():
                assert info.compress_type in (zipfile.ZIP_STORED, zipfile.ZIP_DEFLATED), info
                assert "\\" not in info.filename
                assert info.extract_version <= 20, (info.filename, info.extract_version)
                assert info.flag_bits & 0x1 == 0, "no encryption"
            html = z.read("documentation/index.html").decode()
            scene = (REPO / "fmu" / fmu.stem / "scene.toml").read_bytes()
            # The equations of the model kind (docs/model.md, docs/train.md).
            train = b"[[mesh]]" in scene
            equation = "M xi'' + C xi' + K_b xi + sum_n a_n F_n = F_ext" if train else "m_e x'' + F(x, x', p) = F_ext"
            # Element FMUs (docs/elements.md): the element's equation of motion.
            element = {b'kind = "motor"': "J_m w' = T_e + T_r + T_flange - d_m w",
                       b'kind = "shaft"': "tau = k (phi_a - phi_b) + c (w_a - w_b)",
                       b'kind = "load"': "J_L w' = T_flange - T_0 - c_v w - c_d w|w|",
                       b'kind = "inertia"': "J w' = T_a + T_b - d w"}
            equation = next((e for k, e in element.items() if b"[element]" in scene and k in scene), equation)
            assert equation in html, f"{fmu.name}: equations documented"
            for v in md.modelVariables:
                assert v.name in html
            assert z.read("resources/scene.toml") == scene


def test_checked_in_description_is_the_shipped_one(shipped_fmus):
    for fmu in shipped_fmus:
        with zipfile.ZipFile(fmu) as z:
            shipped = z.read("modelDescription.xml")
        ident = fmpy.read_model_description(str(fmu)).coSimulation.modelIdentifier
        assert (REPO / "modelDescription" / f"{ident}.xml").read_bytes() == shipped


def _extract_so(fmu, tmp_path):
    ident = fmpy.read_model_description(str(fmu)).coSimulation.modelIdentifier
    with zipfile.ZipFile(fmu) as z:
        return pathlib.Path(z.extract(f"binaries/linux64/{ident}.so", tmp_path))


@pytest.mark.skipif(shutil.which("nm") is None, reason="nm (binutils) not installed")
def test_exports_exactly_the_fmi_functions(shipped_fmus, tmp_path):
    for fmu in shipped_fmus:
        so = _extract_so(fmu, tmp_path / fmu.stem)
        out = subprocess.run(["nm", "-D", "--defined-only", str(so)], capture_output=True,
                             text=True, check=True).stdout
        symbols = sorted(line.split()[-1] for line in out.splitlines() if line.strip())
        assert symbols == FMI2_CS_FUNCTIONS


def test_depends_only_on_libc_libm_libgcc(shipped_fmus, tmp_path):
    allowed = {"libc.so.6", "libm.so.6", "libgcc_s.so.1"}
    for fmu in shipped_fmus:
        so = _extract_so(fmu, tmp_path / fmu.stem)
        out = subprocess.run(["ldd", str(so)], capture_output=True, text=True, check=True).stdout
        libs = set()
        for line in out.splitlines():
            name = line.split()[0]
            if name.startswith("linux-vdso") or "ld-linux" in name:
                continue  # the kernel's vDSO and the dynamic loader itself
            libs.add(name)
        assert libs <= allowed and "libc.so.6" in libs, out


@pytest.mark.parametrize(
    "name, edit, field",
    [
        ("spur_pair", ("inertia = 0.002621", "inertia = -0.002621"), "gear[0].inertia = -0.002621"),
        ("spur_pair", ("teeth = 38", "teeth = 0"), "gear[0].teeth = 0"),
        ("spur_pair", ("contact = \"backlash\"", "contact = \"sticky\""), "sticky"),
        ("spur_pair", ("mean = 2.9831e8", "mean = 2.9831e8\nbogus = 1"), "bogus"),
        ("idler_gearset", ("inertia = 0.002621", "inertia = -0.002621"), "gear[0].inertia = -0.002621"),
        ("idler_gearset", ('gear = "idler"', 'gear = "nowhere"'), 'mesh[0].gear = "nowhere"'),
        ("countershaft_gearset", ("contact_ratio = 1.70", "contact_ratio = 0.7"), "mesh[1].stiffness.contact_ratio = 0.7"),
    ],
)
def test_bad_scene_gives_clear_error_and_no_fmu(tmp_path, geardyn_bin, name, edit, field):
    text = (REPO / "fmu" / name / "scene.toml").read_text()
    assert edit[0] in text
    scene = tmp_path / "scene.toml"
    scene.write_text(text.replace(edit[0], edit[1], 1))
    out = tmp_path / "out"
    r = run_geardyn("fmu", "build", scene, "--out", out, check=False)
    assert r.returncode != 0
    assert field in r.stderr, r.stderr
    assert "error" in r.stderr.lower()
    assert not out.exists() or list(out.iterdir()) == [], "nothing written"
