//! Light-path expressions: a grammar in the OSL / Gaffer / RenderMan style, parsed into an NFA
//! (Thompson's construction) and compiled, for all of a render's expressions at once, into one small
//! DFA whose states carry the mask of the expressions they accept.
//!
//! ## Events
//! A path is a word over events, each a *type*, a *scattering* and, for lights, *labels*:
//!
//! | type | event                                      | scattering        | labels                       |
//! |------|--------------------------------------------|-------------------|------------------------------|
//! | `C`  | the camera (every path starts with it)     | —                 | —                            |
//! | `R`  | reflection off the lobe the vertex chose   | `D`, `G` or `S`   | —                            |
//! | `T`  | transmission (glass refraction)            | `G` or `S`        | —                            |
//! | `L`  | a UsdLux light (dome included)             | —                 | its light group, its prim name |
//! | `O`  | emission of a surface (`emissiveColor`)     | —                 | —                            |
//! | `B`  | background: no renderer event is one (the dome is a light, `L`), so it matches no path |
//!
//! Scattering: `D` diffuse, `G` glossy (a microfacet lobe of α above [`SINGULAR_ALPHA`]), `S`
//! singular (a smooth lobe). As in RenderMan and Arnold, where every non-diffuse lobe is
//! "specular", the letter `S` in an expression matches glossy and singular events; `G` matches
//! glossy alone.
//!
//! ## Grammar
//! ```text
//! alt   := seq ('|' seq)*
//! seq   := rep*
//! rep   := atom ('*' | '+' | '?')*
//! atom  := '(' alt ')' | '<' item+ '>' | item
//! item  := letter | '.' | ''' label ''' | '[' '^'? (letter | ''' label ''')* ']'
//! ```
//! Outside `<…>` a letter matches any event of that type (`C R T L O B`) or scattering (`D G S`), a
//! label any event with it, `.` any event. Inside, items are positional — type, scattering, then
//! labels — and `.` is a wildcard there: `<RD>`, `<L.'key'>`, `<T.*>`… (a trailing `*` in an
//! event is ignored, as Gaffer writes it). Examples: `C<RD>L` direct diffuse, `C<RD>.+L` indirect
//! diffuse, `C<RS>L`, `C<T.>.*L`, `CO`, `C.*O`, `C.*<L.'key'>` a light group's beauty.
//!
//! A path's contribution is added at an emitter event (`L` or `O`) to every expression whose
//! automaton accepts after it.

/// Glossy lobes have α above this; at or below it a lobe is singular (`S`).
pub const SINGULAR_ALPHA: f32 = 0.01;

/// Most expressions one render compiles (the accept mask is a `u64`).
pub const MAX_EXPRESSIONS: usize = 64;

/// Most DFA states (a runaway subset construction is an error, not a stall).
pub const MAX_STATES: usize = 4096;

/// The dead state: no expression can accept any more.
pub const DEAD: u32 = 0;

/// Scattering events, the symbols they are in the automaton's alphabet.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u32)]
pub enum Scatter {
    /// `<RD>`.
    ReflectDiffuse = 0,
    /// `<RG>`.
    ReflectGlossy = 1,
    /// `<RS>`.
    ReflectSingular = 2,
    /// `<TD>` (no lobe transmits diffusely today; kept so the alphabet is whole).
    TransmitDiffuse = 3,
    /// `<TG>`.
    TransmitGlossy = 4,
    /// `<TS>`.
    TransmitSingular = 5,
}

impl Scatter {
    /// The scattering event of a lobe of GGX `alpha` (1 for diffuse), reflecting or transmitting.
    pub fn of(diffuse: bool, alpha: f32, transmit: bool) -> Self {
        let kind = if diffuse {
            0
        } else if alpha > SINGULAR_ALPHA {
            1
        } else {
            2
        };
        match (transmit, kind) {
            (false, 0) => Scatter::ReflectDiffuse,
            (false, 1) => Scatter::ReflectGlossy,
            (false, _) => Scatter::ReflectSingular,
            (true, 0) => Scatter::TransmitDiffuse,
            (true, 1) => Scatter::TransmitGlossy,
            (true, _) => Scatter::TransmitSingular,
        }
    }
}

