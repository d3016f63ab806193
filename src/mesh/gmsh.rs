//! Reader for Gmsh MSH 4.1 ASCII meshes (2D: z is ignored).
//!
//! Supported elements: 15 (point), 1 (2-node line), 2 (3-node triangle), 3 (4-node quadrangle).
//! Physical groups become sets: dimension 2 -> cell sets, 1 -> edge sets, 0 -> node sets; a
//! group's name comes from `$PhysicalNames` (else its number). Elements of a surface entity
//! whose cells are all clockwise (a surface with a -z normal) are reoriented; an entity with
//! mixed orientation keeps its cells, so a truly inverted cell is reported by validation.

use super::{Cell, Mesh2, MeshError};
use nalgebra::Point2;
use std::collections::{BTreeMap, HashMap};

#[derive(Debug, thiserror::Error)]
pub enum GmshError {
    #[error("{path}: cannot read file: {source}")]
    Io { path: String, source: std::io::Error },
    #[error("{path}:{line}: {msg}")]
    Parse { path: String, line: usize, msg: String },
    #[error("{path}: unsupported MSH format version '{version}' (only 4.1 ASCII is read)")]
    Version { path: String, version: String },
    #[error("{path}: element {element} has unsupported Gmsh type {gmsh_type} ({name}); supported: points (15), 2-node lines (1), 3-node triangles (2), 4-node quadrangles (3)")]
    UnsupportedElement { path: String, element: usize, gmsh_type: usize, name: &'static str },
    #[error("{path}: element {element} references unknown node tag {node}")]
    UnknownNode { path: String, element: usize, node: usize },
    #[error("{path}: {source}")]
    Mesh { path: String, source: MeshError },
}

fn gmsh_type_name(t: usize) -> &'static str {
    match t {
        4 => "4-node tetrahedron",
        5 => "8-node hexahedron",
        6 => "6-node prism",
        7 => "5-node pyramid",
        8 => "3-node second-order line",
        9 => "6-node second-order triangle",
        10 => "9-node second-order quadrangle",
        16 => "8-node second-order quadrangle",
        _ => "unsupported element",
    }
}

struct Tokens<'a> {
    path: &'a str,
    lines: Vec<(usize, &'a str)>,
    pos: usize,
}

impl<'a> Tokens<'a> {
    fn err(&self, msg: impl Into<String>) -> GmshError {
        let line = self.lines.get(self.pos.saturating_sub(1)).map(|l| l.0).unwrap_or(0);
        GmshError::Parse { path: self.path.to_string(), line, msg: msg.into() }
    }
    fn next_line(&mut self) -> Result<&'a str, GmshError> {
        let l = self.lines.get(self.pos).map(|l| l.1).ok_or_else(|| self.err("unexpected end of file"))?;
        self.pos += 1;
        Ok(l)
    }
    /// Lines left in the file.
    fn remaining(&self) -> usize {
        self.lines.len() - self.pos
    }
    /// A count read from the file, checked before anything is sized by it: a whole number,
    /// not negative, and no more items than the rest of the file can hold at `lines_each`
    /// lines per item (a damaged count must not ask for terabytes before the file runs out).
    fn count(&self, raw: i64, lines_each: usize, what: &str) -> Result<usize, GmshError> {
        let n = usize::try_from(raw).map_err(|_| self.err(format!("{what} is {raw}, must not be negative")))?;
        if n.saturating_mul(lines_each) > self.remaining() {
            return Err(self.err(format!("{what} is {n}, but the file has only {} lines left", self.remaining())));
        }
        Ok(n)
    }
    fn nums<T: std::str::FromStr>(&mut self, at_least: usize) -> Result<Vec<T>, GmshError> {
        let l = self.next_line()?;
        let v: Result<Vec<T>, _> = l.split_whitespace().map(|t| t.parse::<T>()).collect();
        let v = v.map_err(|_| self.err(format!("expected numbers, found '{l}'")))?;
        if v.len() < at_least {
            return Err(self.err(format!("expected at least {at_least} numbers, found '{l}'")));
        }
        Ok(v)
    }
}

