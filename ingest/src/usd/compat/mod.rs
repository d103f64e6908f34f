//! Workarounds for bugs and gaps of the `openusd` crate 0.6.0, in one place, so that each can be
//! removed when the crate is fixed.
//!
//! Every layer the resolver serves passes through the first three before the crate sees it; the
//! stage checks each loaded layer with the fourth before composing a prim; the last catches what
//! they miss. For each: what it covers in openusd, and what would make it
//! removable. No fix is known upstream for any of them yet ("open upstream as of openusd 0.6.0");
//! when the crate is upgraded, rerun the layer fuzzer (`ingest/tests`, `fuzz_layers`) and the
//! survey tests below without the workaround before deleting it.
//!
//! - [`crate_check`]: a structural check of `.usdc` crate files. openusd's crate reader trusts
//!   the file: it allocates `vec![T; count]` for counts read from it before checking the bytes
//!   exist (a multi-exabyte allocation aborts the process), indexes its token, string, field and
//!   path tables with unchecked indices (a panic), follows path-tree jumps without a range or
//!   visit check (exponential walks) and recurses through dictionaries and time samples with no
//!   depth limit (a stack overflow). Its `repair` also rewrites the times of time samples in
//!   crate files older than 0.7.0, which openusd reads in the array layout of the file's version
//!   instead of the 64-bit vector layout usd-core writes (every time-sampled attribute is then
//!   rejected as "Invalid time samples count"). Removable when the crate reader bounds-checks
//!   counts, indices and jumps, limits recursion and decodes `DoubleVector` as usd-core does:
//!   open upstream as of openusd 0.6.0. The survey test `crate_check::tests::survey`
//!   (`CRATE_CHECK_SURVEY=DIR`) checks a folder of real assets against it.
//! - [`layer_fix`]: token-level rewrites of `.usda` text that usd-core reads and the openusd
//!   parser rejects (`.5`/`5.` numbers, Sdf's legacy type names such as `Vec3f` and
//!   `PointIndex`, a string where an asset path is expected, `@...@` inside scalar time samples,
//!   list ops on prim metadata it does not know such as `inactiveIds`), plus a structural check
//!   that refuses nesting deeper than [`layer_fix::MAX_NESTING`] (the parser, composition and
//!   the reader recurse once per level; deeper files overflow the stack) and reports where the
//!   parser stops (`parse_error_location`). `shared/assets/OPENUSD-0.6-COMPAT.md` lists the 28
//!   shared OpenUSD assets that openusd 0.6.0 alone fails to open, with the parser error of each.
//!   Removable rewrite by rewrite when the parser accepts each construct and bounds its
//!   recursion: open upstream as of openusd 0.6.0.
//! - [`path_syntax`]: Sdf's path grammar, checked on every authored path reference (`<...>`)
//!   and on property names that come from values (`xformOpOrder`, a primvar reader's
//!   `varname`). openusd takes any text between `<` and `>` as a path, and its path queries
//!   (parent, prim path) loop forever or overflow the stack on malformed ones (spaces, quotes, a
//!   `}` without `{`). Removable when openusd validates paths on parse and `append_property`:
//!   open upstream as of openusd 0.6.0. The survey test `path_syntax::survey`
//!   (`TEXT_CHECK_SURVEY=DIR`) runs the text checks on a folder of real assets.
//! - [`class_arcs`]: inherits/specializes cycles among classes, and class hierarchies whose
//!   walks branch exponentially, refused with the chain before the crate composes them. openusd's
//!   pre-cache of inherit targets recurses through composed classes with no visited set (a stack
//!   overflow, or a hang). Removable when the pre-cache keeps a visited set: open upstream as of
//!   openusd 0.6.0.
//! - [`reader_panic`]: the backstop. A panic still raised inside the composition engine (it
//!   indexes freely) becomes [`UsdErrorKind::Internal`](super::UsdErrorKind::Internal) naming the
//!   root layer, and [`reader_panic::quiet_reader_panics`] keeps the panic banner out of the
//!   binary's output. Removable when openusd reports malformed input as errors rather than
//!   panics: open upstream as of openusd 0.6.0.

pub(super) mod class_arcs;
pub(super) mod crate_check;
pub(super) mod layer_fix;
pub(super) mod path_syntax;
pub(super) mod reader_panic;
