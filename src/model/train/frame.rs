//! Whether the rotating carrier frame's terms (`gyroscopic = true`, `docs/planetary.md`,
//! "Gyroscopic terms") can be assembled for a scene.

use crate::scene::Scene;

/// Why a scene with `gyroscopic = true` on a stage cannot run, if it cannot. The terms are
/// taken at the carrier's constant nominal speed, so the nominal-speed form is needed (with
/// ports or elements, or a speed profile, the carrier's speed is not constant), and the
/// stage must be held torsionally: in a free rotation of the stage the planets orbit (η_n =
/// r_c θ̃_c), and the centripetal term of eq. (1) pulls on that orbit with nothing to balance
/// it (the model has no geometric stiffness of the centrifugal preload), so the free
/// rotation would diverge instead of staying neutral.
pub fn gyroscopic_refusal(scene: &Scene) -> Option<String> {
    let st = scene.planetary.iter().find(|s| s.gyroscopic)?;
    let carrier = &scene.gears[st.carrier].name;
    let head = format!(
        "scene {:?}: carrier {carrier:?} has gyroscopic = true (the rotating frame's terms at \
         the carrier's constant nominal speed, docs/planetary.md, \"Gyroscopic terms\")",
        scene.name
    );
    if scene.carries_rotation() {
        return Some(format!(
            "{head}; with [[port]] or elements the carrier's speed is a state, not a constant: \
             run the nominal-speed form (no ports) or set gyroscopic = false"
        ));
    }
    if scene.profiles.speed.is_some() {
        return Some(format!(
            "{head}; a speed profile changes the carrier's speed over the run: run at a \
             constant operating.input_speed or set gyroscopic = false"
        ));
    }
    let mut rest = scene.clone();
    for s in &mut rest.planetary {
        s.gyroscopic = false;
    }
    let asm = super::assembly::Assembly::new(&rest);
    if let Ok(red) = super::assembly::Reduction::new(&asm) {
        if red.rigid_dim() > 0 {
            return Some(format!(
                "{head}; the train turns freely ({} rigid-body mode(s)): in a free rotation the \
                 planets orbit and the centripetal term of Lin & Parker's eq. (1) acts on that \
                 orbit unbalanced (the model has no geometric stiffness of the centrifugal \
                 preload), so the free rotation would diverge; hold the stage torsionally \
                 (a ground_stiffness on the input and output members, as in the papers' \
                 gyroscopic analyses) or set gyroscopic = false",
                red.rigid_dim()
            ));
        }
    }
    None
}
