//! Lookups allocate nothing: a counting global allocator for this test binary proves it.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

use super::{at, float_image, set_of};
use crate::{sample, sample_with, ColorSpace, Filter, Lookup, PageTouches, Samples, SourceImage, Wrap};

struct Counting;

thread_local! {
    // Per thread, so tests running in parallel do not see each other's allocations. `const` init and a
    // `Copy` payload mean no lazy initialisation and no destructor, so `with` never allocates itself.
    static ALLOCATIONS: Cell<u64> = const { Cell::new(0) };
}

// SAFETY: forwards every call unchanged to `System`, which upholds the `GlobalAlloc` contract; the
// counter update neither allocates nor unwinds.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.with(|c| c.set(c.get() + 1));
        // SAFETY: the caller's contract for `alloc` is passed through.
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: `ptr` came from `System.alloc` with this layout.
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        ALLOCATIONS.with(|c| c.set(c.get() + 1));
        // SAFETY: the caller's contract for `realloc` is passed through.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static COUNTING: Counting = Counting;

fn allocations() -> u64 {
    ALLOCATIONS.with(|c| c.get())
}

#[test]
fn lookups_do_not_allocate() {
    let rgba8 = SourceImage {
        width: 100,
        height: 60,
        channels: 4,
        samples: Samples::U8((0..100 * 60 * 4).map(|i| (i * 7 % 256) as u8).collect()),
    };
    let grey_f = float_image(37, 1, 1, (0..37).map(|i| i as f32).collect());
    let set = set_of(&[(rgba8, ColorSpace::Auto), (grey_f, ColorSpace::Raw)]);
    let view = set.view().unwrap();
    let touches = PageTouches::new(set.texels.len());

    let before = allocations();
    let mut sum = 0.0;
    for t in 0..2 {
        let tex = view.texture(t).unwrap();
        for filter in Filter::ALL {
            for wrap in [Wrap::Repeat, Wrap::Mirror, Wrap::Clamp, Wrap::Black] {
                for i in 0..200 {
                    let f = i as f32 * 0.013 - 0.5;
                    let d = [f * 0.1, 0.003];
                    sum += sample(&tex, [f, 1.0 - f], d, [0.001, -f * 0.05], filter, wrap, wrap)[0];
                    let q = Lookup { uv: [f, f], duv_dx: d, duv_dy: d, filter, wrap_s: wrap, wrap_t: wrap };
                    sum += sample_with(&tex, &q, &touches)[1];
                }
            }
        }
    }
    sum += view.sample_udim(0, &at([0.5, 0.5], Filter::Moonray), [0.0; 4])[0];
    assert_eq!(allocations() - before, 0, "lookups allocated");
    assert!(sum.is_finite());
    assert!(touches.touched_bytes() > 0 && touches.touched_bytes() <= set.texels.len() as u64);
}
