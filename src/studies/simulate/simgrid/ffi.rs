//! Hand-written bindings to SimGrid 3.32's C API (Debian's `libsimgrid-dev`) and the safe
//! wrappers the simulation protocols use. The only `unsafe` of the simulator lives here.
//!
//! Imports and actor callbacks are `extern "C-unwind"`: SimGrid ends daemon actors and actors
//! of a host turned off by unwinding their stacks, and with `"C"` the Rust destructors on those
//! stacks would be skipped. SimGrid runs every actor on one thread (boost contexts), so the
//! wrappers keep their registry in a thread-local.

use std::cell::RefCell;
use std::ffi::{c_char, c_int, c_long, c_void, CStr, CString};
use std::marker::PhantomData;

#[repr(C)]
struct OpaqueHost {
    _private: [u8; 0],
}
#[repr(C)]
struct OpaqueActor {
    _private: [u8; 0],
}
#[repr(C)]
struct OpaqueMailbox {
    _private: [u8; 0],
}
#[repr(C)]
struct OpaqueComm {
    _private: [u8; 0],
}
#[repr(C)]
struct OpaqueSem {
    _private: [u8; 0],
}

type ActorMain = extern "C-unwind" fn(c_int, *mut *mut c_char);
type Cleanup = extern "C" fn(*mut c_void);

extern "C" {
    fn free(p: *mut c_void);
}

crate::util::dl::dl_api! {
    /// SimGrid's functions, resolved in the library opened with `RTLD_LOCAL`.
    struct Api, abi "C-unwind", missing |name| format!("SimGrid has no symbol {name}");
    simgrid_init: fn(*mut c_int, *mut *mut c_char);
    simgrid_load_platform: fn(*const c_char);
    simgrid_run: fn();
    simgrid_get_clock: fn() -> f64;
    sg_host_count: fn() -> usize;
    sg_host_list: fn() -> *mut *mut OpaqueHost;
    sg_host_get_name: fn(*const OpaqueHost) -> *const c_char;
    sg_host_get_speed: fn(*const OpaqueHost) -> f64;
    sg_host_core_count: fn(*const OpaqueHost) -> c_int;
    sg_host_turn_off: fn(*mut OpaqueHost);
    sg_host_get_route_latency: fn(*const OpaqueHost, *const OpaqueHost) -> f64;
    sg_host_get_route_bandwidth: fn(*const OpaqueHost, *const OpaqueHost) -> f64;
    sg_actor_create_: fn(*const c_char, *mut OpaqueHost, ActorMain, c_int, *mut *mut c_char) -> *mut OpaqueActor;
    sg_actor_daemonize: fn(*mut OpaqueActor);
    sg_actor_execute: fn(f64);
    sg_actor_sleep_for: fn(f64);
    sg_mailbox_by_name: fn(*const c_char) -> *mut OpaqueMailbox;
    sg_mailbox_set_receiver: fn(*const c_char);
    sg_mailbox_listen: fn(*const c_char) -> c_int;
    sg_mailbox_put_init: fn(*mut OpaqueMailbox, *mut c_void, c_long) -> *mut OpaqueComm;
    sg_comm_detach: fn(*mut OpaqueComm, Option<Cleanup>);
    sg_mailbox_get: fn(*mut OpaqueMailbox) -> *mut c_void;
    sg_sem_init: fn(c_int) -> *mut OpaqueSem;
    sg_sem_acquire: fn(*mut OpaqueSem);
    sg_sem_acquire_timeout: fn(*mut OpaqueSem, f64) -> c_int;
    sg_sem_release: fn(*mut OpaqueSem);
}

