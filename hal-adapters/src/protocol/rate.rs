//! Output rate dividers: a frame every N events (IMU samples), or never.

/// Fires on every `every`-th call of [`Self::tick`] (the first call included); never when
/// `every` is 0.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RateDivider {
    every: u16,
    count: u16,
}

impl RateDivider {
    /// A divider firing once every `every` ticks (0: off).
    pub const fn new(every: u16) -> Self {
        Self { every, count: 0 }
    }

    /// Counts one event; true when a frame is due.
    pub fn tick(&mut self) -> bool {
        if self.every == 0 {
            return false;
        }
        let due = self.count == 0;
        self.count += 1;
        if self.count == self.every {
            self.count = 0;
        }
        due
    }
}

#[cfg(test)]
mod tests {
    use super::RateDivider;

    #[test]
    fn fires_every_nth_tick_from_the_first_or_never() {
        let fired = |every: u16, n: usize| {
            let mut d = RateDivider::new(every);
            (0..n).filter(|_| d.tick()).count()
        };
        assert_eq!(fired(1, 400), 400);
        assert_eq!(fired(40, 400), 10);
        assert_eq!(fired(400, 401), 2);
        assert_eq!(fired(0, 1000), 0);
        let mut d = RateDivider::new(3);
        let pattern: [bool; 6] = core::array::from_fn(|_| d.tick());
        assert_eq!(pattern, [true, false, false, true, false, false]);
    }
}
