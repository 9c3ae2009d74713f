//! The moves of a [`super::DirectCache`]'s last updates, while its receivers find the shadow
//! rays a mover changed in turn ([`super::DirectCache::update`]).

use std::collections::VecDeque;

use shrad_scene::Aabb;

/// Per update (at most `turns - 1` of them, the last ones): each mover, the box it left and
/// the box it went to.
#[derive(Clone, Debug, Default)]
pub(super) struct RecentMoves(VecDeque<Vec<(u32, Aabb, Aabb)>>);

impl RecentMoves {
    /// Whether some receiver has not been found since a move.
    pub(super) fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    /// The objects that moved since the receivers whose shadow rays this update finds were
    /// last found, with per object the union of the boxes it left and of those it went to:
    /// this update's moves (`movers`, `old`, `new`) and, when receivers are found in turn
    /// (`turns` above 1), the last `turns - 1` updates' (kept for the next ones). Where a
    /// mover was in between cannot matter: a ray it blocked on the way and no longer blocks
    /// is as it was, and one it blocks now meets where it is now. With `turns` 1 every
    /// receiver is found now, so nothing is kept.
    pub(super) fn since_last_turn(
        &mut self,
        movers: &[u32],
        (old, new): (&[Aabb], &[Aabb]),
        turns: usize,
    ) -> (Vec<u32>, Vec<Aabb>, Vec<Aabb>) {
        let this: Vec<(u32, Aabb, Aabb)> = (movers.iter().zip(old).zip(new))
            .map(|((&o, &a), &b)| (o, a, b))
            .collect();
        let mut union: Vec<(u32, Aabb, Aabb)> = Vec::new();
        for &(o, a, b) in self.0.iter().flatten().chain(&this) {
            match union.iter_mut().find(|u| u.0 == o) {
                Some(u) => (u.1, u.2) = (u.1.union(a), u.2.union(b)),
                None => union.push((o, a, b)),
            }
        }
        self.0.push_back(this);
        while self.0.len() >= turns {
            self.0.pop_front();
        }
        (
            union.iter().map(|u| u.0).collect(),
            union.iter().map(|u| u.1).collect(),
            union.iter().map(|u| u.2).collect(),
        )
    }
}