/// SimGrid's functions, the library opened on first use. SimGrid is opened, not linked: it
/// exports its own `MPI_*` functions (SMPI), which would take the place of OpenMPI's in a
/// binary built with `mpi` too. `RTLD_LOCAL | RTLD_DEEPBIND` keeps each library's names to
/// itself.
///
/// # Errors
/// The library or one of its functions is missing (the message says to install
/// libsimgrid-dev).
pub fn open() -> Result<(), super::SimgridError> {
    match loaded() {
        Ok(_) => Ok(()),
        Err(e) => Err(super::SimgridError::Library(e.clone())),
    }
}

fn loaded() -> &'static Result<Api, String> {
    static API: std::sync::OnceLock<Result<Api, String>> = std::sync::OnceLock::new();
    API.get_or_init(|| {
        let lib = crate::util::dl::Library::open_first(&["libsimgrid.so", "libsimgrid.so.3.32"])
            .map_err(|e| format!("cannot open SimGrid (install libsimgrid-dev): {e}"))?;
        // SAFETY: `lib` is SimGrid's library, opened by its name and never closed.
        unsafe { Api::resolve(&lib) }
    })
}

/// The functions, once [`init`] has opened them (every other call here comes after it).
fn api() -> &'static Api {
    match loaded() {
        Ok(api) => api,
        // Unreachable after `init`'s check; a one-line exit rather than a panic in C's stack.
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(2)
        }
    }
}

/// Start the engine with SimGrid command-line options (`--cfg=…`, `--log=…`). Once per process:
/// SimGrid's engine is a singleton that cannot be re-created after a run.
///
/// # Errors
/// SimGrid cannot be opened ([`open`]).
pub fn init(options: &[String]) -> Result<(), super::SimgridError> {
    open()?;
    let mut owned: Vec<CString> = std::iter::once("raysched".to_string())
        .chain(options.iter().cloned())
        .map(|s| CString::new(s).unwrap_or_default())
        .collect();
    let mut argv: Vec<*mut c_char> = owned
        .iter_mut()
        .map(|s| s.as_ptr() as *mut c_char)
        .collect();
    argv.push(std::ptr::null_mut());
    let mut argc = owned.len() as c_int;
    // SAFETY: argc/argv describe NUL-terminated strings that outlive the call (SimGrid copies
    // what it keeps); the array ends with a null pointer as a C main's argv does.
    unsafe { (api().simgrid_init)(&mut argc, argv.as_mut_ptr()) };
    std::mem::forget(owned); // SimGrid may keep argv[0]; a few bytes, once per process.
    Ok(())
}

/// Load a platform XML file. A malformed file makes SimGrid abort the process: callers load
/// it in a child process first ([`crate::studies::simulate::simgrid::inspect_platform`]).
pub fn load_platform(path: &str) {
    let c = CString::new(path).unwrap_or_default();
    // SAFETY: a valid NUL-terminated path, read during the call only.
    unsafe { (api().simgrid_load_platform)(c.as_ptr()) }
}

/// Run the simulation until no non-daemon actor is left.
pub fn run() {
    // SAFETY: no arguments; the engine was initialised and the platform loaded by the caller.
    unsafe { (api().simgrid_run)() }
}

/// Simulated time, seconds.
pub fn clock() -> f64 {
    // SAFETY: reads the engine's clock; no pointers.
    unsafe { (api().simgrid_get_clock)() }
}

/// A host of the loaded platform.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Host(*mut OpaqueHost);

