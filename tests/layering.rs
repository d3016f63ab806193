//! The library's rooms import one way only, down the stack
//!
//! ```text
//! mesh, solver -> fem -> assembly, surface -> cut -> moving, mortar -> contact -> wear, fatigue
//!   -> state -> model -> geometry -> solve -> driver -> post -> scenes -> io, case -> relocation
//! ```
//!
//! (`wear` is the wear physics: laws, swept integration, rate filter, cycle jump; it knows
//! neither the model nor the solve. `state` is the one mutable struct, `model` the immutable
//! problem data, `geometry` what moves and re-pairs a discretisation, `solve` the solve of one step, `driver` the run and the wear loop around the solve, `scenes` the
//! model scenes of the tests and benches, which nothing in the library imports; `relocation` the
//! node-relocation baseline, which rebuilds cases on moved meshes; the binary,
//! `main.rs` and `cli/`, sits above every room.)
//!
//! The test reads every file under `src/` (comment lines skipped), lists the `crate::<room>`
//! paths it uses, prints the table, and fails on any path that names a room above or beside
//! its own. Run it alone with `cargo test --release --test layering -- --nocapture` to see the
//! table.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

/// Rooms from the bottom of the stack up; a room may use the rooms of earlier layers only.
const LAYERS: &[&[&str]] = &[
    &["mesh", "solver"],
    &["fem"],
    &["assembly", "surface"],
    &["cut"],
    &["moving", "mortar"],
    &["contact"],
    &["wear", "fatigue"],
    &["state"],
    &["model"],
    &["geometry"],
    &["solve"],
    &["driver"],
    &["post"],
    &["scenes"],
    &["io", "case"],
    &["relocation"],
];

fn layer_of(room: &str) -> Option<usize> {
    LAYERS.iter().position(|l| l.contains(&room))
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let p = entry.unwrap().path();
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|e| e == "rs") {
            out.push(p);
        }
    }
}

/// The room a file belongs to: its folder under `src/`, or its file stem.
fn room_of(src: &Path, file: &Path) -> String {
    let rel = file.strip_prefix(src).unwrap();
    let first = rel.components().next().unwrap().as_os_str().to_string_lossy().into_owned();
    first.trim_end_matches(".rs").to_string()
}

/// The rooms named by `crate::<room>` paths in code (not in comments).
fn used_rooms(text: &str) -> BTreeSet<String> {
    let mut rooms = BTreeSet::new();
    for line in text.lines().filter(|l| !l.trim_start().starts_with("//")) {
        let mut rest = line;
        while let Some(at) = rest.find("crate::") {
            rest = &rest[at + 7..];
            let name: String = rest.chars().take_while(|c| c.is_ascii_alphanumeric() || *c == '_').collect();
            if name.is_empty() {
                // `crate::{a, b::c}`: every room in the group.
                let group = rest.trim_start_matches('{');
                let end = group.find('}').unwrap_or(group.len());
                for item in group[..end].split(',') {
                    let room: String =
                        item.trim().chars().take_while(|c| c.is_ascii_alphanumeric() || *c == '_').collect();
                    if !room.is_empty() {
                        rooms.insert(room);
                    }
                }
            } else {
                rooms.insert(name);
            }
        }
    }
    rooms
}

#[test]
fn every_room_imports_only_down_the_stack() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = vec![];
    rust_files(&src, &mut files);
    files.sort();
    let mut violations = vec![];
    let mut checked = 0;
    for file in &files {
        let room = room_of(&src, file);
        if room == "lib" || room == "main" || room == "cli" {
            continue; // the crate root and the binary sit above every room
        }
        let own = layer_of(&room).unwrap_or_else(|| panic!("{}: room '{room}' is in no layer", file.display()));
        let used = used_rooms(&std::fs::read_to_string(file).unwrap());
        println!("{:<32} {:<15} uses {:?}", file.strip_prefix(&src).unwrap().display(), room, used);
        if used.contains("scenes") {
            violations.push(format!("{} ({room}) uses crate::scenes (the tests' and benches' scenes)", file.display()));
        }
        for other in used.iter().filter(|r| **r != room) {
            match layer_of(other) {
                Some(l) if l < own => {}
                _ => violations.push(format!("{} ({room}) uses crate::{other}", file.display())),
            }
        }
        checked += 1;
    }
    assert!(checked >= 25, "only {checked} files read under {}", src.display());
    assert!(violations.is_empty(), "imports up or across the stack:\n{}", violations.join("\n"));
}

/// The scanner itself: grouped and nested paths, comments skipped.
#[test]
fn the_scanner_reads_grouped_paths_and_skips_comments() {
    let text = "use crate::{mesh::Mesh2, fem};\n// use crate::driver;\nlet x = crate::wear::f(1);";
    let rooms: Vec<String> = used_rooms(text).into_iter().collect();
    assert_eq!(rooms, ["fem", "mesh", "wear"]);
}
