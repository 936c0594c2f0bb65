//! Composite transitions of recurring *sequences* of guard-free segments.
//!
//! A drivetrain of `N` meshes switches its stiffness `2N` times per mesh period (lumped
//! rectangular meshes), so the segment-wise propagation pays `2N` mat-vecs of the lifted
//! dimension `n_z ≈ 2·DOF` per period: `O(DOF³)`, and beyond a few meshes the cached
//! `e^{Aτ}` of all modes no longer fit in cache, so each mat-vec streams its matrix from memory.
//! Where no segment of a run of segments has a guard and the model's stops do not depend on
//! the state ([`super::PiecewiseLti::stops_independent_of_state`]), the run is a fixed
//! product of transitions: the propagator walks the model's stops first (recording each
//! segment's mode and its end's offset from the sequence start), and a sequence met before
//! costs one mat-vec with the product `Φ_k ⋯ Φ_1` of its transitions, `O(n_z²)` per sequence.
//!
//! A sequence matches a recorded one when it has the same modes in the same order and every
//! switching instant lies within [`offset_tolerance`] (4 ulps of the time) of the recorded
//! one relative to the sequence start: the rounding the stop times carry anyway. The product
//! is built from the same binned transitions the segment-wise path applies
//! ([`super::transition::ModeTransitions::transition_matrix`]), once a sequence has been seen
//! [`BUILD_AFTER`] times, so a sequence that does not recur costs no matrix product.
//!
//! A sequence with guards (a mesh period on the contact-loss law while contact holds) is
//! recorded here too, with its product and what decides it ([`Guarded`], built and used by
//! [`super::guarded`]): it is applied whole only where its certificate proves that no guard
//! crosses.
//!
//! Like the other caches, composites are dropped with the modes (new inputs, parameters) and
//! with the recurring-segment references (state capture), so a restored run continues as the
//! captured one does.

use nalgebra::DMatrix;

use super::guarded::Certificate;

/// Sequences remembered (recorded or with their product); the least recently used is replaced.
const CAPACITY: usize = 16;
/// Sightings of a sequence before its product is built (the first one only records it).
pub const BUILD_AFTER: u32 = 2;
/// Longest sequence: a long advance is cut into sequences of at most this many segments
/// (or at the return to the sequence's first mode, [`super::ExactPropagator`]).
pub const MAX_LENGTH: usize = 4096;

/// Tolerance of the switching instants' offsets from the sequence start, `4ε|t|`: stop times
/// of a periodic schedule are computed afresh every period and differ by their rounding.
pub fn offset_tolerance(t_end: f64) -> f64 {
    4.0 * f64::EPSILON * t_end.abs()
}

/// One segment of a sequence: the mode's position in the mode cache, its duration and its
/// end's offset from the sequence start.
#[derive(Clone, Copy, Debug)]
pub struct Step {
    pub mode: usize,
    pub tau: f64,
    pub offset: f64,
}

struct Composite {
    signature: u64,
    steps: Vec<Step>,
    seen: u32,
    last_used: u64,
    /// `Φ_k ⋯ Φ_1` once built, column-major.
    product: Option<DMatrix<f64>>,
    /// A sequence with guards: what decides it ([`super::guarded`]), built with the product.
    guarded: Option<Guarded>,
}

/// The data of a guarded sequence ([`super::guarded`]).
pub struct Guarded {
    /// The spreads `s_{k,l}`, segment `k` at `[k n, (k+1) n)`.
    pub spreads: Vec<f64>,
    /// The certificate of the last reference start, if one was proved.
    pub certificate: Option<Certificate>,
}

/// The recorded sequences of one mode cache.
#[derive(Default)]
pub struct Composites {
    entries: Vec<Composite>,
    clock: u64,
    /// Products built and sequences decided by a product, for tests and benchmarks.
    pub builds: u64,
    pub hits: u64,
}

/// What the cache says about a walked sequence.
pub enum Lookup<'a> {
    /// Apply this product.
    Product(&'a DMatrix<f64>),
    /// Apply the segments one by one; `build` says to build the product now (the sequence
    /// has been seen [`BUILD_AFTER`] times), in entry `slot`.
    Segments { build: Option<usize> },
}

