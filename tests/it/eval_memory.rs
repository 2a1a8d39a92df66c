//! `eval` keeps its promise (nothing written unless every row succeeds) in bounded
//! memory: the allocator of this test binary counts live bytes, and a large input
//! must not raise the peak by more than a fixed bound.
//!
//! One test per file: the counting allocator is global to the test binary.

use std::alloc::{GlobalAlloc, Layout, System};
use std::io::{Read, Write};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

use lobefit::family::EvalFlags;
use lobefit::fits::{self, FitOptions};
use lobefit::tables::Table;

/// System allocator that tracks live and peak heap bytes.
struct Counting;

static LIVE: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        // SAFETY: forwarded unchanged to the system allocator.
        let p = unsafe { System.alloc(layout) };
        if !p.is_null() {
            let now = LIVE.fetch_add(layout.size(), Ordering::Relaxed) + layout.size();
            PEAK.fetch_max(now, Ordering::Relaxed);
        }
        p
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: `ptr` came from `alloc` with this layout.
        unsafe { System.dealloc(ptr, layout) };
        LIVE.fetch_sub(layout.size(), Ordering::Relaxed);
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

/// Rows of the generated input: about 7 MB of CSV in, 26 MB out.
const ROWS: usize = 300_000;
/// Allowed rise of the heap peak during `eval_csv`: the output spool's memory part
/// (4 MiB) plus buffers, with room to spare, and far below what holding the rows
/// takes (about 70 MB before the output was spooled).
const PEAK_BOUND: usize = 16 << 20;

static INPUT_DONE: AtomicBool = AtomicBool::new(false);

/// `e1,e2,alpha` rows of lobe-product's domain, generated on demand.
struct Rows {
    next: usize,
    pending: Vec<u8>,
}

impl Read for Rows {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        if self.pending.is_empty() {
            let i = self.next;
            if i > ROWS {
                INPUT_DONE.store(true, Ordering::SeqCst);
                return Ok(0);
            }
            self.pending = if i == 0 {
                b"e1,e2,alpha\n".to_vec()
            } else {
                let (e1, e2, a) = (1 + i % 997, 1 + (7 * i) % 991, (i % 311) as f64 * 0.01);
                format!("{e1},{e2},{a}\n").into_bytes()
            };
            self.next += 1;
        }
        let n = self.pending.len().min(buf.len());
        buf[..n].copy_from_slice(&self.pending[..n]);
        self.pending.drain(..n);
        Ok(n)
    }
}

/// Counts output bytes; fails the write if the input is not yet exhausted.
struct Sink(u64);

impl Write for Sink {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        assert!(
            INPUT_DONE.load(Ordering::SeqCst),
            "output written before every row was read"
        );
        self.0 += buf.len() as u64;
        Ok(buf.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

#[test]
fn eval_memory_is_bounded_and_output_waits_for_the_last_row() {
    let family = fits::for_eval("lobe-product", &EvalFlags::default(), FitOptions::default()).unwrap();
    let lookup = family.runtime(Table::from_bytes(family.embedded()).unwrap()).unwrap();
    let mut sink = Sink(0);
    let base = LIVE.load(Ordering::SeqCst);
    PEAK.store(base, Ordering::SeqCst);
    let input = Rows {
        next: 0,
        pending: Vec::new(),
    };
    let n = lobefit::eval::eval_csv(family.as_ref(), Some(lookup.as_ref()), input, &mut sink)
        .unwrap()
        .rows;
    let rise = PEAK.load(Ordering::SeqCst) - base;
    assert_eq!(n, ROWS);
    assert!(sink.0 > 20_000_000, "{} output bytes", sink.0);
    assert!(rise < PEAK_BOUND, "heap peak rose by {rise} bytes for {ROWS} rows");
}
