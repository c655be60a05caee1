//! Runs under `mpirun` / `srun` (cargo feature `mpi`; docs/cluster.md): rank 0 is the
//! coordinator of the run — it owns the output directory and the plan, runs units on its own
//! threads and hands ready units to the other ranks, one at a time each
//! ([`grainwave_experiments::work`]); every other rank is a worker that runs the units it is sent
//! ([`grainwave_experiments::registry::serve`]). Messages are byte strings sent with the
//! standard MPI point-to-point calls on the world communicator.

use crate::Ranks;
use grainwave_experiments::work::{Link, WorkerLink};
use mpi::datatype::Equivalence;
use mpi::environment::Universe;
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;
use std::sync::{Arc, Mutex};

/// The MPI environment: finalized when dropped (after every use of its [`Comm`]).
pub struct Mpi {
    _universe: Universe,
}

/// True when one of the MPI launchers started this process (Open MPI's `mpirun`, MPICH's and
/// Intel MPI's hydra, PMIx / PMI-2 launchers such as Slurm's `srun --mpi=…`).
pub fn launched() -> bool {
    ["OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_RANK", "PMI_RANK", "MPI_LOCALNRANKS"].iter().any(|v| std::env::var_os(v).is_some())
}

/// Initializes MPI when launched by an MPI launcher; `None` otherwise (then nothing changes).
pub fn start() -> anyhow::Result<Option<(Mpi, Ranks)>> {
    if !launched() {
        return Ok(None);
    }
    let Some((universe, threading)) = mpi::initialize_with_threading(mpi::Threading::Serialized) else {
        anyhow::bail!("MPI was already initialized");
    };
    // rank 0 calls MPI from one thread per worker rank, one call at a time (under a lock)
    if matches!(threading, mpi::Threading::Single | mpi::Threading::Funneled) {
        anyhow::bail!("the MPI library offers the thread level {threading:?}; grainwave needs `Serialized` or above");
    }
    let world = universe.world();
    let (rank, size) = (world.rank() as usize, world.size() as usize);
    let comm = Arc::new(Comm { world: Mutex::new(world), rank, size });
    let role = if size <= 1 {
        Ranks::Alone
    } else if rank == 0 {
        Ranks::Coordinator(comm)
    } else {
        Ranks::Worker(comm)
    };
    Ok(Some((Mpi { _universe: universe }, role)))
}

/// The world communicator, used by one thread at a time.
pub struct Comm {
    world: Mutex<SimpleCommunicator>,
    rank: usize,
    size: usize,
}

// SAFETY: a `SimpleCommunicator` is a handle (an integer or a pointer to a communicator that
// lives until MPI_Finalize, which runs after every `Comm` is gone: `Mpi` outlives them). MPI was
// initialized at the `Serialized` thread level or above, which allows calls from any thread as
// long as no two are concurrent; every call goes through the mutex.
unsafe impl Send for Comm {}
// SAFETY: as above: shared use is serialized by the mutex.
unsafe impl Sync for Comm {}

impl Comm {
    fn send_to(&self, rank: usize, bytes: &[u8]) -> Result<(), String> {
        if i32::try_from(bytes.len()).is_err() {
            return Err(format!("a message of {} bytes is larger than MPI can send at once (2 GiB)", bytes.len()));
        }
        let world = self.world.lock().map_err(|_| "a thread panicked while sending".to_string())?;
        world.process_at_rank(rank as i32).send(bytes);
        Ok(())
    }

    fn try_receive_from(&self, rank: usize) -> Result<Option<Vec<u8>>, String> {
        let world = self.world.lock().map_err(|_| "a thread panicked while receiving".to_string())?;
        let Some((message, status)) = world.process_at_rank(rank as i32).immediate_matched_probe() else { return Ok(None) };
        let mut bytes = vec![0u8; status.count(u8::equivalent_datatype()).max(0) as usize];
        message.matched_receive_into(&mut bytes[..]);
        Ok(Some(bytes))
    }
}

impl Link for Comm {
    fn workers(&self) -> usize {
        self.size - 1
    }
    fn send(&self, rank: usize, bytes: &[u8]) -> Result<(), String> {
        self.send_to(rank, bytes)
    }
    fn try_receive(&self, rank: usize) -> Result<Option<Vec<u8>>, String> {
        self.try_receive_from(rank)
    }
}

impl WorkerLink for Comm {
    fn rank(&self) -> usize {
        self.rank
    }
    fn receive(&self) -> Result<Vec<u8>, String> {
        // polled rather than a blocking probe, which spins a core in most MPI libraries
        grainwave_experiments::work::poll(|| self.try_receive_from(0))
    }
    fn send(&self, bytes: &[u8]) -> Result<(), String> {
        self.send_to(0, bytes)
    }
}