/// Reads a mesh file from disk.
pub fn read_msh(path: &std::path::Path) -> Result<Mesh2, GmshError> {
    let p = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|e| GmshError::Io { path: p.clone(), source: e })?;
    parse_msh(&text, &p)
}

/// Parses MSH 4.1 ASCII text; `path` is only used in error messages.
pub fn parse_msh(text: &str, path: &str) -> Result<Mesh2, GmshError> {
    let lines: Vec<(usize, &str)> =
        text.lines().enumerate().map(|(i, l)| (i + 1, l.trim())).filter(|(_, l)| !l.is_empty()).collect();
    let mut tk = Tokens { path, lines, pos: 0 };
    let mut phys_names: HashMap<(usize, i64), String> = HashMap::new();
    // entity (dim, tag) -> physical tags
    let mut entity_phys: HashMap<(usize, i64), Vec<i64>> = HashMap::new();
    let mut node_index: HashMap<usize, usize> = HashMap::new();
    let mut mesh = Mesh2::default();
    let mut saw_format = false;
    let mut saw_elements = false;

    while tk.pos < tk.lines.len() {
        let head = tk.next_line()?;
        match head {
            "$MeshFormat" => {
                read_mesh_format(&mut tk)?;
                saw_format = true;
            }
            "$PhysicalNames" => read_physical_names(&mut tk, &mut phys_names)?,
            "$Entities" => read_entities(&mut tk, &mut entity_phys)?,
            "$Nodes" => read_nodes(&mut tk, &mut node_index, &mut mesh)?,
            "$Elements" => {
                saw_elements = true;
                read_elements(&mut tk, &phys_names, &entity_phys, &node_index, &mut mesh)?;
            }
            other if other.starts_with('$') => {
                // Skip an unknown section ($NodeData, $Periodic, ...).
                let end = format!("$End{}", &other[1..]);
                while tk.next_line()? != end {}
            }
            other => return Err(tk.err(format!("unexpected line '{other}'"))),
        }
    }
    if !saw_format {
        return Err(GmshError::Parse { path: path.into(), line: 1, msg: "missing $MeshFormat section".into() });
    }
    if !saw_elements {
        return Err(GmshError::Parse { path: path.into(), line: 1, msg: "missing $Elements section".into() });
    }
    for set in mesh.node_sets.values_mut() {
        set.sort_unstable();
        set.dedup();
    }
    mesh.orient_edge_sets().map_err(|e| GmshError::Mesh { path: path.into(), source: e })?;
    mesh.validate().map_err(|e| GmshError::Mesh { path: path.into(), source: e })?;
    Ok(mesh)
}

/// `$MeshFormat`: checks the version is 4.1 ASCII.
fn read_mesh_format(tk: &mut Tokens) -> Result<(), GmshError> {
    let l = tk.next_line()?;
    let f: Vec<&str> = l.split_whitespace().collect();
    if f.len() < 3 || f[0] != "4.1" || f[1] != "0" {
        return Err(GmshError::Version { path: tk.path.into(), version: l.to_string() });
    }
    expect_end(tk, "$EndMeshFormat")
}

/// `$PhysicalNames`: adds each physical group's name, by (dimension, tag).
fn read_physical_names(tk: &mut Tokens, phys_names: &mut HashMap<(usize, i64), String>) -> Result<(), GmshError> {
    let n = tk.nums::<usize>(1)?[0];
    for _ in 0..n {
        let l = tk.next_line()?;
        let mut it = l.splitn(3, char::is_whitespace);
        let dim = it.next().and_then(|s| s.parse::<usize>().ok());
        let tag = it.next().and_then(|s| s.parse::<i64>().ok());
        let name = it.next().map(|s| s.trim().trim_matches('"').to_string());
        match (dim, tag, name) {
            (Some(d), Some(t), Some(nm)) => {
                phys_names.insert((d, t), nm);
            }
            _ => return Err(tk.err(format!("bad physical name line '{l}'"))),
        }
    }
    expect_end(tk, "$EndPhysicalNames")
}

