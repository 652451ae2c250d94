//! Raw MPI calls on `MPI_COMM_WORLD`, with their return codes kept, and [`backoff`], how every
//! loop that polls them idles.
//!
//! The `mpi` crate initialises and owns the [`mpi::environment::Universe`], but its
//! point-to-point calls drop MPI's return codes. After a rank is killed (`kill -9` under
//! `mpirun --enable-recovery`) the survivors only keep going if the communicator's error handler
//! is `MPI_ERRORS_RETURN` and every call's code is looked at, so the few calls this module needs
//! go straight to `mpi-sys`. Everything here runs on the one thread that initialised MPI
//! (`MPI_THREAD_FUNNELED`): [`Comm`] is neither `Send` nor `Sync`.

use mpi::environment::Universe;
use mpi::ffi;
use mpi::Threading;
use std::marker::PhantomData;
use std::os::raw::c_int;
use std::time::Duration;

/// Message tags of the raysched protocol.
pub mod tag {
    /// rank 0 → worker: an encoded `WorkItem`.
    pub const ITEM: i32 = 1;
    /// worker → rank 0: an encoded `TileResult` plus busy nanoseconds.
    pub const RESULT: i32 = 2;
    /// rank 0 → worker: stop; one byte, 1 = call `MPI_Finalize`, 0 = exit without it.
    pub const STOP: i32 = 3;
    /// worker → rank 0: the scene was (or was not) built; see `wire::Ready`.
    pub const READY: i32 = 4;
    /// worker → rank 0: acknowledges STOP, nothing of it follows.
    pub const BYE: i32 = 5;
    /// rank 0 → worker: an encoded `ScenePackage` to build (replacing the current scene);
    /// answered with READY. `raysched run` sends one per (scene, tracer).
    pub const SCENE: i32 = 6;
    /// worker → rank 0: alive and busy (empty), sent while an item takes long.
    pub const HEARTBEAT: i32 = 7;
}

#[derive(Debug, thiserror::Error)]
#[error("MPI_{call} failed with error code {code}")]
/// An MPI call that returned an error code.
pub struct MpiError {
    /// The call, without its `MPI_` prefix (`Send`, `Iprobe`, …).
    pub call: &'static str,
    /// MPI's return code (-1 for a check of this module's own).
    pub code: i32,
}

fn check(call: &'static str, code: c_int) -> Result<(), MpiError> {
    if code == ffi::MPI_SUCCESS as c_int {
        Ok(())
    } else {
        Err(MpiError { call, code })
    }
}

/// The world communicator of an initialised MPI; owns the universe.
pub struct Comm {
    universe: Option<Universe>,
    /// This process's rank in `MPI_COMM_WORLD`.
    pub rank: i32,
    /// Number of ranks in `MPI_COMM_WORLD`.
    pub size: i32,
    _not_send: PhantomData<*const ()>,
}

/// A send in flight; its buffer lives until MPI says the send is done.
pub struct SendReq {
    req: ffi::MPI_Request,
    buf: Option<Box<[u8]>>,
}

impl Drop for SendReq {
    fn drop(&mut self) {
        // Never completed (a dead rank): MPI may still read the buffer, so leak it.
        if let Some(b) = self.buf.take() {
            std::mem::forget(b);
        }
    }
}

/// A message waiting to be received.
#[derive(Clone, Copy, Debug)]
pub struct Pending {
    /// The sending rank.
    pub source: i32,
    /// The message's tag (see [`tag`]).
    pub tag: i32,
    /// Its length in bytes.
    pub bytes: usize,
}

impl Comm {
    /// Initialise MPI (`FUNNELED`: only this thread will call MPI) and make errors return.
    pub fn init() -> Result<Self, MpiError> {
        let (universe, _level) =
            mpi::initialize_with_threading(Threading::Funneled).ok_or(MpiError {
                call: "Init_thread (MPI already initialised)",
                code: -1,
            })?;
        let (mut rank, mut size) = (0, 0);
        // SAFETY: MPI is initialised; RSMPI_COMM_WORLD and RSMPI_ERRORS_RETURN are valid handles
        // exported by mpi-sys, and rank/size are valid out-pointers.
        unsafe {
            check(
                "Comm_set_errhandler",
                ffi::MPI_Comm_set_errhandler(ffi::RSMPI_COMM_WORLD, ffi::RSMPI_ERRORS_RETURN),
            )?;
            check(
                "Comm_rank",
                ffi::MPI_Comm_rank(ffi::RSMPI_COMM_WORLD, &mut rank),
            )?;
            check(
                "Comm_size",
                ffi::MPI_Comm_size(ffi::RSMPI_COMM_WORLD, &mut size),
            )?;
        }
        Ok(Self {
            universe: Some(universe),
            rank,
            size,
            _not_send: PhantomData,
        })
    }