/// Symbols before the lights': the six scatterings, then camera, object emission, background.
const SYM_CAMERA: usize = 6;
const SYM_OBJECT: usize = 7;
const SYM_BACKGROUND: usize = 8;
const FIXED_SYMBOLS: usize = 9;

/// An event as the parser sees it: type letter, scattering letter (`-` none) and labels.
#[derive(Clone, Debug)]
struct EventShape<'a> {
    ty: u8,
    scatter: u8,
    labels: &'a [&'a str],
}

/// One set of letters and labels, possibly negated; `None` is the wildcard.
#[derive(Clone, Debug, Default, PartialEq)]
struct Set {
    negated: bool,
    letters: Vec<u8>,
    labels: Vec<String>,
}

impl Set {
    fn letter_matches(letter: u8, actual: u8) -> bool {
        // `S` is "specular": glossy or singular (see the module docs).
        letter == actual || (letter == b'S' && actual == b'G')
    }

    /// Whether this set matches position `slot` of `e` (0 type, 1 scattering, 2 labels), or any
    /// position when outside an event.
    fn matches(&self, e: &EventShape, slot: Option<usize>) -> bool {
        let letter_hit = |l: u8| match slot {
            Some(0) => l == e.ty,
            Some(1) => Self::letter_matches(l, e.scatter),
            Some(_) => false,
            None => l == e.ty || Self::letter_matches(l, e.scatter),
        };
        let label_hit = |l: &String| matches!(slot, None | Some(2)) && e.labels.contains(&l.as_str());
        let hit = self.letters.iter().any(|&l| letter_hit(l)) || self.labels.iter().any(label_hit);
        hit != self.negated
    }
}

/// What one event atom accepts.
#[derive(Clone, Debug)]
enum Pred {
    /// Outside `<…>`: one set over every position (`None`: `.`).
    Loose(Option<Set>),
    /// `<type scatter label…>`: each position a set or a wildcard.
    Event(Vec<Option<Set>>),
}

impl Pred {
    fn matches(&self, e: &EventShape) -> bool {
        match self {
            Pred::Loose(None) => true,
            Pred::Loose(Some(s)) => s.matches(e, None),
            Pred::Event(items) => items.iter().enumerate().all(|(i, item)| match item {
                None => true,
                Some(s) => s.matches(e, Some(i.min(2))),
            }),
        }
    }
}

#[derive(Clone, Debug)]
enum Ast {
    Atom(Pred),
    Seq(Vec<Ast>),
    Alt(Vec<Ast>),
    Star(Box<Ast>),
    Plus(Box<Ast>),
    Optional(Box<Ast>),
}

impl Ast {
    /// Every label the expression names.
    fn labels(&self, out: &mut Vec<String>) {
        let mut set = |s: &Option<Set>| {
            if let Some(s) = s {
                out.extend(s.labels.iter().cloned());
            }
        };
        match self {
            Ast::Atom(Pred::Loose(s)) => set(s),
            Ast::Atom(Pred::Event(items)) => items.iter().for_each(set),
            Ast::Seq(v) | Ast::Alt(v) => v.iter().for_each(|a| a.labels(out)),
            Ast::Star(a) | Ast::Plus(a) | Ast::Optional(a) => a.labels(out),
        }
    }
}

/// A syntax error: the expression, where and what.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct LpeError {
    /// The expression.
    pub expression: String,
    /// Byte offset of the problem.
    pub at: usize,
    /// What was wrong.
    pub message: String,
}

impl std::fmt::Display for LpeError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "light-path expression {:?}: {} at byte {}", self.expression, self.message, self.at)
    }
}

struct Parser<'a> {
    text: &'a [u8],
    at: usize,
    source: &'a str,
}

const TYPE_LETTERS: &[u8] = b"CRTLOB";
const SCATTER_LETTERS: &[u8] = b"DGS";