/// `$Entities`: adds each entity's physical tags, by (dimension, entity tag).
fn read_entities(tk: &mut Tokens, entity_phys: &mut HashMap<(usize, i64), Vec<i64>>) -> Result<(), GmshError> {
    let c = tk.nums::<usize>(4)?;
    for (dim, &count) in c.iter().take(4).enumerate() {
        for _ in 0..count {
            let v = tk.nums::<f64>(1)?;
            // point: tag x y z nphys phys...; others: tag 6 bbox nphys phys... nbound ...
            let k = if dim == 0 { 4 } else { 7 };
            if v.len() <= k {
                return Err(tk.err("truncated entity line"));
            }
            // The count of physical tags is read as a float like the rest of the line: it must
            // be a whole number that the line holds (inf or 1e30 would saturate `as usize`).
            let available = v.len() - k - 1;
            if !(v[k] >= 0.0 && v[k].fract() == 0.0 && v[k] <= available as f64) {
                return Err(tk.err(format!(
                    "entity {}: physical tag count {} is not a whole number of at most the {available} values left on its line",
                    v[0], v[k]
                )));
            }
            let np = v[k] as usize;
            let phys: Vec<i64> = v[k + 1..k + 1 + np].iter().map(|&x| x as i64).collect();
            entity_phys.insert((dim, v[0] as i64), phys);
        }
    }
    expect_end(tk, "$EndEntities")
}

/// `$Nodes`: appends the nodes to `mesh`, recording each tag's node index.
fn read_nodes(tk: &mut Tokens, node_index: &mut HashMap<usize, usize>, mesh: &mut Mesh2) -> Result<(), GmshError> {
    let h = tk.nums::<i64>(4)?;
    let blocks = tk.count(h[0], 1, "the number of node blocks")?;
    // A node takes two lines: its tag and its coordinates.
    let total = tk.count(h[1], 2, "the number of nodes")?;
    mesh.nodes.reserve(total);
    for _ in 0..blocks {
        let b = tk.nums::<i64>(4)?;
        let parametric = b[2];
        if parametric != 0 {
            return Err(tk.err("parametric node coordinates are not supported"));
        }
        let n = tk.count(b[3], 2, "the number of nodes in a block")?;
        let mut tags = Vec::with_capacity(n);
        for _ in 0..n {
            tags.push(tk.nums::<usize>(1)?[0]);
        }
        for &t in &tags {
            let x = tk.nums::<f64>(3)?;
            node_index.insert(t, mesh.nodes.len());
            mesh.nodes.push(Point2::new(x[0], x[1]));
        }
    }
    expect_end(tk, "$EndNodes")
}

/// `$Elements`: adds the cells, and the node, edge and cell sets of their physical groups.
fn read_elements(
    tk: &mut Tokens,
    phys_names: &HashMap<(usize, i64), String>,
    entity_phys: &HashMap<(usize, i64), Vec<i64>>,
    node_index: &HashMap<usize, usize>,
    mesh: &mut Mesh2,
) -> Result<(), GmshError> {
    let path = tk.path;
    let h = tk.nums::<usize>(4)?;
    let blocks = h[0];
    let mut cell_sets: BTreeMap<String, Vec<usize>> = BTreeMap::new();
    for _ in 0..blocks {
        let b = tk.nums::<i64>(4)?;
        let (dim, ent, etype) = (b[0] as usize, b[1], b[2] as usize);
        let n = tk.count(b[3], 1, "the number of elements in a block")?;
        let nn = match etype {
            15 => 1,
            1 => 2,
            2 => 3,
            3 => 4,
            _ => {
                let first = tk.nums::<usize>(1)?[0];
                return Err(GmshError::UnsupportedElement {
                    path: path.into(),
                    element: first,
                    gmsh_type: etype,
                    name: gmsh_type_name(etype),
                });
            }
        };
        let names: Vec<String> = entity_phys
            .get(&(dim, ent))
            .map(|ps| ps.iter().map(|p| phys_names.get(&(dim, *p)).cloned().unwrap_or_else(|| p.to_string())).collect())
            .unwrap_or_default();
        let first_cell = mesh.cells.len();
        for _ in 0..n {
            let v = tk.nums::<usize>(1 + nn)?;
            let mut idx = [0usize; 4];
            for k in 0..nn {
                idx[k] = *node_index.get(&v[1 + k]).ok_or(GmshError::UnknownNode {
                    path: path.into(),
                    element: v[0],
                    node: v[1 + k],
                })?;
            }
            match etype {
                15 => {
                    for nm in &names {
                        mesh.node_sets.entry(nm.clone()).or_default().push(idx[0]);
                    }
                }
                1 => {
                    for nm in &names {
                        mesh.edge_sets.entry(nm.clone()).or_default().push([idx[0], idx[1]]);
                    }
                }
                2 => mesh.cells.push(Cell::tri3(idx[0], idx[1], idx[2])),
                _ => mesh.cells.push(Cell::quad4(idx[0], idx[1], idx[2], idx[3])),
            }
        }
        if dim == 2 {
            reorient_if_clockwise(mesh, first_cell);
            for nm in &names {
                cell_sets.entry(nm.clone()).or_default().extend(first_cell..mesh.cells.len());
            }
        }
    }
    mesh.cell_sets = cell_sets;
    expect_end(tk, "$EndElements")
}

