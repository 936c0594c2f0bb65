"""A third-party FMU for the host runner tests: exported by PythonFMU (PyPI `pythonfmu`).

A forced mass-spring-damper m x'' + c x' + k x = F integrated with classic RK4 substeps of at
most 1 ms inside each communication step (so any step size lands exactly on t + h).
The parameters are tunable, so fmpy (and geardyn) also accept them as input-file columns.
Discrete inputs `gain` (Integer) and `enabled` (Boolean) scale and switch the force; discrete
outputs `steps` (Integer) and `moving` (Boolean) exercise the recording of non-Real columns.
"""

from pythonfmu import Boolean, Fmi2Causality, Fmi2Slave, Fmi2Variability, Integer, Real


class Oscillator(Fmi2Slave):
    author = "geardyn tests"
    description = "Forced mass-spring-damper, RK4 substeps"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.m = 1.0
        self.k = 40.0
        self.c = 0.4
        self.F = 0.0
        self.x = 0.1
        self.v = 0.0
        self.gain = 1
        self.enabled = True
        self.steps = 0
        self.moving = False
        self.register_variable(Real("m", causality=Fmi2Causality.parameter, variability=Fmi2Variability.tunable))
        self.register_variable(Real("k", causality=Fmi2Causality.parameter, variability=Fmi2Variability.tunable))
        self.register_variable(Real("c", causality=Fmi2Causality.parameter, variability=Fmi2Variability.tunable))
        self.register_variable(Real("F", causality=Fmi2Causality.input))
        self.register_variable(Real("x", causality=Fmi2Causality.output))
        self.register_variable(Real("v", causality=Fmi2Causality.output))
        self.register_variable(Integer("gain", causality=Fmi2Causality.input, variability=Fmi2Variability.discrete))
        self.register_variable(Boolean("enabled", causality=Fmi2Causality.input, variability=Fmi2Variability.discrete))
        self.register_variable(Integer("steps", causality=Fmi2Causality.output, variability=Fmi2Variability.discrete))
        self.register_variable(Boolean("moving", causality=Fmi2Causality.output, variability=Fmi2Variability.discrete))

    def do_step(self, current_time, step_size):
        n = max(1, int(step_size / 1e-3 + 0.999999))
        h = step_size / n
        force = self.F * self.gain if self.enabled else 0.0
        for _ in range(n):
            def f(x, v):
                return v, (force - self.c * v - self.k * x) / self.m
            k1 = f(self.x, self.v)
            k2 = f(self.x + 0.5 * h * k1[0], self.v + 0.5 * h * k1[1])
            k3 = f(self.x + 0.5 * h * k2[0], self.v + 0.5 * h * k2[1])
            k4 = f(self.x + h * k3[0], self.v + h * k3[1])
            self.x += h / 6 * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0])
            self.v += h / 6 * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1])
        self.steps += 1
        self.moving = abs(self.v) > 0.1
        return True
