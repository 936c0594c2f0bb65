//! Steady-state and stability analysis on top of the model and the propagators.

pub mod floquet;

pub use floquet::{exact_monodromy, Floquet};
