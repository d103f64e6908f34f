//! Times `SceneView::parse` on blob files: `cargo run --release -p blob --example parse_time -- FILE...`.
//! Prints the parse time (best of five), the structural part alone (`parse_deferring_checksums`, what
//! render waits for before it starts), and the time of one checksum pass over the whole file for scale
//! (parse checksums every section once; the structural checks come on top).

/// Depth (root = 1) of a validated BVH8: children follow their parent, so one forward pass.
fn depth(nodes: &[blob::BvhNode]) -> u32 {
    let mut d = vec![1u32; nodes.len()];
    for (i, node) in nodes.iter().enumerate() {
        for &c in node.children.iter().filter(|&&c| !blob::child_ref::is_leaf(c)) {
            d[c as usize] = d[i] + 1;
        }
    }
    d.into_iter().max().unwrap_or(0)
}

fn main() {
    for path in std::env::args().skip(1) {
        let bytes = match std::fs::read(&path) {
            Ok(b) => blob::AlignedBytes::copy_from(&b),
            Err(e) => {
                eprintln!("{path}: {e}");
                continue;
            }
        };
        let best = |f: &dyn Fn()| {
            (0..5)
                .map(|_| {
                    let t = std::time::Instant::now();
                    f();
                    t.elapsed().as_secs_f64() * 1e3
                })
                .fold(f64::INFINITY, f64::min)
        };
        let result = std::cell::Cell::new(String::new());
        let parse_ms = best(&|| {
            result.set(match blob::SceneView::parse(&bytes) {
                Ok(v) => format!(
                    "ok: {} BVH nodes (depth {}), {} prototype nodes, {} curve nodes, {} positions",
                    v.bvh_nodes.len(),
                    depth(v.bvh_nodes),
                    v.instancing.prototype_nodes.len(),
                    v.curves.bvh_nodes.len(),
                    v.positions.len()
                ),
                Err(e) => format!("rejected: {e}"),
            })
        });
        let structure_ms = best(&|| {
            std::hint::black_box(blob::SceneView::parse_deferring_checksums(&bytes).is_ok());
        });
        let checksum_ms = best(&|| {
            std::hint::black_box(blob::checksum(&bytes));
        });
        println!(
            "{path}: {} MB, parse {parse_ms:.1} ms (structure {structure_ms:.1} ms), one checksum pass \
             {checksum_ms:.1} ms; {}",
            bytes.len() / 1_000_000,
            result.take()
        );
    }
}
