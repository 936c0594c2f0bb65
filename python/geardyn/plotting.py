"""Plotting helpers that return matplotlib figures, axes labelled with units.

Each takes a result of the module and returns a new ``matplotlib.figure.Figure`` (nothing is
shown or saved: ``fig.savefig(path)``, or display it in a notebook). ``ax=`` draws into an
existing axes instead and returns its figure. The results' own ``.plot(...)`` methods call
these."""

from typing import Optional, Sequence

import numpy as np


def _label(name: str, unit: Optional[str]) -> str:
    return f"{name} [{unit}]" if unit else name


def _axes(ax, figsize=(7.0, 3.6)):
    import matplotlib.figure

    if ax is not None:
        return ax.figure, ax
    # A Figure not registered with pyplot: no global state, freed with the object.
    fig = matplotlib.figure.Figure(figsize=figsize, layout="constrained")
    return fig, fig.add_subplot()


def simulation(run, signals: Optional[Sequence[str]] = None, ax=None):
    """The columns ``signals`` of a :class:`~geardyn.Simulation` or :class:`~geardyn.FmuRun`
    over time (default: every DTE column), one axes per unit."""
    import matplotlib.figure

    signals = list(signals) if signals else [n for n in run.names if n.endswith("dte")]
    if not signals:
        raise ValueError(f"signals: none given and the run has no DTE column ({', '.join(run.names)})")
    missing = [s for s in signals if s not in run.names]
    if missing:
        raise KeyError(f"signals: no column {missing[0]!r} (columns: {', '.join(run.names)})")
    by_unit = {}
    for s in signals:
        by_unit.setdefault(run.units.get(s), []).append(s)
    if ax is not None and len(by_unit) > 1:
        raise ValueError(f"ax: the signals have {len(by_unit)} units; give signals of one unit")
    if ax is None:
        fig = matplotlib.figure.Figure(figsize=(7.0, 2.4 * len(by_unit) + 0.6), layout="constrained")
        axes = fig.subplots(len(by_unit), 1, sharex=True, squeeze=False)[:, 0]
    else:
        fig, axes = ax.figure, [ax]
    for a, (unit, names) in zip(axes, by_unit.items()):
        for n in names:
            a.plot(run.time, run[n], label=n, lw=0.9)
        a.set_ylabel(_label(names[0] if len(names) == 1 else "value", unit))
        if len(names) > 1:
            a.legend(fontsize="small")
    axes[-1].set_xlabel(_label("time", "s"))
    return fig


def table(result, y: Sequence[str], x: str = "speed", ax=None):
    """Columns ``y`` of a :class:`~geardyn.Table` (a sweep, an hb branch) against ``x``; a
    sweep's up and down directions as separate curves, an hb branch's unstable points
    marked."""
    fig, ax = _axes(ax)
    ys = [y] if isinstance(y, str) else list(y)
    for c in [x, *ys]:
        if c not in result.columns:
            raise KeyError(f"no column {c!r} (columns: {', '.join(result.columns)})")
    direction = result["direction"] if "direction" in result.columns else np.ones(len(result))
    for c in ys:
        for d, style in ((1.0, "-"), (-1.0, "--")):
            rows = direction == d
            if rows.any():
                suffix = "" if (direction == direction[0]).all() else (" up" if d > 0 else " down")
                ax.plot(result[x][rows], result[c][rows], style, marker=".", label=c + suffix)
        if "stable" in result.columns:
            unstable = result["stable"] == 0
            if unstable.any():
                ax.plot(result[x][unstable], result[c][unstable], "x", color="k", label="unstable")
    ax.set_xlabel(_label(x, result.units.get(x)))
    units = {result.units.get(c) for c in ys}
    ax.set_ylabel(_label(ys[0] if len(ys) == 1 else "value", units.pop() if len(units) == 1 else None))
    ax.legend(fontsize="small")
    return fig


def spectrum(result, signal: Optional[str] = None, lines: int = 8, ax=None):
    """A stem plot of one signal's amplitude over frequency (default: the first), the
    ``lines`` largest labelled with their orders."""
    fig, ax = _axes(ax)
    amplitude = [c for c in result.columns if "_amplitude_" in c]
    column = next((c for c in amplitude if signal is None or c.startswith(f"{signal}_amplitude_")), None)
    if column is None:
        raise KeyError(f"signal: no amplitude of {signal!r} (columns: {', '.join(amplitude)})")
    f, a = result["frequency_Hz"], result[column]
    ax.stem(f, a, basefmt=" ", markerfmt=".")
    for i in np.argsort(a)[::-1][:lines]:
        if result.labels[i]:
            ax.annotate(result.labels[i], (f[i], a[i]), textcoords="offset points", xytext=(2, 3),
                        fontsize="x-small")
    ax.set_xlabel(_label("frequency", "Hz"))
    ax.set_ylabel(_label(column.rsplit("_amplitude_", 1)[0] + " amplitude", result.units.get(column)))
    return fig
