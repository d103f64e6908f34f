//! A farm's parts back into one frame (`render merge`): tiles (`--tile I/N`) are placed by their
//! data windows, sample slices (`--sample-range A..B`) are added in sample order. Every part is a
//! checkpoint ([`crate::checkpoint`]) carrying its exact pixel sums, so
//!
//! * tiles of one sample range assemble to the single-process render's sums, and the image is that
//!   render's byte for byte;
//! * slices add their sums (`s₁ + s₂`) where one process would have added sample by sample: the
//!   merged mean differs from the single-process mean by float rounding only — each pixel's
//!   relative difference is at most about `n · 2⁻²⁴` for `n` samples (two f32 summation orders of
//!   the same positive terms; the tests assert ≤ 1e-5 at 16 spp).
//!
//! The RenderProducts' sums ([`crate::aov`]) merge with the beauty's when the blob's plan is given
//! (`render merge --blob`): tiles place them (the products are the single render's byte for
//! byte); slices add the light-path and position sums (the beauty's rounding bound) and merge the
//! Cryptomatte slots by id ([`crate::aov::Plan::add_slice`]: the single render's ids and counts
//! exactly, except in a pixel where a slice saw more than eight distinct ids, where both drop
//! samples of some). Parts that hold product sums are refused without the plan, rather than
//! merged into a beauty that silently drops them.
//!
//! Parts must share the blob, the settings and the frame; within a sample range they must cover
//! one rectangle without overlap, every range must cover the same rectangle, and the ranges must
//! follow each other without gap or overlap. Anything else is an error naming the parts.

use crate::checkpoint::Provenance;
use crate::error::RenderError;
use crate::film::PixelSum;
use crate::frame::Accumulation;
use std::path::{Path, PathBuf};

/// One part as read from its file.
pub struct Part {
    /// The file, for errors.
    pub path: PathBuf,
    /// Its pixels and sample range.
    pub film: Accumulation,
    /// What it was rendered from.
    pub provenance: Provenance,
}

/// Reads the parts at `paths` ([`crate::checkpoint::read_checkpoint`]).
pub fn read_parts(paths: &[PathBuf]) -> Result<Vec<Part>, RenderError> {
    paths
        .iter()
        .map(|path| {
            let (film, provenance) = crate::checkpoint::read_checkpoint(path)?;
            Ok(Part { path: path.clone(), film, provenance })
        })
        .collect()
}

fn fail(path: &Path, message: String) -> RenderError {
    RenderError::Checkpoint { path: path.to_path_buf(), message }
}

