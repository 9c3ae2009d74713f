//! Packing the charts' rectangles into one atlas without overlap: shelves (rows) filled
//! tallest first, the classic next-fit-decreasing-height packer. Each rectangle already
//! holds its chart's padding, so rectangles may touch.

/// Where each rectangle goes (its top-left texel) and the atlas's height, packing
/// `sizes` (width, height in texels) into rows of `width` texels; `None` when a rectangle
/// is wider than the atlas.
pub fn shelves(sizes: &[(u32, u32)], width: u32) -> Option<(Vec<(u32, u32)>, u32)> {
    let mut order: Vec<usize> = (0..sizes.len()).collect();
    order.sort_by_key(|&k| (std::cmp::Reverse(sizes[k].1), std::cmp::Reverse(sizes[k].0)));
    let mut at = vec![(0, 0); sizes.len()];
    let (mut x, mut y, mut row) = (0u32, 0u32, 0u32);
    for k in order {
        let (w, h) = sizes[k];
        if w > width {
            return None;
        }
        if x + w > width {
            y += row;
            (x, row) = (0, 0);
        }
        at[k] = (x, y);
        x += w;
        row = row.max(h);
    }
    Some((at, y + row))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// No two rectangles overlap, all lie inside the atlas, and a too wide one is refused.
    #[test]
    fn no_overlap_inside_the_atlas() {
        let sizes: Vec<(u32, u32)> = (0..60u32)
            .map(|k| (1 + (k * 37) % 23, 1 + (k * 11) % 17))
            .collect();
        let (at, height) = shelves(&sizes, 64).unwrap();
        let area: u32 = sizes.iter().map(|s| s.0 * s.1).sum();
        assert!(height * 64 >= area);
        for a in 0..sizes.len() {
            assert!(at[a].0 + sizes[a].0 <= 64 && at[a].1 + sizes[a].1 <= height);
            for b in 0..a {
                let apart = at[a].0 + sizes[a].0 <= at[b].0
                    || at[b].0 + sizes[b].0 <= at[a].0
                    || at[a].1 + sizes[a].1 <= at[b].1
                    || at[b].1 + sizes[b].1 <= at[a].1;
                assert!(apart, "rectangles {a} and {b} overlap");
            }
        }
        assert!(shelves(&[(65, 1)], 64).is_none());
    }
}
