"""A raw ctypes host for one FMU binary, for tests that need to pass what fmpy's wrappers
refuse (NULL arrays, unknown value references, calls in the wrong state) and to capture log
messages. The logger goes through fmpy's native proxy (`addLoggerProxy`), which formats the
variadic arguments in C, as every real host must (FMI 2.0.x §2.1.5)."""

import ctypes as C
import pathlib

import fmpy
from fmpy.fmi2 import fmi2CallbackFunctions, fmi2CallbackLoggerTYPE
from fmpy.logging import addLoggerProxy

OK, WARNING, DISCARD, ERROR, FATAL = 0, 1, 2, 3, 4

_SIGS = {
    "fmi2Instantiate": (C.c_void_p, [C.c_char_p, C.c_int, C.c_char_p, C.c_char_p, C.c_void_p, C.c_int, C.c_int]),
    "fmi2FreeInstance": (None, [C.c_void_p]),
    "fmi2SetDebugLogging": (C.c_int, [C.c_void_p, C.c_int, C.c_size_t, C.c_void_p]),
    "fmi2SetupExperiment": (C.c_int, [C.c_void_p, C.c_int, C.c_double, C.c_double, C.c_int, C.c_double]),
    "fmi2EnterInitializationMode": (C.c_int, [C.c_void_p]),
    "fmi2ExitInitializationMode": (C.c_int, [C.c_void_p]),
    "fmi2Terminate": (C.c_int, [C.c_void_p]),
    "fmi2Reset": (C.c_int, [C.c_void_p]),
    "fmi2GetReal": (C.c_int, [C.c_void_p, C.c_void_p, C.c_size_t, C.c_void_p]),
    "fmi2GetInteger": (C.c_int, [C.c_void_p, C.c_void_p, C.c_size_t, C.c_void_p]),
    "fmi2GetBoolean": (C.c_int, [C.c_void_p, C.c_void_p, C.c_size_t, C.c_void_p]),
    "fmi2GetString": (C.c_int, [C.c_void_p, C.c_void_p, C.c_size_t, C.c_void_p]),
    "fmi2SetReal": (C.c_int, [C.c_void_p, C.c_void_p, C.c_size_t, C.c_void_p]),
    "fmi2SetInteger": (C.c_int, [C.c_void_p, C.c_void_p, C.c_size_t, C.c_void_p]),
    "fmi2SetBoolean": (C.c_int, [C.c_void_p, C.c_void_p, C.c_size_t, C.c_void_p]),
    "fmi2SetString": (C.c_int, [C.c_void_p, C.c_void_p, C.c_size_t, C.c_void_p]),
    "fmi2GetFMUstate": (C.c_int, [C.c_void_p, C.c_void_p]),
    "fmi2SetFMUstate": (C.c_int, [C.c_void_p, C.c_void_p]),
    "fmi2FreeFMUstate": (C.c_int, [C.c_void_p, C.c_void_p]),
    "fmi2SerializedFMUstateSize": (C.c_int, [C.c_void_p, C.c_void_p, C.c_void_p]),
    "fmi2SerializeFMUstate": (C.c_int, [C.c_void_p, C.c_void_p, C.c_void_p, C.c_size_t]),
    "fmi2DeSerializeFMUstate": (C.c_int, [C.c_void_p, C.c_void_p, C.c_size_t, C.c_void_p]),
    "fmi2GetDirectionalDerivative": (C.c_int, [C.c_void_p, C.c_void_p, C.c_size_t, C.c_void_p, C.c_size_t, C.c_void_p, C.c_void_p]),
    "fmi2SetRealInputDerivatives": (C.c_int, [C.c_void_p, C.c_void_p, C.c_size_t, C.c_void_p, C.c_void_p]),
    "fmi2GetRealOutputDerivatives": (C.c_int, [C.c_void_p, C.c_void_p, C.c_size_t, C.c_void_p, C.c_void_p]),
    "fmi2DoStep": (C.c_int, [C.c_void_p, C.c_double, C.c_double, C.c_int]),
    "fmi2CancelStep": (C.c_int, [C.c_void_p]),
    "fmi2GetStatus": (C.c_int, [C.c_void_p, C.c_int, C.c_void_p]),
    "fmi2GetRealStatus": (C.c_int, [C.c_void_p, C.c_int, C.c_void_p]),
    "fmi2GetIntegerStatus": (C.c_int, [C.c_void_p, C.c_int, C.c_void_p]),
    "fmi2GetBooleanStatus": (C.c_int, [C.c_void_p, C.c_int, C.c_void_p]),
    "fmi2GetStringStatus": (C.c_int, [C.c_void_p, C.c_int, C.c_void_p]),
}


class Host:
    """Loads an extracted FMU's binary once; instantiates any number of instances."""

    def __init__(self, fmu_path, unzip_dir):
        md = fmpy.read_model_description(str(fmu_path))
        self.md = md
        self.guid = md.guid.encode()
        self.vars = {v.name: v for v in md.modelVariables}
        lib = pathlib.Path(unzip_dir) / "binaries" / "linux64" / f"{md.coSimulation.modelIdentifier}.so"
        self.dll = C.CDLL(str(lib))
        for name, (res, args) in _SIGS.items():
            f = getattr(self.dll, name)
            f.restype, f.argtypes = res, args
        self.resources = (pathlib.Path(unzip_dir) / "resources").as_uri().encode()
        self.messages = []  # (instance, status, category, message)
        self._logger = fmi2CallbackLoggerTYPE(self._log)
        self.callbacks = fmi2CallbackFunctions()
        self.callbacks.logger = self._logger
        addLoggerProxy(C.byref(self.callbacks))
        # fmpy's logging.so keeps the forwarding target in one process-global pointer, which
        # addLoggerProxy overwrites; fmpy's own default callbacks then also forward here.
        # The ctypes closure must therefore outlive this Host, or a later FMU log message
        # (e.g. from FMU2Slave in another test module) jumps into freed memory (segfault).
        _KEEP_ALIVE.append(self._logger)

    def _log(self, env, name, status, category, message):
        self.messages.append((name.decode(), status, (category or b"").decode(), message.decode()))

    def __getattr__(self, name):
        return getattr(self.dll, name)

    def instantiate(self, name=b"inst", logging_on=0, guid=None):
        return self.dll.fmi2Instantiate(name, 1, guid or self.guid, self.resources,
                                        C.byref(self.callbacks), 0, logging_on)

    def vr(self, name):
        return self.vars[name].valueReference


_KEEP_ALIVE = []


def reals(*xs):
    return (C.c_double * len(xs))(*xs)


def vrs(*xs):
    return (C.c_uint * len(xs))(*xs)
