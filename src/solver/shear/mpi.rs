//! The MPI transport of a decomposed run (issue #39, the `mpi` feature): the bricks'
//! [`Transport`] over a communicator of rsmpi (the `mpi` crate, over the system's MPI).
//! A rebuild's exchange is one `MPI_Alltoall` of the message sizes and one `MPI_Alltoallv`
//! of the messages, each encoded as MessagePack (every f64 as its 64 bits: the bricks' bits
//! travel unchanged); a step's ghost messages are nonblocking point-to-point messages between
//! neighbouring bricks (`MPI_Isend` / `MPI_Irecv`, numbers as they are), its sums one
//! `MPI_Allreduce` (MPI_SUM of 64-bit words).

use super::decompose::{Traffic, Transport, Wire};
use mpi::collective::SystemOperation;
use mpi::datatype::{Partition, PartitionMut};
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;
use std::sync::atomic::{AtomicU64, Ordering::Relaxed};
use std::time::Instant;

/// The tag of a step's ghost messages.
const STEP_TAG: i32 = 39;

/// A communicator's ranks as bricks.
pub struct Mpi {
    world: SimpleCommunicator,
    meter: Meter,
}

/// [`Traffic`] counted as it goes (atomics: a handle may be lent to the threads of a pool,
/// though only one of them calls MPI at a time).
#[derive(Default)]
struct Meter {
    calls: AtomicU64,
    messages: AtomicU64,
    bytes: AtomicU64,
    nanos: AtomicU64,
}

impl Meter {
    /// One call that began at `t0` and sent `sizes[r]` bytes to rank r (`me` excluded).
    fn add(&self, t0: Instant, sizes: impl Iterator<Item = usize>, me: usize) {
        let (mut messages, mut bytes) = (0, 0);
        for (r, n) in sizes.enumerate() {
            if r != me && n > 0 {
                messages += 1;
                bytes += n as u64;
            }
        }
        self.calls.fetch_add(1, Relaxed);
        self.messages.fetch_add(messages, Relaxed);
        self.bytes.fetch_add(bytes, Relaxed);
        self.nanos
            .fetch_add(t0.elapsed().as_nanos() as u64, Relaxed);
    }
}

impl Mpi {
    pub fn new(world: SimpleCommunicator) -> Self {
        Mpi {
            world,
            meter: Meter::default(),
        }
    }

    /// `MPI_COMM_WORLD` (MPI initialised): a handle per thread that calls MPI (a
    /// communicator handle is not shared between threads; the calls are serialised).
    pub fn world() -> Self {
        Mpi::new(SimpleCommunicator::world())
    }
}

/// Offsets of consecutive blocks of sizes `counts`.
fn offsets(counts: &[i32]) -> Vec<i32> {
    counts
        .iter()
        .scan(0i32, |at, &c| {
            let o = *at;
            *at += c;
            Some(o)
        })
        .collect()
}

/// One `MPI_Alltoallv` of `send` (blocks of `counts`) into blocks of `got_counts`.
fn all_to_all<T: Equivalence + Default + Clone>(
    world: &SimpleCommunicator,
    send: &[T],
    counts: &[i32],
    got_counts: &[i32],
) -> Vec<T> {
    let (sent_at, got_at) = (offsets(counts), offsets(got_counts));
    let mut got = vec![T::default(); got_counts.iter().map(|&c| c as usize).sum()];
    {
        let s = Partition::new(send, counts, &sent_at[..]);
        let mut r = PartitionMut::new(&mut got[..], got_counts, &got_at[..]);
        world.all_to_all_varcount_into(&s, &mut r);
    }
    got
}

/// Message lengths as MPI counts (a message over 2^31 items is a bug of the caller).
fn counts(lengths: impl Iterator<Item = usize>) -> Vec<i32> {
    lengths
        .map(|n| i32::try_from(n).expect("a brick's message under 2^31 items"))
        .collect()
}

