//! Directional albedo of the GGX specular lobe, tabulated once: what the diffuse lobe is scaled by so
//! that diffuse plus specular conserve energy at every angle (Kulla & Conty 2017, "Revisiting
//! Physically Based Shading at Imageworks": albedo scaling).
//!
//! The specular lobe with Schlick's Fresnel `F = F0 + (F90 − F0)(1 − v·h)⁵` reflects
//! `E(μ) = F0·A(μ, α) + F90·B(μ, α)` of the light arriving from `μ = n·v`, with `A` and `B` integrals
//! of the lobe with weights `1 − (1 − v·h)⁵` and `(1 − v·h)⁵`. The diffuse lobe becomes
//!
//! ```text
//! f_d = c/π · (1 − E(μo)) (1 − E(μi)) / (1 − E_avg),     E_avg = 2 ∫ E(μ) μ dμ
//! ```
//!
//! which is reciprocal and makes a white base under any specular layer reflect exactly
//! `E(μo) + (1 − E(μo)) = 1`: where the old `(1 − F(μo))` factor took up to 45 % off a rough matte
//! floor towards the horizon (Schlick's F → 1 there while a rough lobe's E does not), the floor now
//! keeps what the specular lobe did not reflect.
//!
//! The tables (`A`, `B` on a 32 × 16 grid over `μ` and `r = √α`, and their cosine-weighted averages
//! over `μ`) are integrated once per process, deterministically (a stratified 16 × 16 grid of visible
//! normals per entry, f64 sums of the same f32 lobe code the BSDF samples with), so every thread
//! and both integrators read the same numbers. Both read them through [`view_terms`] and
//! [`light_terms`], so the lanes equal the scalar BSDF by construction; the lanes keep the view
//! halves per BSDF (built with it), which takes one table lookup and the divisions out of every
//! evaluation.
//!
//! The same tables give the specular lobe's multiple scattering (Kulla & Conty's compensation
//! lobe, `f_ms = F_ms (1 − E1(μo))(1 − E1(μi)) / (π (1 − E1_avg))` with `E1 = A + B` the unit-Fresnel
//! albedo): single-scattering GGX loses up to 69 % at α = 1 (a rough F0 = 1 metal read 0.31 head-on),
//! and the lobe gives it back, so a white metal reads 1 at every roughness. The diffuse scaling
//! counts the compensation lobe in `E`, so a white plastic still reads exactly 1.
//!
//! A third table, `C` (weight `(v·h)(1 − v·h)⁶`), carries the F82-tint correction of metals
//! (OpenPBR's `specular_color` on metal, [`super::f82_b`]): `F = Schlick − b·(v·h)(1 − v·h)⁶`
//! reflects `F0·A + F90·B − b·C`. With `b = 0` (every material without a metal edge tint) each sum
//! subtracts an exact zero, so the Schlick-only figures keep their bits.

use super::{ggx_g2, ggx_lambda, sample_ggx_vndf, MIN_ALPHA};
use glam::Vec3;
use std::sync::OnceLock;

/// Grid points over `μ = n·v` in [0, 1].
const MU: usize = 32;
/// Grid points over `r = √α` in [0, 1].
const ROUGHNESS: usize = 16;
/// Visible-normal samples per entry and axis.
const STRATA: usize = 16;

/// `A`, `B` and `C` at every grid point, and the averages of `A` and `B` per roughness.
pub(crate) struct Tables {
    /// `[r][μ]` → (A, B, C).
    lobe: [[[f32; 3]; MU]; ROUGHNESS],
    /// `[r]` → (2∫A μ dμ, 2∫B μ dμ, 2∫C μ dμ).
    average: [[f32; 3]; ROUGHNESS],
}

/// The smallest `μ` integrated (the lobe at exactly grazing view has no visible normals).
const MIN_MU: f32 = 1e-3;

