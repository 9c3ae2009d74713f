//! [`SparseRows`]: the one sparse-row store of shrad. Row `i` is a slice of entries; rows are
//! packed in one array (compressed rows), so a million rows cost two allocations, not a
//! million. It holds the reference's form factors (`(patch seen, F)`), the wall exchange's
//! rows among boundary patches (re-traced row by row while objects move), an object's self
//! form factors, and the splat smoothing's neighbour lists.

/// Rows of entries `T`, packed. A row may be replaced ([`SparseRows::set_row`]): in place
/// when the new one is no longer, else appended; the store compacts itself once more than
/// half of it is dead, so its size stays within twice what it holds.
#[derive(Clone, Debug, PartialEq)]
pub struct SparseRows<T> {
    /// Where each row starts in `entries`.
    start: Vec<usize>,
    /// Each row's length.
    len: Vec<u32>,
    entries: Vec<T>,
    /// Entries no row refers to any more.
    dead: usize,
}

impl<T> Default for SparseRows<T> {
    fn default() -> Self {
        SparseRows {
            start: Vec::new(),
            len: Vec::new(),
            entries: Vec::new(),
            dead: 0,
        }
    }
}

impl<T: Copy> SparseRows<T> {
    /// The rows of `rows`, in order.
    pub fn from_rows<R: IntoIterator<Item = T>>(rows: impl IntoIterator<Item = R>) -> Self {
        let mut out = SparseRows::default();
        for row in rows {
            out.push_row(row);
        }
        out
    }

    /// Append a row.
    pub fn push_row(&mut self, row: impl IntoIterator<Item = T>) {
        let start = self.entries.len();
        self.entries.extend(row);
        self.start.push(start);
        self.len.push(row_len(self.entries.len() - start));
    }

    /// Number of rows.
    pub fn len(&self) -> usize {
        self.start.len()
    }

    /// Whether there is no row.
    pub fn is_empty(&self) -> bool {
        self.start.is_empty()
    }

    /// Row `i` (empty when there is no row `i`).
    pub fn row(&self, i: usize) -> &[T] {
        match (self.start.get(i), self.len.get(i)) {
            (Some(&s), Some(&n)) => &self.entries[s..s + n as usize],
            _ => &[],
        }
    }

    /// Every row, in order.
    pub fn rows(&self) -> impl ExactSizeIterator<Item = &[T]> + '_ {
        (0..self.len()).map(move |i| self.row(i))
    }

    /// Entries held by the rows.
    pub fn entries(&self) -> usize {
        self.entries.len() - self.dead
    }

    /// Bytes of the entries (dead ones included) and the row table.
    pub fn bytes(&self) -> usize {
        self.entries.len() * std::mem::size_of::<T>()
            + self.start.len() * std::mem::size_of::<usize>()
            + self.len.len() * std::mem::size_of::<u32>()
    }

    /// Replace row `i` (which must exist) by `row`.
    pub fn set_row(&mut self, i: usize, row: &[T]) {
        let (s, old) = (self.start[i], self.len[i] as usize);
        if row.len() <= old {
            self.entries[s..s + row.len()].copy_from_slice(row);
            self.dead += old - row.len();
        } else {
            self.dead += old;
            self.start[i] = self.entries.len();
            self.entries.extend_from_slice(row);
        }
        self.len[i] = row_len(row.len());
        if self.dead > self.entries.len() / 2 {
            self.compact();
        }
    }

    /// Pack the rows again, in order, without dead entries.
    fn compact(&mut self) {
        let mut entries = Vec::with_capacity(self.entries());
        for i in 0..self.len() {
            let (s, n) = (self.start[i], self.len[i] as usize);
            self.start[i] = entries.len();
            entries.extend_from_slice(&self.entries[s..s + n]);
        }
        self.entries = entries;
        self.dead = 0;
    }
}

/// A row's length as stored (rows hold at most `u32::MAX` entries: a row is one patch's rays
/// or neighbours).
fn row_len(n: usize) -> u32 {
    u32::try_from(n).expect("a sparse row holds at most u32::MAX entries")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_read_back_and_replace() {
        let mut s = SparseRows::from_rows([vec![1u32, 2, 3], vec![], vec![4]]);
        assert_eq!((s.len(), s.entries()), (3, 4));
        assert_eq!(s.row(0), &[1, 2, 3]);
        assert!(s.row(1).is_empty() && s.row(7).is_empty());
        s.set_row(0, &[9]);
        assert_eq!((s.row(0), s.row(2)), (&[9][..], &[4][..]));
        s.set_row(2, &[5, 6, 7, 8]);
        assert_eq!(s.row(2), &[5, 6, 7, 8]);
        assert_eq!(s.entries(), 5);
        // Replacing again and again keeps the store within twice what it holds.
        for k in 0..100u32 {
            s.set_row((k % 3) as usize, &vec![k; (k % 5) as usize]);
            assert!(
                s.entries.len() <= 2 * s.entries() + 4,
                "{}",
                s.entries.len()
            );
        }
        let rows: Vec<&[u32]> = s.rows().collect();
        assert_eq!(rows[0], &vec![99; 4][..]);
        assert_eq!(rows[1], &[97, 97][..]);
        assert_eq!(rows[2], &[98, 98, 98][..]);
    }
}
