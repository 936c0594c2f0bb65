//! What [`GearTrain::new`] derives from the scene besides the assembly: each mesh's
//! manufacturing errors seen in the mesh, the nominal rotation, and the cycle tables of the
//! pair-based models (Liu 2007 Models 1–3).

use super::*;
use crate::mesh::eccentricity::{Centre, MeshGeometry};

/// The errors of mesh `n`'s two gears as the mesh sees them (`docs/errors.md`): the line of
/// action `β_n = centre_angle + σ_a·pressure_angle` of the assembly, and per gear the teeth
/// between this mesh and the gear's first mesh, `k = round(σ_g z (α_n − α_1)/2π)` with `α` the
/// direction from the gear's centre to its mate (teeth numbered against the rotation, so the
/// tooth at a mesh further along the rotation sense has a lower number).
pub(super) fn mesh_errors(scene: &Scene, n: usize, p0: f64, offset: f64) -> MeshErrors {
    let sm = &scene.meshes[n];
    let beta = sm.centre_angle + scene.rotation[sm.pinion] * sm.pressure_angle;
    let towards_mate = |g: usize, m: &crate::scene::Mesh| {
        if m.pinion == g {
            m.centre_angle
        } else {
            m.centre_angle + std::f64::consts::PI
        }
    };
    let gear = |g: usize, side: f64| {
        let first = scene
            .meshes
            .iter()
            .find(|m| m.pinion == g || m.gear == g)
            .expect("the gear takes part in mesh n");
        let z = scene.gears[g].teeth;
        let turn =
            scene.rotation[g] * f64::from(z) * (towards_mate(g, sm) - towards_mate(g, first)) / TAU;
        GearInMesh {
            errors: &scene.gears[g].errors,
            teeth: z,
            side,
            sense: scene.rotation[g],
            line_of_action: beta,
            tooth_offset: turn.round() as i64,
        }
    };
    MeshErrors::new(&[gear(sm.pinion, 1.0), gear(sm.gear, -1.0)], p0, offset)
}

/// The nominal motion per rad/s of input speed in the physical coordinates (`u_b = ρ_b θ_b`,
/// translations 0): rolling without slip on the base circles, `d_n·v = 0` for every mesh (so
/// the nominal motion deflects no mesh even where tabulated radii and tooth counts differ in
/// the last digits), and coaxial gears on an elastic shaft turning together. Parts the input
/// does not drive stand still.
pub(super) fn nominal_rotation(scene: &Scene, asm: &Assembly) -> DVector<f64> {
    let bodies = asm.body_radius.len();
    if !scene.planetary.is_empty() {
        // A stage's mesh vectors couple three rotations (sun or ring, planet, carrier): the
        // nominal speeds are the scene's kinematics (Willis, docs/planetary.md eq. P1–P2).
        let mut v = DVector::zeros(asm.dim());
        for (g, &ratio) in scene.speed_ratio.iter().enumerate() {
            let b = asm.body_of[g];
            v[asm.body_dof[b]] = asm.body_radius[b] * ratio;
        }
        return v;
    }
    let mut omega: Vec<Option<f64>> = vec![None; bodies];
    omega[asm.body_of[scene.input_gear]] = Some(1.0);
    let mut changed = true;
    while changed {
        changed = false;
        for (n, m) in scene.meshes.iter().enumerate() {
            let (a, b) = (asm.body_of[m.pinion], asm.body_of[m.gear]);
            // d_n·v = 0 on the two rotations: c_a ρ_a ω_a + c_b ρ_b ω_b = 0.
            let ca = asm.mesh[n][asm.body_dof[a]] * asm.body_radius[a];
            let cb = asm.mesh[n][asm.body_dof[b]] * asm.body_radius[b];
            match (omega[a], omega[b]) {
                (Some(wa), None) => {
                    omega[b] = Some(-ca * wa / cb);
                    changed = true;
                }
                (None, Some(wb)) => {
                    omega[a] = Some(-cb * wb / ca);
                    changed = true;
                }
                _ => {}
            }
        }
        for s in &scene.shafts {
            let (a, b) = (asm.body_of[s.gears[0]], asm.body_of[s.gears[1]]);
            match (omega[a], omega[b]) {
                (Some(w), None) => {
                    omega[b] = Some(w);
                    changed = true;
                }
                (None, Some(w)) => {
                    omega[a] = Some(w);
                    changed = true;
                }
                _ => {}
            }
        }
    }
    let mut v = DVector::zeros(asm.dim());
    for (body, w) in omega.iter().enumerate() {
        v[asm.body_dof[body]] = asm.body_radius[body] * w.unwrap_or(0.0);
    }
    v
}

