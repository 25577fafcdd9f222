//! The layout's rules (ARCHITECTURE.md), checked on the source itself: `sim/` uses nothing
//! from `io/`, `lab/` or the door; `io/` nothing from `lab/` or the door; the door
//! (`cli`, `progargs`, `error`, and the `fluid` binary) nothing from `lab/`, so the
//! `fluid` binary's path reaches no workbench code; `lab/` nothing from the door. Every
//! module lives in a wing or at the door. Inside `sim/`, the top-level modules sit in
//! layers ([`SIM_LAYERS`]: constants and derived parameters below the models, the models
//! below the driver), and a module uses only lower ones (and its own folder), so no import
//! circle can form between them; `sim/mod.rs` uses none of them, so that no re-export
//! there can hide a use.
//!
//! Each file under `src/` is parsed with `syn`. A use of another module is any path that
//! starts with `crate`, `self` or `super` (or `fluid` in a binary), in `use` items, in
//! code, in types, and in the tokens of macro calls and attributes. What would hide code
//! or a path from this map is refused: `#[path]` (also inside `cfg_attr`), `include!`,
//! `extern crate` and `#[macro_use]`.

use proc_macro2::{TokenStream, TokenTree};
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use syn::visit::Visit;

/// Where a module sits in the layout.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Wing {
    /// `lib.rs`, which declares the wings.
    Root,
    /// `sim/`: the model and one time step.
    Sim,
    /// `io/`: files in and out.
    Io,
    /// `lab/` and the `fluid-lab` binary: the workbench.
    Lab,
    /// `cli`, `progargs`, `error` and the `fluid` binary: the fixed contract.
    Door,
}

impl Wing {
    /// The wing of a module, by its path from the crate root; `None` outside every wing.
    fn of(module: &[String]) -> Option<Wing> {
        match module.first().map(String::as_str) {
            None => Some(Wing::Root),
            Some("sim") => Some(Wing::Sim),
            Some("io") => Some(Wing::Io),
            Some("lab" | "bin:fluid-lab") => Some(Wing::Lab),
            Some("cli" | "progargs" | "error" | "bin:fluid") => Some(Wing::Door),
            Some(_) => None,
        }
    }

    /// Whether code in `self` may use modules of `other`.
    fn may_use(self, other: Wing) -> bool {
        use Wing::*;
        match self {
            Root => true,
            Sim => other == Sim,
            Io => matches!(other, Sim | Io),
            Lab => matches!(other, Sim | Io | Lab),
            Door => matches!(other, Sim | Io | Door),
        }
    }
}

/// The layers of `sim/`'s modules, lowest first. Outside its tests (which may set up a
/// whole simulation), a module of `sim/` uses only modules of lower layers, those of its
/// own folder and the wing's root (`sim/mod.rs`); a module of `sim/` in no layer is refused.
const SIM_LAYERS: [&[&str]; 9] = [
    &["params", "isa"],
    &["particles", "grid"],
    &["timestep", "cells"],
    &["neighbours", "skin", "stages"],
    &["lists"],
    &["kernel"],
    &["model"],
    &["method"],
    &["simulation"],
];

/// The layer of a module of `sim/` (by its folder or file below `sim/`): `None` for the
/// wing's root, `Some(None)` for a module in no layer, `Some(Some(k))` for layer k.
fn sim_layer(module: &[String]) -> Option<Option<usize>> {
    match module {
        [wing, top, ..] if wing == "sim" => Some(
            SIM_LAYERS
                .iter()
                .position(|layer| layer.contains(&top.as_str())),
        ),
        _ => None,
    }
}

/// One use of a module by another.
#[derive(Debug, Clone)]
struct Edge {
    from: Vec<String>,
    to: Vec<String>,
    /// The path as written.
    text: String,
    /// Inside `#[cfg(test)]`: not part of any binary.
    test_only: bool,
    file: PathBuf,
}

