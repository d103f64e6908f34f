//! Inherits/specializes cycles found before openusd recurses into them.
//!
//! openusd 0.6.0 pre-caches a prim's inherit and specialize targets before composing it
//! (`IndexCache::precache_inherit_targets`), and recurses into each already-composed target's own
//! targets with no visited set. A cycle among classes that are already composed (`X` inherits
//! `C1`, `C1` inherits `C2`, `C2` inherits `C1`; or a class that specializes itself) therefore
//! recurses until the native stack overflows and the process aborts: no error, no unwinding.
//! Cycles through the prim being composed are caught by the crate (it marks that prim in
//! progress) and reported as `ArcCycle`; those through classes are not. Chains that branch and
//! rejoin (a diamond of classes, repeated) make the same recursion exponential: a hang.
//!
//! [`ClassArcs`] collects every authored `inheritPaths` and `specializes` opinion of the layers
//! the stage has loaded, as edges between prim paths (the raw authored paths, made absolute at
//! the prim that authors them, the same paths the crate's pre-cache starts from), and refuses a
//! stage whose edges hold an exact cycle (naming the chain) or whose walks from one prim exceed
//! [`MAX_CLASS_WALK`] hops. It is fed each layer once, as layers load (the crate opens referenced
//! layers lazily, while prims compose), and is asked before each prim is composed.
//!
//! Edges are keyed by path across layers: the crate's pre-cache also looks fields up by path in
//! every layer of the prim's parent index, so an edge in one layer and its return edge in another
//! compose into the same loop there. What this does not see: a cycle that only closes after a
//! target is mapped through a reference (the crate also tries each target mapped across the
//! composing prim's ancestral arcs); none is known to occur outside crafted files.
//!
//! Removable when openusd's pre-cache keeps a visited set: open upstream as of openusd 0.6.0.

use std::collections::{HashMap, HashSet};
use std::path::Path as FsPath;

use openusd::sdf;

/// Most class-arc hops one prim's pre-cache may walk (counting each path through a diamond once
/// per way it is reached, as the crate's recursion does). Real assets walk a handful; 100,000
/// is far beyond any authored class hierarchy and still a fraction of a second in the crate.
pub(crate) const MAX_CLASS_WALK: u64 = 100_000;

/// Longest inherits/specializes chain accepted. The crate's pre-cache recurses once per class of
/// a chain on the native stack, so a deeper chain is refused as the explicit limit rather than
/// left to overflow; 1,000 is twice usd-core's composition depth and composes on the stack the
/// reader runs on (see [`crate::usd::load`]).
pub(crate) const MAX_CLASS_DEPTH: u32 = 1_000;

/// The arc kinds the pre-cache follows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Arc {
    Inherit,
    Specialize,
}

impl Arc {
    fn name(self) -> &'static str {
        match self {
            Arc::Inherit => "inherit",
            Arc::Specialize => "specialize",
        }
    }
}

/// One authored class arc.
#[derive(Clone, Debug)]
struct Edge {
    target: String,
    arc: Arc,
    /// The layer that authors it.
    layer: String,
}

/// What [`ClassArcs::check`] refuses.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct ClassArcProblem {
    /// The layer that authors the first arc of the chain.
    pub layer: String,
    /// The prim the chain starts at.
    pub prim: String,
    /// The chain and what is wrong with it.
    pub message: String,
}

/// Authored inherit/specialize arcs of the loaded layers (see the module docs).
#[derive(Default)]
pub(crate) struct ClassArcs {
    scanned: HashSet<String>,
    edges: HashMap<String, Vec<Edge>>,
    /// Whether edges were added since the last [`ClassArcs::check`].
    dirty: bool,
}

fn file_name(layer: &str) -> String {
    FsPath::new(layer).file_name().map_or(layer.to_string(), |f| f.to_string_lossy().into())
}

impl ClassArcs {
    /// How many layers were scanned.
    pub(crate) fn scanned_count(&self) -> usize {
        self.scanned.len()
    }

    /// Whether the layer `identifier` was scanned already.
    pub(crate) fn has_scanned(&self, identifier: &str) -> bool {
        self.scanned.contains(identifier)
    }

    /// Adds the class arcs `layer` authors (once per identifier).
    pub(crate) fn scan(&mut self, identifier: &str, data: &dyn sdf::AbstractData) {
        if !self.scanned.insert(identifier.to_string()) {
            return;
        }
        for spec in data.spec_paths() {
            for (field, arc) in [("inheritPaths", Arc::Inherit), ("specializes", Arc::Specialize)] {
                let Ok(Some(value)) = data.try_field(&spec, field) else { continue };
                let sdf::Value::PathListOp(list_op) = value.into_owned() else { continue };
                for target in list_op.flatten() {
                    let target = spec.make_absolute(&target).as_str().to_string();
                    let edge = Edge { target, arc, layer: identifier.to_string() };
                    self.edges.entry(spec.as_str().to_string()).or_default().push(edge);
                    self.dirty = true;
                }
            }
        }
    }

    /// The first cycle or oversized walk among the arcs scanned so far, if any.
    pub(crate) fn check(&mut self) -> Result<(), ClassArcProblem> {
        if !std::mem::take(&mut self.dirty) {
            return Ok(());
        }
        let mut starts: Vec<&String> = self.edges.keys().collect();
        // Sorted so that the same stage reports the same chain on every run.
        starts.sort();
        // (walk count, longest chain) of finished prims (memoised: the graph is acyclic below them).
        let mut walks: HashMap<&str, (u64, u32)> = HashMap::new();
        for start in starts {
            self.walk_from(start, &mut walks)?;
        }
        Ok(())
    }