    /// Blocking send of `bytes` to `dest`.
    pub fn send(&self, dest: i32, tag: i32, bytes: &[u8]) -> Result<(), MpiError> {
        // SAFETY: the buffer is valid for `bytes.len()` bytes for the duration of the blocking
        // call; the datatype and communicator are valid mpi-sys handles.
        check("Send", unsafe {
            ffi::MPI_Send(
                bytes.as_ptr().cast(),
                bytes.len() as c_int,
                ffi::RSMPI_UINT8_T,
                dest,
                tag,
                ffi::RSMPI_COMM_WORLD,
            )
        })
    }

    /// Non-blocking send of `bytes` to `dest`: the hub must never block on a rank that died
    /// (measured: OpenMPI 4.1's blocking `MPI_Send` to a `kill -9`ed rank over tcp hangs
    /// forever, even under `--enable-recovery`).
    pub fn isend(&self, dest: i32, tag: i32, bytes: Vec<u8>) -> Result<SendReq, MpiError> {
        let buf = bytes.into_boxed_slice();
        let mut req = std::mem::MaybeUninit::<ffi::MPI_Request>::uninit();
        // SAFETY: `buf` is heap memory owned by the returned SendReq, which keeps it alive
        // (or leaks it) until MPI reports the send complete; the handles are valid.
        check("Isend", unsafe {
            ffi::MPI_Isend(
                buf.as_ptr().cast(),
                buf.len() as c_int,
                ffi::RSMPI_UINT8_T,
                dest,
                tag,
                ffi::RSMPI_COMM_WORLD,
                req.as_mut_ptr(),
            )
        })?;
        Ok(SendReq {
            // SAFETY: MPI_Isend succeeded and wrote the request.
            req: unsafe { req.assume_init() },
            buf: Some(buf),
        })
    }

    /// Has the send completed? (Then its buffer is released.)
    pub fn test(&self, s: &mut SendReq) -> Result<bool, MpiError> {
        if s.buf.is_none() {
            return Ok(true);
        }
        let mut flag = 0;
        let mut status = std::mem::MaybeUninit::<ffi::MPI_Status>::zeroed();
        // SAFETY: `s.req` is an active request from MPI_Isend; flag and status are valid
        // out-pointers.
        check("Test", unsafe {
            ffi::MPI_Test(&mut s.req, &mut flag, status.as_mut_ptr())
        })?;
        if flag != 0 {
            s.buf = None;
        }
        Ok(flag != 0)
    }

    fn pending_of(status: &ffi::MPI_Status) -> Result<Pending, MpiError> {
        let mut count = 0;
        // SAFETY: `status` was filled by a successful probe; count is a valid out-pointer.
        check("Get_count", unsafe {
            ffi::MPI_Get_count(status, ffi::RSMPI_UINT8_T, &mut count)
        })?;
        Ok(Pending {
            source: status.MPI_SOURCE,
            tag: status.MPI_TAG,
            bytes: count.max(0) as usize,
        })
    }

    /// Is a message from `source` (`None` = any) waiting? Never blocks.
    pub fn iprobe(&self, source: Option<i32>) -> Result<Option<Pending>, MpiError> {
        let mut flag = 0;
        let mut status = std::mem::MaybeUninit::<ffi::MPI_Status>::zeroed();
        // SAFETY: flag and status are valid out-pointers; the handles are valid.
        unsafe {
            check(
                "Iprobe",
                ffi::MPI_Iprobe(
                    source.unwrap_or(ffi::RSMPI_ANY_SOURCE),
                    ffi::RSMPI_ANY_TAG,
                    ffi::RSMPI_COMM_WORLD,
                    &mut flag,
                    status.as_mut_ptr(),
                ),
            )?;
            if flag == 0 {
                return Ok(None);
            }
            Self::pending_of(&status.assume_init()).map(Some)
        }
    }

