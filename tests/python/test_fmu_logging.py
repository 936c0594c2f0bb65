"""Logging through the host's variadic logger (FMI 2.0.x §2.1.5), captured with fmpy's native
logger proxy: categories switched by fmi2SetDebugLogging, messages passed verbatim (the FMU
sends them through a "%s" format), errors name the call and the state."""

import ctypes as C

import pytest
from fmi_host import ERROR, OK, WARNING, Host
from fmpy import extract


@pytest.fixture(scope="module")
def host(spur_fmu, tmp_path_factory):
    return Host(spur_fmu, extract(str(spur_fmu), str(tmp_path_factory.mktemp("log"))))


def _cats(*names):
    arr = (C.c_char_p * len(names))(*[n.encode() for n in names])
    return C.cast(arr, C.c_void_p), arr


def test_errors_name_call_and_state(host):
    host.messages.clear()
    c = host.instantiate(b"inst-a", logging_on=0)
    assert host.fmi2DoStep(c, 0.0, 1e-5, 1) == ERROR
    assert host.messages == [("inst-a", ERROR, "logStatusError",
                              "fmi2DoStep: not allowed in state instantiated")]
    host.fmi2FreeInstance(c)


def test_categories_are_switched(host):
    c = host.instantiate(logging_on=0)
    host.messages.clear()
    assert host.fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0) == OK
    assert host.fmi2EnterInitializationMode(c) == OK
    assert host.fmi2ExitInitializationMode(c) == OK
    assert host.messages == [], "events are off unless enabled"
    p, keep = _cats("logEvents")
    assert host.fmi2SetDebugLogging(c, 1, 1, p) == OK
    assert host.fmi2Terminate(c) == OK
    assert [m[2] for m in host.messages] == ["logEvents"]
    assert host.messages[0][3].startswith("terminated at t = ")
    # All off: even an error is silent.
    host.messages.clear()
    assert host.fmi2SetDebugLogging(c, 0, 0, None) == OK
    assert host.fmi2DoStep(c, 0.0, 1e-5, 1) == ERROR
    assert host.messages == []
    host.fmi2FreeInstance(c)


def test_log_all_traces_calls(host):
    c = host.instantiate(logging_on=1)
    host.messages.clear()
    host.fmi2SetupExperiment(c, 0, 0.0, 0.0, 1, 1.0)
    host.fmi2EnterInitializationMode(c)
    host.fmi2ExitInitializationMode(c)
    assert host.fmi2DoStep(c, 0.0, 2.5e-5, 1) == OK
    traces = [m[3] for m in host.messages if m[2] == "logAll"]
    assert "fmi2DoStep(tc=0.0, h=2.5e-5)" in traces
    assert any(t.startswith("fmi2SetupExperiment(") for t in traces)
    host.fmi2FreeInstance(c)


def test_messages_are_verbatim_and_hash_escaped(host):
    c = host.instantiate(logging_on=0)
    host.messages.clear()
    p, keep = _cats("logStatusWarning", "50%d %s #x")
    assert host.fmi2SetDebugLogging(c, 1, 2, p) == WARNING
    (name, status, cat, msg), = host.messages
    assert (status, cat) == (WARNING, "logStatusWarning")
    # '%' reaches the host unformatted; '#' is doubled (it starts a variable reference).
    assert '["50%d %s ##x"]' in msg, msg
    host.fmi2FreeInstance(c)


def test_bad_parameter_message_names_variable_and_value(host):
    c = host.instantiate(logging_on=0)
    host.messages.clear()
    vr = (C.c_uint * 1)(host.vr("pinion.inertia"))
    x = (C.c_double * 1)(-2.5)
    assert host.fmi2SetReal(c, vr, 1, x) == ERROR
    (_, _, _, msg), = host.messages
    assert "'pinion.inertia'" in msg and "-2.5" in msg, msg
    host.fmi2FreeInstance(c)


def test_instantiate_failure_is_logged(host):
    host.messages.clear()
    c = host.instantiate(b"bad-guid", guid=b"{not-the-guid}")
    assert c is None
    (name, status, cat, msg), = host.messages
    assert name == "bad-guid" and status == ERROR and "fmuGUID" in msg


def test_callback_struct_is_copied_at_instantiation(host):
    # FMI 2.0.x §2.1.5: the `functions` pointer is only valid during fmi2Instantiate. Give
    # the FMU a struct of its own, then wipe it: logging must still reach the host.
    from fmpy.fmi2 import fmi2CallbackFunctions

    cb = fmi2CallbackFunctions()
    C.memmove(C.byref(cb), C.byref(host.callbacks), C.sizeof(cb))
    c = host.dll.fmi2Instantiate(b"copied", 1, host.guid, host.resources, C.byref(cb), 0, 0)
    assert c
    C.memset(C.byref(cb), 0, C.sizeof(cb))
    host.messages.clear()
    assert host.fmi2DoStep(c, 0.0, 1e-5, 1) == ERROR
    assert [m[0] for m in host.messages] == ["copied"]
    host.fmi2FreeInstance(c)
