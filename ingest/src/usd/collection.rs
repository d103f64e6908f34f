//! UsdCollectionAPI membership, as usd-core's `UsdCollectionAPI::ComputeMembershipQuery` and
//! `UsdCollectionMembershipQuery::IsPathIncluded` evaluate it for prim paths (checked against
//! usd-core by `tests/python/test_light_linking.py`).
//!
//! A collection `collection:<name>` is read into a map from path to rule: every `includes` target
//! gets the collection's `expansionRule`, `includeRoot = true` adds the absolute root `/` with it,
//! and every `excludes` target is an exclusion (an exclusion wins over an inclusion of the same
//! path). A prim path is then a member when:
//! - `explicitOnly`: it is in the map and not excluded (no ancestor counts);
//! - `expandPrims` / `expandPrimsAndProperties`: its nearest entry, itself or an ancestor, is an
//!   inclusion (for prims the two rules are the same; they differ only for property paths, which
//!   never name a gprim).
//!
//! What is supported, and what is not (each unsupported part is one warning naming the prim):
//! - `includes`, `excludes`, `expansionRule`, `includeRoot`, with each collection's schema fallback
//!   (the caller passes it: UsdLuxLightAPI's `lightLink` and `shadowLink` fall back to
//!   `includeRoot = true`, so an unauthored collection holds everything);
//! - not supported: a target naming another collection (`</Light.collection:other>`, usd-core's
//!   nested collections; the target is ignored) and `membershipExpression` (path expressions; the
//!   rule map above is used as if it were not authored); a target naming a GeomSubset (face-set
//!   linking, which usd-core's membership does not extend to the gprim either) is kept as a path,
//!   with a warning that the gprim's own membership decides.

use std::collections::HashMap;

/// How a collection's includes expand (`expansionRule`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum ExpansionRule {
    /// Only the paths named.
    ExplicitOnly,
    /// The paths named and every prim below them.
    ExpandPrims,
    /// As `ExpandPrims`, plus their properties.
    ExpandPrimsAndProperties,
}

impl ExpansionRule {
    /// The rule a token names; `None` for an unknown token.
    pub(super) fn from_token(token: &str) -> Option<Self> {
        match token {
            "explicitOnly" => Some(ExpansionRule::ExplicitOnly),
            "expandPrims" => Some(ExpansionRule::ExpandPrims),
            "expandPrimsAndProperties" => Some(ExpansionRule::ExpandPrimsAndProperties),
            _ => None,
        }
    }
}

/// A collection's authored membership, ready for [`Membership::includes`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub(super) struct Membership {
    rule: ExpansionRule,
    /// Path → included (`false`: excluded).
    paths: HashMap<String, bool>,
}

impl Membership {
    /// The membership of `includes` minus `excludes` under `rule`, with the root included when
    /// `include_root` is set.
    pub(super) fn new(
        rule: ExpansionRule,
        include_root: bool,
        includes: &[String],
        excludes: &[String],
    ) -> Self {
        let mut paths: HashMap<String, bool> = includes.iter().map(|p| (p.clone(), true)).collect();
        if include_root {
            paths.insert("/".to_string(), true);
        }
        for p in excludes {
            paths.insert(p.clone(), false);
        }
        Membership { rule, paths }
    }

    /// Whether the collection holds every prim (the root included, nothing excluded, expanding):
    /// the common case, which needs no per-gprim evaluation.
    pub(super) fn is_everything(&self) -> bool {
        self.rule != ExpansionRule::ExplicitOnly
            && self.paths.get("/") == Some(&true)
            && self.paths.values().all(|&i| i)
    }

    /// Whether the prim at absolute path `path` is a member.
    pub(super) fn includes(&self, path: &str) -> bool {
        if self.rule == ExpansionRule::ExplicitOnly {
            // usd-core never counts the pseudo-root itself as a member.
            return path != "/" && self.paths.get(path) == Some(&true);
        }
        let mut at = path;
        loop {
            if let Some(&included) = self.paths.get(at) {
                return included;
            }
            if at == "/" {
                return false;
            }
            at = match at.rfind('/') {
                Some(0) | None => "/",
                Some(i) => &at[..i],
            };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn paths(p: &[&str]) -> Vec<String> {
        p.iter().map(|s| s.to_string()).collect()
    }

    /// The cases below were run through usd-core 26.11 (`Usd.CollectionAPI(...).
    /// ComputeMembershipQuery().IsPathIncluded`); the expected values are its answers.
    #[test]
    fn membership_matches_usd_core_on_includes_excludes_and_rules() {
        use ExpansionRule::*;
        let m = Membership::new(ExpandPrims, true, &[], &[]);
        assert!(m.is_everything());
        assert!(m.includes("/W/A/a1") && m.includes("/W/B/b1"));
        let m = Membership::new(ExpandPrims, false, &paths(&["/W/A"]), &[]);
        assert_eq!(["/W/A", "/W/A/a1", "/W/B/b1"].map(|p| m.includes(p)), [true, true, false]);
        let m = Membership::new(ExpandPrims, false, &paths(&["/W/A"]), &paths(&["/W/A/a2"]));
        assert_eq!(["/W/A/a1", "/W/A/a2"].map(|p| m.includes(p)), [true, false]);
        let m = Membership::new(ExplicitOnly, false, &paths(&["/W/A"]), &paths(&["/W/A/a2"]));
        assert_eq!(["/W/A", "/W/A/a1", "/W/A/a2"].map(|p| m.includes(p)), [true, false, false]);
        let m = Membership::new(ExplicitOnly, false, &paths(&["/W/A", "/W/A/a2"]), &paths(&["/W/A/a2"]));
        assert!(!m.includes("/W/A/a2"), "an exclusion wins over an inclusion of the same path");
        let m = Membership::new(ExpandPrims, false, &paths(&["/W/A/a1", "/W"]), &paths(&["/W/A"]));
        assert_eq!(["/W/A/a1", "/W/B/b1", "/W/A/a2"].map(|p| m.includes(p)), [true, true, false]);
        let m = Membership::new(ExpandPrims, true, &[], &paths(&["/W/A"]));
        assert!(!m.is_everything());
        assert_eq!(["/W/A/a1", "/W/B/b1"].map(|p| m.includes(p)), [false, true]);
        let m = Membership::new(ExplicitOnly, true, &[], &paths(&["/W/A"]));
        assert_eq!(["/W/A/a1", "/W/B/b1", "/"].map(|p| m.includes(p)), [false, false, false]);
        // A sibling whose name extends an included one is not below it.
        let m = Membership::new(ExpandPrimsAndProperties, false, &paths(&["/W/A"]), &[]);
        assert!(!m.includes("/W/AB/x"));
    }
}