impl Transport for Mpi {
    fn rank(&self) -> usize {
        self.world.rank() as usize
    }

    fn size(&self) -> usize {
        self.world.size() as usize
    }

    fn exchange<T: Wire>(&self, out: Vec<T>) -> Vec<T> {
        let t0 = Instant::now();
        let size = self.size();
        assert_eq!(out.len(), size, "one message per rank");
        // an encoding failure or a message over 2 GiB is a bug of the caller, not an input
        let bufs: Vec<Vec<u8>> = out
            .iter()
            .map(|m| rmp_serde::to_vec(m).expect("a brick's message encodes"))
            .collect();
        let sent = counts(bufs.iter().map(Vec::len));
        let mut got_counts = vec![0i32; size];
        self.world.all_to_all_into(&sent[..], &mut got_counts[..]);
        let got = all_to_all(&self.world, &bufs.concat(), &sent, &got_counts);
        self.meter.add(t0, bufs.iter().map(Vec::len), self.rank());
        let got_at = offsets(&got_counts);
        (0..size)
            .map(|k| {
                let at = got_at[k] as usize;
                let bytes = &got[at..at + got_counts[k] as usize];
                rmp_serde::from_slice(bytes).expect("a brick's message decodes")
            })
            .collect()
    }

    fn exchange_f64(&self, out: &[Vec<f64>], got: &mut [Vec<f64>]) {
        let t0 = Instant::now();
        let me = self.rank();
        assert_eq!(out.len(), self.size(), "one message per rank");
        got[me].copy_from_slice(&out[me]);
        // the ranks received from, in the order their requests are added
        let from: Vec<(usize, usize)> = got
            .iter()
            .enumerate()
            .filter(|&(r, b)| r != me && !b.is_empty())
            .map(|(r, b)| (r, b.len()))
            .collect();
        let mut done = Vec::new();
        // nonblocking receives and sends with the ranks that have a message, then wait for
        // all (the counts are fixed at a rebuild on both sides: a short message is a bug,
        // checked from the receives' status; a long one is an MPI error)
        mpi::request::multiple_scope(2 * out.len(), |scope, all| {
            for (r, buf) in got.iter_mut().enumerate() {
                if r != me && !buf.is_empty() {
                    let rank = self.world.process_at_rank(r as i32);
                    all.add(rank.immediate_receive_into_with_tag(scope, &mut buf[..], STEP_TAG));
                }
            }
            for (r, buf) in out.iter().enumerate() {
                if r != me && !buf.is_empty() {
                    let rank = self.world.process_at_rank(r as i32);
                    all.add(rank.immediate_send_with_tag(scope, &buf[..], STEP_TAG));
                }
            }
            all.wait_all(&mut done);
        });
        for (k, status, _) in &done {
            if let Some(&(r, len)) = from.get(*k) {
                let n = status.count(f64::equivalent_datatype());
                assert_eq!(
                    n as usize, len,
                    "a step message from rank {r} of the length expected"
                );
            }
        }
        self.meter
            .add(t0, out.iter().map(|m| 8 * m.len()), self.rank());
    }

    fn sum_u64(&self, words: &mut [u64]) {
        let t0 = Instant::now();
        let mine = words.to_vec();
        self.world
            .all_reduce_into(&mine[..], words, SystemOperation::sum());
        // counted as one message of the words to one other rank (what 2 ranks send)
        let bytes = 8 * words.len();
        self.meter.add(
            t0,
            (0..self.size()).map(|r| {
                if r == (self.rank() + 1) % self.size() {
                    bytes
                } else {
                    0
                }
            }),
            self.rank(),
        );
    }

    fn traffic(&self) -> Option<Traffic> {
        let m = &self.meter;
        Some(Traffic {
            calls: m.calls.load(Relaxed),
            messages: m.messages.load(Relaxed),
            bytes: m.bytes.load(Relaxed),
            seconds: m.nanos.load(Relaxed) as f64 * 1e-9,
        })
    }
}
