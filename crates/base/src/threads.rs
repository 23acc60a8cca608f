//! Worker threads: the rayon pool every parallel stage of plsr runs on.

use crate::error::{Error, Result};

/// Worker threads allowed per core of the machine: more only costs
/// memory and start-up time (100 000 threads take minutes to start).
pub const MAX_THREADS_PER_CORE: usize = 8;

/// The most worker threads a pool may have on this machine:
/// [`MAX_THREADS_PER_CORE`] per core, and at least 64.
pub fn max_threads() -> usize {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    (MAX_THREADS_PER_CORE * cores).max(64)
}

/// A rayon pool whose workers run with flush-to-zero and denormals-are-zero,
/// as Embree requires of every thread that traces rays. `threads` is 1 to
/// [`max_threads`]; `None` uses every core.
pub fn thread_pool(threads: Option<usize>) -> Result<rayon::ThreadPool> {
    check_thread_count(threads)?;
    let mut b = rayon::ThreadPoolBuilder::new().start_handler(|_| enable_flush_to_zero());
    if let Some(n) = threads {
        b = b.num_threads(n);
    }
    b.build()
        .map_err(|e| Error::InvalidArgument(format!("cannot start worker threads: {e}")))
}

/// Checks a thread count asked for: 1 to [`max_threads`] (`None`: every
/// core). Commands check it before anything sized by it, such as a
/// render's memory estimate.
pub fn check_thread_count(threads: Option<usize>) -> Result<()> {
    match threads {
        Some(0) => Err(Error::InvalidArgument(
            "thread count must be at least 1".into(),
        )),
        Some(n) if n > max_threads() => Err(Error::InvalidArgument(format!(
            "thread count {n} is more than {} ({MAX_THREADS_PER_CORE} per core of this machine)",
            max_threads()
        ))),
        _ => Ok(()),
    }
}

/// Sets flush-to-zero and denormals-are-zero in this thread's MXCSR register.
///
/// Embree asks for both on every thread that traces rays; plsr's rayon pools
/// call this from their start handler. A no-op on targets other than x86-64.
pub fn enable_flush_to_zero() {
    #[cfg(target_arch = "x86_64")]
    {
        const FTZ: u32 = 1 << 15;
        const DAZ: u32 = 1 << 6;
        let mut csr: u32 = 0;
        // SAFETY: stmxcsr/ldmxcsr only read and write the calling thread's
        // SSE control register; setting FTZ and DAZ changes how denormals are
        // rounded and cannot cause undefined behaviour.
        unsafe {
            std::arch::asm!("stmxcsr [{}]", in(reg) &mut csr, options(nostack));
            csr |= FTZ | DAZ;
            std::arch::asm!("ldmxcsr [{}]", in(reg) &csr, options(nostack, readonly));
        }
    }
}

/// Whether flush-to-zero and denormals-are-zero are set on this thread.
pub fn flush_to_zero_enabled() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        let mut csr: u32 = 0;
        // SAFETY: stmxcsr only stores the calling thread's control register.
        unsafe { std::arch::asm!("stmxcsr [{}]", in(reg) &mut csr, options(nostack)) };
        csr & (1 << 15) != 0 && csr & (1 << 6) != 0
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        true
    }
}
