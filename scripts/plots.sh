#!/usr/bin/env bash
# Draws the plots shown in README.md and docs/spectrum.md into docs/img/ from the shipped
# examples (release build). Every PNG written here was looked at before it was committed;
# re-run after a change to src/plot/ and look again.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release
g=target/release/geardyn
out=docs/img
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
mkdir -p "$out"
$g spectrum --example spur_pair --signal mesh.dte,mesh.force --out "$tmp/s.csv" \
    --plot "$out/spectrum.png"
$g spectrum --example idler_gearset --signal mesh1.dte,mesh1.force --out "$tmp/s2.csv" \
    --plot "$out/spectrum_orders_db.png" --db --order-range 0:200
$g waterfall --example runup_spur --out "$tmp/w.csv" --plot "$out/waterfall.png" \
    --frequency-range 0:12000 --order-cuts "$tmp/o.csv" --mesh-orders 1,2,3 \
    --order-plot "$out/order_cuts.png" --db
$g waterfall --example runup_spur --out "$tmp/w2.csv" --plot "$out/waterfall_orders.png" \
    --order-range 0:130
$g modes --example runup_spur --campbell "$out/campbell.png" --rpm 0:9000 > /dev/null
$g modes --example idler_gearset --campbell "$out/campbell_idler.png" > /dev/null
$g sweep --example spur_pair --speed 3000rpm:6000rpm:61 --out "$tmp/frf.csv" \
    --plot "$out/sweep.png"
$g hb --example spur_pair --speed 3000rpm:6000rpm --out "$tmp/hb.csv" --plot "$out/hb.png" \
   
ls -l "$out"