impl Parser<'_> {
    fn fail<T>(&self, message: impl Into<String>) -> Result<T, LpeError> {
        Err(LpeError { expression: self.source.to_string(), at: self.at, message: message.into() })
    }

    fn peek(&self) -> Option<u8> {
        self.text.get(self.at).copied()
    }

    fn skip_space(&mut self) {
        while self.peek().is_some_and(|c| c.is_ascii_whitespace()) {
            self.at += 1;
        }
    }

    fn alt(&mut self) -> Result<Ast, LpeError> {
        let mut arms = vec![self.seq()?];
        while self.peek() == Some(b'|') {
            self.at += 1;
            arms.push(self.seq()?);
        }
        Ok(if arms.len() == 1 { arms.pop().unwrap_or(Ast::Seq(Vec::new())) } else { Ast::Alt(arms) })
    }

    fn seq(&mut self) -> Result<Ast, LpeError> {
        let mut items = Vec::new();
        loop {
            self.skip_space();
            match self.peek() {
                None | Some(b'|') | Some(b')') => break,
                _ => items.push(self.rep()?),
            }
        }
        Ok(Ast::Seq(items))
    }

    fn rep(&mut self) -> Result<Ast, LpeError> {
        let mut ast = self.atom()?;
        loop {
            ast = match self.peek() {
                Some(b'*') => Ast::Star(Box::new(ast)),
                Some(b'+') => Ast::Plus(Box::new(ast)),
                Some(b'?') => Ast::Optional(Box::new(ast)),
                _ => return Ok(ast),
            };
            self.at += 1;
        }
    }

    fn atom(&mut self) -> Result<Ast, LpeError> {
        match self.peek() {
            Some(b'(') => {
                self.at += 1;
                let inner = self.alt()?;
                if self.peek() != Some(b')') {
                    return self.fail("expected `)`");
                }
                self.at += 1;
                Ok(inner)
            }
            Some(b'<') => {
                self.at += 1;
                let mut items = Vec::new();
                loop {
                    self.skip_space();
                    match self.peek() {
                        Some(b'>') => break,
                        // Gaffer's `<T.*>`: a trailing `*` inside an event means "any further labels".
                        Some(b'*') => self.at += 1,
                        None => return self.fail("expected `>`"),
                        _ => items.push(self.item(true)?),
                    }
                }
                self.at += 1;
                if items.is_empty() {
                    return self.fail("empty event `<>`");
                }
                Ok(Ast::Atom(Pred::Event(items)))
            }
            Some(b'*' | b'+' | b'?') => self.fail("repetition with nothing to repeat"),
            Some(b'>' | b']') => self.fail("unbalanced bracket"),
            _ => Ok(Ast::Atom(Pred::Loose(self.item(false)?))),
        }
    }

    /// A letter, `.`, a label or a set; `None` for `.`.
    fn item(&mut self, in_event: bool) -> Result<Option<Set>, LpeError> {
        match self.peek() {
            Some(b'.') => {
                self.at += 1;
                Ok(None)
            }
            Some(b'[') => {
                self.at += 1;
                let mut set = Set::default();
                if self.peek() == Some(b'^') {
                    set.negated = true;
                    self.at += 1;
                }
                loop {
                    self.skip_space();
                    match self.peek() {
                        Some(b']') => break,
                        Some(b'\'') => set.labels.push(self.label()?),
                        Some(c) if TYPE_LETTERS.contains(&c) || SCATTER_LETTERS.contains(&c) => {
                            set.letters.push(c);
                            self.at += 1;
                        }
                        Some(c) => return self.fail(format!("`{}` is not an event letter", c as char)),
                        None => return self.fail("expected `]`"),
                    }
                }
                self.at += 1;
                Ok(Some(set))
            }
            Some(b'\'') => Ok(Some(Set { labels: vec![self.label()?], ..Set::default() })),
            Some(c) if TYPE_LETTERS.contains(&c) || SCATTER_LETTERS.contains(&c) => {
                self.at += 1;
                Ok(Some(Set { letters: vec![c], ..Set::default() }))
            }
            Some(c) => {
                let what = if in_event { "in an event" } else { "here" };
                self.fail(format!("`{}` is not an event letter, `.`, a set or a label {what}", c as char))
            }
            None => self.fail("unexpected end"),
        }
    }

    fn label(&mut self) -> Result<String, LpeError> {
        self.at += 1;
        let start = self.at;
        while self.peek().is_some_and(|c| c != b'\'') {
            self.at += 1;
        }
        if self.peek().is_none() {
            return self.fail("unterminated label");
        }
        let label = String::from_utf8_lossy(&self.text[start..self.at]).into_owned();
        self.at += 1;
        Ok(label)
    }
}

/// Parses one expression.
fn parse(source: &str) -> Result<Ast, LpeError> {
    let mut p = Parser { text: source.as_bytes(), at: 0, source };
    let ast = p.alt()?;
    if p.at != p.text.len() {
        return p.fail("unexpected `)`");
    }
    Ok(ast)
}

