//! The build's memory ledger (issue 13, item 5): every array the build
//! holds (the reference arrays of the nodes on the way, their sorted
//! split events, each task's scratch and spare arrays) and the tree it
//! emits are charged when taken and released when dropped, so the build
//! knows its live bytes, their peak, and fails with
//! [`BuildError::MemoryBudget`] as soon as they would exceed
//! [`KdBuildParams::memory_budget`](super::KdBuildParams::memory_budget).
//!
//! Arrays are charged by capacity, not length (what the allocator holds);
//! the emitted nodes and leaf indices by their final size (their growth
//! slack and the copy made when a subtree built on another thread is
//! appended are not counted). The mesh, which the caller gives, is not.
//!
//! Each task of the build charges an [`Account`] of its own, which takes
//! bytes from the shared [`Ledger`] in chunks of [`CHUNK`]: one shared
//! counter updated at every node cost the two-thread build of a
//! million-triangle scene a fifth of its speed (1.79x one thread became
//! 1.54x: both threads wrote the same cache line several times a node).
//! So the ledger's live bytes (and the peak) include up to two chunks
//! unused per open account (a task's, and each of its parents' up the
//! `rayon::join` recursion); a charge takes a new chunk only where it fits
//! the budget, else only what it needs, and fails only if that does not
//! fit (other accounts' unused chunks still count).

use super::params::BuildError;
use std::sync::atomic::{AtomicUsize, Ordering};

/// Bytes an account takes from the ledger at a time.
pub(crate) const CHUNK: usize = 32 << 10;

/// Live and peak bytes of one build, shared by its tasks.
#[derive(Debug)]
pub(crate) struct Ledger {
    live: AtomicUsize,
    peak: AtomicUsize,
    budget: Option<usize>,
}

impl Ledger {
    pub(crate) fn new(budget: Option<usize>) -> Ledger {
        Ledger {
            live: AtomicUsize::new(0),
            peak: AtomicUsize::new(0),
            budget,
        }
    }

    /// Take `need` bytes and, within the budget, `slack` more; returns
    /// the bytes taken. A compare-and-swap loop, so that a failed attempt
    /// never counts for another thread.
    fn reserve(&self, need: usize, slack: usize) -> Result<usize, BuildError> {
        let mut live = self.live.load(Ordering::Relaxed);
        loop {
            let budget = self.budget.unwrap_or(usize::MAX);
            let take = if live.saturating_add(need + slack) <= budget {
                need + slack
            } else if live.saturating_add(need) <= budget {
                need
            } else {
                return Err(BuildError::MemoryBudget {
                    needed: live.saturating_add(need),
                    budget,
                });
            };
            match self.live.compare_exchange_weak(
                live,
                live + take,
                Ordering::Relaxed,
                Ordering::Relaxed,
            ) {
                Ok(_) => {
                    self.peak.fetch_max(live + take, Ordering::Relaxed);
                    return Ok(take);
                }
                Err(now) => live = now,
            }
        }
    }

    fn unreserve(&self, bytes: usize) {
        self.live.fetch_sub(bytes, Ordering::Relaxed);
    }

    /// The most bytes live at once so far.
    pub(crate) fn peak(&self) -> usize {
        self.peak.load(Ordering::Relaxed)
    }

    /// The bytes live now.
    #[cfg(test)]
    pub(crate) fn live(&self) -> usize {
        self.live.load(Ordering::Relaxed)
    }
}

/// One task's charges against a [`Ledger`]: bytes taken from it in
/// chunks, `free` of them not yet charged. Its unused bytes go back when
/// it is dropped.
#[derive(Debug)]
pub(crate) struct Account<'a> {
    ledger: &'a Ledger,
    free: usize,
}

impl<'a> Account<'a> {
    pub(crate) fn new(ledger: &'a Ledger) -> Account<'a> {
        Account { ledger, free: 0 }
    }

    /// Charge `bytes` (until [`Account::release`]d, by this account or any
    /// other of the same ledger).
    ///
    /// # Errors
    /// [`BuildError::MemoryBudget`] if the ledger's live bytes would exceed
    /// the budget.
    #[inline]
    pub(crate) fn charge(&mut self, bytes: usize) -> Result<(), BuildError> {
        if bytes <= self.free {
            self.free -= bytes;
            return Ok(());
        }
        let need = bytes - self.free;
        let took = self.ledger.reserve(need, CHUNK)?;
        self.free = took - need;
        Ok(())
    }

    /// Give back `bytes` charged before.
    #[inline]
    pub(crate) fn release(&mut self, bytes: usize) {
        self.free += bytes;
        if self.free > 2 * CHUNK {
            self.ledger.unreserve(self.free - CHUNK);
            self.free = CHUNK;
        }
    }

    /// Hold `bytes` instead of `*held` (an array that grew or shrank).
    ///
    /// # Errors
    /// As [`Account::charge`].
    #[inline]
    pub(crate) fn resize(&mut self, held: &mut usize, bytes: usize) -> Result<(), BuildError> {
        if bytes >= *held {
            self.charge(bytes - *held)?;
        } else {
            self.release(*held - bytes);
        }
        *held = bytes;
        Ok(())
    }
}

impl Drop for Account<'_> {
    fn drop(&mut self) {
        self.ledger.unreserve(self.free);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn charges_come_in_chunks_and_go_back() {
        let l = Ledger::new(None);
        let mut a = Account::new(&l);
        a.charge(100).unwrap();
        assert_eq!(l.live(), 100 + CHUNK);
        // Within the chunk: no change on the ledger.
        a.charge(CHUNK - 50).unwrap();
        assert_eq!(l.live(), 100 + CHUNK);
        // Charged by one account, released by another.
        let mut b = Account::new(&l);
        b.release(CHUNK + 50);
        let mut held = 0;
        b.resize(&mut held, 5 * CHUNK).unwrap();
        assert!(l.peak() >= 5 * CHUNK);
        // Released bytes beyond two chunks go back at once.
        b.resize(&mut held, 0).unwrap();
        assert!(l.live() <= 4 * CHUNK + 100);
        drop(b);
        // Everything is released: the ledger is empty again, its peak kept.
        drop(a);
        assert_eq!(l.live(), 0);
        assert!(l.peak() >= 5 * CHUNK);
    }

    #[test]
    fn a_budget_counts_the_need_not_the_slack() {
        let l = Ledger::new(Some(1000));
        let mut a = Account::new(&l);
        // The chunk does not fit, the need does.
        a.charge(600).unwrap();
        assert_eq!(l.live(), 600);
        a.charge(400).unwrap();
        assert_eq!(
            a.charge(1).unwrap_err(),
            BuildError::MemoryBudget {
                needed: 1001,
                budget: 1000
            }
        );
        // The failed charge took nothing.
        assert_eq!(l.live(), 1000);
        a.release(1000);
        drop(a);
        assert_eq!((l.live(), l.peak()), (0, 1000));
    }
}