fn signature(steps: &[Step]) -> u64 {
    let mut h = steps.len() as u64;
    for s in steps {
        h = (h.rotate_left(5) ^ s.mode as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    }
    h
}

impl Composites {
    /// Drops every sequence (and resets the counts).
    pub fn clear(&mut self) {
        *self = Composites::default();
    }

    /// Looks `steps` up (switching instants within `tol`), recording it if new.
    pub fn lookup(&mut self, steps: &[Step], tol: f64) -> Lookup<'_> {
        let Some(k) = self.sighting(steps, tol) else {
            return Lookup::Segments { build: None };
        };
        let entry = &mut self.entries[k];
        if entry.product.is_some() {
            self.hits += 1;
            return Lookup::Product(self.entries[k].product.as_ref().expect("built"));
        }
        entry.seen += 1;
        let build = (entry.seen >= BUILD_AFTER).then_some(k);
        Lookup::Segments { build }
    }

    /// [`Composites::lookup`] of a sequence with guards: its entry `Ok(slot)` if its product
    /// (and spreads) are built, else whether to build them now in entry `slot`.
    pub fn lookup_guarded(&mut self, steps: &[Step], tol: f64) -> Result<usize, Option<usize>> {
        let Some(k) = self.sighting(steps, tol) else {
            return Err(None);
        };
        let entry = &mut self.entries[k];
        if entry.product.is_some() && entry.guarded.is_some() {
            return Ok(k);
        }
        entry.seen += 1;
        Err((entry.seen >= BUILD_AFTER).then_some(k))
    }

    /// The entry of `steps` if it was recorded before (its use noted), else `None` after
    /// recording it (replacing the least recently used entry when the set is full).
    fn sighting(&mut self, steps: &[Step], tol: f64) -> Option<usize> {
        self.clock += 1;
        let sig = signature(steps);
        let found = self.entries.iter().position(|c| {
            c.signature == sig
                && c.steps.len() == steps.len()
                && c.steps
                    .iter()
                    .zip(steps)
                    .all(|(a, b)| a.mode == b.mode && (a.offset - b.offset).abs() <= tol)
        });
        if let Some(k) = found {
            self.entries[k].last_used = self.clock;
            return Some(k);
        }
        let entry = Composite {
            signature: sig,
            steps: steps.to_vec(),
            seen: 1,
            last_used: self.clock,
            product: None,
            guarded: None,
        };
        if self.entries.len() < CAPACITY {
            self.entries.push(entry);
        } else {
            let (slot, _) = self
                .entries
                .iter()
                .enumerate()
                .min_by_key(|(_, c)| c.last_used)
                .expect("a full set");
            self.entries[slot] = entry;
        }
        None
    }

    /// The product and the guarded data of entry `slot` (built: [`Composites::lookup_guarded`]).
    pub fn guarded(&mut self, slot: usize) -> (&DMatrix<f64>, &mut Guarded) {
        let entry = &mut self.entries[slot];
        (
            entry.product.as_ref().expect("built"),
            entry.guarded.as_mut().expect("built"),
        )
    }

    /// Sets the product and the spreads of the guarded entry `slot`.
    pub fn set_guarded(&mut self, slot: usize, product: DMatrix<f64>, spreads: Vec<f64>) {
        self.builds += 1;
        let entry = &mut self.entries[slot];
        entry.product = Some(product);
        entry.guarded = Some(Guarded {
            spreads,
            certificate: None,
        });
    }

    /// The recorded steps of entry `slot` (the product is built from these, so that it is a
    /// function of the recorded sequence alone).
    pub fn steps(&self, slot: usize) -> &[Step] {
        &self.entries[slot].steps
    }

    /// Heap bytes of the recorded sequences and their products.
    pub fn heap_bytes(&self) -> usize {
        self.entries
            .iter()
            .map(|c| {
                c.steps.capacity() * std::mem::size_of::<Step>()
                    + c.product.as_ref().map_or(0, |p| p.len() * 8)
                    + c.guarded.as_ref().map_or(0, |g| {
                        g.spreads.capacity() * 8
                            + g.certificate.as_ref().map_or(0, Certificate::heap_bytes)
                    })
            })
            .sum()
    }

    pub fn set_product(&mut self, slot: usize, product: DMatrix<f64>) {
        self.builds += 1;
        self.entries[slot].product = Some(product);
    }
}