/// The NFA: states with ε-edges and symbol-set edges; state 0 of each expression is its start.
#[derive(Default)]
struct Nfa {
    epsilon: Vec<Vec<usize>>,
    /// (symbols, target) per state.
    edges: Vec<Vec<(Vec<bool>, usize)>>,
    /// Expression index per accepting state.
    accept: Vec<Option<usize>>,
}

impl Nfa {
    fn state(&mut self) -> usize {
        self.epsilon.push(Vec::new());
        self.edges.push(Vec::new());
        self.accept.push(None);
        self.epsilon.len() - 1
    }

    /// Thompson's construction of `ast` from `from`; returns the end state.
    fn build(&mut self, ast: &Ast, from: usize, symbols: &[EventShape]) -> usize {
        match ast {
            Ast::Atom(pred) => {
                let to = self.state();
                let set = symbols.iter().map(|e| pred.matches(e)).collect();
                self.edges[from].push((set, to));
                to
            }
            Ast::Seq(items) => items.iter().fold(from, |at, item| self.build(item, at, symbols)),
            Ast::Alt(arms) => {
                let end = self.state();
                for arm in arms {
                    let start = self.state();
                    self.epsilon[from].push(start);
                    let out = self.build(arm, start, symbols);
                    self.epsilon[out].push(end);
                }
                end
            }
            Ast::Star(inner) | Ast::Plus(inner) | Ast::Optional(inner) => {
                let start = self.state();
                let end = self.state();
                self.epsilon[from].push(start);
                let out = self.build(inner, start, symbols);
                self.epsilon[out].push(end);
                if !matches!(ast, Ast::Plus(_)) {
                    self.epsilon[from].push(end);
                }
                if !matches!(ast, Ast::Optional(_)) {
                    self.epsilon[out].push(start);
                }
                end
            }
        }
    }

    fn closure(&self, states: &mut Vec<usize>) {
        let mut i = 0;
        while i < states.len() {
            for &next in &self.epsilon[states[i]] {
                if !states.contains(&next) {
                    states.push(next);
                }
            }
            i += 1;
        }
        states.sort_unstable();
    }
}

/// A light as the automaton sees it: its light group (if any) and prim path.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct LightNames {
    /// The light group.
    pub group: Option<String>,
    /// The prim path (its last element is the name labels match).
    pub path: String,
}

/// The compiled automaton of a render's expressions.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Automaton {
    /// Symbols of the alphabet: [`FIXED_SYMBOLS`] and one class per distinct light label set.
    symbols: usize,
    /// Symbol of each light.
    light_symbol: Vec<u32>,
    /// `next[state × symbols + symbol]`.
    next: Vec<u32>,
    /// Accepted expressions per state (bit `i`: expression `i`).
    accepts: Vec<u64>,
    /// The state after the camera event.
    start: u32,
}

