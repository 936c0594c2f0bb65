"""Scene values given with units (``"4500rpm"``, ``("150", "N*m")``, a pint Quantity),
converted to the SI unit the scene format uses for that path (``geardyn.unit(path)``).

Speeds in rpm or rad/s are read as the CLI's ``--speed`` reads them (so ``"4500rpm"`` is the
same double on both); any other unit is converted by pint, which is then needed."""

import functools
import json
import numbers

from . import _geardyn
from ._geardyn import GeardynError


@functools.lru_cache(maxsize=1)
def _registry():
    try:
        import pint
    except ImportError:
        return None
    return pint.UnitRegistry()


def is_quantity(value) -> bool:
    """A value that carries a unit: a string, a (magnitude, unit) pair or a pint Quantity."""
    if isinstance(value, str):
        return True
    if isinstance(value, tuple) and len(value) == 2 and isinstance(value[1], str):
        return True
    return hasattr(value, "magnitude") and hasattr(value, "units") and hasattr(value, "to")


def to_si(path: str, value) -> float:
    """The number, in the scene format's unit for ``path``, of ``value`` given with a unit."""
    unit = _geardyn.parameter_unit(path)
    # Shown as the scene reader shows values: a string in TOML's double quotes.
    if isinstance(value, str):
        shown = json.dumps(value)
    elif hasattr(value, "units"):
        shown = f"{value:~}"
    else:
        shown = repr(value)
    if unit is None:
        raise GeardynError(f"scene path '{path}' = {shown}: this parameter has no unit; give a "
                           "plain value (units: geardyn.unit(path))")
    if unit == "rad/s" and isinstance(value, str):
        try:
            return _geardyn.parse_speed(value)
        except GeardynError:
            pass  # not rpm or rad/s: pint may know it (e.g. "75 Hz" is not a speed here)
    ureg = _registry()
    if ureg is None:
        raise GeardynError(f"scene path '{path}' = {shown}: converting units needs pint "
                           f"(pip install pint), or give the value in {unit}")
    try:
        if isinstance(value, str):
            q = ureg.Quantity(value)
        elif isinstance(value, tuple):
            magnitude = value[0]
            if isinstance(magnitude, str):
                magnitude = float(magnitude)
            if not isinstance(magnitude, numbers.Real):
                raise ValueError(f"magnitude {value[0]!r} is not a number")
            q = ureg.Quantity(magnitude, value[1])
        else:
            q = ureg.Quantity(value.magnitude, str(value.units))
        return float(q.to(unit).magnitude)
    except Exception as e:  # pint's errors name the units; the path is added here
        raise GeardynError(f"scene path '{path}' = {shown}: {e} (the scene's unit is {unit})") from None