impl Host {
    /// Every host, in the engine's order.
    pub fn all() -> Vec<Host> {
        // SAFETY: sg_host_count/sg_host_list read the loaded platform; the list holds
        // sg_host_count() pointers, is owned by the caller and freed with free() after copying.
        unsafe {
            let n = (api().sg_host_count)();
            let list = (api().sg_host_list)();
            if list.is_null() {
                return Vec::new();
            }
            let hosts = std::slice::from_raw_parts(list, n)
                .iter()
                .map(|&h| Host(h))
                .collect();
            free(list as *mut c_void);
            hosts
        }
    }
    /// The host's name.
    pub fn name(self) -> String {
        // SAFETY: self is a live host of the platform; the returned string is owned by SimGrid
        // and copied before anything can free it.
        unsafe { CStr::from_ptr((api().sg_host_get_name)(self.0)) }
            .to_string_lossy()
            .into_owned()
    }
    /// Peak speed of one core, flop/s.
    pub fn speed(self) -> f64 {
        // SAFETY: self is a live host of the platform.
        unsafe { (api().sg_host_get_speed)(self.0) }
    }
    /// Number of cores.
    pub fn cores(self) -> usize {
        // SAFETY: self is a live host of the platform.
        unsafe { (api().sg_host_core_count)(self.0) }.max(0) as usize
    }
    /// The route to `to` as the platform file writes it: Σ of its links' latencies, seconds,
    /// and its narrowest link's bandwidth, bytes/s (the network model's factors not applied).
    pub fn route_to(self, to: Host) -> (f64, f64) {
        // SAFETY: both hosts belong to the loaded platform; the calls only read its routing.
        unsafe {
            (
                (api().sg_host_get_route_latency)(self.0, to.0),
                (api().sg_host_get_route_bandwidth)(self.0, to.0),
            )
        }
    }
    /// Turn the host off: its actors are killed (their stacks unwound), its comms fail.
    pub fn turn_off(self) {
        // SAFETY: self is a live host; called from an actor during the run.
        unsafe { (api().sg_host_turn_off)(self.0) }
    }
}

/// An actor's body, run once when SimGrid starts the actor.
type Body = Box<dyn FnOnce()>;

thread_local! {
    /// Bodies of actors created but not started yet; an actor's argv[1] is its index here.
    static BODIES: RefCell<Vec<Option<Body>>> = const { RefCell::new(Vec::new()) };
}

extern "C-unwind" fn trampoline(argc: c_int, argv: *mut *mut c_char) {
    let index = if argc >= 2 {
        // SAFETY: SimGrid passes argc valid NUL-terminated strings in argv.
        unsafe { CStr::from_ptr(*argv.add(1)) }
            .to_str()
            .ok()
            .and_then(|s| s.parse::<usize>().ok())
    } else {
        None
    };
    let body =
        index.and_then(|i| BODIES.with(|b| b.borrow_mut().get_mut(i).and_then(Option::take)));
    if let Some(body) = body {
        body();
    }
}

/// Create an actor named `name` on `host` running `body`; a daemon is killed when the last
/// non-daemon actor ends.
pub fn spawn(name: &str, host: Host, daemon: bool, body: impl FnOnce() + 'static) {
    let index = BODIES.with(|b| {
        let mut b = b.borrow_mut();
        b.push(Some(Box::new(body)));
        b.len() - 1
    });
    let name = CString::new(name).unwrap_or_default();
    let arg = CString::new(index.to_string()).unwrap_or_default();
    let mut argv = [name.as_ptr() as *mut c_char, arg.as_ptr() as *mut c_char];
    // SAFETY: host is a live host; argv holds two NUL-terminated strings that outlive the call
    // (SimGrid copies them into the actor's own argument vector); trampoline has the C
    // signature SimGrid expects.
    unsafe {
        let actor =
            (api().sg_actor_create_)(name.as_ptr(), host.0, trampoline, 2, argv.as_mut_ptr());
        if daemon && !actor.is_null() {
            (api().sg_actor_daemonize)(actor);
        }
    }
}

/// Compute `flops` on the calling actor's host (shared with the host's other executions).
pub fn execute(flops: f64) {
    if flops > 0.0 {
        // SAFETY: called from an actor; no pointers.
        unsafe { (api().sg_actor_execute)(flops) }
    }
}

/// Let `seconds` of simulated time pass for the calling actor, using no CPU.
pub fn sleep_for(seconds: f64) {
    if seconds > 0.0 {
        // SAFETY: called from an actor; no pointers.
        unsafe { (api().sg_actor_sleep_for)(seconds) }
    }
}