/// The module graph of a crate's sources.
#[derive(Debug, Default)]
struct Graph {
    /// Every module: file modules and inline ones.
    modules: BTreeSet<Vec<String>>,
    /// The file each module's own code is in (an inline module's is its parent's).
    files: BTreeMap<Vec<String>, PathBuf>,
    /// Modules declared inside `#[cfg(test)]`: not part of any binary.
    test_modules: BTreeSet<Vec<String>>,
    /// Names the crate root re-exports (`pub use`), and what they stand for.
    root_exports: BTreeMap<String, Vec<String>>,
    edges: Vec<Edge>,
    /// Defects that are not edges (a `#[path]` attribute, a file syn cannot parse).
    defects: Vec<String>,
}

/// The module path of a source file below `src/`; binaries get a module of their own.
fn module_of(relative: &Path) -> Vec<String> {
    let parts: Vec<String> = relative
        .with_extension("")
        .iter()
        .map(|part| part.to_string_lossy().into_owned())
        .collect();
    match parts.iter().map(String::as_str).collect::<Vec<_>>()[..] {
        ["lib"] => Vec::new(),
        ["main"] => vec!["bin:fluid".into()],
        ["bin", name] | ["bin", name, "main"] => vec![format!("bin:{name}")],
        _ if parts.last().is_some_and(|last| last == "mod") => parts[..parts.len() - 1].to_vec(),
        _ => parts,
    }
}

fn is_cfg_test(attrs: &[syn::Attribute]) -> bool {
    attrs.iter().any(|attr| {
        attr.path().is_ident("cfg")
            && matches!(&attr.meta, syn::Meta::List(list) if list.tokens.to_string() == "test")
    })
}

fn item_attrs(item: &syn::Item) -> &[syn::Attribute] {
    match item {
        syn::Item::Const(i) => &i.attrs,
        syn::Item::Enum(i) => &i.attrs,
        syn::Item::Fn(i) => &i.attrs,
        syn::Item::Impl(i) => &i.attrs,
        syn::Item::Mod(i) => &i.attrs,
        syn::Item::Static(i) => &i.attrs,
        syn::Item::Struct(i) => &i.attrs,
        syn::Item::Trait(i) => &i.attrs,
        syn::Item::Type(i) => &i.attrs,
        syn::Item::Use(i) => &i.attrs,
        _ => &[],
    }
}

/// Collects the anchored paths of one file.
struct FileVisitor<'g> {
    graph: &'g mut Graph,
    file: PathBuf,
    /// The module being visited (the file's, then inline modules).
    module: Vec<String>,
    /// Depth of `#[cfg(test)]` items around the current position.
    test_depth: usize,
    /// Paths written, relative to `module` at the time: (module, segments, test-only).
    paths: Vec<(Vec<String>, Vec<String>, bool)>,
}

impl FileVisitor<'_> {
    fn refuse(&mut self, what: String) {
        let defect = format!("{}: {what} is refused", self.file.display());
        self.graph.defects.push(defect);
    }

    fn record(&mut self, segments: Vec<String>) {
        let anchored = matches!(
            segments.first().map(String::as_str),
            Some("crate" | "self" | "super" | "fluid")
        );
        if anchored {
            self.paths
                .push((self.module.clone(), segments, self.test_depth > 0));
        }
    }

    /// Every `crate::a::b` (or `super::`, `self::`, `fluid::`) run of tokens in a macro call.
    fn scan_tokens(&mut self, tokens: TokenStream) {
        let tokens: Vec<TokenTree> = tokens.into_iter().collect();
        let mut i = 0;
        while i < tokens.len() {
            match &tokens[i] {
                TokenTree::Group(group) => self.scan_tokens(group.stream()),
                TokenTree::Ident(ident) => {
                    let mut segments = vec![ident.to_string()];
                    let mut j = i + 1;
                    while let (Some(TokenTree::Punct(a)), Some(TokenTree::Punct(b))) =
                        (tokens.get(j), tokens.get(j + 1))
                    {
                        let Some(TokenTree::Ident(next)) = tokens.get(j + 2) else {
                            break;
                        };
                        if a.as_char() != ':' || b.as_char() != ':' {
                            break;
                        }
                        segments.push(next.to_string());
                        j += 3;
                    }
                    if segments.len() > 1 {
                        self.record(segments);
                    }
                    i = j - 1;
                }
                _ => {}
            }
            i += 1;
        }
    }
}

