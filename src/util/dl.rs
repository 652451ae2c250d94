//! Libraries opened at run time, never linked: `dlopen(RTLD_NOW | RTLD_LOCAL | RTLD_DEEPBIND)`
//! keeps each library's exported names to itself. Embree 4 exports the same unversioned
//! `rtc*` names as Embree 3, and SimGrid exports its own `MPI_*` (SMPI): linked, either would
//! take the place of the other library's functions in a binary built with both features.
//! Each user resolves its own typed function table from [`Library::symbol`].

use std::ffi::{c_char, c_int, c_void, CStr, CString};

// glibc's dynamic loader (in libc.so.6 since glibc 2.34).
const RTLD_NOW: c_int = 2;
const RTLD_LOCAL: c_int = 0;
const RTLD_DEEPBIND: c_int = 8;
extern "C" {
    fn dlopen(filename: *const c_char, flags: c_int) -> *mut c_void;
    fn dlsym(handle: *mut c_void, symbol: *const c_char) -> *mut c_void;
    fn dlerror() -> *mut c_char;
}

/// Why no library opened: every name's `dlerror()` message, joined by `; `.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct DlError(pub String);

/// An open library. The handle is never closed, so every symbol resolved from it stays valid
/// for the whole process.
#[derive(Debug)]
pub struct Library {
    handle: *mut c_void,
}

// SAFETY: a dlopen handle is a process-wide token; glibc's dlsym is thread-safe.
unsafe impl Send for Library {}
// SAFETY: as above; `Library` has no interior state.
unsafe impl Sync for Library {}

/// The last `dlerror()` message.
fn last_error() -> String {
    // SAFETY: `dlerror` returns NULL or a NUL-terminated string valid until the next dl call on
    // this thread; it is copied at once.
    let msg = unsafe { dlerror() };
    if msg.is_null() {
        "unknown dlopen error".into()
    } else {
        // SAFETY: see above.
        unsafe { CStr::from_ptr(msg) }
            .to_string_lossy()
            .into_owned()
    }
}

impl Library {
    /// The first of `names` (paths, or file names looked up through the rpath and
    /// `LD_LIBRARY_PATH`) that opens.
    ///
    /// # Errors
    /// Every name's `dlerror()` message, joined.
    pub fn open_first<S: AsRef<str>>(names: &[S]) -> Result<Self, DlError> {
        let mut errors = Vec::new();
        for name in names {
            let Ok(c_name) = CString::new(name.as_ref()) else {
                errors.push(format!("{}: contains NUL", name.as_ref()));
                continue;
            };
            // SAFETY: `c_name` is NUL-terminated. Opening runs the library's initialisers,
            // which is what using it means.
            let handle = unsafe { dlopen(c_name.as_ptr(), RTLD_NOW | RTLD_LOCAL | RTLD_DEEPBIND) };
            if handle.is_null() {
                errors.push(last_error());
            } else {
                return Ok(Self { handle });
            }
        }
        Err(DlError(errors.join("; ")))
    }

    /// The address of symbol `name` (NUL-terminated, e.g. `"rtcNewDevice\0"`), or null when
    /// the library has none. Calling it needs the caller's knowledge of its signature.
    pub fn symbol(&self, name: &str) -> *mut c_void {
        if !name.ends_with('\0') {
            return std::ptr::null_mut();
        }
        // SAFETY: `handle` came from a successful dlopen and `name` is NUL-terminated.
        unsafe { dlsym(self.handle, name.as_ptr().cast()) }
    }
}

/// A typed function table resolved from a [`Library`]: `dl_api! { struct NAME, abi "C",
/// missing |name| message; fname: fn(args) -> ret; … }` declares `struct NAME` with one
/// `unsafe extern ABI fn` field per function (fields as visible as the struct) and
/// `unsafe fn NAME::resolve(&Library) -> Result<NAME, String>`, which looks every symbol up by
/// its own name and returns `missing(name)` for the first one the library lacks. The ABI is a
/// parameter because SimGrid ends its actors by unwinding through Rust frames (`"C-unwind"`)
/// and Embree never unwinds (`"C"`).
macro_rules! dl_api {
    (
        $(#[$meta:meta])*
        $vis:vis struct $api:ident, abi $abi:literal, missing $missing:expr;
        $($name:ident: fn($($arg:ty),*) $(-> $ret:ty)?;)*
    ) => {
        $(#[$meta])*
        $vis struct $api {
            $($vis $name: unsafe extern $abi fn($($arg),*) $(-> $ret)?,)*
        }

        impl $api {
            /// # Safety
            /// `lib` is the library this table was declared for, whose functions have the
            /// signatures above.
            unsafe fn resolve(lib: &$crate::util::dl::Library) -> Result<Self, String> {
                let missing: fn(&str) -> String = $missing;
                Ok(Self {
                    $($name: {
                        let p = lib.symbol(concat!(stringify!($name), "\0"));
                        if p.is_null() {
                            return Err(missing(stringify!($name)));
                        }
                        // SAFETY: the symbol is the C function of that name (see `# Safety`).
                        unsafe {
                            std::mem::transmute::<
                                *mut std::ffi::c_void,
                                unsafe extern $abi fn($($arg),*) $(-> $ret)?,
                            >(p)
                        }
                    },)*
                })
            }
        }
    };
}
pub(crate) use dl_api;

#[cfg(test)]
mod tests {
    use super::Library;

    #[test]
    fn libc_opens_and_resolves_its_own_names_only() {
        let lib = Library::open_first(&["no-such-library.so", "libc.so.6"]).unwrap();
        assert!(!lib.symbol("malloc\0").is_null());
        assert!(lib.symbol("no_such_symbol_here\0").is_null());
        assert!(
            lib.symbol("malloc").is_null(),
            "a name without NUL is refused"
        );
        let err = Library::open_first(&["no-such-library.so"]).unwrap_err();
        assert!(err.0.contains("no-such-library.so"), "{err}");
    }
}
