//! The end-of-run summary: rays, throughput and seconds per phase, printed on stderr and optionally
//! written as JSON.

use crate::film::RenderStats;
use serde::Serialize;

/// Figures of one `render` run.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Summary {
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Samples per pixel.
    pub spp: u32,
    /// Worker threads.
    pub threads: usize,
    /// Camera rays.
    pub camera_rays: u64,
    /// Continuation rays (BSDF bounces and transparency pass-throughs).
    pub bounce_rays: u64,
    /// Shadow rays.
    pub shadow_rays: u64,
    /// All rays.
    pub rays: u64,
    /// Million rays per second of render time.
    pub mrays_per_second: f64,
    /// Million camera samples per second of render time.
    pub msamples_per_second: f64,
    /// Samples discarded as NaN/∞.
    pub nonfinite_samples: u64,
    /// Seconds mapping and validating the blob.
    pub load_seconds: f64,
    /// Seconds rendering.
    pub render_seconds: f64,
    /// Seconds writing outputs.
    pub write_seconds: f64,
    /// Texel bytes in the blob.
    pub texture_bytes_total: u64,
    /// Bytes of the texel pages the render read (counted only with `--stats`).
    pub texture_bytes_touched: u64,
    /// Integrator (`scalar` or `wavefront`).
    pub integrator: String,
    /// Wavefront CPU-seconds per stage (intersection, shading, sort/queue overhead; zero for scalar).
    pub stages: crate::wavefront::StageSeconds,
}

impl Summary {
    /// Fills the render figures from `stats`; timings of the other phases are set by the caller.
    pub fn from_render(stats: &RenderStats, width: u32, height: u32, spp: u32) -> Self {
        let secs = stats.seconds.max(1e-9);
        Summary {
            width,
            height,
            spp,
            threads: stats.threads,
            camera_rays: stats.rays.camera,
            bounce_rays: stats.rays.bounce,
            shadow_rays: stats.rays.shadow,
            rays: stats.rays.total(),
            mrays_per_second: stats.rays.total() as f64 / secs / 1e6,
            msamples_per_second: stats.samples as f64 / secs / 1e6,
            nonfinite_samples: stats.nonfinite_samples,
            render_seconds: stats.seconds,
            texture_bytes_total: stats.texture_bytes_total,
            texture_bytes_touched: stats.texture_bytes_touched,
            stages: stats.stages,
            ..Summary::default()
        }
    }

    /// A few human-readable lines.
    pub fn to_text(&self) -> String {
        format!(
            "{}x{} @ {} spp on {} threads\n\
             rays: {} ({} camera, {} bounce, {} shadow), {:.2} Mrays/s, {:.3} Msamples/s\n\
             time: load {:.3} s, render {:.3} s, write {:.3} s{}{}{}",
            self.width,
            self.height,
            self.spp,
            self.threads,
            self.rays,
            self.camera_rays,
            self.bounce_rays,
            self.shadow_rays,
            self.mrays_per_second,
            self.msamples_per_second,
            self.load_seconds,
            self.render_seconds,
            self.write_seconds,
            if self.texture_bytes_total > 0 && self.texture_bytes_touched == 0 {
                // Page counting costs a shared-bitmap mark per texel fetch, so it runs only with --stats.
                format!(
                    "\ntextures: {:.1} MiB in the blob (pages touched are counted with --stats)",
                    self.texture_bytes_total as f64 / 1048576.0
                )
            } else if self.texture_bytes_total > 0 {
                format!(
                    "\ntextures: {:.1} MiB touched of {:.1} MiB ({:.1}%)",
                    self.texture_bytes_touched as f64 / 1048576.0,
                    self.texture_bytes_total as f64 / 1048576.0,
                    100.0 * self.texture_bytes_touched as f64 / self.texture_bytes_total as f64
                )
            } else {
                String::new()
            },
            {
                let s = &self.stages;
                let total = s.generate + s.intersect + s.sort + s.shade + s.occlusion + s.accumulate;
                if total > 0.0 {
                    format!(
                        "\nwavefront stages (CPU s): intersect {:.3}, occlusion {:.3}, shade {:.3}, \
                         queues/sort {:.3} (generate {:.3}, sort {:.3}, accumulate {:.3})",
                        s.intersect,
                        s.occlusion,
                        s.shade,
                        s.generate + s.sort + s.accumulate,
                        s.generate,
                        s.sort,
                        s.accumulate
                    )
                } else {
                    String::new()
                }
            },
            if self.nonfinite_samples > 0 {
                format!("\nwarning: {} NaN/inf samples discarded", self.nonfinite_samples)
            } else {
                String::new()
            }
        )
    }
}
