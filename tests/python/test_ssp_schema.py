"""Every shipped SSP file validates against the SSP 1.0 schema (issue 32, item 5).

The schema files are the ones fmpy ships (fmpy/ssp/schema/*.xsd, SSP 1.0); lxml, which fmpy
installs, validates against them. Shipped files: every `*.ssd` and `*.ssv` under
`examples/`. The validator is shown to refuse what the issue found (two DefaultExperiment
elements, a comment with a double hyphen), so a pass means something.
"""

import pathlib

import fmpy
import pytest
from lxml import etree

from conftest import REPO

SCHEMA = pathlib.Path(fmpy.__file__).parent / "ssp" / "schema"
SHIPPED = sorted(p for ext in ("*.ssd", "*.ssv") for p in (REPO / "examples").rglob(ext))


def schema(name):
    return etree.XMLSchema(etree.parse(str(SCHEMA / name)))


def validator(path):
    return schema("SystemStructureDescription.xsd" if path.suffix == ".ssd" else "SystemStructureParameterValues.xsd")


def test_files_are_shipped():
    assert {p.suffix for p in SHIPPED} == {".ssd", ".ssv"}, SHIPPED
    assert len([p for p in SHIPPED if p.suffix == ".ssd"]) >= 3


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: str(p.relative_to(REPO)))
def test_shipped_file_validates_against_the_ssp_1_0_schema(path, report):
    doc = etree.parse(str(path))  # raises on XML that is not well-formed, naming the line
    v = validator(path)
    ok = v.validate(doc)
    assert ok, "\n".join(f"{path.name}:{e.line}: {e.message}" for e in v.error_log)
    report(f"{path.relative_to(REPO)}: valid SSP 1.0 ({doc.getroot().tag.split('}')[1]})")


def test_the_validator_refuses_what_the_issue_found():
    text = (REPO / "examples/systems/drivetrain3/SystemStructure.ssd").read_text()
    experiment = '<ssd:DefaultExperiment startTime="0" stopTime="0.01"/>'
    assert text.count(experiment) == 1
    twice = text.replace(experiment, experiment + "\n  " + experiment)
    v = validator(pathlib.Path("x.ssd"))
    assert not v.validate(etree.fromstring(twice.encode()).getroottree())
    assert "DefaultExperiment" in str(v.error_log)
    with pytest.raises(etree.XMLSyntaxError, match="Double hyphen"):
        etree.fromstring(text.replace("<!--", "<!-- a -- b", 1).encode())
