//! The work budget of one advance ([`super::WorkBudget`]): a runaway of state events that no
//! stop pays for is stopped, while the same number of events between the model's stops (work
//! the interval asked for) is not.

use nalgebra::DMatrix;

use super::{ExactPropagator, ModeKey, PiecewiseLti, MAX_WORK_PER_ADVANCE};
use crate::solve::{HybridSystem, SolveError};

/// Lifted dimension: padded so that the base budget (`2^30 / 64³ = 4096` segments) is small.
const NZ: usize = 64;

/// `x'' = −x` with the guard `s·x`: the sign `s` flips at every crossing, so the guard
/// fires every π (an endless event sequence, as contact chatter would be). Optional stops
/// every π, half-way between the events.
struct Chatter {
    sign: f64,
    stops_every: Option<f64>,
    next_stop: f64,
}

impl Chatter {
    fn new(stops_every: Option<f64>) -> Self {
        Chatter {
            sign: 1.0,
            stops_every,
            next_stop: stops_every.unwrap_or(f64::INFINITY),
        }
    }
}

impl HybridSystem for Chatter {
    fn dim(&self) -> usize {
        2
    }
    fn rhs(&self, _t: f64, y: &[f64], dy: &mut [f64]) {
        dy[0] = y[1];
        dy[1] = -y[0];
    }
    fn guard_count(&self) -> usize {
        1
    }
    fn guards(&self, _t: f64, y: &[f64], g: &mut [f64]) {
        g[0] = self.sign * y[0];
    }
    fn next_stop(&self) -> f64 {
        self.next_stop
    }
    fn on_stop(&mut self, _t: f64, _y: &mut [f64]) {
        if let Some(every) = self.stops_every {
            self.next_stop += every;
        }
    }
    fn on_event(&mut self, _t: f64, y: &mut [f64], _index: usize) {
        y[0] = 0.0;
        self.sign = -self.sign;
    }
}

impl PiecewiseLti for Chatter {
    fn lti_dim(&self) -> usize {
        NZ
    }
    fn lift(&self, _t: f64, y: &[f64], z: &mut [f64]) {
        z.fill(0.0);
        z[..2].copy_from_slice(y);
    }
    fn lti_matrix(&self, a: &mut DMatrix<f64>) {
        a.fill(0.0);
        a[(0, 1)] = 1.0;
        a[(1, 0)] = -1.0;
    }
    fn guard_row(&self, _index: usize, w: &mut [f64]) {
        w.fill(0.0);
        w[0] = self.sign;
    }
    fn mode_key(&self, key: &mut ModeKey) {
        key.clear();
        key.push(u64::from(self.sign > 0.0), 2);
    }
    fn max_frequency(&self) -> f64 {
        1.0
    }
}

fn run(stops_every: Option<f64>, t_end: f64) -> (Result<(), SolveError>, u64) {
    let mut sys = Chatter::new(stops_every);
    let mut p = ExactPropagator::new(&sys);
    p.set_state(0.0, &[1.0, 0.0]);
    let result = p.advance_to(&mut sys, t_end);
    (result, p.stats().events)
}

#[test]
fn a_runaway_of_events_is_stopped_but_events_between_stops_are_not() {
    let base = (MAX_WORK_PER_ADVANCE / (NZ as f64).powi(3)) as u64;
    assert_eq!(base, 4096);
    // 6000 events without a stop: refused once the base budget is spent.
    let t_end = 6000.0 * std::f64::consts::PI;
    let (result, events) = run(None, t_end);
    match result {
        Err(SolveError::TooManySteps { max_steps, .. }) => assert_eq!(max_steps, base),
        other => panic!("expected the work bound, got {other:?} after {events} events"),
    }
    assert!(events <= base, "{events} events");
    // The same events with a stop every π between them: each stop pays for its piece.
    let (result, events) = run(Some(std::f64::consts::PI), t_end);
    assert_eq!(result, Ok(()));
    assert!(events >= 5999, "{events} events");
}