/// The paths a `use` tree names, each with the name it binds (a glob binds none).
fn use_tree_paths(
    tree: &syn::UseTree,
    prefix: &mut Vec<String>,
    out: &mut Vec<(Vec<String>, Option<String>)>,
) {
    match tree {
        syn::UseTree::Path(path) => {
            prefix.push(path.ident.to_string());
            use_tree_paths(&path.tree, prefix, out);
            prefix.pop();
        }
        syn::UseTree::Name(name) => {
            let mut full = prefix.clone();
            if name.ident != "self" {
                full.push(name.ident.to_string());
            }
            let bound = full.last().cloned();
            out.push((full, bound));
        }
        syn::UseTree::Rename(rename) => {
            let mut full = prefix.clone();
            if rename.ident != "self" {
                full.push(rename.ident.to_string());
            }
            out.push((full, Some(rename.rename.to_string())));
        }
        syn::UseTree::Glob(_) => out.push((prefix.clone(), None)),
        syn::UseTree::Group(group) => {
            for item in &group.items {
                use_tree_paths(item, prefix, out);
            }
        }
    }
}

impl<'ast> Visit<'ast> for FileVisitor<'_> {
    fn visit_item(&mut self, item: &'ast syn::Item) {
        let test = is_cfg_test(item_attrs(item));
        self.test_depth += usize::from(test);
        syn::visit::visit_item(self, item);
        self.test_depth -= usize::from(test);
    }

    fn visit_attribute(&mut self, attr: &'ast syn::Attribute) {
        let path = attr.path();
        let hidden_path = path.is_ident("cfg_attr")
            && matches!(&attr.meta, syn::Meta::List(list) if list.tokens.clone().into_iter()
                .any(|token| matches!(token, TokenTree::Ident(ident) if ident == "path")));
        if path.is_ident("path") || path.is_ident("macro_use") || hidden_path {
            let name = path
                .get_ident()
                .map(ToString::to_string)
                .unwrap_or_default();
            self.refuse(format!("#[{name}]"));
        }
        syn::visit::visit_attribute(self, attr);
    }

    fn visit_item_extern_crate(&mut self, item: &'ast syn::ItemExternCrate) {
        self.refuse(format!("extern crate {}", item.ident));
    }

    fn visit_item_mod(&mut self, item: &'ast syn::ItemMod) {
        self.module.push(item.ident.to_string());
        self.graph.modules.insert(self.module.clone());
        if item.content.is_some() {
            let file = self.file.clone();
            self.graph.files.insert(self.module.clone(), file);
        }
        if self.test_depth > 0 {
            self.graph.test_modules.insert(self.module.clone());
        }
        syn::visit::visit_item_mod(self, item);
        self.module.pop();
    }

    fn visit_item_use(&mut self, item: &'ast syn::ItemUse) {
        if self.module == ["sim"] && self.test_depth == 0 {
            // A re-export there would let a lower layer name a higher one as `crate::sim::X`.
            self.refuse("a `use` in the root of sim/, which only declares its modules,".into());
        }
        let mut paths = Vec::new();
        use_tree_paths(&item.tree, &mut Vec::new(), &mut paths);
        if self.module.is_empty() && matches!(item.vis, syn::Visibility::Public(_)) {
            for (path, bound) in &paths {
                if let Some(name) = bound {
                    let target = path.iter().skip_while(|s| *s == "crate" || *s == "self");
                    let target = target.cloned().collect();
                    self.graph.root_exports.insert(name.clone(), target);
                }
            }
        }
        for (path, _) in paths {
            self.record(path);
        }
    }

    fn visit_path(&mut self, path: &'ast syn::Path) {
        let segments = path.segments.iter().map(|s| s.ident.to_string()).collect();
        self.record(segments);
        syn::visit::visit_path(self, path);
    }

    fn visit_vis_restricted(&mut self, _: &'ast syn::VisRestricted) {
        // `pub(super)`, `pub(in crate::x)` limit who sees an item; they use nothing.
    }

    fn visit_macro(&mut self, mac: &'ast syn::Macro) {
        if mac.path.is_ident("include") {
            self.refuse("include!".to_string());
        }
        syn::visit::visit_macro(self, mac);
    }

    /// The tokens of macro calls and of attributes (`#[arg(value_parser = crate::x)]`).
    fn visit_token_stream(&mut self, tokens: &'ast TokenStream) {
        self.scan_tokens(tokens.clone());
    }
}