fn integrate() -> Tables {
    let mut lobe = [[[0.0f32; 3]; MU]; ROUGHNESS];
    let mut average = [[0.0f32; 3]; ROUGHNESS];
    for (j, row) in lobe.iter_mut().enumerate() {
        let r = j as f32 / (ROUGHNESS - 1) as f32;
        let alpha = (r * r).max(MIN_ALPHA);
        for (i, entry) in row.iter_mut().enumerate() {
            let mu = (i as f32 / (MU - 1) as f32).max(MIN_MU);
            let wo = Vec3::new((1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu);
            let g1 = 1.0 / (1.0 + ggx_lambda(wo, alpha));
            let (mut a, mut b, mut c) = (0.0f64, 0.0f64, 0.0f64);
            for s in 0..STRATA {
                for t in 0..STRATA {
                    let u = [(s as f32 + 0.5) / STRATA as f32, (t as f32 + 0.5) / STRATA as f32];
                    let h = sample_ggx_vndf(wo, alpha, u);
                    let cos = wo.dot(h);
                    let wi = 2.0 * cos * h - wo;
                    if wi.z <= 0.0 {
                        continue;
                    }
                    // f·cos/pdf of the visible-normal sample is F·G₂/G₁.
                    let weight = (ggx_g2(wo, wi, alpha) / g1) as f64;
                    let m = (1.0 - cos).clamp(0.0, 1.0) as f64;
                    let m5 = m * m * m * m * m;
                    a += weight * (1.0 - m5);
                    b += weight * m5;
                    c += weight * (1.0 - m) * m5 * m;
                }
            }
            let n = (STRATA * STRATA) as f64;
            *entry = [(a / n) as f32, (b / n) as f32, (c / n) as f32];
        }
        // 2∫E μ dμ by the trapezoid rule over the grid.
        let mut sums = [0.0f64; 3];
        for i in 0..MU - 1 {
            let (m0, m1) = (i as f64 / (MU - 1) as f64, (i + 1) as f64 / (MU - 1) as f64);
            let h = m1 - m0;
            for (k, sum) in sums.iter_mut().enumerate() {
                *sum += h * 0.5 * (row[i][k] as f64 * m0 + row[i + 1][k] as f64 * m1);
            }
        }
        average[j] = sums.map(|x| (2.0 * x) as f32);
    }
    Tables { lobe, average }
}

/// The tables, integrated on first use. Kernels take the reference once per call, outside their
/// lane loops.
pub(crate) fn tables() -> &'static Tables {
    static TABLES: OnceLock<Tables> = OnceLock::new();
    TABLES.get_or_init(integrate)
}

/// The fuzz (sheen) lobe's directional albedo `E_f` on a `[r][μ]` grid over fuzz roughness and
/// `μ = n·v` ([`super::sheen`], untinted): what the layers under the fuzz are scaled by.
pub(crate) struct SheenTable([[f32; MU]; ROUGHNESS]);

/// Directions per axis (`cos θ`, `φ`) of the sheen table's midpoint rule.
const SHEEN_STRATA: usize = 96;

fn integrate_sheen() -> SheenTable {
    let mut table = [[0.0f32; MU]; ROUGHNESS];
    for (j, row) in table.iter_mut().enumerate() {
        let alpha = super::sheen_alpha(j as f32 / (ROUGHNESS - 1) as f32);
        for (i, entry) in row.iter_mut().enumerate() {
            let mu = (i as f32 / (MU - 1) as f32).max(MIN_MU);
            let wo = Vec3::new((1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu);
            let mut sum = 0.0f64;
            for s in 0..SHEEN_STRATA {
                let z = (s as f32 + 0.5) / SHEEN_STRATA as f32;
                let r = (1.0 - z * z).max(0.0).sqrt();
                for t in 0..SHEEN_STRATA {
                    let phi = std::f32::consts::TAU * (t as f32 + 0.5) / SHEEN_STRATA as f32;
                    let wi = Vec3::new(r * phi.cos(), r * phi.sin(), z);
                    let h = (wo + wi).normalize();
                    sum += (super::sheen(wo, wi, h, alpha) * z) as f64;
                }
            }
            let n = (SHEEN_STRATA * SHEEN_STRATA) as f64;
            *entry = (sum * std::f64::consts::TAU / n).min(1.0) as f32;
        }
    }
    SheenTable(table)
}

/// The sheen table, integrated on first use.
pub(crate) fn sheen_table() -> &'static SheenTable {
    static TABLE: OnceLock<SheenTable> = OnceLock::new();
    TABLE.get_or_init(integrate_sheen)
}

