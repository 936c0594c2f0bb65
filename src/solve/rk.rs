//! Explicit Runge–Kutta methods with dense output, PI step control, stops and event location.
