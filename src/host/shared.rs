//! Memory shared between `geardyn run` and the process it forks to run the FMU
//! ([`super::supervise`]).
//!
//! An anonymous `MAP_SHARED` mapping made before the fork is the same memory in both processes.
//! The child writes to it with plain stores (no system call, no message per step), and the
//! parent reads it after the child has ended, however it ended: this is how the rows computed
//! but not yet written and the FMI call in progress survive a crash of the FMU.

use std::io;
use std::ptr::NonNull;

/// One zero-initialised, page-aligned `MAP_SHARED | MAP_ANONYMOUS` mapping, unmapped on drop
/// (each process unmaps its own view; the memory lives while either still maps it).
pub struct SharedMemory {
    ptr: NonNull<u8>,
    bytes: usize,
}

impl SharedMemory {
    /// Map `bytes` bytes (at least one), all zero.
    pub fn new(bytes: usize) -> io::Result<SharedMemory> {
        let bytes = bytes.max(1);
        // SAFETY: a fresh anonymous mapping; no existing memory is touched.
        let p = unsafe {
            libc::mmap(
                std::ptr::null_mut(),
                bytes,
                libc::PROT_READ | libc::PROT_WRITE,
                libc::MAP_SHARED | libc::MAP_ANONYMOUS,
                -1,
                0,
            )
        };
        if p == libc::MAP_FAILED {
            return Err(io::Error::last_os_error());
        }
        Ok(SharedMemory {
            ptr: NonNull::new(p.cast()).expect("mmap returned a null mapping"),
            bytes,
        })
    }

    /// The start of the mapping (page-aligned, so aligned for any type).
    pub fn as_ptr(&self) -> *mut u8 {
        self.ptr.as_ptr()
    }
}

impl Drop for SharedMemory {
    fn drop(&mut self) {
        // SAFETY: the mapping was made by `new` with this length and is unmapped once.
        unsafe { libc::munmap(self.ptr.as_ptr().cast(), self.bytes) };
    }
}

// SAFETY: the mapping is plain memory; the types placed in it decide how it is shared.
unsafe impl Send for SharedMemory {}
