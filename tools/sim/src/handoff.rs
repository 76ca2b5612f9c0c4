//! A one-slot handoff between two threads that meet once per communication step of a coupled
//! run (a few microseconds apart): the receiver spins briefly, because parking and waking a
//! thread costs more than a whole step, then yields, so that an oversubscribed machine is not
//! kept busy by a waiting thread.

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Mutex, PoisonError};

/// How many times a receiver checks before it starts yielding its time slice: some tens of
/// microseconds, several steps' worth.
const SPINS_BEFORE_YIELDING: u32 = 20_000;

/// Values passed one at a time from one thread to another, numbered from 1. Aligned to two
/// cache lines so that the two handoffs of a run, side by side on a stack, do not share one:
/// each thread spins on one and writes the other.
#[repr(align(128))]
pub(crate) struct Handoff<T> {
    /// How many values were sent.
    sent: AtomicU64,
    slot: Mutex<Option<T>>,
    /// Set when the sending side is gone (it ended or panicked): a receiver waiting for a value
    /// that will never come returns `None` instead of waiting for ever.
    closed: AtomicBool,
}

impl<T> Handoff<T> {
    pub(crate) fn new() -> Self {
        Handoff { sent: AtomicU64::new(0), slot: Mutex::new(None), closed: AtomicBool::new(false) }
    }

    /// Hands over the next value. The receiver must have taken the previous one: the two
    /// threads alternate, which is how the master uses it.
    pub(crate) fn send(&self, value: T) {
        *self.slot.lock().unwrap_or_else(PoisonError::into_inner) = Some(value);
        self.sent.fetch_add(1, Ordering::Release);
    }

    /// Waits for the `n`th value (counted from 1) and takes it; `None` if the sender is gone
    /// without sending it.
    pub(crate) fn receive(&self, n: u64) -> Option<T> {
        let mut spins = 0;
        loop {
            if self.sent.load(Ordering::Acquire) >= n {
                return self.slot.lock().unwrap_or_else(PoisonError::into_inner).take();
            }
            if self.closed.load(Ordering::Acquire) {
                // A value sent just before closing is still delivered.
                return (self.sent.load(Ordering::Acquire) >= n)
                    .then(|| self.slot.lock().unwrap_or_else(PoisonError::into_inner).take())
                    .flatten();
            }
            if spins < SPINS_BEFORE_YIELDING {
                spins += 1;
                std::hint::spin_loop();
            } else {
                std::thread::yield_now();
            }
        }
    }

    /// Marks the sending side gone when the returned guard drops (at the end of its scope or
    /// while a panic unwinds it).
    pub(crate) fn closing_on_drop(&self) -> ClosingOnDrop<'_, T> {
        ClosingOnDrop(self)
    }
}

/// See [`Handoff::closing_on_drop`].
pub(crate) struct ClosingOnDrop<'a, T>(&'a Handoff<T>);

impl<T> Drop for ClosingOnDrop<'_, T> {
    fn drop(&mut self) {
        self.0.closed.store(true, Ordering::Release);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_arrive_in_order_between_two_threads() {
        let forth: Handoff<u64> = Handoff::new();
        let back: Handoff<u64> = Handoff::new();
        std::thread::scope(|scope| {
            scope.spawn(|| {
                let _closing = back.closing_on_drop();
                for n in 1..=10_000 {
                    let value = forth.receive(n).expect("sent");
                    back.send(value * 2);
                }
            });
            let _closing = forth.closing_on_drop();
            for n in 1..=10_000 {
                forth.send(n);
                assert_eq!(back.receive(n), Some(2 * n));
            }
        });
    }

    #[test]
    fn a_receiver_whose_sender_panicked_gets_none_instead_of_waiting_for_ever() {
        let handoff: Handoff<u64> = Handoff::new();
        let outcome = std::thread::scope(|scope| {
            let sender = scope.spawn(|| {
                let _closing = handoff.closing_on_drop();
                handoff.send(1);
                panic!("the sending lane failed");
            });
            let first = handoff.receive(1);
            let second = handoff.receive(2);
            (first, second, sender.join().is_err())
        });
        assert_eq!(outcome, (Some(1), None, true));
    }
}
