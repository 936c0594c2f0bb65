//! Value reference → position in the model's variable table.
//!
//! A host reads every output after every communication step (fmpy, `geardyn run`), so this
//! lookup is on the hot path of `fmi2GetReal`. The value references of our models are small
//! integers in a few blocks (the largest, a drivetrain's outputs, start at 10 000), so a
//! direct table indexed by the value reference costs a few kB and one load; a model with
//! larger value references falls back to a binary search over the sorted pairs.

/// Value references up to this use the direct table (4 bytes per possible reference).
const DIRECT_LIMIT: u32 = 1 << 16;
/// Marks a value reference that names no variable in the direct table.
const NONE: u32 = u32::MAX;

pub enum VrIndex {
    /// `table[vr]` = position of the variable, or [`NONE`].
    Direct(Vec<u32>),
    /// `(value reference, position)`, sorted by value reference.
    Sorted(Vec<(u32, usize)>),
}

impl VrIndex {
    /// The index of `value_references` (in table order).
    pub fn new(value_references: impl Iterator<Item = u32> + Clone) -> VrIndex {
        match value_references.clone().max() {
            Some(max) if max < DIRECT_LIMIT => {
                let mut table = vec![NONE; max as usize + 1];
                for (position, vr) in value_references.enumerate() {
                    table[vr as usize] = position as u32;
                }
                VrIndex::Direct(table)
            }
            _ => {
                let mut sorted: Vec<(u32, usize)> = value_references
                    .enumerate()
                    .map(|(position, vr)| (vr, position))
                    .collect();
                sorted.sort_unstable();
                VrIndex::Sorted(sorted)
            }
        }
    }

    /// The position of the variable with value reference `vr`, if any.
    #[inline(always)]
    pub fn position(&self, vr: u32) -> Option<usize> {
        match self {
            VrIndex::Direct(table) => match table.get(vr as usize) {
                Some(&p) if p != NONE => Some(p as usize),
                _ => None,
            },
            VrIndex::Sorted(sorted) => sorted
                .binary_search_by_key(&vr, |&(r, _)| r)
                .ok()
                .map(|k| sorted[k].1),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Both layouts answer the same: every listed reference finds its position, and every
    /// other one (between, beyond, far beyond) finds none.
    #[test]
    fn direct_and_sorted_agree() {
        let small = [40u32, 0, 7, 3000, 10_001];
        let large = [40u32, 0, 7, 3000, DIRECT_LIMIT + 5];
        for vrs in [&small[..], &large[..]] {
            let index = VrIndex::new(vrs.iter().copied());
            assert_eq!(
                matches!(index, VrIndex::Direct(_)),
                vrs.iter().all(|&v| v < DIRECT_LIMIT)
            );
            for (position, &vr) in vrs.iter().enumerate() {
                assert_eq!(index.position(vr), Some(position), "vr {vr}");
            }
            for vr in [1, 39, 41, 2999, 10_000, 10_002, DIRECT_LIMIT + 4, u32::MAX] {
                assert_eq!(index.position(vr), None, "vr {vr}");
            }
        }
        assert_eq!(VrIndex::new([].into_iter()).position(0), None);
    }
}