/// `E_f` at `μ` and fuzz roughness `r` (bilinear; both clamp to [0, 1]).
#[inline(always)]
pub(crate) fn sheen_albedo(t: &SheenTable, mu: f32, r: f32) -> f32 {
    let (j, fr) = cell(r, ROUGHNESS);
    let (i, fm) = cell(mu, MU);
    let lerp = |a: f32, b: f32, f: f32| a + (b - a) * f;
    lerp(lerp(t.0[j][i], t.0[j][i + 1], fm), lerp(t.0[j + 1][i], t.0[j + 1][i + 1], fm), fr)
}

/// Grid cell and weight of `x` in [0, 1] on `n` points (NaN and out-of-range values clamp).
#[inline(always)]
fn cell(x: f32, n: usize) -> (usize, f32) {
    let t = x.clamp(0.0, 1.0) * (n - 1) as f32;
    // `as` saturates (NaN → 0), and the `min` keeps the upper neighbour in range.
    let i = (t as usize).min(n - 2);
    (i, t - i as f32)
}

/// The tabulated lobe at `μ` and GGX `alpha`: `(A, B, C, A_avg, B_avg, C_avg)`, bilinear in `μ`
/// and `√α`.
#[inline(always)]
pub(crate) fn lobe_albedo(t: &Tables, mu: f32, alpha: f32) -> [f32; 6] {
    let (j, fr) = cell(alpha.sqrt(), ROUGHNESS);
    let [a, b, c] = lobe_at(t, j, fr, mu);
    let lerp = |k: usize| t.average[j][k] + (t.average[j + 1][k] - t.average[j][k]) * fr;
    [a, b, c, lerp(0), lerp(1), lerp(2)]
}

/// `(A, B, C)` of [`lobe_albedo`] only (what the light side needs).
#[inline(always)]
pub(crate) fn lobe_albedo_ab(t: &Tables, mu: f32, alpha: f32) -> [f32; 3] {
    let (j, fr) = cell(alpha.sqrt(), ROUGHNESS);
    lobe_at(t, j, fr, mu)
}

#[inline(always)]
fn lobe_at(t: &Tables, j: usize, fr: f32, mu: f32) -> [f32; 3] {
    let (i, fm) = cell(mu, MU);
    let lerp = |a: f32, b: f32, f: f32| a + (b - a) * f;
    let at = |c: usize| {
        let (lo, hi) = (t.lobe[j][i][c], t.lobe[j + 1][i][c]);
        let (lo1, hi1) = (t.lobe[j][i + 1][c], t.lobe[j + 1][i + 1][c]);
        lerp(lerp(lo, lo1, fm), lerp(hi, hi1, fm), fr)
    };
    [at(0), at(1), at(2)]
}

/// Grid points over the relative index `η` in [1, [`MAX_ETA`]] (below 1: `1/η`, in the table of
/// the other side).
const ETA: usize = 16;
/// The largest relative index tabulated; denser interfaces read its row.
pub(crate) const MAX_ETA: f32 = 3.0;

/// The single-scattering directional albedo `E_ss(μ, r, η)` of the rough dielectric interface
/// ([`super::dielectric`]), reflection plus transmission with the exact Fresnel term, the
/// transmitted part as an energy fraction (without the radiance's `1/η²`): `[side][η][r][μ]`,
/// side 0 for `η ≥ 1` (entering a denser medium), 1 for `η < 1` (leaving it, with total internal
/// reflection), indexed there by `1/η`; and the thin wall's, `[r][μ]`: the GGX reflection lobe's
/// unit-Fresnel albedo `A + B` (a slab of colour 1 reflects and transmits all of `F` and `1 − F`
/// per microfacet), integrated on a finer grid than [`Tables`]' (whose 16 × 16 visible normals
/// left it up to 0.4 % low, an error a path through a thin-walled sphere meets at every wall).
pub(crate) struct DielectricTable {
    solid: [[[[f32; MU]; ROUGHNESS]; ETA]; 2],
    thin: [[f32; MU]; ROUGHNESS],
}