/// The closed form of a free single pair: one mesh, two rotating bodies (the input and the
/// output), nothing else. Returns `(d_θ, J)` per body, `d_θ = ±r_b` the mesh vector in
/// rotation angle and `J` the body inertia.
pub(super) fn pair_closed_form(
    scene: &Scene,
    asm: &Assembly,
    m: usize,
    rigid: usize,
) -> Option<[(f64, f64); 2]> {
    let single = m == 1
        && rigid == 1
        && asm.dim() == 2
        && scene.meshes.len() == 1
        && asm.k_base.iter().all(|&v| v == 0.0)
        && asm
            .dofs
            .iter()
            .all(|d| matches!(d, DofKind::Rotation { .. }));
    if !single {
        return None;
    }
    let mesh = &scene.meshes[0];
    let body = |g: usize| -> (f64, f64) {
        let b = asm.body_of[g];
        let j: f64 = (0..scene.gears.len())
            .filter(|&k| asm.body_of[k] == b)
            .map(|k| scene.gears[k].inertia)
            .sum();
        let r = scene.gears[g].base_radius;
        let d = if g == mesh.pinion { r } else { -r };
        (d, j)
    };
    let (i, o) = (scene.input_gear, scene.output_gear);
    let on_mesh = |g: usize| g == mesh.pinion || g == mesh.gear;
    (on_mesh(i) && on_mesh(o) && asm.body_of[i] != asm.body_of[o]).then(|| [body(i), body(o)])
}

/// Model-3 table: one slot with the total engaged stiffness and the NLTE as gap (eq. 2.11).
pub(super) fn nlte_table(pairs: &CycleTable) -> CycleTable {
    let nlte = loaded_ste(pairs, 0.0);
    single_slot_table(pairs, &nlte, |iv, r| {
        let k0: f64 = iv.laws.iter().flatten().map(|l| l.k(r)).sum();
        let k1: f64 = iv.laws.iter().flatten().map(|l| l.k1).sum();
        (k0, k1)
    })
}

/// Model-2 table: one slot with the mean stiffness and the loaded STE minus its mean as gap
/// (eq. 2.10), at the static mesh force `force`.
pub(super) fn loaded_ste_table(pairs: &CycleTable, force: f64, k_mean: f64) -> CycleTable {
    let ste = loaded_ste(pairs, force);
    let mean = ste.mean();
    let shifted = Ste {
        pieces: ste
            .pieces
            .iter()
            .map(|p| crate::model::train::statics::LinPiece {
                v0: p.v0 - mean,
                ..*p
            })
            .collect(),
    };
    single_slot_table(pairs, &shifted, |_, _| (k_mean, 0.0))
}

pub(super) fn single_slot_table(
    pairs: &CycleTable,
    gap: &Ste,
    k: impl Fn(&Interval, f64) -> (f64, f64),
) -> CycleTable {
    let intervals = gap
        .pieces
        .iter()
        .filter(|p| p.end > p.start)
        .map(|p| {
            let iv = &pairs.intervals[pairs.interval_at(0.5 * (p.start + p.end))];
            let (k0, k1) = k(iv, p.start - iv.start);
            Interval {
                start: p.start,
                end: p.end,
                laws: vec![Some(SlotLaw {
                    k0,
                    k1,
                    g0: p.v0,
                    g1: p.slope,
                })],
            }
        })
        .collect();
    CycleTable {
        slots: 1,
        shift_on_wrap: false,
        intervals,
    }
}

