//! Which chunks of patches ([`crate::energy::CHUNK`] each) a frame changed the light of:
//! while something moves, Step 4's pass over the boundary and the energy meter visit only
//! those, so a frame costs what moved (the 1M-patch room's two passes over every patch took
//! a quarter of its moving frame). Every writer of the irradiance arrays (`direct`,
//! `probe_irradiance`, `indirect`, `wall`) marks what it wrote; a frame where nothing moves,
//! or a light changed, or the guard acted, marks everything.

use std::ops::Range;

use crate::energy::CHUNK;

/// Per chunk of patches: whether its light changed since the last meter.
#[derive(Clone, Debug, Default)]
pub(super) struct Touched(Vec<bool>);

impl Touched {
    /// Every chunk of `patches` patches marked.
    pub(super) fn new(patches: usize) -> Touched {
        Touched(vec![true; patches.div_ceil(CHUNK)])
    }

    pub(super) fn patch(&mut self, i: usize) {
        self.0[i / CHUNK] = true;
    }

    pub(super) fn range(&mut self, r: Range<usize>) {
        if !r.is_empty() {
            self.0[r.start / CHUNK..r.end.div_ceil(CHUNK)].fill(true);
        }
    }

    pub(super) fn everything(&mut self) {
        self.0.fill(true);
    }

    /// The chunks marked, ascending.
    pub(super) fn chunks(&self) -> Vec<usize> {
        (0..self.0.len()).filter(|&c| self.0[c]).collect()
    }

    pub(super) fn clear(&mut self) {
        self.0.fill(false);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn marks_the_chunks_of_what_was_written() {
        let mut t = Touched::new(5 * CHUNK + 1);
        assert_eq!(t.chunks(), vec![0, 1, 2, 3, 4, 5]);
        t.clear();
        assert!(t.chunks().is_empty());
        t.patch(CHUNK - 1);
        t.range(3 * CHUNK..3 * CHUNK);
        t.range(4 * CHUNK - 1..4 * CHUNK + 1);
        assert_eq!(t.chunks(), vec![0, 3, 4]);
        t.patch(5 * CHUNK);
        assert_eq!(t.chunks(), vec![0, 3, 4, 5]);
    }
}
