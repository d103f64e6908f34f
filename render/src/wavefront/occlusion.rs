//! Stage 5: occlusion. Reads the occlusion queue and the shadow-ray side table; adds the contribution of
//! every unoccluded light sample to its path. One ray at a time: any-hit packets
//! lost here (ARCHITECTURE.md).

use super::{prefetch, Context, RayState, ShadowRay};
use texture::Touch;

/// Traces every queued shadow ray and empties the queue: any hit among the triangles (with
/// stochastic pass-through, as in the scalar path), then among the curves and points, which always
/// block.
pub(super) fn any_hit<T: Touch>(
    ctx: &Context<'_, '_, T>,
    states: &mut [RayState],
    shadow: &[ShadowRay],
    aov: &mut super::aovs::AovColumns,
    occlusion: &mut Vec<u32>,
) {
    let filter = ctx.settings.filter;
    let scene = ctx.scene;
    let queue = occlusion.as_slice();
    for (j, &i) in queue.iter().enumerate() {
        // The shadow ray and radiance of the ray after next, read by shading order (random in the
        // pool): one any-hit query hides their misses ([`super::prefetch`]).
        if let Some(&next) = queue.get(j + 2) {
            prefetch::entry(shadow, next as usize);
            prefetch::field(&states[next as usize].radiance);
        }
        let r = &shadow[i as usize];
        let light = (r.light != blob::NONE).then_some(r.light as usize);
        let time = states[i as usize].time;
        let kept = scene
            .shadow_transmittance(r.origin, r.dir, r.tmax, time, r.seed, r.delta, light, filter, ctx.touch);
        if kept > 0.0 && !scene.curves.any_hit(r.origin, r.dir, r.tmax) {
            let c = r.contribution * kept;
            states[i as usize].radiance += c;
            // The expressions shading noted for this light sample (the scalar integrator adds
            // the same `c` to them).
            let mask = aov.shadow_mask.get(i as usize).copied().unwrap_or(0);
            if let Some(mut k) = ctx.aov.and_then(|plan| aov.sink(plan, i as usize)) {
                k.add(mask, c);
            }
        }
    }
    occlusion.clear();
}