impl Graph {
    /// The graph of `files` (path below `src/`, source text).
    fn of(files: &[(PathBuf, String)]) -> Graph {
        let mut graph = Graph::default();
        let mut written = Vec::new();
        for (relative, source) in files {
            let module = module_of(relative);
            graph.modules.insert(module.clone());
            graph.files.insert(module.clone(), relative.clone());
            let parsed = match syn::parse_file(source) {
                Ok(parsed) => parsed,
                Err(error) => {
                    graph
                        .defects
                        .push(format!("{}: {error}", relative.display()));
                    continue;
                }
            };
            let mut visitor = FileVisitor {
                graph: &mut graph,
                file: relative.clone(),
                module,
                test_depth: 0,
                paths: Vec::new(),
            };
            visitor.visit_file(&parsed);
            let paths = std::mem::take(&mut visitor.paths);
            written.extend(paths.into_iter().map(|p| (relative.clone(), p)));
        }
        for (file, (from, segments, test_only)) in written {
            if let Some(to) = graph.resolve(&from, &segments) {
                if to != from {
                    let text = segments.join("::");
                    graph.edges.push(Edge {
                        from,
                        to,
                        text,
                        test_only,
                        file,
                    });
                }
            }
        }
        graph
    }

    /// The module a path written in `from` names: the longest known module it starts with.
    fn resolve(&self, from: &[String], segments: &[String]) -> Option<Vec<String>> {
        let binary = from.first().is_some_and(|first| first.starts_with("bin:"));
        let mut absolute: Vec<String> = match segments[0].as_str() {
            "crate" if !binary => Vec::new(),
            "fluid" if binary => Vec::new(),
            "self" if !binary => from.to_vec(),
            "super" if !binary => from.to_vec(),
            _ => return None,
        };
        let mut rest = &segments[1..];
        if segments[0] == "super" {
            absolute.pop();
            while rest.first().is_some_and(|s| s == "super") {
                absolute.pop();
                rest = &rest[1..];
            }
        }
        // A name the crate root re-exports (and that is not a module) stands for its target.
        let re_export = rest
            .first()
            .filter(|name| absolute.is_empty() && !self.modules.contains(&vec![name.to_string()]))
            .and_then(|name| self.root_exports.get(name));
        if let Some(target) = re_export {
            absolute = target.clone();
            rest = &rest[1..];
        }
        absolute.extend(rest.iter().cloned());
        (0..=absolute.len())
            .rev()
            .map(|n| absolute[..n].to_vec())
            .find(|prefix| self.modules.contains(prefix))
    }

    /// The wing of a module: that of the file its code is in (so an inline module of
    /// `lib.rs` is the root's).
    fn wing(&self, module: &[String]) -> Option<Wing> {
        match self.files.get(module) {
            Some(file) => Wing::of(&module_of(file)),
            None => Wing::of(module),
        }
    }