    /// Wait for a message from `source`.
    pub fn probe(&self, source: i32) -> Result<Pending, MpiError> {
        let mut status = std::mem::MaybeUninit::<ffi::MPI_Status>::zeroed();
        // SAFETY: status is a valid out-pointer; the handles are valid.
        unsafe {
            check(
                "Probe",
                ffi::MPI_Probe(
                    source,
                    ffi::RSMPI_ANY_TAG,
                    ffi::RSMPI_COMM_WORLD,
                    status.as_mut_ptr(),
                ),
            )?;
            Self::pending_of(&status.assume_init())
        }
    }

    /// Receive the message `p` announced by a probe.
    pub fn recv(&self, p: Pending) -> Result<Vec<u8>, MpiError> {
        let mut buf = vec![0u8; p.bytes];
        let mut status = std::mem::MaybeUninit::<ffi::MPI_Status>::zeroed();
        // SAFETY: buf has room for `p.bytes` bytes, the size the probe reported for this
        // (source, tag); status is a valid out-pointer.
        check("Recv", unsafe {
            ffi::MPI_Recv(
                buf.as_mut_ptr().cast(),
                p.bytes as c_int,
                ffi::RSMPI_UINT8_T,
                p.source,
                p.tag,
                ffi::RSMPI_COMM_WORLD,
                status.as_mut_ptr(),
            )
        })?;
        Ok(buf)
    }

    /// Broadcast a byte buffer from rank 0 (length first, then the bytes).
    pub fn broadcast(&self, bytes: Option<Vec<u8>>) -> Result<Vec<u8>, MpiError> {
        let mut len: u64 = bytes.as_ref().map_or(0, |b| b.len() as u64);
        // SAFETY: `len` is one valid u64 on every rank; the handles are valid.
        check("Bcast", unsafe {
            ffi::MPI_Bcast(
                (&mut len as *mut u64).cast(),
                8,
                ffi::RSMPI_UINT8_T,
                0,
                ffi::RSMPI_COMM_WORLD,
            )
        })?;
        let mut buf = bytes.unwrap_or_else(|| vec![0u8; len as usize]);
        // Scene packages beyond 2 GiB would need chunking; refuse them rather than truncate.
        if len > c_int::MAX as u64 {
            return Err(MpiError {
                call: "Bcast (scene package over 2 GiB)",
                code: -1,
            });
        }
        if len > 0 {
            // SAFETY: buf holds exactly `len` bytes on every rank.
            check("Bcast", unsafe {
                ffi::MPI_Bcast(
                    buf.as_mut_ptr().cast(),
                    len as c_int,
                    ffi::RSMPI_UINT8_T,
                    0,
                    ffi::RSMPI_COMM_WORLD,
                )
            })?;
        }
        Ok(buf)
    }

    /// Shut down: `MPI_Finalize` when every rank is alive; after a rank was lost, exit without
    /// it (measured with OpenMPI 4.1 `--enable-recovery`: finalize then hangs or errors, while
    /// skipping it lets mpirun end the job cleanly, 6 of 6 runs).
    pub fn shutdown(mut self, finalize: bool, code: i32) -> ! {
        use std::io::Write;
        let _ = std::io::stdout().flush();
        let _ = std::io::stderr().flush();
        if finalize {
            drop(self.universe.take()); // MPI_Finalize
        } else {
            std::mem::forget(self.universe.take());
        }
        std::process::exit(code)
    }
}

/// Poll hard while messages flow, then yield, then sleep briefly, and longer once idle for
/// long (a worker between runs while rank 0 times local threads): a loop that only spun
/// would take a core from the renderers on a small machine. The 200 µs sleep bounds the
/// extra start latency of a run at 0.2 ms.
pub fn backoff(idle: u32) {
    if idle == 0 {
    } else if idle < 64 {
        std::hint::spin_loop();
    } else if idle < 4096 {
        std::thread::yield_now();
    } else if idle < 20_000 {
        std::thread::sleep(Duration::from_micros(50));
    } else {
        std::thread::sleep(Duration::from_micros(200));
    }
}
