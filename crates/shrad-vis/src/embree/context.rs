//! How a query leaves objects out: instance ray masks where that is exact, else a context
//! filter function that rejects hits on the excluded instances (see the module above).

use super::ffi::*;

/// The intersect context with the exclude list behind it, so that the filter can find it
/// (Embree passes our context pointer through unchanged; `ctx` must be the first field),
/// and the ray mask that goes with it.
#[repr(C)]
pub(super) struct ExcludeContext {
    ctx: RTCIntersectContext,
    exclude: *const u32,
    exclude_len: usize,
    /// Mask of every ray of this query: all bits, or the excluded instances' bits cleared.
    pub(super) ray_mask: u32,
}

/// Which of the 32 ray-mask bits each instance has, and the instances of each bit.
pub(super) struct MaskBits {
    bit: Vec<u8>,
    members: Vec<Vec<u32>>,
}

impl MaskBits {
    /// A bit each up to 32 objects; beyond, the first 31 objects flagged `often_excluded`
    /// get one each and every other object shares bit 31.
    pub(super) fn new(often_excluded: &[bool]) -> MaskBits {
        let n = often_excluded.len();
        let mut bit = vec![31u8; n];
        if n <= 32 {
            bit.iter_mut().enumerate().for_each(|(o, b)| *b = o as u8);
        } else {
            let flagged = (0..n).filter(|&o| often_excluded[o]);
            for (b, o) in flagged.take(31).enumerate() {
                bit[o] = b as u8;
            }
        }
        let mut members = vec![Vec::new(); 32];
        for (o, &b) in bit.iter().enumerate() {
            members[b as usize].push(o as u32);
        }
        MaskBits { bit, members }
    }

    pub(super) fn mask(&self, o: usize) -> u32 {
        1 << self.bit[o]
    }

    /// The ray mask that keeps only the objects in `among`, if there is one exactly: no
    /// object outside `among` may share a bit with one inside.
    pub(super) fn only(&self, among: &[u32]) -> Option<u32> {
        let exact = among.iter().all(|&o| {
            self.bit
                .get(o as usize)
                .is_some_and(|&b| self.members[b as usize].iter().all(|m| among.contains(m)))
        });
        exact.then(|| among.iter().fold(0, |m, &o| m | self.mask(o as usize)))
    }

    /// The ray mask that excludes `exclude` exactly, if there is one: every object sharing
    /// a bit with an excluded object must be excluded too.
    pub(super) fn excluding(&self, exclude: &[u32]) -> Option<u32> {
        let exact = exclude.iter().all(|&e| {
            self.bit
                .get(e as usize)
                .is_some_and(|&b| self.members[b as usize].iter().all(|o| exclude.contains(o)))
        });
        exact.then(|| {
            exclude
                .iter()
                .fold(u32::MAX, |m, &e| m & !self.mask(e as usize))
        })
    }
}

impl ExcludeContext {
    /// `bits`: the instances' mask bits, `None` when the library does not test ray masks.
    pub(super) fn new(flags: u32, exclude: &[u32], bits: Option<&MaskBits>) -> ExcludeContext {
        let by_mask = if exclude.is_empty() {
            None
        } else {
            bits.and_then(|b| b.excluding(exclude))
        };
        let ray_mask = by_mask.unwrap_or(u32::MAX);
        let by_mask = by_mask.is_some();
        // rtcInitIntersectContext is an inline function in the header: replicated here.
        ExcludeContext {
            ctx: RTCIntersectContext {
                flags,
                filter: if exclude.is_empty() || by_mask {
                    None
                } else {
                    Some(exclude_filter)
                },
                inst_id: [RTC_INVALID_GEOMETRY_ID; MAX_INST],
            },
            exclude: exclude.as_ptr(),
            exclude_len: exclude.len(),
            ray_mask,
        }
    }

    /// A context without a filter whose rays carry `ray_mask`.
    pub(super) fn masked(flags: u32, ray_mask: u32) -> ExcludeContext {
        ExcludeContext {
            ctx: RTCIntersectContext {
                flags,
                filter: None,
                inst_id: [RTC_INVALID_GEOMETRY_ID; MAX_INST],
            },
            exclude: std::ptr::null(),
            exclude_len: 0,
            ray_mask,
        }
    }

    pub(super) fn as_ptr(&mut self) -> *mut RTCIntersectContext {
        &mut self.ctx
    }
}

/// Context filter: reject candidate hits on excluded instances.
unsafe extern "C" fn exclude_filter(args: *const RTCFilterFunctionNArguments) {
    // SAFETY: Embree passes valid arguments; `context` is the `ctx` field of the
    // `ExcludeContext` we passed (repr(C), first field), alive for the whole call; the hit is
    // in RTCHitN layout: Ng_x, Ng_y, Ng_z, u, v, primID, geomID, instID[0], N lanes each.
    unsafe {
        let args = &*args;
        let ctx = &*(args.context as *const ExcludeContext);
        let exclude = std::slice::from_raw_parts(ctx.exclude, ctx.exclude_len);
        let n = args.n as usize;
        let inst = (args.hit as *const u32).add(7 * n);
        for i in 0..n {
            let v = args.valid.add(i);
            if *v != 0 && exclude.contains(&*inst.add(i)) {
                *v = 0;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::MaskBits;

    #[test]
    fn mask_bits_exclude_exactly_or_not_at_all() {
        // Up to 32 objects: a bit each, any exclusion is exact.
        let few = MaskBits::new(&[false; 20]);
        assert_eq!(few.excluding(&[3]), Some(!(1 << 3)));
        assert_eq!(few.excluding(&[3, 7]), Some(!(1 << 3 | 1 << 7)));
        // 40 objects, 3 flagged: it has bit 0 alone; the others share bit 31.
        let mut flags = [false; 40];
        flags[3] = true;
        let many = MaskBits::new(&flags);
        assert_eq!(many.excluding(&[3]), Some(!1));
        assert_eq!(many.excluding(&[35]), None);
        assert_eq!(many.excluding(&[3, 35]), None);
        // Out of range: no mask (the filter then ignores it).
        assert_eq!(few.excluding(&[99]), None);
        // Keeping only some objects: exact when none of the others shares their bits.
        assert_eq!(few.only(&[3, 7]), Some(1 << 3 | 1 << 7));
        assert_eq!(many.only(&[3]), Some(1));
        assert_eq!(many.only(&[35]), None);
        assert_eq!(few.only(&[99]), None);
    }
}