fn expect_end(tk: &mut Tokens, end: &str) -> Result<(), GmshError> {
    let l = tk.next_line()?;
    if l != end {
        return Err(tk.err(format!("expected '{end}', found '{l}'")));
    }
    Ok(())
}

fn signed_area(mesh: &Mesh2, c: &Cell) -> f64 {
    let n = c.nodes();
    let mut a = 0.0;
    for i in 0..n.len() {
        let p = mesh.nodes[n[i]];
        let q = mesh.nodes[n[(i + 1) % n.len()]];
        a += p.x * q.y - q.x * p.y;
    }
    0.5 * a
}

fn reorient_if_clockwise(mesh: &mut Mesh2, first: usize) {
    let all_cw = mesh.cells[first..].iter().all(|c| signed_area(mesh, c) < 0.0);
    if all_cw && mesh.cells.len() > first {
        for c in mesh.cells[first..].iter_mut() {
            let n = c.nodes().to_vec();
            *c = if n.len() == 3 { Cell::tri3(n[0], n[2], n[1]) } else { Cell::quad4(n[0], n[3], n[2], n[1]) };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    pub(crate) const UNIT_SQUARE: &str = r#"$MeshFormat
4.1 0 8
$EndMeshFormat
$PhysicalNames
3
1 1 "bottom"
1 2 "top"
2 3 "body"
$EndPhysicalNames
$Entities
0 2 1 0
1 0 0 0 1 0 0 1 1 0
2 0 1 0 1 1 0 1 2 0
1 0 0 0 1 1 0 1 3 0
$EndEntities
$Nodes
1 6 1 6
2 1 0 6
1
2
3
4
5
6
0 0 0
0.5 0 0
1 0 0
0 1 0
0.5 1 0
1 1 0
$EndNodes
$Elements
3 5 1 5
1 1 1 2
1 1 2
2 2 3
1 2 1 1
3 5 4
2 1 3 2
4 1 2 5 4
5 2 3 6 5
$EndElements
"#;

    #[test]
    fn reads_quads_and_physical_groups() {
        let m = parse_msh(UNIT_SQUARE, "square.msh").expect("valid mesh");
        assert_eq!(m.num_nodes(), 6);
        assert_eq!(m.num_cells(), 2);
        assert_eq!(m.edge_sets["bottom"].len(), 2);
        assert_eq!(m.cell_sets["body"], vec![0, 1]);
        assert!((m.area() - 1.0).abs() < 1e-15);
        // The "top" edge is given in either direction in the file; it is reoriented to keep the cell on the left.
        let (n, _) = m.edge_normal(m.edge_sets["top"][0]);
        assert!((n.y - 1.0).abs() < 1e-15);
    }

    #[test]
    fn rejects_second_order_triangles() {
        let t = UNIT_SQUARE.replace("2 1 3 2\n", "2 1 9 2\n");
        match parse_msh(&t, "t6.msh") {
            Err(GmshError::UnsupportedElement { gmsh_type: 9, element: 4, .. }) => {}
            other => panic!("expected UnsupportedElement, got {other:?}"),
        }
    }
}