/// Visible-normal samples per axis of each dielectric entry (both lobes are taken from every
/// microfacet, weighted by `F` and `1 − F`, so there is no lobe choice to add noise).
const DIELECTRIC_STRATA: usize = 24;

fn integrate_dielectric() -> DielectricTable {
    let mut table = [[[[0.0f32; MU]; ROUGHNESS]; ETA]; 2];
    for (side, etas) in table.iter_mut().enumerate() {
        for (k, rows) in etas.iter_mut().enumerate() {
            let x = 1.0 + (MAX_ETA - 1.0) * k as f32 / (ETA - 1) as f32;
            let eta = if side == 0 { x } else { 1.0 / x };
            for (j, row) in rows.iter_mut().enumerate() {
                let r = j as f32 / (ROUGHNESS - 1) as f32;
                let alpha = (r * r).max(MIN_ALPHA);
                for (i, entry) in row.iter_mut().enumerate() {
                    let mu = (i as f32 / (MU - 1) as f32).max(MIN_MU);
                    let wo = Vec3::new((1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu);
                    let g1 = 1.0 / (1.0 + ggx_lambda(wo, alpha));
                    let mut e = 0.0f64;
                    for s in 0..DIELECTRIC_STRATA {
                        for t in 0..DIELECTRIC_STRATA {
                            let n = DIELECTRIC_STRATA as f32;
                            let u = [(s as f32 + 0.5) / n, (t as f32 + 0.5) / n];
                            let h = sample_ggx_vndf(wo, alpha, u);
                            let cos = wo.dot(h);
                            let f = super::dielectric::fresnel_dielectric(cos, eta);
                            // f·|cos|/pdf of a visible-normal sample is G₂/G₁ on either lobe.
                            let wr = 2.0 * cos * h - wo;
                            if wr.z > 0.0 {
                                e += (f * ggx_g2(wo, wr, alpha) / g1) as f64;
                            }
                            if let Some(wt) = super::dielectric::refract(wo, h, eta) {
                                if wt.z < 0.0 {
                                    e += ((1.0 - f) * ggx_g2(wo, wt, alpha) / g1) as f64;
                                }
                            }
                        }
                    }
                    *entry = (e / (DIELECTRIC_STRATA * DIELECTRIC_STRATA) as f64).min(1.0) as f32;
                }
            }
        }
    }
    let mut thin = [[0.0f32; MU]; ROUGHNESS];
    for (j, row) in thin.iter_mut().enumerate() {
        let r = j as f32 / (ROUGHNESS - 1) as f32;
        let alpha = (r * r).max(MIN_ALPHA);
        for (i, entry) in row.iter_mut().enumerate() {
            let mu = (i as f32 / (MU - 1) as f32).max(MIN_MU);
            let wo = Vec3::new((1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu);
            let g1 = 1.0 / (1.0 + ggx_lambda(wo, alpha));
            let mut e = 0.0f64;
            for s in 0..THIN_STRATA {
                for t in 0..THIN_STRATA {
                    let n = THIN_STRATA as f32;
                    let h = sample_ggx_vndf(wo, alpha, [(s as f32 + 0.5) / n, (t as f32 + 0.5) / n]);
                    let wr = 2.0 * wo.dot(h) * h - wo;
                    if wr.z > 0.0 {
                        e += (ggx_g2(wo, wr, alpha) / g1) as f64;
                    }
                }
            }
            *entry = (e / (THIN_STRATA * THIN_STRATA) as f64).min(1.0) as f32;
        }
    }
    DielectricTable { solid: table, thin }
}

/// Visible-normal samples per axis of each thin-wall entry.
const THIN_STRATA: usize = 48;

/// The thin wall's `E_ss` at `μ` and roughness `r` (bilinear, both clamp to [0, 1]).
#[inline]
pub(crate) fn thin_wall_albedo(t: &DielectricTable, mu: f32, r: f32) -> f32 {
    let (j, fr) = cell(r, ROUGHNESS);
    let (i, fm) = cell(mu, MU);
    let lerp = |a: f32, b: f32, f: f32| a + (b - a) * f;
    let t = &t.thin;
    lerp(lerp(t[j][i], t[j][i + 1], fm), lerp(t[j + 1][i], t[j + 1][i + 1], fm), fr)
}

/// The dielectric table, integrated on first use.
pub(crate) fn dielectric_table() -> &'static DielectricTable {
    static TABLE: OnceLock<DielectricTable> = OnceLock::new();
    TABLE.get_or_init(integrate_dielectric)
}

/// `E_ss` at `μ`, roughness `r` (α = r²) and relative index `eta` (trilinear; `μ` and `r` clamp to
/// [0, 1], `η` or `1/η` to [1, [`MAX_ETA`]]).
#[inline]
pub(crate) fn dielectric_albedo(t: &DielectricTable, mu: f32, r: f32, eta: f32) -> f32 {
    let (side, x) = if eta >= 1.0 { (0, eta) } else { (1, 1.0 / eta) };
    let (k, fk) = cell((x - 1.0) / (MAX_ETA - 1.0), ETA);
    let (j, fr) = cell(r, ROUGHNESS);
    let (i, fm) = cell(mu, MU);
    let lerp = |a: f32, b: f32, f: f32| a + (b - a) * f;
    let t = &t.solid[side];
    let at = |k: usize, j: usize| lerp(t[k][j][i], t[k][j][i + 1], fm);
    let at_k = |k: usize| lerp(at(k, j), at(k, j + 1), fr);
    lerp(at_k(k), at_k(k + 1), fk)
}

/// Schlick's F90 of the specular lobe for F0 `(x, y, z)` (see `bsdf::schlick`).
#[inline(always)]
pub(crate) fn f90(x: f32, y: f32, z: f32) -> f32 {
    (50.0 * 0.33 * (x + y + z)).clamp(0.0, 1.0)
}

/// Kulla & Conty's multiple-scattering Fresnel of one colour channel: `F_avg² E_avg / (1 − F_avg (1 −
/// E_avg))` with Schlick's average `F_avg = F0 + (F90 − F0)/21 − b/126` (the F82 term's
/// cosine-weighted average is `2∫μ·μ(1 − μ)⁶ dμ = 1/126`) and the lobe's unit-Fresnel average
/// albedo `E_avg` (from [`lobe_albedo`] `at`).
#[inline(always)]
pub(crate) fn ms_fresnel(f0: f32, f90: f32, b82: f32, at: [f32; 6]) -> f32 {
    let e1_avg = at[3] + at[4];
    let f_avg = f0 + (f90 - f0) * (1.0 / 21.0) - b82 * (1.0 / 126.0);
    f_avg * f_avg * e1_avg / (1.0 - f_avg * (1.0 - e1_avg)).max(1e-4)
}

/// What one colour channel's specular layer reflects in all from cosine `μ`, single scattering
/// `f0·A + f90·B − b82·C` (the F82 tint's term; with `b82 = 0` exactly Schlick's) plus the
/// multiple-scattering lobe's `f_ms (1 − (A + B))`.
#[inline(always)]
fn specular_energy(f0: f32, f90: f32, b82: f32, f_ms: f32, [a, b, c]: [f32; 3]) -> f32 {
    f0 * a + f90 * b - b82 * c + f_ms * (1.0 - (a + b))
}

/// The view halves of one colour channel's lobes at `μo` ([`lobe_albedo`] `at_o`): the diffuse
/// lobe's `d (1 − E(μo)) / (1 − E_avg)` for diffuse colour `d`, the multiple-scattering lobe's
/// `f_ms (1 − E1(μo)) / (1 − E1_avg)`, and `f_ms` ([`ms_fresnel`]). A BSDF seen from one direction
/// keeps them (the lanes build them with the BSDF); the scalar BSDF computes them per evaluation,
/// with the same operations.
#[inline(always)]
pub(crate) fn view_terms(d: f32, f0: f32, f90: f32, b82: f32, at_o: [f32; 6]) -> [f32; 3] {
    let f_ms = ms_fresnel(f0, f90, b82, at_o);
    let e_o = specular_energy(f0, f90, b82, f_ms, [at_o[0], at_o[1], at_o[2]]);
    let e_avg = specular_energy(f0, f90, b82, f_ms, [at_o[3], at_o[4], at_o[5]]);
    let diffuse = d * ((1.0 - e_o) / (1.0 - e_avg).max(1e-4));
    let ms = f_ms * ((1.0 - (at_o[0] + at_o[1])) / (1.0 - (at_o[3] + at_o[4])).max(1e-4));
    [diffuse, ms, f_ms]
}

/// One colour channel's diffuse and multiple-scattering lobe values times π from their
/// [`view_terms`] `view` and [`lobe_albedo_ab`] at `μi`.
#[inline(always)]
pub(crate) fn light_terms(view: [f32; 3], f0: f32, f90: f32, b82: f32, at_i: [f32; 3]) -> [f32; 2] {
    let [diffuse, ms, f_ms] = view;
    let e_i = specular_energy(f0, f90, b82, f_ms, at_i);
    [diffuse * (1.0 - e_i), ms * (1.0 - (at_i[0] + at_i[1]))]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Against a direct integration of the lobe over the hemisphere (uniform directions, no
    /// visible-normal sampling) at points between the grid's.
    #[test]
    fn tables_match_a_direct_integration() {
        let mut worst = 0.0f32;
        for (mu, roughness) in [(0.9f32, 0.5f32), (0.3, 0.7), (0.12, 0.93), (0.55, 0.3)] {
            let alpha = roughness * roughness;
            let wo = Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
            let n = 400;
            let (mut a, mut b) = (0.0f64, 0.0f64);
            for s in 0..n {
                for t in 0..n {
                    let z = (s as f32 + 0.5) / n as f32;
                    let phi = std::f32::consts::TAU * (t as f32 + 0.5) / n as f32;
                    let r = (1.0 - z * z).sqrt();
                    let wi = Vec3::new(r * phi.cos(), r * phi.sin(), z);
                    let h = (wo + wi).normalize();
                    let f = super::super::ggx_d(h, alpha) * ggx_g2(wo, wi, alpha) / (4.0 * wo.z * wi.z);
                    let m = (1.0 - wo.dot(h)).clamp(0.0, 1.0) as f64;
                    let m5 = m.powi(5);
                    let w = (f * wi.z) as f64 * std::f64::consts::TAU / (n * n) as f64;
                    a += w * (1.0 - m5);
                    b += w * m5;
                }
            }
            let [ta, tb, ..] = lobe_albedo(tables(), mu, alpha);
            eprintln!("μ {mu} r {roughness}: A {ta:.4} vs {a:.4}, B {tb:.4} vs {b:.4}");
            worst = worst.max((ta - a as f32).abs()).max((tb - b as f32).abs());
        }
        assert!(worst < 0.01, "worst difference {worst}");
    }

    /// With F0 = F90 = 1 the lobe is the single-scattering GGX albedo: 1 − ln 2 at α = 1 head-on.
    #[test]
    fn unit_fresnel_albedo_is_known_at_alpha_one() {
        let [a, b, ..] = lobe_albedo(tables(), 1.0, 1.0);
        assert!((a + b - (1.0 - std::f32::consts::LN_2)).abs() < 3e-3, "{}", a + b);
        let [a, b, ..] = lobe_albedo(tables(), 1.0, MIN_ALPHA);
        assert!((a + b - 1.0).abs() < 1e-3 && b < 1e-6, "smooth mirror head-on: A {a}, B {b}");
    }
}
