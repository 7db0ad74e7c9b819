//! What a command keeps in memory while a run goes, bounded however long
//! the run: the frames of `view.html` and the points of a picture are
//! thinned uniformly in time once they reach their cap (every other kept
//! item dropped, and from then on every second, fourth, ... pushed item
//! kept), so memory stays within the cap and the record still spans the
//! whole run. The files a run writes (OBJ frames, `steps.csv`) are streamed
//! and never thinned.

/// Memory for the frames of `view.html` (positions and speeds, 32 bytes
/// per particle and frame): 256 MiB, a page of at most about 90 MB.
pub const VIEW_BYTES: usize = 256 << 20;

/// Points of a picture of one quantity over time (a tutorial run's `y(t)`).
pub const PLOT_POINTS: usize = 100_000;

/// The most `view.html` frames of `particles` particles within [`VIEW_BYTES`].
pub fn max_view_frames(particles: usize) -> usize {
    (VIEW_BYTES / particles.max(1).saturating_mul(32)).max(2)
}

/// A sequence kept at most `cap` items long by thinning (see the module).
#[derive(Debug, Clone)]
pub struct Thinned<T> {
    items: Vec<T>,
    /// Every `stride`-th pushed item is kept.
    stride: usize,
    /// Items pushed so far.
    pushed: usize,
    cap: usize,
}

impl<T> Thinned<T> {
    /// An empty sequence of at most `cap` (at least 2) items.
    pub fn new(cap: usize) -> Self {
        Self {
            items: Vec::new(),
            stride: 1,
            pushed: 0,
            cap: cap.max(2),
        }
    }

    /// Offers the next item; it is kept if its index is a multiple of the
    /// current stride.
    pub fn push(&mut self, item: T) {
        let index = self.pushed;
        self.pushed += 1;
        if !index.is_multiple_of(self.stride) {
            return;
        }
        if self.items.len() == self.cap {
            // Keep the items at even multiples of the stride, double it.
            let mut k = 0;
            self.items.retain(|_| {
                k += 1;
                (k - 1) % 2 == 0
            });
            self.stride *= 2;
            if !index.is_multiple_of(self.stride) {
                return;
            }
        }
        self.items.push(item);
    }

    /// `[stride, pushed, cap]`: with the items, all a checkpoint needs.
    pub fn counters(&self) -> [usize; 3] {
        [self.stride, self.pushed, self.cap]
    }

    /// The sequence of a checkpoint: `items` kept with the
    /// [`counters`](Self::counters); `None` if they do not fit each other.
    pub fn restored(items: Vec<T>, [stride, pushed, cap]: [usize; 3]) -> Option<Self> {
        (stride.is_power_of_two() && cap >= 2 && items.len() <= cap && items.len() <= pushed)
            .then_some(Self {
                items,
                stride,
                pushed,
                cap,
            })
    }

    /// The kept items, in order.
    pub fn items(&self) -> &[T] {
        &self.items
    }

    /// The kept items, taken out.
    pub fn take(&mut self) -> Vec<T> {
        std::mem::take(&mut self.items)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The kept indices are exactly the multiples of the final stride, a
    /// power of two, and never more than the cap.
    #[test]
    fn thinning_keeps_every_stride_th_item_within_the_cap() {
        for cap in [2, 3, 7, 10, 64] {
            for n in [0, 1, 5, 10, 11, 100, 1000] {
                let mut t = Thinned::new(cap);
                for i in 0..n {
                    t.push(i);
                }
                let kept = t.items();
                assert!(kept.len() <= cap, "cap {cap}, n {n}: {}", kept.len());
                let stride: usize = if n == 0 {
                    1
                } else {
                    kept.get(1).map_or(1, |s| s - kept[0])
                };
                assert!(stride.is_power_of_two());
                let expected: Vec<usize> = (0..n).step_by(stride).collect();
                assert_eq!(kept, expected.as_slice(), "cap {cap}, n {n}");
                // Half full at least once thinning began: the record spans the run.
                if n > cap {
                    assert!(kept.len() * 2 >= cap, "cap {cap}, n {n}");
                }
            }
        }
    }

    #[test]
    fn view_frames_fit_the_budget() {
        assert_eq!(max_view_frames(0), VIEW_BYTES / 32);
        assert!(max_view_frames(64 * 64) * 64 * 64 * 32 <= VIEW_BYTES);
        assert_eq!(max_view_frames(usize::MAX), 2);
    }
}