    /// Depth-first from `start` with an explicit stack (a crafted chain may be as long as the
    /// file allows): a cycle is an edge back to a prim on the stack; each finished prim's walk
    /// count is 1 + the sum of its targets', its chain length 1 + the longest of theirs.
    fn walk_from<'a>(
        &'a self,
        start: &'a str,
        walks: &mut HashMap<&'a str, (u64, u32)>,
    ) -> Result<(), ClassArcProblem> {
        if walks.contains_key(start) {
            return Ok(());
        }
        // (prim, the edge that reached it, index of its next edge to follow)
        let mut stack: Vec<(&str, Option<&Edge>, usize)> = vec![(start, None, 0)];
        let mut on_stack: HashSet<&str> = HashSet::from([start]);
        while let Some(top) = stack.last_mut() {
            let prim = top.0;
            let edges = self.edges.get(prim).map_or(&[][..], Vec::as_slice);
            if let Some(edge) = edges.get(top.2) {
                top.2 += 1;
                let target = edge.target.as_str();
                if on_stack.contains(target) {
                    return Err(self.cycle(&stack, edge));
                }
                if !walks.contains_key(target) {
                    on_stack.insert(target);
                    stack.push((target, Some(edge), 0));
                }
                continue;
            }
            let finished = |e: &Edge| walks.get(e.target.as_str()).copied().unwrap_or((1, 1));
            let count = edges.iter().fold(1u64, |n, e| n.saturating_add(finished(e).0));
            let depth = 1 + edges.iter().map(|e| finished(e).1).max().unwrap_or(0);
            let too_many = count > MAX_CLASS_WALK;
            if too_many || depth > MAX_CLASS_DEPTH {
                let layer = edges.first().map_or(String::new(), |e| e.layer.clone());
                let what = if too_many {
                    format!(
                        "branch into more than {MAX_CLASS_WALK} class arcs (classes reached by many paths, each composed separately by openusd 0.6)"
                    )
                } else {
                    format!("chain more than {MAX_CLASS_DEPTH} classes deep (the composition depth limit)")
                };
                return Err(ClassArcProblem {
                    message: format!("inherits/specializes from <{prim}> in {} {what}", file_name(&layer)),
                    layer,
                    prim: prim.to_string(),
                });
            }
            walks.insert(prim, (count, depth));
            on_stack.remove(prim);
            stack.pop();
        }
        Ok(())
    }

    /// The cycle closed by `closing` (whose target is on `stack`), as a chain from that target.
    fn cycle(&self, stack: &[(&str, Option<&Edge>, usize)], closing: &Edge) -> ClassArcProblem {
        let first = stack.iter().position(|(p, _, _)| *p == closing.target).unwrap_or(0);
        // The hops after the cycle's first prim, then the closing one.
        let hops: Vec<&Edge> =
            stack[first + 1..].iter().filter_map(|(_, e, _)| *e).chain([closing]).collect();
        let layer = hops[0].layer.clone();
        let mut message = format!("composition cycle: <{}> in {}", closing.target, file_name(&layer));
        for hop in &hops {
            message.push_str(&format!(
                " -{}-> <{}> in {}",
                hop.arc.name(),
                hop.target,
                file_name(&hop.layer)
            ));
        }
        message.push_str(" (openusd 0.6 would recurse on it without end, so the stage is refused)");
        ClassArcProblem { layer, prim: closing.target.clone(), message }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(text: &str) -> Result<(), ClassArcProblem> {
        let specs = openusd::usda::parser::Parser::new(text).parse().expect("parse usda");
        let mut arcs = ClassArcs::default();
        arcs.scan("/x/a.usda", &sdf::Data::from_specs(specs));
        arcs.check()
    }

    #[test]
    fn a_class_cycle_names_its_chain() {
        let problem = check(
            "#usda 1.0\ndef \"X\" (inherits = </C1>) {}\nclass \"C1\" (inherits = </C2>) {}\nclass \"C2\" (specializes = </C1>) {}\n",
        )
        .unwrap_err();
        assert_eq!(problem.prim, "/C1");
        assert!(
            problem.message.starts_with(
                "composition cycle: </C1> in a.usda -inherit-> </C2> in a.usda -specialize-> </C1> in a.usda"
            ),
            "{}",
            problem.message
        );
    }

    #[test]
    fn a_self_specialize_is_a_cycle() {
        let problem = check("#usda 1.0\nclass \"C\" (specializes = </C>) {}\n").unwrap_err();
        assert!(problem
            .message
            .starts_with("composition cycle: </C> in a.usda -specialize-> </C> in a.usda"));
    }

    #[test]
    fn a_long_acyclic_chain_and_a_diamond_pass() {
        let mut text = String::from("#usda 1.0\n");
        for i in 0..2000 {
            text.push_str(&format!("class \"C{i}\" (inherits = [</C{}>, </D{i}>]) {{}}\nclass \"D{i}\" (inherits = </C{}>) {{}}\n", i + 1, i + 1));
        }
        // 2000 diamonds in a row would be 2^2000 walks: refused, naming the first prim.
        let problem = check(&text).unwrap_err();
        assert!(problem.message.contains("more than 100000 class arcs"), "{}", problem.message);
        let chain = |n: usize| -> String {
            let classes: String =
                (0..n).map(|i| format!("class \"C{i}\" (inherits = </C{}>) {{}}\n", i + 1)).collect();
            format!("#usda 1.0\n{classes}")
        };
        assert_eq!(check(&chain(999)), Ok(()));
        let problem = check(&chain(1000)).unwrap_err();
        assert_eq!(problem.prim, "/C0");
        assert_eq!(
            problem.message,
            "inherits/specializes from </C0> in a.usda chain more than 1000 classes deep (the composition depth limit)"
        );
    }
}
