"""The long-double period map of a free compliant chain on the linear law
(`tests/python/free_chain_reference.py`, `Chain.linear_periods_by_vectors`: physical
coordinates, the rigid mode kept), as rows for `cargo run --release --example
free_chain_rows -- --compare`: `.venv/bin/python scripts/free_chain_long_double.py MESHES
PERIODS OUT` (64 meshes, 6 periods: about 3 minutes)."""

import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests" / "python"))
from free_chain_reference import Chain, dte_and_deflection, free_chain_text  # noqa: E402

meshes, periods, out = int(sys.argv[1]), int(sys.argv[2]), sys.argv[3]
with tempfile.TemporaryDirectory() as tmp:
    scene = Path(tmp) / "scene.toml"
    scene.write_text(free_chain_text(meshes, "linear"))
    chain = Chain(scene)
states = chain.linear_periods_by_vectors(periods)
dte, defl = dte_and_deflection(chain, states.astype(float))
with open(out, "w") as f:
    f.write(f"# delta {float(chain.static_deflection)!r} long-double period map\n")
    for k in range(1, periods + 1):
        row = [repr(float(v)) for j in range(meshes) for v in (dte[k, j], defl[k, j])]
        f.write(f"P {k} " + " ".join(row) + "\n")
