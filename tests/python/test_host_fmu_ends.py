"""`geardyn run` when an FMU ends the simulation itself or refuses a step, against
`fmpy.simulate_fmu` on the same FMU (issue 39).

The C stub FMU of the Rust tests (tests/fixtures/stub_fmu.c, compiled here with `cc`):
* `quit_at`: once a step would pass it, fmi2DoStep does a quarter of the step and returns
  fmi2Discard with fmi2Terminated = true (a load cycle that is over: the FMU ends the
  simulation itself, FMI 2.0.5 §4.2.3), logging "end of the load cycle reached";
* `fail_at`: once a step would pass it, fmi2DoStep does half the step and returns fmi2Discard
  with fmi2Terminated = false (a refused step), logging "state diverged after 50% of the step".
y = k·∫u, t = the FMU's time: the rows show exactly where each run stopped.
"""


import numpy as np
import pytest
from fmpy import simulate_fmu

from conftest import build_stub_fmu, run_geardyn

MD = """<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="2.0" modelName="stub" guid="{stub-fmu}">
  <CoSimulation modelIdentifier="stub" canHandleVariableCommunicationStepSize="true"/>
  <DefaultExperiment startTime="0" stopTime="1" stepSize="0.1"/>
  <ModelVariables>
    <ScalarVariable name="k" valueReference="0" causality="parameter" variability="fixed"><Real start="2"/></ScalarVariable>
    <ScalarVariable name="fail_at" valueReference="1" causality="parameter" variability="fixed"><Real start="1e300"/></ScalarVariable>
    <ScalarVariable name="u" valueReference="3" causality="input"><Real start="0"/></ScalarVariable>
    <ScalarVariable name="y" valueReference="4" causality="output"><Real/></ScalarVariable>
    <ScalarVariable name="t" valueReference="5" causality="output"><Real/></ScalarVariable>
    <ScalarVariable name="quit_at" valueReference="6" causality="parameter" variability="fixed"><Real start="1e300"/></ScalarVariable>
  </ModelVariables>
  <ModelStructure>
    <Outputs><Unknown index="4"/><Unknown index="5"/></Outputs>
    <InitialUnknowns><Unknown index="4"/><Unknown index="5"/></InitialUnknowns>
  </ModelStructure>
</fmiModelDescription>
"""


@pytest.fixture(scope="module")
def stub(tmp_path_factory):
    return build_stub_fmu(tmp_path_factory.mktemp("stub_ends"), MD)


def rows(csv):
    text = csv.read_text().splitlines()
    assert text[0] == '"time","y","t"', text[0]
    return np.array([[float(c) for c in line.split(",")] for line in text[1:]])


def fmpy_rows(result):
    return np.column_stack([result["time"], result["y"], result["t"]])


def test_an_fmu_that_ends_itself_is_a_normal_end_with_the_rows_of_fmpy(stub, tmp_path, report):
    out = tmp_path / "g.csv"
    r = run_geardyn("run", stub, "--out", out, "--start", "quit_at=0.25", "--start", "u=1", check=False)
    assert r.returncode == 0, r.stderr
    # One informational line with the FMU's reason; no error.
    lines = r.stderr.splitlines()
    assert len(lines) == 1, r.stderr
    assert lines[0].startswith("note: the FMU ended the simulation itself at t = 0.22500000000000003, before the stop time 1 "), lines[0]
    assert "fmi2Terminated" in lines[0] and "end of the load cycle reached" in lines[0], lines[0]
    ours = rows(out)
    theirs = fmpy_rows(simulate_fmu(str(stub), start_values={"quit_at": 0.25, "u": 1.0}))
    # 0, 0.1, 0.2 and the last successful time, a quarter into the step 0.2 → 0.3, in both,
    # bit for bit.
    assert ours.shape == (4, 3) and ours[-1, 0] == ours[-1, 2] == 0.2 + (0.30000000000000004 - 0.2) / 4
    np.testing.assert_array_equal(ours, theirs)
    report(f"stub FMU ending itself (fmi2Terminated) at t = {ours[-1, 0]}: geardyn run exit 0, {len(ours)} rows = fmpy.simulate_fmu bit for bit")


def test_a_refused_step_is_an_error_naming_the_reason_with_the_rows_of_fmpy_before_it(stub, tmp_path, report):
    out = tmp_path / "g.csv"
    r = run_geardyn("run", stub, "--out", out, "--start", "fail_at=0.35", "--start", "u=1", check=False)
    assert r.returncode == 1, r.stderr
    # The reason, at the default log level, once, in the one error line.
    lines = r.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), r.stderr
    assert "state diverged after 50% of the step" in lines[0] and "fmi2Discard" in lines[0], lines[0]
    assert "last successful time 0.35" in lines[0] and "asked to terminate" not in lines[0], lines[0]
    ours = rows(out)
    # fmpy 0.3.32 does not stop at a Discard without fmi2Terminated: it samples a row at the
    # start time of the refused step and retries that step forever. Stopped at its first step
    # that does not advance, its rows before that repeated row are geardyn's.
    seen = []

    def advancing(time, recorder):
        if seen and time == seen[-1]:
            return False
        seen.append(time)
        return True

    theirs = fmpy_rows(simulate_fmu(str(stub), start_values={"fail_at": 0.35, "u": 1.0}, step_finished=advancing))
    assert theirs[-1, 0] == theirs[-2, 0], "fmpy retried the refused step"
    assert ours.shape == (4, 3) and ours[-1, 0] == 0.30000000000000004
    np.testing.assert_array_equal(ours, theirs[:-1])
    report(f"stub FMU refusing a step (fmi2Discard, not terminated) at t = {ours[-1, 0]}: geardyn run exit 1 with the FMU's reason, {len(ours)} rows = fmpy's rows before its retry")
