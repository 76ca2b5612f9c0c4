//! A one-slot handoff between two threads that meet once per communication step of a coupled
//! run (a microsecond or two apart): the receiver spins briefly, because parking and waking a
//! thread costs more than a whole step, then yields, so that an oversubscribed machine is not
//! kept busy by a waiting thread.
//!
//! What crosses is a fixed number of `f64` held in atomics, written with plain stores and
//! published by one release increment of the message count: a step's handoff moves the counter's
//! cache line and the values' lines, and no lock's. (A `Mutex<Option<T>>` slot took about 165 ns
//! a round trip on the development machine, the atomics alone about 107 ns.) The rare messages
//! that are not values, an error or "stop", go through a lock beside them.

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Mutex, PoisonError};

/// How many times a receiver checks before it starts yielding its time slice: some tens of
/// microseconds, several steps' worth.
const SPINS_BEFORE_YIELDING: u32 = 20_000;

/// What a receiver gets.
#[derive(Debug, PartialEq)]
pub(crate) enum Received<E, const N: usize> {
    Values([f64; N]),
    /// The sender asked the receiver to stop.
    Stop,
    /// The sender failed with this error.
    Failed(E),
    /// The sending side is gone (it ended or panicked) without sending the awaited message.
    Gone,
}

/// A message that is not values: kept under a lock, since it comes at most once per run.
enum Rare<E> {
    Stop,
    Failed(E),
}

/// Messages of `N` values passed one at a time from one thread to another, numbered from 1.
/// Aligned to two cache lines so that the two handoffs of a run, side by side on a stack, do
/// not share one: each thread spins on one and writes the other.
#[repr(align(128))]
pub(crate) struct Handoff<E, const N: usize> {
    /// How many messages were sent.
    sent: AtomicU64,
    /// The number of the message that is in `rare` instead of `values` (0: none).
    rare_number: AtomicU64,
    values: [AtomicU64; N],
    rare: Mutex<Option<Rare<E>>>,
    /// Set when the sending side is gone (it ended or panicked): a receiver waiting for a message
    /// that will never come gets [`Received::Gone`] instead of waiting for ever.
    closed: AtomicBool,
}

impl<E, const N: usize> Handoff<E, N> {
    pub(crate) fn new() -> Self {
        Handoff {
            sent: AtomicU64::new(0),
            rare_number: AtomicU64::new(0),
            values: std::array::from_fn(|_| AtomicU64::new(0)),
            rare: Mutex::new(None),
            closed: AtomicBool::new(false),
        }
    }

    /// Hands over the next values. The receiver must have taken the previous message: the two
    /// threads alternate, which is how the master uses it.
    pub(crate) fn send(&self, values: &[f64; N]) {
        for (slot, value) in self.values.iter().zip(values) {
            // Relaxed: the release increment below publishes them.
            slot.store(value.to_bits(), Ordering::Relaxed);
        }
        self.sent.fetch_add(1, Ordering::Release);
    }

    /// Asks the receiver to stop.
    pub(crate) fn send_stop(&self) {
        self.send_rare(Rare::Stop);
    }

    /// Tells the receiver that the sender failed.
    pub(crate) fn send_failure(&self, error: E) {
        self.send_rare(Rare::Failed(error));
    }

    fn send_rare(&self, message: Rare<E>) {
        *self.rare.lock().unwrap_or_else(PoisonError::into_inner) = Some(message);
        let number = self.sent.load(Ordering::Relaxed) + 1;
        self.rare_number.store(number, Ordering::Relaxed);
        self.sent.store(number, Ordering::Release);
    }

    /// Waits for the `n`th message (counted from 1) and takes it.
    pub(crate) fn receive(&self, n: u64) -> Received<E, N> {
        let mut spins = 0;
        loop {
            if self.sent.load(Ordering::Acquire) >= n {
                return self.take(n);
            }
            if self.closed.load(Ordering::Acquire) {
                // A message sent just before closing is still delivered.
                return if self.sent.load(Ordering::Acquire) >= n { self.take(n) } else { Received::Gone };
            }
            if spins < SPINS_BEFORE_YIELDING {
                spins += 1;
                std::hint::spin_loop();
            } else {
                std::thread::yield_now();
            }
        }
    }

    /// The `n`th message, once the count says it was sent.
    fn take(&self, n: u64) -> Received<E, N> {
        if self.rare_number.load(Ordering::Relaxed) == n {
            return match self.rare.lock().unwrap_or_else(PoisonError::into_inner).take() {
                Some(Rare::Stop) => Received::Stop,
                Some(Rare::Failed(error)) => Received::Failed(error),
                None => Received::Gone,
            };
        }
        Received::Values(std::array::from_fn(|i| f64::from_bits(self.values[i].load(Ordering::Relaxed))))
    }

    /// Marks the sending side gone when the returned guard drops (at the end of its scope or
    /// while a panic unwinds it).
    pub(crate) fn closing_on_drop(&self) -> ClosingOnDrop<'_, E, N> {
        ClosingOnDrop(self)
    }
}

/// See [`Handoff::closing_on_drop`].
pub(crate) struct ClosingOnDrop<'a, E, const N: usize>(&'a Handoff<E, N>);

impl<E, const N: usize> Drop for ClosingOnDrop<'_, E, N> {
    fn drop(&mut self) {
        self.0.closed.store(true, Ordering::Release);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_arrive_in_order_and_whole_between_two_threads() {
        let forth: Handoff<(), 3> = Handoff::new();
        let back: Handoff<(), 3> = Handoff::new();
        std::thread::scope(|scope| {
            scope.spawn(|| {
                let _closing = back.closing_on_drop();
                for n in 1.. {
                    match forth.receive(n) {
                        Received::Values(v) => back.send(&[v[0] * 2.0, v[1] * 2.0, v[2] * 2.0]),
                        _ => return,
                    }
                }
            });
            let _closing = forth.closing_on_drop();
            for n in 1..=10_000u64 {
                let x = n as f64;
                forth.send(&[x, -x, x + 0.5]);
                assert_eq!(back.receive(n), Received::Values([2.0 * x, -2.0 * x, 2.0 * x + 1.0]));
            }
            forth.send_stop();
        });
    }

    #[test]
    fn a_failure_and_a_stop_arrive_as_such_after_values() {
        let handoff: Handoff<String, 1> = Handoff::new();
        handoff.send(&[1.0]);
        assert_eq!(handoff.receive(1), Received::Values([1.0]));
        handoff.send_failure("the lane failed".to_string());
        assert_eq!(handoff.receive(2), Received::Failed("the lane failed".to_string()));
        handoff.send(&[3.0]);
        assert_eq!(handoff.receive(3), Received::Values([3.0]));
        handoff.send_stop();
        assert_eq!(handoff.receive(4), Received::Stop);
    }

    #[test]
    fn a_receiver_whose_sender_panicked_gets_gone_instead_of_waiting_for_ever() {
        let handoff: Handoff<(), 1> = Handoff::new();
        let outcome = std::thread::scope(|scope| {
            let sender = scope.spawn(|| {
                let _closing = handoff.closing_on_drop();
                handoff.send(&[1.0]);
                panic!("the sending lane failed");
            });
            let first = handoff.receive(1);
            let second = handoff.receive(2);
            (first, second, sender.join().is_err())
        });
        assert_eq!(outcome, (Received::Values([1.0]), Received::Gone, true));
    }
}
