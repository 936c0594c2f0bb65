"""`geardyn run` vs `fmpy simulate` on an FMU without canHandleVariableCommunicationStepSize.

The C stub FMU of the Rust tests (tests/fixtures/stub_fmu.c, compiled here with `cc`) declared
with canHandleVariableCommunicationStepSize="false": input events must not cut steps, and a
stop time off the grid ends the run at the last full grid point (fmpy's rule). Outputs are
the integral of the held input, so any difference in input timing shows.
"""


import pytest

from conftest import build_stub_fmu, run_geardyn
from test_host_thirdparty import assert_same, fmpy_cli, read

MD = """<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="2.0" modelName="stub" guid="{stub-fmu}">
  <CoSimulation modelIdentifier="stub" canHandleVariableCommunicationStepSize="false"/>
  <DefaultExperiment startTime="0" stopTime="1" stepSize="0.1"/>
  <ModelVariables>
    <ScalarVariable name="k" valueReference="0" causality="parameter" variability="fixed"><Real start="2"/></ScalarVariable>
    <ScalarVariable name="u" valueReference="3" causality="input"><Real start="0"/></ScalarVariable>
    <ScalarVariable name="y" valueReference="4" causality="output"><Real/></ScalarVariable>
    <ScalarVariable name="t" valueReference="5" causality="output"><Real/></ScalarVariable>
  </ModelVariables>
  <ModelStructure>
    <Outputs><Unknown index="3"/><Unknown index="4"/></Outputs>
    <InitialUnknowns><Unknown index="3"/><Unknown index="4"/></InitialUnknowns>
  </ModelStructure>
</fmiModelDescription>
"""


@pytest.fixture(scope="module")
def stub(tmp_path_factory):
    return build_stub_fmu(tmp_path_factory.mktemp("stub"), MD)


def test_no_variable_step_no_event_cut_and_early_stop(stub, tmp_path, report):
    csv = tmp_path / "in.csv"
    csv.write_text('"time","u"\n0,1\n0.35,1\n0.35,-2\n0.62,0.5\n0.9,3\n')
    args = ["--stop-time", "0.95", "--output-interval", "0.1"]
    g = tmp_path / "g.csv"
    r = run_geardyn("run", stub, "--out", g, "--input", csv, *args, check=False)
    assert r.returncode == 0, r.stderr
    assert "cannot shorten a step" in r.stderr
    f = fmpy_cli(stub, tmp_path / "f.csv", "--input-file", csv, *args)
    rel = assert_same(g, f)
    assert g.read_text() == f.read_text()
    t = read(g)[1][:, 0]
    # 0, 0.1, ..., 0.9: no row at the input event 0.35, none at the stop time 0.95.
    assert len(t) == 10 and abs(t[-1] - 0.9) < 1e-12
    assert 0.35 not in t
    report(f"stub FMU without variable step size, geardyn run --input vs fmpy --input-file: {len(t)} rows, max rel diff {rel:.3g}, byte-identical")