    /// Every broken rule, one line each.
    fn violations(&self) -> Vec<String> {
        let name = |module: &[String]| match module {
            [] => "the crate root".to_string(),
            _ => module.join("::"),
        };
        let mut found = self.defects.clone();
        for module in &self.modules {
            if self.wing(module).is_none() {
                found.push(format!(
                    "{} is in no wing (sim, io, lab) nor at the door",
                    name(module)
                ));
            }
        }
        for edge in &self.edges {
            let (Some(from), Some(to)) = (self.wing(&edge.from), self.wing(&edge.to)) else {
                continue;
            };
            if !from.may_use(to) {
                found.push(format!(
                    "{}: {} ({from:?}) uses {} ({to:?}) through {}",
                    edge.file.display(),
                    name(&edge.from),
                    name(&edge.to),
                    edge.text
                ));
            }
        }
        for module in &self.modules {
            if sim_layer(module) == Some(None) && module.len() == 2 {
                found.push(format!("{} is in none of sim/'s layers", name(module)));
            }
        }
        for edge in self.edges.iter().filter(|edge| !edge.test_only) {
            if edge.from == ["sim"] && sim_layer(&edge.to).is_some() {
                found.push(format!(
                    "{}: sim uses {} through {}: the wing's root uses none of its layers",
                    edge.file.display(),
                    name(&edge.to),
                    edge.text
                ));
            }
            let (Some(Some(from)), Some(Some(to))) = (sim_layer(&edge.from), sim_layer(&edge.to))
            else {
                continue;
            };
            if edge.from[1] != edge.to[1] && from <= to {
                found.push(format!(
                    "{}: {} (sim layer {from}) uses {} (sim layer {to}) through {}",
                    edge.file.display(),
                    name(&edge.from),
                    name(&edge.to),
                    edge.text
                ));
            }
        }
        for module in self.reachable(&["bin:fluid".to_string()]) {
            if self.wing(&module) == Some(Wing::Lab) {
                found.push(format!("the fluid binary reaches {}", name(&module)));
            }
        }
        found
    }

    /// The modules that non-test code of `start` uses, directly or through others. A
    /// module also reaches the modules it declares (a use of a child module by its bare
    /// name is not an anchored path), and a use of the crate root reaches every wing.
    fn reachable(&self, start: &[String]) -> BTreeSet<Vec<String>> {
        let mut seen = BTreeSet::new();
        let mut stack = vec![start.to_vec()];
        while let Some(module) = stack.pop() {
            if !seen.insert(module.clone()) {
                continue;
            }
            let file = self.files.get(&module);
            let uses = self.edges.iter().filter(|edge| {
                !edge.test_only && Some(&edge.file) == file && edge.from.starts_with(&module)
            });
            stack.extend(uses.map(|edge| edge.to.clone()));
            let children = self.modules.iter().filter(|child| {
                child.len() == module.len() + 1
                    && child.starts_with(&module)
                    && !self.test_modules.contains(*child)
            });
            stack.extend(children.cloned());
        }
        seen
    }
}

/// Every `.rs` file below `dir`, as (path below `dir`, text).
fn sources(dir: &Path) -> Vec<(PathBuf, String)> {
    let mut found = Vec::new();
    let mut folders = vec![dir.to_path_buf()];
    while let Some(folder) = folders.pop() {
        for entry in std::fs::read_dir(&folder).expect("a readable source folder") {
            let path = entry.expect("a readable entry").path();
            if path.is_dir() {
                folders.push(path);
            } else if path.extension().is_some_and(|e| e == "rs") {
                let text = std::fs::read_to_string(&path).expect("a readable source file");
                found.push((path.strip_prefix(dir).unwrap().to_path_buf(), text));
            }
        }
    }
    found.sort();
    found
}

