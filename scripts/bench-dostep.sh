#!/usr/bin/env bash
# Benchmark: one fmi2DoStep of one mesh period vs the native integrator (ratio), per shipped scene.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo run --release --locked --example bench_dostep
