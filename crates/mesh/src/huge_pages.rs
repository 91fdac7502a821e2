//! The global allocator of the Python extension: the system allocator, with
//! every block of at least [`ADVISED_FROM`] bytes (32 MiB) offered transparent huge
//! pages (`madvise(MADV_HUGEPAGE)` on the 2 MiB pages that lie wholly inside
//! it). Linux's default THP mode, `madvise`, gives huge pages only where
//! asked. The largest buffers of a big map (at 1M vertices the hierarchy's
//! quadrics and the sweeps' star references, each over 32 MiB) are touched
//! first in parallel passes and then read at random: with 4 KiB pages each
//! first touch is a page fault (327k of them in one process that makes and
//! maps a 1M-vertex shape) and each random read risks a TLB miss.
//!
//! Measured on 1M-vertex `tentacles`, default map, 2 threads (issue 27): see
//! `docs/benchmarks.md`, "Issue 27: session 11". The advice changes no result:
//! only where the memory sits.
//!
//! Where the kernel has THP off (`never`), or on other systems, the advice
//! is ignored or compiled out and this is the system allocator.

use std::alloc::{GlobalAlloc, Layout, System};

/// Size of the huge pages advised (x86-64 and aarch64 with 4 KiB base pages).
const HUGE_PAGE: usize = 2 << 20;
/// Smallest block advised: 32 MiB, the most glibc's dynamic mmap threshold
/// can rise to, so every advised block is a mapping of its own and the advice
/// covers it whole. Smaller blocks may come from the allocator's heaps, where
/// the advice splits the heap's mapping and its later trims split the huge
/// pages again: advising from 4 MiB, the 10M-vertex `tentacles` map took
/// 60.5 s against 48.2 s without advice (43.2 s from 32 MiB), though 1M
/// vertices gained either way.
pub const ADVISED_FROM: usize = 32 << 20;

/// See the module notes.
pub struct HugePageAllocator;

/// Advises huge pages for the whole 2 MiB pages inside `[ptr, ptr + size)`.
fn advise(ptr: *mut u8, size: usize) {
    #[cfg(target_os = "linux")]
    if size >= ADVISED_FROM && !ptr.is_null() {
        let start = (ptr as usize).next_multiple_of(HUGE_PAGE);
        let end = (ptr as usize + size) / HUGE_PAGE * HUGE_PAGE;
        if end > start {
            // SAFETY: the range lies inside a block the system allocator has
            // just handed out and no one else owns; MADV_HUGEPAGE changes only
            // how the kernel backs the pages, never their contents, and its
            // failure (THP off, old kernel) leaves them as they were.
            unsafe {
                libc::madvise(start as *mut libc::c_void, end - start, libc::MADV_HUGEPAGE);
            }
        }
    }
    #[cfg(not(target_os = "linux"))]
    let _ = (ptr, size);
}

// SAFETY: every call is the system allocator's, with the same arguments;
// `advise` only adds a hint about how the kernel backs the block's pages.
unsafe impl GlobalAlloc for HugePageAllocator {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let block = System.alloc(layout);
        advise(block, layout.size());
        block
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        let block = System.alloc_zeroed(layout);
        advise(block, layout.size());
        block
    }

    unsafe fn dealloc(&self, block: *mut u8, layout: Layout) {
        System.dealloc(block, layout)
    }

    unsafe fn realloc(&self, block: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        let moved = System.realloc(block, layout, new_size);
        advise(moved, new_size);
        moved
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The `THPeligible` flag of the mapping that holds `address`, from
    /// /proc/self/smaps (None where the kernel does not report it).
    #[cfg(target_os = "linux")]
    fn eligible(address: usize) -> Option<bool> {
        let smaps = std::fs::read_to_string("/proc/self/smaps").ok()?;
        let mut inside = false;
        for line in smaps.lines() {
            let first = line.split_whitespace().next().unwrap_or("");
            if let Some((lo, hi)) = first.split_once('-') {
                if let (Ok(lo), Ok(hi)) =
                    (usize::from_str_radix(lo, 16), usize::from_str_radix(hi, 16))
                {
                    inside = (lo..hi).contains(&address);
                    continue;
                }
            }
            if inside {
                if let Some(flag) = line.strip_prefix("THPeligible:") {
                    return Some(flag.trim() == "1");
                }
            }
        }
        None
    }

    #[test]
    fn blocks_keep_their_contents_through_realloc_and_free() {
        let allocator = HugePageAllocator;
        for size in [16, ADVISED_FROM - 8, ADVISED_FROM, 3 * ADVISED_FROM + 12_345] {
            let layout = Layout::from_size_align(size, 16).unwrap();
            unsafe {
                let block = allocator.alloc_zeroed(layout);
                assert!(!block.is_null());
                assert!((0..size).step_by(4093).all(|i| *block.add(i) == 0));
                for i in (0..size).step_by(4093) {
                    *block.add(i) = (i % 251) as u8;
                }
                let grown = allocator.realloc(block, layout, 2 * size);
                assert!((0..size).step_by(4093).all(|i| *grown.add(i) == (i % 251) as u8));
                allocator.dealloc(grown, Layout::from_size_align(2 * size, 16).unwrap());
            }
        }
    }

    #[cfg(target_os = "linux")]
    #[test]
    fn a_large_block_is_offered_huge_pages_where_the_kernel_has_them() {
        let mode = std::fs::read_to_string("/sys/kernel/mm/transparent_hugepage/enabled");
        let Ok(mode) = mode else { return };
        if mode.contains("[never]") {
            return;
        }
        let allocator = HugePageAllocator;
        let size = ADVISED_FROM + 4 * HUGE_PAGE;
        let layout = Layout::from_size_align(size, 64).unwrap();
        unsafe {
            let block = allocator.alloc(layout);
            let inside = (block as usize).next_multiple_of(HUGE_PAGE);
            let verdict = eligible(inside);
            allocator.dealloc(block, layout);
            if let Some(verdict) = verdict {
                assert!(verdict, "the block's 2 MiB pages are not THP-eligible");
            }
        }
    }
}