fn graph_of(files: &[(&str, &str)]) -> Graph {
    let files: Vec<(PathBuf, String)> = files
        .iter()
        .map(|(path, text)| (PathBuf::from(path), text.to_string()))
        .collect();
    Graph::of(&files)
}

fn has_edge(graph: &Graph, from: &str, to: &str) -> bool {
    let split = |m: &str| -> Vec<String> { m.split("::").map(String::from).collect() };
    graph
        .edges
        .iter()
        .any(|edge| edge.from == split(from) && edge.to == split(to))
}

#[test]
fn the_source_keeps_the_layout_rules() {
    let graph = Graph::of(&sources(&Path::new(env!("CARGO_MANIFEST_DIR")).join("src")));
    // The map is not empty: uses across files are resolved to the modules they name.
    assert!(graph.modules.len() > 40, "{} modules", graph.modules.len());
    assert!(has_edge(&graph, "sim::simulation", "sim::model"));
    assert!(has_edge(&graph, "sim::model::course", "sim::kernel"));
    assert!(has_edge(&graph, "cli", "io::fld"));
    assert!(has_edge(&graph, "bin:fluid", "cli"));
    assert!(has_edge(&graph, "lab::commands::run", "lab::diagnostics"));
    let reached = graph.reachable(&["bin:fluid".to_string()]);
    assert!(reached.contains(&vec![
        "sim".to_string(),
        "kernel".to_string(),
        "simd".to_string()
    ]));
    let violations = graph.violations();
    assert!(violations.is_empty(), "{}", violations.join("\n"));
}

/// A small crate in the real layout, for the checks below to break.
const LIB: &str =
    "pub mod sim; pub mod io; pub mod lab; pub mod cli; pub use sim::grid::Grid as BlockGrid;";
const SIM: &str = "pub mod grid;";
const IO: &str = "pub mod fld;";
const LAB: &str = "pub mod scene;";

fn crate_with(extra: &[(&str, &str)]) -> Vec<String> {
    let mut files = vec![
        ("lib.rs", LIB),
        ("sim/mod.rs", SIM),
        ("sim/grid.rs", "pub struct Grid;"),
        ("io/mod.rs", IO),
        ("io/fld.rs", "use crate::sim::grid::Grid;"),
        ("lab/mod.rs", LAB),
        ("lab/scene.rs", "use crate::io::fld; use crate::BlockGrid;"),
        ("bin/fluid-lab.rs", "fn main() { fluid::lab::run(); }"),
        ("cli.rs", "use crate::io::fld;"),
        ("main.rs", "fn main() { fluid::cli::run(); }"),
    ];
    for (path, text) in extra {
        files.retain(|(existing, _)| existing != path);
        files.push((path, text));
    }
    graph_of(&files).violations()
}

#[test]
fn a_well_layered_crate_passes() {
    assert_eq!(crate_with(&[]), Vec::<String>::new());
}

