#!/usr/bin/env bash
# The numerical stress suite (issue 9, acceptance 4; tests/stress/) and the FMI fuzzer's long
# variant (issue 17; tests/fmi_fuzz.rs): the short variants (run by
# `cargo test` in CI, seconds) and the long ones marked #[ignore] (1e6 mesh periods, 1e5-period
# energy balance, 1e4 grazing and rattle cycles, ...), in release mode. Prints the measured
# numbers.
# Usage: bash scripts/stress.sh [extra cargo-test args]
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
cargo test --release --locked --test stress -- --include-ignored --nocapture --test-threads 1 "$@"
# The long scene-mutation fuzzer (issue 17: 1e5 mutations, no panic, hang or partial output).
cargo test --release --locked --test scene_fuzz -- --ignored --nocapture
# The long SSD mutation fuzzer (issue 34: 1e5 mutations of the shipped systems).
cargo test --release --locked --test ssd_fuzz -- --ignored --nocapture --exact ssd_mutations_long
# The FMI call-sequence fuzzer's long variant (issue 17, 34): 1e6 seeded calls over the C ABI
# and every shipped FMU, none over 1 s of CPU.
cargo test --release --locked --test fmi_fuzz -- --ignored --nocapture --exact fmi_call_sequences_long
# The free 64-mesh compliant chain, exact against DOP853 at rtol 1e-12 over one mesh period
# (issue 37 acceptance 2; CI runs 4 and 16 meshes): minutes of DOP853.
cargo test --release --locked --test chains -- --ignored --nocapture --exact free_compliant_chain_of_64_meshes_matches_dop853
# The exact propagator's memory bound on the free 64-mesh compliant chain with contact loss
# under the default 512 MiB (issue 37 acceptance 3; CI runs 16 meshes under 16 MiB): peak RSS
# of 20 and GEARDYN_MEMORY_PERIODS (default 1000) mesh periods, seconds per period.
cargo test --release --locked --test exact_memory -- --ignored --nocapture --exact the_64_mesh_chain_holds_the_default_budget
# The error-controlled co-simulation master over 1 s against the monolithic drivetrain
# (issue 32 acceptance 1 and 3; CI runs 0.1 s). Needs the venv and the built FMUs.
GEARDYN_LONG=1 .venv/bin/python -m pytest tests/python/test_cosim_tolerance.py -q -s