impl Automaton {
    /// Compiles `expressions` for a scene with `lights`. An `lpe:` prefix (RenderMan's spelling) is
    /// dropped.
    pub fn compile(expressions: &[&str], lights: &[LightNames]) -> Result<Self, LpeError> {
        let too_many =
            |what: &str| LpeError { expression: expressions.join(" "), at: 0, message: what.into() };
        if expressions.len() > MAX_EXPRESSIONS {
            return Err(too_many("more than 64 light-path expressions in one render"));
        }
        let asts: Vec<Ast> = expressions
            .iter()
            .map(|e| parse(e.strip_prefix("lpe:").unwrap_or(e)))
            .collect::<Result<_, _>>()?;
        // The alphabet: lights are classed by the labels they carry, so a thousand lights of three
        // groups make three symbols.
        let mut mentioned = Vec::new();
        asts.iter().for_each(|a| a.labels(&mut mentioned));
        let names: Vec<Vec<&str>> = lights
            .iter()
            .map(|l| {
                let name = l.path.rsplit('/').next().unwrap_or(&l.path);
                let mut labels: Vec<&str> = l.group.as_deref().into_iter().chain([name]).collect();
                labels.retain(|l| mentioned.iter().any(|m| m == l));
                labels.sort_unstable();
                labels.dedup();
                labels
            })
            .collect();
        let mut classes: Vec<&Vec<&str>> = Vec::new();
        let mut light_symbol = Vec::with_capacity(lights.len());
        for n in &names {
            let class = classes.iter().position(|c| *c == n).unwrap_or_else(|| {
                classes.push(n);
                classes.len() - 1
            });
            light_symbol.push((FIXED_SYMBOLS + class) as u32);
        }
        let none: &[&str] = &[];
        let mut shapes: Vec<EventShape> =
            [(b'R', b'D'), (b'R', b'G'), (b'R', b'S'), (b'T', b'D'), (b'T', b'G'), (b'T', b'S')]
                .iter()
                .map(|&(ty, scatter)| EventShape { ty, scatter, labels: none })
                .collect();
        for ty in [b'C', b'O', b'B'] {
            shapes.push(EventShape { ty, scatter: b'-', labels: none });
        }
        for c in &classes {
            shapes.push(EventShape { ty: b'L', scatter: b'-', labels: c });
        }
        let symbols = shapes.len();

        let mut nfa = Nfa::default();
        let root = nfa.state();
        for (i, ast) in asts.iter().enumerate() {
            let start = nfa.state();
            nfa.epsilon[root].push(start);
            let end = nfa.build(ast, start, &shapes);
            nfa.accept[end] = Some(i);
        }
        // Subset construction; DFA state 0 is the dead (empty) set.
        let mut sets: Vec<Vec<usize>> = vec![Vec::new()];
        let mut first = vec![root];
        nfa.closure(&mut first);
        sets.push(first);
        let mut next = Vec::new();
        let mut i = 0;
        while i < sets.len() {
            for sym in 0..symbols {
                let mut to: Vec<usize> = Vec::new();
                for &s in &sets[i] {
                    for (set, target) in &nfa.edges[s] {
                        if set[sym] && !to.contains(target) {
                            to.push(*target);
                        }
                    }
                }
                nfa.closure(&mut to);
                let index = match sets.iter().position(|s| *s == to) {
                    Some(index) => index,
                    None => {
                        if sets.len() >= MAX_STATES {
                            return Err(too_many("the expressions need more than 4096 automaton states"));
                        }
                        sets.push(to);
                        sets.len() - 1
                    }
                };
                next.push(index as u32);
            }
            i += 1;
        }
        let accepts = sets
            .iter()
            .map(|set| set.iter().filter_map(|&s| nfa.accept[s]).fold(0u64, |m, e| m | 1 << e))
            .collect();
        let start = next[symbols + SYM_CAMERA];
        Ok(Automaton { symbols, light_symbol, next, accepts, start })
    }

    /// The state of a path that left the camera.
    #[inline]
    pub fn start(&self) -> u32 {
        self.start
    }

    /// Distinct light symbols: above one, the expressions tell some lights apart.
    pub fn light_classes(&self) -> usize {
        self.symbols - FIXED_SYMBOLS
    }

    /// Number of states (the dead state included).
    pub fn state_count(&self) -> usize {
        self.accepts.len()
    }

    #[inline]
    fn step(&self, state: u32, symbol: usize) -> u32 {
        self.next[state as usize * self.symbols + symbol]
    }

    /// The state after scattering event `scatter`.
    #[inline]
    pub fn scatter(&self, state: u32, scatter: Scatter) -> u32 {
        self.step(state, scatter as usize)
    }

    /// The expressions that accept a path in `state` ending at light `light`.
    #[inline]
    pub fn light_accepts(&self, state: u32, light: usize) -> u64 {
        let symbol = self.light_symbol.get(light).map_or(SYM_BACKGROUND, |&s| s as usize);
        self.accepts[self.step(state, symbol) as usize]
    }

