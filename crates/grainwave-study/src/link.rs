//! The transport between a coordinating process and the worker processes that run units of
//! work for it (MPI ranks under `mpirun`, threads in the tests): two traits, implemented by the
//! front end that has the transport (the command line's MPI link). What travels over it is
//! [`crate::work::Message`]; the run context holds the coordinator's side
//! ([`crate::protocol::RunContext::set_remote`]).

/// The coordinator's side of the connection to worker processes that run units for it (MPI ranks
/// 1 … n under `mpirun`; threads in the tests). Messages from one worker arrive in the order it
/// sent them. Errors are texts (the transport's own).
pub trait Link: Send + Sync {
    /// The number of workers: ranks 1 to `workers()`.
    fn workers(&self) -> usize;
    /// Sends `bytes` to worker `rank`.
    fn send(&self, rank: usize, bytes: &[u8]) -> std::result::Result<(), String>;
    /// The next message from worker `rank`, if one has arrived (returns at once).
    fn try_receive(&self, rank: usize) -> std::result::Result<Option<Vec<u8>>, String>;
}

/// A worker's side of a [`Link`].
pub trait WorkerLink {
    /// This worker's rank (≥ 1).
    fn rank(&self) -> usize;
    /// Waits for the next message from the coordinator.
    fn receive(&self) -> std::result::Result<Vec<u8>, String>;
    /// Sends `bytes` to the coordinator.
    fn send(&self, bytes: &[u8]) -> std::result::Result<(), String>;
}