/// A mailbox carrying boxed values of type `T` only.
pub struct Mailbox<T> {
    raw: *mut OpaqueMailbox,
    name: CString,
    _t: PhantomData<fn(T) -> T>,
}

extern "C" fn drop_box<T>(p: *mut c_void) {
    if !p.is_null() {
        // SAFETY: p came from Box::<T>::into_raw in put_detached and was not delivered.
        drop(unsafe { Box::from_raw(p as *mut T) });
    }
}

impl<T: 'static> Mailbox<T> {
    /// The mailbox called `name` (created on first use).
    pub fn by_name(name: &str) -> Self {
        let name = CString::new(name).unwrap_or_default();
        // SAFETY: a valid NUL-terminated name; SimGrid owns the mailbox for the whole run.
        let raw = unsafe { (api().sg_mailbox_by_name)(name.as_ptr()) };
        Self {
            raw,
            name,
            _t: PhantomData,
        }
    }
    /// Make the calling actor this mailbox's receiver: messages are transferred as soon as
    /// they are sent (eager), not when `get` is called.
    pub fn set_receiver(&self) {
        // SAFETY: a valid NUL-terminated name; called from an actor.
        unsafe { (api().sg_mailbox_set_receiver)(self.name.as_ptr()) }
    }
    /// Is a message waiting (sent or already transferred)?
    pub fn has_message(&self) -> bool {
        // SAFETY: a valid NUL-terminated name; called from an actor.
        unsafe { (api().sg_mailbox_listen)(self.name.as_ptr()) != 0 }
    }
    /// Send `value`, simulated as `bytes` bytes, without waiting for its delivery. An
    /// undeliverable value (its receiver's host turned off) is dropped by SimGrid's cleanup.
    pub fn put_detached(&self, value: T, bytes: u64) {
        let payload = Box::into_raw(Box::new(value)) as *mut c_void;
        // SAFETY: the mailbox is live; payload is a Box<T> pointer owned from here on by the
        // comm, which either delivers it to `get` (which boxes it back) or frees it with
        // drop_box::<T>, the matching destructor.
        unsafe {
            let comm = (api().sg_mailbox_put_init)(self.raw, payload, bytes.max(1) as c_long);
            (api().sg_comm_detach)(comm, Some(drop_box::<T>));
        }
    }
    /// Wait for the next value.
    pub fn get(&self) -> T {
        // SAFETY: every payload on a Mailbox<T> was put by put_detached as a Box<T> (the type
        // parameter makes another type impossible), and each is delivered exactly once.
        unsafe { *Box::from_raw((api().sg_mailbox_get)(self.raw) as *mut T) }
    }
}

/// A counting semaphore of the simulation: a synchronisation without any network or CPU use.
#[derive(Clone, Copy, Debug)]
pub struct Semaphore(*mut OpaqueSem);

impl Semaphore {
    /// A semaphore holding `count` tokens (lives until the process ends: one run per process).
    pub fn new(count: u32) -> Self {
        // SAFETY: creates a semaphore object; no pointers passed.
        Self(unsafe { (api().sg_sem_init)(count.min(i32::MAX as u32) as c_int) })
    }
    /// Take a token, waiting (in simulated time) until one is released.
    pub fn acquire(self) {
        // SAFETY: self.0 is a live semaphore (never destroyed); called from an actor.
        unsafe { (api().sg_sem_acquire)(self.0) }
    }
    /// Take a token, waiting at most `timeout` seconds of simulated time; false if none came.
    pub fn acquire_timeout(self, timeout: f64) -> bool {
        // SAFETY: as in `acquire`. SimGrid returns non-zero on a timeout.
        unsafe { (api().sg_sem_acquire_timeout)(self.0, timeout) == 0 }
    }
    /// Give a token back, waking one waiting actor.
    pub fn release(self) {
        // SAFETY: as in `acquire`.
        unsafe { (api().sg_sem_release)(self.0) }
    }
}