#[test]
fn every_way_of_naming_another_wing_is_seen() {
    let sim_uses = |what: &str, to: &str, wing: &str| {
        format!("sim/grid.rs: sim::grid (Sim) uses {to} ({wing}) through {what}")
    };
    let cases = [
        ("sim/grid.rs", "use crate::lab::scene;", sim_uses("crate::lab::scene", "lab::scene", "Lab")),
        ("sim/grid.rs", "use crate::{sim::grid, io::{fld}};", sim_uses("crate::io::fld", "io::fld", "Io")),
        ("sim/grid.rs", "use super::super::io::fld::*;", sim_uses("super::super::io::fld", "io::fld", "Io")),
        ("sim/grid.rs", "fn f() { let _ = crate::io::fld::read(); }", sim_uses("crate::io::fld::read", "io::fld", "Io")),
        ("sim/grid.rs", "fn f(_: crate::lab::scene::Scene) {}", sim_uses("crate::lab::scene::Scene", "lab::scene", "Lab")),
        ("sim/grid.rs", "fn f() { println!(\"{}\", crate::lab::scene::name()); }", sim_uses("crate::lab::scene::name", "lab::scene", "Lab")),
        ("sim/grid.rs", "#[derive(clap::Args)] struct A { #[arg(value_parser = crate::io::fld::parse)] a: u8 }", sim_uses("crate::io::fld::parse", "io::fld", "Io")),
        ("sim/grid.rs", "#[cfg(test)] mod tests { use crate::lab::scene::generate; }", "sim/grid.rs: sim::grid::tests (Sim) uses lab::scene (Lab) through crate::lab::scene::generate".to_string()),
        ("sim/grid.rs", "use crate::cli;", sim_uses("crate::cli", "cli", "Door")),
        ("io/fld.rs", "use crate::lab::scene;", "io/fld.rs: io::fld (Io) uses lab::scene (Lab) through crate::lab::scene".to_string()),
        ("io/fld.rs", "use crate::cli::run;", "io/fld.rs: io::fld (Io) uses cli (Door) through crate::cli::run".to_string()),
        ("lab/scene.rs", "use crate::cli::run;", "lab/scene.rs: lab::scene (Lab) uses cli (Door) through crate::cli::run".to_string()),
        ("cli.rs", "use crate::lab::scene;", "cli.rs: cli (Door) uses lab::scene (Lab) through crate::lab::scene".to_string()),
        ("main.rs", "use fluid::lab::scene; fn main() {}", "main.rs: bin:fluid (Door) uses lab::scene (Lab) through fluid::lab::scene".to_string()),
        ("bin/fluid-lab.rs", "fn main() { fluid::cli::run(); }", "bin/fluid-lab.rs: bin:fluid-lab (Lab) uses cli (Door) through fluid::cli::run".to_string()),
    ];
    for (file, text, expected) in cases {
        let found = crate_with(&[(file, text)]);
        assert!(found.contains(&expected), "{file}: {text}: {found:?}");
    }
}

#[test]
fn sim_modules_use_only_lower_layers() {
    const SIM_FULL: &str = "pub mod grid; pub mod params; pub mod model; pub mod simulation;";
    let layered = [
        ("sim/mod.rs", SIM_FULL),
        ("sim/params.rs", "pub const G: f64 = 9.8;"),
        ("sim/grid.rs", "use crate::sim::params::G;"),
        ("sim/model/mod.rs", "pub mod course; use super::grid::Grid;"),
        (
            "sim/model/course.rs",
            "use super::super::params::G; use crate::sim::model::X;",
        ),
        (
            "sim/simulation.rs",
            "use crate::sim::{grid::Grid, model::course::Course};",
        ),
    ];
    assert_eq!(crate_with(&layered), Vec::<String>::new());
    // A circle: the constants use the driver (one use goes down a layer, the other up).
    let mut circle = layered.to_vec();
    circle.push(("sim/params.rs", "use crate::sim::simulation::Simulation;"));
    assert_eq!(
        crate_with(&circle),
        [
            "sim/params.rs: sim::params (sim layer 0) uses sim::simulation (sim layer 8) \
          through crate::sim::simulation::Simulation"
        ]
    );
    // Up two layers, from a model's own file; a test module may use any layer.
    let mut sideways = layered.to_vec();
    sideways.push((
        "sim/model/course.rs",
        "use crate::sim::simulation::Simulation; #[cfg(test)] mod tests { use crate::sim::simulation; }",
    ));
    assert_eq!(
        crate_with(&sideways),
        [
            "sim/model/course.rs: sim::model::course (sim layer 6) uses sim::simulation \
          (sim layer 8) through crate::sim::simulation::Simulation"
        ]
    );
    // Two modules of one layer use each other no more than a lower one uses a higher.
    let mut same = layered.to_vec();
    same.extend([
        (
            "sim/mod.rs",
            "pub mod grid; pub mod params; pub mod particles;",
        ),
        ("sim/particles.rs", "use crate::sim::grid::Grid;"),
    ]);
    assert_eq!(
        crate_with(&same),
        [
            "sim/particles.rs: sim::particles (sim layer 1) uses sim::grid (sim layer 1) through \
          crate::sim::grid::Grid"
        ]
    );
    let mut stray = layered.to_vec();
    stray.extend([
        ("sim/mod.rs", "pub mod grid; pub mod params; pub mod wcsph;"),
        ("sim/wcsph.rs", ""),
    ]);
    assert_eq!(
        crate_with(&stray),
        ["sim::wcsph is in none of sim/'s layers"]
    );
    // A re-export in the wing's root would hide a use from the layers.
    let mut hidden = layered.to_vec();
    hidden.push((
        "sim/mod.rs",
        "pub mod grid; pub mod simulation; pub use simulation::Simulation;",
    ));
    assert_eq!(
        crate_with(&hidden),
        ["sim/mod.rs: a `use` in the root of sim/, which only declares its modules, is refused"]
    );
    let mut named = layered.to_vec();
    named.push((
        "sim/mod.rs",
        "pub mod grid; fn f() { crate::sim::grid::g(); }",
    ));
    assert_eq!(
        crate_with(&named),
        [
            "sim/mod.rs: sim uses sim::grid through crate::sim::grid::g: the wing's root uses \
          none of its layers"
        ]
    );
}