/// The moving involute geometry of mesh `n` when one of its gears has runout
/// (`docs/errors.md`, "Runout as a moving centre"); `None` without runout.
pub(super) fn mesh_eccentricity(
    scene: &Scene,
    n: usize,
    p0: f64,
) -> Result<Option<Eccentricity>, String> {
    let sm = &scene.meshes[n];
    let centre = |g: usize, side: f64| {
        let r = scene.gears[g].errors.runout?;
        (r.amplitude != 0.0).then(|| Centre {
            signed_amplitude: -side * r.amplitude,
            sense: scene.rotation[g],
            phase: r.phase,
            teeth: f64::from(scene.gears[g].teeth),
        })
    };
    let centres: Vec<Centre> = [centre(sm.pinion, 1.0), centre(sm.gear, -1.0)]
        .into_iter()
        .flatten()
        .collect();
    if centres.is_empty() {
        return Ok(None);
    }
    let alpha = sm.pressure_angle;
    if !(alpha > 0.0 && alpha < std::f64::consts::FRAC_PI_2) {
        return Err(format!(
            "mesh '{}': pressure_angle = {}°; a gear runout moves the operating centre distance, \
             so the mesh needs its operating pressure angle (docs/errors.md)",
            sm.name,
            alpha.to_degrees()
        ));
    }
    let sense = scene.rotation[sm.pinion];
    let geometry = MeshGeometry {
        base_radii: (
            scene.gears[sm.pinion].base_radius,
            scene.gears[sm.gear].base_radius,
        ),
        pinion_teeth: scene.gears[sm.pinion].teeth,
        pinion_sense: sense,
        pressure_angle: alpha,
        line_of_action: sm.centre_angle + sense * alpha,
    };
    Eccentricity::new(geometry, &centres, p0)
        .map(Some)
        .map_err(|e| format!("mesh '{}': {e}", sm.name))
}

/// The interval whose start is where a tooth pair enters, so that the runout moves it
/// (`docs/errors.md`): in a two-level lumped table (`kind = "rectangular"`: one level per
/// number of pairs in contact) the start of the higher level; in a Model-1 pair table the
/// start of the interval where a slot becomes engaged (its pair law read from the nominal
/// start of contact, so the pair keeps its place relative to the pinion tip). `None` for
/// other sources (trapezoidal, table, Fourier, geometry curves, Models 2 and 3), whose shape
/// the runout does not move. An error when the runout moves the start of contact by more
/// than half the narrower of the two intervals beside it.
pub(super) fn entry_knot(
    stiffness: &Stiffness,
    geometry: &Eccentricity,
    name: &str,
) -> Result<Option<(usize, f64)>, String> {
    let Stiffness::Table(t) = stiffness else {
        return Ok(None);
    };
    let constant = |iv: &Interval| match iv.laws.as_slice() {
        [Some(l)] if l.k1 == 0.0 && l.g0 == 0.0 && l.g1 == 0.0 => Some(l.k0),
        _ => None,
    };
    let index = if t.slots == 1 {
        match t.intervals.as_slice() {
            [low, high] => match (constant(low), constant(high)) {
                (Some(k_low), Some(k_high)) if k_high > k_low => Some(1),
                _ => None,
            },
            _ => None,
        }
    } else if t.shift_on_wrap {
        // Model-1: the one interval per cycle where a slot goes from no pair to a pair.
        (1..t.intervals.len()).find(|&i| {
            let (before, after) = (&t.intervals[i - 1].laws, &t.intervals[i].laws);
            before
                .iter()
                .zip(after)
                .any(|(b, a)| b.is_none() && a.is_some())
        })
    } else {
        None
    };
    let Some(i) = index else {
        return Ok(None);
    };
    let start = t.intervals[i].start;
    let width = (start - t.intervals[i - 1].start).min(t.intervals[i].end - start);
    if !(geometry.entry_bound() < 0.5 * width) {
        return Err(format!(
            "mesh '{name}': the runout moves the start of contact by up to {:e} cycles, not \
             small against the stiffness intervals beside it ({width:e} cycles)",
            geometry.entry_bound()
        ));
    }
    Ok(Some((i, start)))
}
