"""Wrap an FMI 2.0 CS FMU in fmpy's container FMU (a third-party C binary shipped in the fmpy
wheel, `fmpy/container_fmu/binaries/x86_64-linux/container_fmu.so`), exposing its input
`operating.input_torque` and outputs `mesh.dte`, `mesh.force`.

Usage: python make_container.py <inner.fmu> <out.fmu>
fmpy's container API is experimental; this follows fmpy 0.3.32 (`create_container_fmu`).
"""

import sys, uuid, pathlib, tempfile
from fmpy import read_model_description
from fmpy.model_description import ModelDescription, ModelVariable, CoSimulation, Unknown, DefaultExperiment
from fmpy.container_fmu.config import Configuration, Component
from fmpy.container_fmu.cli import create_container_fmu

inner = pathlib.Path(sys.argv[1]).resolve()
out = pathlib.Path(sys.argv[2]).resolve()
imd = read_model_description(str(inner))
iv = {v.name: v for v in imd.modelVariables}
comp = Component(name="gear", filename=inner, modelDescription=imd)

md = ModelDescription()
md.fmiVersion = "2.0"
md.modelName = "GearContainer"
md.guid = "{" + str(uuid.uuid4()) + "}"
md.instantiationToken = md.guid
md.generationTool = "fmpy container_fmu"
md.coSimulation = CoSimulation(modelIdentifier="container_fmu")
md.coSimulation.fixedInternalStepSize = 1e-5
md.coSimulation.canHandleVariableCommunicationStepSize = True
md.defaultExperiment = DefaultExperiment(startTime="0", stopTime="0.005", stepSize="1e-5")
mappings = {}
# The container binary reserves value reference 0 for the independent variable (time) and
# maps value reference k to the k-th variable mapping.
t = ModelVariable(name="time", causality="independent", valueReference=0, type="Real")
t.variability = "continuous"
md.modelVariables.append(t)
for name, causality in [("operating.input_torque", "input"), ("mesh.dte", "output"), ("mesh.force", "output")]:
    src = iv[name]
    v = ModelVariable(name=name, causality=causality, valueReference=0, type="Real")
    v.variability = "continuous"
    if causality == "input":
        v.start = src.start
    else:
        v.initial = "calculated"
    md.modelVariables.append(v)
    mappings[v] = [(comp, src)]
for i, v in enumerate(md.modelVariables):
    v.valueReference = i
md.outputs = [Unknown(index=i + 1, variable=v) for i, v in enumerate(md.modelVariables) if v.causality == "output"]
md.initialUnknowns = list(md.outputs)
cfg = Configuration(parallelDoStep=False, modelDescription=md, components=[comp], connections=[], variableMappings=mappings)
with tempfile.TemporaryDirectory() as d:
    create_container_fmu(cfg, pathlib.Path(d), out)
print(out)