/// Merges `parts` into one accumulation (see the module docs), and returns it with the shared
/// provenance. `plan` is the products' plan of the blob the parts were rendered from
/// ([`crate::aov::Plan::new`]), or `None` to merge the beauty alone.
pub fn merge(
    parts: &[Part],
    plan: Option<std::sync::Arc<crate::aov::Plan>>,
) -> Result<(Accumulation, Provenance), RenderError> {
    let first = parts.first().ok_or_else(|| fail(Path::new("render merge"), "no parts given".into()))?;
    let plan = plan.filter(|p| !p.products.is_empty());
    let stride = plan.as_ref().map_or(0, |p| p.stride());
    for p in parts {
        match (&plan, p.provenance.product_sums) {
            (None, Some(_)) => {
                return Err(fail(
                    &p.path,
                    "holds the sums of RenderProducts: give the blob it was rendered from (render merge --blob SCENE.blob) to merge and write them".into(),
                ))
            }
            (Some(_), stored) if stored.unwrap_or(0) != stride || p.film.aov.len() != p.film.sums.len() * stride => {
                return Err(fail(
                    &p.path,
                    format!(
                        "holds {} RenderProduct sums per pixel, the blob's products need {stride}",
                        stored.map_or("no".to_string(), |s| s.to_string())
                    ),
                ))
            }
            _ => {}
        }
        if p.provenance.blob != first.provenance.blob {
            return Err(fail(
                &p.path,
                format!(
                    "rendered from blob {:016x}, {} from blob {:016x}",
                    p.provenance.blob,
                    first.path.display(),
                    first.provenance.blob
                ),
            ));
        }
        if p.provenance.settings != first.provenance.settings
            || p.film.frame != first.film.frame
            || p.film.region != first.film.region
        {
            return Err(fail(
                &p.path,
                format!(
                    "rendered with {} at {}x{} (region {:?}), {} with {} at {}x{} (region {:?})",
                    p.provenance.settings,
                    p.film.frame[0],
                    p.film.frame[1],
                    p.film.region,
                    first.path.display(),
                    first.provenance.settings,
                    first.film.frame[0],
                    first.film.frame[1],
                    first.film.region
                ),
            ));
        }
    }
    // Sample ranges in order, each with its parts.
    let mut ranges: Vec<[u32; 2]> = parts.iter().map(|p| [p.film.first_sample, p.film.samples]).collect();
    ranges.sort_unstable();
    ranges.dedup();
    for pair in ranges.windows(2) {
        let ([a0, a1], [b0, b1]) = (pair[0], pair[1]);
        if b0 != a1 {
            let what = if b0 < a1 { "overlap" } else { "leave a gap" };
            return Err(fail(
                Path::new("render merge"),
                format!("sample ranges {a0}..{a1} and {b0}..{b1} {what}: slices must follow each other"),
            ));
        }
    }
    // The parts' common region: what the tiles of every sample range must cover.
    let bounds = first.film.region;
    let (w, h) = (bounds.width() as usize, bounds.height() as usize);
    let mut total: Option<(Vec<PixelSum>, Vec<f32>)> = None;
    for &[r0, r1] in &ranges {
        let mut sums = vec![PixelSum::default(); w * h];
        let mut aov = vec![0.0f32; w * h * stride];
        let mut owner: Vec<Option<&Path>> = vec![None; w * h];
        for p in parts.iter().filter(|p| [p.film.first_sample, p.film.samples] == [r0, r1]) {
            let win = p.film.window;
            for y in win.y0..win.y1 {
                for x in win.x0..win.x1 {
                    let at = (y - bounds.y0) as usize * w + (x - bounds.x0) as usize;
                    if let Some(other) = owner[at] {
                        return Err(fail(
                            &p.path,
                            format!("overlaps {} at pixel ({x}, {y}) of samples {r0}..{r1}", other.display()),
                        ));
                    }
                    owner[at] = Some(&p.path);
                    let src = (y - win.y0) as usize * win.width() as usize + (x - win.x0) as usize;
                    sums[at] = p.film.sums[src];
                    aov[at * stride..(at + 1) * stride]
                        .copy_from_slice(&p.film.aov[src * stride..(src + 1) * stride]);
                }
            }
        }
        if let Some(at) = owner.iter().position(Option::is_none) {
            let (x, y) = (bounds.x0 + (at % w) as u32, bounds.y0 + (at / w) as u32);
            return Err(fail(
                Path::new("render merge"),
                format!(
                    "no part holds pixel ({x}, {y}) of samples {r0}..{r1} (the parts span columns {}..{}, rows {}..{})",
                    bounds.x0, bounds.x1, bounds.y0, bounds.y1
                ),
            ));
        }
        total = Some(match total {
            None => (sums, aov),
            Some((mut acc, mut acc_aov)) => {
                for (a, s) in acc.iter_mut().zip(&sums) {
                    add_sums(a, s);
                }
                if let Some(plan) = plan.as_ref().filter(|_| stride > 0) {
                    for (a, b) in acc_aov.chunks_exact_mut(stride).zip(aov.chunks_exact(stride)) {
                        plan.add_slice(a, b);
                    }
                }
                (acc, acc_aov)
            }
        });
    }
    let (sums, aov) = total.expect("at least one range");
    let film = Accumulation {
        window: bounds,
        region: bounds,
        frame: first.film.frame,
        first_sample: ranges[0][0],
        samples: ranges[ranges.len() - 1][1],
        sums,
        plan: plan.unwrap_or_default(),
        aov,
        stats: Default::default(),
        adaptive: None,
    };
    Ok((film, first.provenance.clone()))
}

/// Adds a later slice's sums of a pixel.
fn add_sums(a: &mut PixelSum, b: &PixelSum) {
    a.sum += b.sum;
    a.albedo += b.albedo;
    a.normal += b.normal;
    a.depth += b.depth;
    a.hits += b.hits;
    a.nonfinite += b.nonfinite;
}