#[test]
fn modules_outside_the_wings_and_what_hides_code_are_refused() {
    let stray = crate_with(&[
        ("lib.rs", &format!("{LIB} pub mod stray;")),
        ("stray.rs", ""),
    ]);
    assert_eq!(
        stray,
        ["stray is in no wing (sim, io, lab) nor at the door"]
    );
    let root_tests = crate_with(&[("lib.rs", &format!("{LIB} #[cfg(test)] mod tests {{}}"))]);
    assert_eq!(root_tests, Vec::<String>::new());
    let refused = [
        ("#[path = \"../lab/scene.rs\"] pub mod grid;", "#[path]"),
        (
            "#[cfg_attr(all(), path = \"../lab/scene.rs\")] pub mod grid;",
            "#[cfg_attr]",
        ),
        ("include!(\"../lab/scene.rs\");", "include!"),
        ("extern crate self as fluid;", "extern crate self"),
        ("#[macro_use] mod grid;", "#[macro_use]"),
    ];
    for (text, what) in refused {
        let found = crate_with(&[("sim/mod.rs", text)]);
        assert!(
            found.contains(&format!("sim/mod.rs: {what} is refused")),
            "{text}: {found:?}"
        );
    }
}

#[test]
fn the_fluid_binary_reaches_no_workbench_code() {
    // io::fld breaks its own rule by using lab, and so brings lab into fluid's path.
    let found = crate_with(&[("io/fld.rs", "use crate::lab::scene::Scene;")]);
    assert!(
        found
            .iter()
            .any(|v| v == "the fluid binary reaches lab::scene"),
        "{found:?}"
    );
    // Workbench code used only by tests of the door is not in the binary's path.
    let tests = crate_with(&[(
        "cli.rs",
        "#[cfg(test)] mod tests { use crate::lab::scene; }",
    )]);
    assert!(
        !tests.iter().any(|v| v.starts_with("the fluid binary")),
        "{tests:?}"
    );
}

#[test]
fn root_re_exports_resolve_to_their_module() {
    let graph = graph_of(&[
        ("lib.rs", LIB),
        ("sim/mod.rs", SIM),
        ("sim/grid.rs", ""),
        ("lab/mod.rs", LAB),
        ("lab/scene.rs", "use crate::BlockGrid;"),
    ]);
    assert!(has_edge(&graph, "lab::scene", "sim::grid"));
}
