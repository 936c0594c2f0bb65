//! One macro step of one element (`fmi2DoStep`), as the serial and the parallel master take
//! it: a refused step says why; a step in which the element ended the simulation is
//! [`StepEnd::Ended`].

use crate::host::instance::Instance;

/// Why a macro step did not complete.
pub(super) enum StepEnd {
    Failed(String),
    /// An element ended the simulation itself: the note that says so.
    Ended(String),
}

impl From<String> for StepEnd {
    fn from(m: String) -> Self {
        StepEnd::Failed(m)
    }
}

/// `fmi2DoStep` of element `e`; a refused step says why, and a step in which the element
/// ended the simulation (`fmi2Terminated` after `fmi2Discard`) is [`StepEnd::Ended`].
pub(super) fn do_step(
    inst: &mut Instance,
    name: &str,
    time: f64,
    step: f64,
) -> Result<(), StepEnd> {
    let Err(err) = inst.do_step(time, step) else {
        return Ok(());
    };
    let mut msg = format!(
        "element \"{name}\" refused the step from t = {time} with h = {step} ({}): {err}",
        err.status
    );
    if err.status == crate::host::library::Status::Discard {
        let (terminated, last) = inst.discard_details();
        if terminated == Some(true) {
            let end = last.map_or(String::new(), |t| format!(" at t = {t}"));
            return Err(StepEnd::Ended(format!(
                "element \"{name}\" ended the simulation itself{end} in the step from t = {time} (fmi2Terminated after {}); the rows end at t = {time}",
                err.message
            )));
        }
        if let Some(t) = last {
            msg.push_str(&format!("; last successful time {t}"));
        }
    }
    Err(StepEnd::Failed(msg))
}
