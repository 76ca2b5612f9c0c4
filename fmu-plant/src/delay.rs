//! A pure time delay for piecewise-constant commands, exact at any step size.
//!
//! A command given at time `t_i` and held until the next one is applied from `t_i + delay`.
//! The line keeps the commands issued within the last `delay` seconds (plus the one currently
//! applied), so its length is bounded by `delay / step` and it does not allocate once it has
//! reached that length. Within a step the applied command is piecewise constant; the plant
//! splits the step where it changes, so the delay adds no discretisation error.

use std::collections::VecDeque;

#[derive(Debug, Clone)]
pub(crate) struct DelayLine {
    delay: f64,
    /// (time the command was issued, command), oldest first.
    entries: VecDeque<(f64, f64)>,
}

impl DelayLine {
    pub fn new(delay: f64) -> Self {
        Self { delay, entries: VecDeque::with_capacity(8) }
    }

    pub fn clear(&mut self) {
        self.entries.clear();
    }

    /// Makes this line a copy of `other`, reusing its buffer: no allocation once the buffer has
    /// grown to the other's length, unlike `clone`, which the derived `clone_from` calls.
    pub fn copy_from(&mut self, other: &DelayLine) {
        self.delay = other.delay;
        self.entries.clear();
        self.entries.extend(other.entries.iter().copied());
    }

    /// Records that from time `now` on the command is `value`.
    pub fn push(&mut self, now: f64, value: f64) {
        if self.entries.back().is_some_and(|&(_, last)| last == value) {
            return;
        }
        self.entries.push_back((now, value));
    }

    /// The command applied at time `t`: the last one issued at or before `t - delay`, or zero
    /// before the first command has come through.
    pub fn applied_at(&self, t: f64) -> f64 {
        let issued_by = t - self.delay;
        self.entries.iter().rev().find(|&&(issued, _)| issued <= issued_by).map_or(0.0, |&(_, v)| v)
    }

    /// Calls `add` with every time in the open interval `(from, to)` at which the applied
    /// command changes.
    pub fn changes_between(&self, from: f64, to: f64, mut add: impl FnMut(f64)) {
        for &(issued, _) in &self.entries {
            let applied = issued + self.delay;
            if applied > from && applied < to {
                add(applied);
            }
        }
    }

    /// Forgets commands that can no longer be applied at or after time `now`.
    pub fn forget_before(&mut self, now: f64) {
        let issued_by = now - self.delay;
        while self.entries.len() >= 2 && self.entries[1].0 <= issued_by {
            self.entries.pop_front();
        }
    }

    /// The commands kept, `(time issued, command)`, oldest first (the line's state), written
    /// over `into`, reusing its storage.
    pub fn entries_into(&self, into: &mut Vec<(f64, f64)>) {
        into.clear();
        // Slice by slice, and nothing for an empty line (no delay): extending from the deque's
        // iterator cost some thirty instructions per call, and the plants save their state
        // every step.
        if self.entries.is_empty() {
            return;
        }
        let (front, back) = self.entries.as_slices();
        into.extend_from_slice(front);
        into.extend_from_slice(back);
    }

    /// Restores what [`entries_into`](Self::entries_into) wrote.
    pub fn set_entries(&mut self, entries: Vec<(f64, f64)>) {
        self.entries = entries.into();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_command_appears_exactly_one_delay_after_it_was_issued() {
        let mut line = DelayLine::new(2.5e-3);
        line.push(0.0, 1.0);
        line.push(1e-3, 2.0);
        assert_eq!(line.applied_at(2.4e-3), 0.0);
        assert_eq!(line.applied_at(2.6e-3), 1.0);
        assert_eq!(line.applied_at(3.6e-3), 2.0);
        let mut changes = Vec::new();
        line.changes_between(2e-3, 4e-3, |t| changes.push(t));
        assert_eq!(changes, vec![2.5e-3, 3.5e-3]);
    }

    #[test]
    fn forgetting_keeps_the_command_still_in_force() {
        let mut line = DelayLine::new(1e-3);
        for i in 0..100 {
            line.push(i as f64 * 1e-3, i as f64);
            line.forget_before((i + 1) as f64 * 1e-3);
        }
        assert!(line.entries.len() <= 2, "{} entries kept", line.entries.len());
        // At 100 ms the command issued at 99 ms takes effect and is still known.
        assert_eq!(line.applied_at(100e-3 + 1e-6), 99.0);
    }
}