    /// The expressions that accept a path in `state` ending at an emissive surface.
    #[inline]
    pub fn object_accepts(&self, state: u32) -> u64 {
        self.accepts[self.step(state, SYM_OBJECT) as usize]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use Scatter::*;

    fn lights() -> Vec<LightNames> {
        vec![
            LightNames { group: Some("key".into()), path: "/World/Sun".into() },
            LightNames { group: None, path: "/World/Fill".into() },
        ]
    }

    /// The accept mask of a path of scatterings ending at `end` (`Some(light)` or `None`: object).
    fn run(a: &Automaton, path: &[Scatter], end: Option<usize>) -> u64 {
        let s = path.iter().fold(a.start(), |s, &e| a.scatter(s, e));
        match end {
            Some(l) => a.light_accepts(s, l),
            None => a.object_accepts(s),
        }
    }

    #[test]
    fn the_comp_expressions_accept_the_paths_they_name() {
        let exprs = [
            "C<RD>L",
            "C<RD>.+L",
            "C<RS>L",
            "C<RS>.+L",
            "C<T.*>.*L",
            "C.*O",
            "C.*<L.'key'>",
            "lpe:C[DG]*L",
            "C<R[^D]>L",
            "C(<RD>|<RG>)?'Fill'",
        ];
        let a = Automaton::compile(&exprs, &lights()).unwrap();
        let bit = |i: usize| 1u64 << i;
        assert_eq!(run(&a, &[ReflectDiffuse], Some(1)), bit(0) | bit(7) | bit(9));
        assert_eq!(run(&a, &[ReflectDiffuse], Some(0)), bit(0) | bit(6) | bit(7));
        assert_eq!(run(&a, &[ReflectDiffuse, ReflectGlossy], Some(1)), bit(1) | bit(7));
        assert_eq!(run(&a, &[ReflectGlossy], Some(1)), bit(2) | bit(7) | bit(8) | bit(9));
        assert_eq!(run(&a, &[ReflectSingular], Some(1)), bit(2) | bit(8));
        assert_eq!(run(&a, &[ReflectSingular, TransmitSingular], Some(0)), bit(3) | bit(6));
        assert_eq!(run(&a, &[TransmitSingular, TransmitSingular, ReflectDiffuse], Some(1)), bit(4));
        assert_eq!(run(&a, &[ReflectDiffuse], None), bit(5));
        assert_eq!(run(&a, &[], None), bit(5));
        assert_eq!(run(&a, &[], Some(0)), bit(6) | bit(7));
        assert_eq!(run(&a, &[], Some(1)), bit(7) | bit(9));
        assert!(a.state_count() < 64, "{} states", a.state_count());
    }

    #[test]
    fn the_direct_and_indirect_split_partitions_every_path() {
        let exprs = ["C<RD>L", "C<RD>.+L", "C<RS>L", "C<RS>.+L", "C<T.*>.*L", "C.*O", "CL"];
        let a = Automaton::compile(&exprs, &lights()).unwrap();
        let all = [ReflectDiffuse, ReflectGlossy, ReflectSingular, TransmitGlossy, TransmitSingular];
        // Every path of up to three events ends in exactly one expression.
        let mut paths: Vec<Vec<Scatter>> = vec![vec![]];
        for _ in 0..3 {
            let longer: Vec<Vec<Scatter>> =
                paths.iter().flat_map(|p| all.iter().map(move |&e| [p.clone(), vec![e]].concat())).collect();
            paths.extend(longer);
        }
        paths.dedup();
        for p in &paths {
            for end in [Some(0), Some(1), None] {
                assert_eq!(run(&a, p, end).count_ones(), 1, "{p:?} {end:?}");
            }
        }
    }

    #[test]
    fn syntax_errors_say_where() {
        let err = |e: &str| Automaton::compile(&[e], &[]).unwrap_err().to_string();
        assert_eq!(err("C<RD"), "light-path expression \"C<RD\": expected `>` at byte 4");
        assert_eq!(err("C(RD"), "light-path expression \"C(RD\": expected `)` at byte 4");
        assert_eq!(
            err("C*Q"),
            "light-path expression \"C*Q\": `Q` is not an event letter, `.`, a set or a label here at byte 2"
        );
        assert_eq!(err("C<RD>'key"), "light-path expression \"C<RD>'key\": unterminated label at byte 9");
        assert_eq!(err("*L"), "light-path expression \"*L\": repetition with nothing to repeat at byte 0");
        assert_eq!(err("CL)"), "light-path expression \"CL)\": unexpected `)` at byte 2");
    }

    #[test]
    fn scatter_classes_follow_the_lobe() {
        assert_eq!(Scatter::of(true, 1.0, false), ReflectDiffuse);
        assert_eq!(Scatter::of(false, 0.25, false), ReflectGlossy);
        assert_eq!(Scatter::of(false, 1e-3, false), ReflectSingular);
        assert_eq!(Scatter::of(false, 1e-3, true), TransmitSingular);
    }
}
