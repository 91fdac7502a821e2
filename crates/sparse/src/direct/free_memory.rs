//! Giving the allocator's free memory back to the system before a large
//! numeric factor is allocated (the memory peak of a Tutte map).

/// Factors of at least this many values (32 MB, glibc's largest mmap
/// threshold) are preceded by [`release_free_memory`]; smaller ones, such as
/// the many small systems of the progressive method's Newton steps, are not
/// worth the call.
pub(super) const TRIM_FROM_VALUES: usize = 1 << 22;

/// Hands the allocator's free pages back to the system, so that the factor
/// about to be allocated does not sit beside them: it is the memory peak.
///
/// glibc serves allocations below its mmap threshold, which rises up to 32 MB
/// as large blocks are freed, from its arenas, and keeps what is freed there
/// resident. Before a numeric factorisation the arenas hold what the stages
/// before it freed (the pole search's graph, the cut mesh's half-edges, the
/// weights, the ordering's work arrays): measured at the peak of theta-phi on
/// the 1M helix tube and bumpy blob, 230 MB of free but resident arena memory,
/// a fifth of the peak. `malloc_trim` returns every free page (not only the
/// arena's top); it took 7-33 ms there. Elsewhere it is not needed or
/// not available, and nothing is done.
pub(super) fn release_free_memory() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    {
        extern "C" {
            fn malloc_trim(pad: usize) -> std::ffi::c_int;
        }
        // SAFETY: malloc_trim takes no pointer, only reads and returns the
        // allocator's own free lists, and is thread-safe (glibc locks each
        // arena in turn); Rust's global allocator on linux-gnu is this malloc.
        unsafe {
            malloc_trim(0);
        }
    }
}
