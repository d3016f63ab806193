//! Structured mesh generators: graded rectangle, annular sector (thick cylinder) and half-disc
//! (cylinder pressed on its lowest point) with refinement toward the contact point.

use super::{Cell, CellKind, Mesh2, MeshError};
use nalgebra::{Point2, Vector2};

/// `n + 1` coordinates in `[0, 1]` with a geometric progression of spacings whose last/first
/// ratio is `ratio` (`ratio = 1` gives a uniform division).
pub fn graded(n: usize, ratio: f64) -> Vec<f64> {
    if n == 0 {
        return vec![0.0];
    }
    if (ratio - 1.0).abs() < 1e-14 || n == 1 {
        return (0..=n).map(|i| i as f64 / n as f64).collect();
    }
    let q = ratio.powf(1.0 / (n - 1) as f64);
    let mut x = Vec::with_capacity(n + 1);
    let mut s = 0.0;
    let mut h = 1.0;
    x.push(0.0);
    for _ in 0..n {
        s += h;
        x.push(s);
        h *= q;
    }
    for v in x.iter_mut() {
        *v /= s;
    }
    x[n] = 1.0;
    x
}

/// Coordinates in `[0, 1]` refined symmetrically toward the middle: spacing at the ends is
/// `ratio` times the spacing at the centre (`n` is rounded up to an even number).
pub fn graded_to_centre(n: usize, ratio: f64) -> Vec<f64> {
    let half = n.div_ceil(2).max(1);
    let g = graded(half, 1.0 / ratio);
    let mut x: Vec<f64> = g.iter().map(|t| 0.5 * t).collect();
    for t in g.iter().rev().skip(1) {
        x.push(1.0 - 0.5 * t);
    }
    x
}

/// Coordinates in `[0, 1]`: a uniform plateau over the last `plateau` of the length
/// (`n_plateau` divisions) and `n_grow` divisions growing geometrically toward 0 from the
/// plateau spacing (a contact surface at 1, coarse far from it).
pub fn end_plateau(n_plateau: usize, plateau: f64, n_grow: usize) -> Vec<f64> {
    let n_plateau = n_plateau.max(1);
    let plateau = plateau.clamp(1e-12, 1.0);
    let h = plateau / n_plateau as f64;
    let rest = 1.0 - plateau;
    let mut x: Vec<f64> = if n_grow > 0 && rest > 0.0 {
        let g = geometric_from_start(n_grow, (h / rest).min(1.0));
        g.iter().rev().map(|t| rest * (1.0 - t)).collect()
    } else {
        vec![0.0]
    };
    let start = x[x.len() - 1];
    x.extend((1..n_plateau).map(|i| start + (1.0 - start) * i as f64 / n_plateau as f64));
    x.push(1.0);
    x
}

/// Growth factor `q` in [1e-3, 10] with `total(q) = target` (bisection; `total` increasing).
fn growth_factor(total: impl Fn(f64) -> f64, target: f64) -> f64 {
    let (mut lo, mut hi) = (1e-3f64, 10.0f64);
    for _ in 0..200 {
        let q = 0.5 * (lo + hi);
        if total(q) < target {
            lo = q
        } else {
            hi = q
        }
    }
    0.5 * (lo + hi)
}

/// `n` intervals on [0, 1] growing geometrically from a first interval `first` (a fraction of
/// the length) at 0: fine where a contact surface is, coarse far from it.
pub fn geometric_from_start(n: usize, first: f64) -> Vec<f64> {
    let n = n.max(1);
    let first = first.clamp(1e-12, 1.0);
    let total = |q: f64| (0..n).map(|i| first * q.powi(i as i32)).sum::<f64>();
    let q = growth_factor(total, 1.0);
    let scale = total(q);
    let mut acc = 0.0;
    let mut x = vec![0.0];
    for i in 0..n {
        acc += first * q.powi(i as i32);
        x.push(acc / scale);
    }
    x[n] = 1.0;
    x
}

/// Coordinates in `[0, 1]` with a uniform fine plateau of relative width `plateau` in the middle
/// (`n_fine` divisions) and `n_side` geometrically growing divisions on each side, starting from
/// the plateau spacing (growth factor found by bisection). For contact zones resolved uniformly.
pub fn plateau_graded(n_fine: usize, plateau: f64, n_side: usize) -> Vec<f64> {
    let n_fine = n_fine.max(1);
    let plateau = plateau.clamp(1e-12, 1.0);
    let h = plateau / n_fine as f64;
    let side = 0.5 * (1.0 - plateau);
    let mut x = Vec::with_capacity(n_fine + 2 * n_side + 1);
    let mut sides = Vec::new();
    if n_side > 0 && side > 0.0 {
        // Growth q with sum_{i=1..n} h q^i = side (q >= 1 when the side needs it).
        let total = |q: f64| (1..=n_side).map(|i| h * q.powi(i as i32)).sum::<f64>();
        let q = growth_factor(total, side);
        let mut acc = 0.0;
        for i in 1..=n_side {
            acc += h * q.powi(i as i32);
            sides.push(acc * side / total(q));
        }
    }
    x.push(0.0);
    for s in sides.iter().rev() {
        x.push(side - s);
    }
    for i in 0..=n_fine {
        x.push(side + h * i as f64);
    }
    for s in &sides {
        x.push(side + plateau + s);
    }
    x.dedup_by(|a, b| (*a - *b).abs() < 1e-15);
    let last = x.len() - 1;
    x[last] = 1.0;
    x
}

fn check(cond: bool, msg: &str) -> Result<(), MeshError> {
    if cond {
        Ok(())
    } else {
        Err(MeshError::BadParameter(msg.to_string()))
    }
}

/// Rectangle `[x0, x0+lx] x [y0, y0+ly]` with `nx x ny` divisions; `grading_x` / `grading_y` are
/// last/first spacing ratios. `Tri3` splits every quad along alternating diagonals.
/// Sets: edge and node sets `left`, `right`, `bottom`, `top`; node sets `bottom_left`,
/// `bottom_right`, `top_left`, `top_right`.
// Nine scalars, one per geometric quantity, written in the order every caller (54 of them,
// tests included) reads them in: a parameter struct would only rename them.
#[allow(clippy::too_many_arguments)]
pub fn rectangle(
    x0: f64,
    y0: f64,
    lx: f64,
    ly: f64,
    nx: usize,
    ny: usize,
    grading_x: f64,
    grading_y: f64,
    kind: CellKind,
) -> Result<Mesh2, MeshError> {
    check(lx > 0.0 && ly > 0.0, "rectangle size must be positive")?;
    check(nx >= 1 && ny >= 1, "rectangle needs at least one division per direction")?;
    check(grading_x > 0.0 && grading_y > 0.0, "grading ratios must be positive")?;
    let (origin, size) = (Point2::new(x0, y0), Vector2::new(lx, ly));
    rectangle_from_divisions(origin, size, &graded(nx, grading_x), &graded(ny, grading_y), kind)
}

/// Rectangle whose grid lines sit at `x0 + lx gx[i]`, `y0 + ly gy[j]` (`gx`, `gy` increasing from
/// 0 to 1, e.g. from [`graded`] or [`graded_to_centre`]: a block refined toward the middle of
/// its top for a contact patch). Same sets as [`rectangle`].
pub fn rectangle_from_divisions(
    origin: Point2<f64>,
    size: Vector2<f64>,
    gx: &[f64],
    gy: &[f64],
    kind: CellKind,
) -> Result<Mesh2, MeshError> {
    let (x0, y0, lx, ly) = (origin.x, origin.y, size.x, size.y);
    check(lx > 0.0 && ly > 0.0, "rectangle size must be positive")?;
    check(gx.len() >= 2 && gy.len() >= 2, "rectangle needs at least one division per direction")?;
    check(
        gx.windows(2).all(|w| w[1] > w[0]) && gy.windows(2).all(|w| w[1] > w[0]),
        "grid lines must increase strictly",
    )?;
    let (nx, ny) = (gx.len() - 1, gy.len() - 1);
    let id = |i: usize, j: usize| j * (nx + 1) + i;
    let mut m = Mesh2::default();
    for &ty in gy {
        for &tx in gx {
            m.nodes.push(Point2::new(x0 + lx * tx, y0 + ly * ty));
        }
    }
    for j in 0..ny {
        for i in 0..nx {
            let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
            match kind {
                CellKind::Quad4 => m.cells.push(Cell::quad4(a, b, c, d)),
                CellKind::Tri3 => {
                    if (i + j) % 2 == 0 {
                        m.cells.push(Cell::tri3(a, b, c));
                        m.cells.push(Cell::tri3(a, c, d));
                    } else {
                        m.cells.push(Cell::tri3(a, b, d));
                        m.cells.push(Cell::tri3(b, c, d));
                    }
                }
            }
        }
    }
    m.edge_sets.insert("bottom".into(), (0..nx).map(|i| [id(i, 0), id(i + 1, 0)]).collect());
    m.edge_sets.insert("right".into(), (0..ny).map(|j| [id(nx, j), id(nx, j + 1)]).collect());
    m.edge_sets.insert("top".into(), (0..nx).map(|i| [id(i + 1, ny), id(i, ny)]).collect());
    m.edge_sets.insert("left".into(), (0..ny).map(|j| [id(0, j + 1), id(0, j)]).collect());
    m.node_sets.insert("bottom_left".into(), vec![id(0, 0)]);
    m.node_sets.insert("bottom_right".into(), vec![id(nx, 0)]);
    m.node_sets.insert("top_left".into(), vec![id(0, ny)]);
    m.node_sets.insert("top_right".into(), vec![id(nx, ny)]);
    m.orient_edge_sets()?;
    m.validate()?;
    Ok(m)
}

/// The region `r_in <= r <= r_out`, `theta0 <= theta <= theta1` (radians) of an annulus
/// centred at the origin.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sector {
    pub r_in: f64,
    pub r_out: f64,
    pub theta0: f64,
    pub theta1: f64,
}

/// Annular sector, `Quad4` cells (`nr` radial, `nt` angular divisions), radial spacing ratio
/// `grading_r` (outer/inner). Sets: `inner`, `outer`, `start` (theta0 ray), `end` (theta1 ray).
pub fn annulus_sector(sector: Sector, nr: usize, nt: usize, grading_r: f64) -> Result<Mesh2, MeshError> {
    let Sector { r_in, r_out, theta0, theta1 } = sector;
    check(r_in > 0.0 && r_out > r_in, "annulus needs 0 < r_in < r_out")?;
    check(
        theta1 > theta0 && theta1 - theta0 <= std::f64::consts::TAU,
        "annulus needs theta0 < theta1 <= theta0 + 2 pi",
    )?;
    check(nr >= 1 && nt >= 1, "annulus needs at least one division per direction")?;
    let gr = graded(nr, grading_r);
    let id = |i: usize, j: usize| j * (nr + 1) + i; // i radial, j angular
    let mut m = Mesh2::default();
    for j in 0..=nt {
        let t = theta0 + (theta1 - theta0) * j as f64 / nt as f64;
        for &s in &gr {
            let r = r_in + (r_out - r_in) * s;
            m.nodes.push(Point2::new(r * t.cos(), r * t.sin()));
        }
    }
    for j in 0..nt {
        for i in 0..nr {
            m.cells.push(Cell::quad4(id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)));
        }
    }
    m.edge_sets.insert("inner".into(), (0..nt).map(|j| [id(0, j + 1), id(0, j)]).collect());
    m.edge_sets.insert("outer".into(), (0..nt).map(|j| [id(nr, j), id(nr, j + 1)]).collect());
    m.edge_sets.insert("start".into(), (0..nr).map(|i| [id(i, 0), id(i + 1, 0)]).collect());
    m.edge_sets.insert("end".into(), (0..nr).map(|i| [id(i + 1, nt), id(i, nt)]).collect());
    m.orient_edge_sets()?;
    m.validate()?;
    Ok(m)
}

/// Lower half-disc of radius `radius` centred at `centre` (the flat side on top), for a cylinder
/// pressed down on its lowest point. Polar grid: `nr` rings graded toward the rim (rim/centre
/// spacing ratio `1/grading_r`), `nt` angular divisions refined toward the lowest point
/// (spacing at the flat side is `grading_t` times the spacing at the bottom). The innermost ring
/// is a fan of `Tri3`, the rest `Quad4`.
/// Sets: `arc` (rim), `top` (flat diameter), node sets `centre` and `bottom` (lowest point; `nt`
/// is made even so that it exists).
pub fn half_disc(
    centre: Point2<f64>,
    radius: f64,
    nr: usize,
    nt: usize,
    grading_r: f64,
    grading_t: f64,
) -> Result<Mesh2, MeshError> {
    check(radius > 0.0, "half-disc radius must be positive")?;
    check(nr >= 1 && nt >= 2, "half-disc needs nr >= 1 and nt >= 2")?;
    check(grading_r > 0.0 && grading_t > 0.0, "grading ratios must be positive")?;
    half_disc_from_divisions(centre, radius, &graded(nr, 1.0 / grading_r), &graded_to_centre(nt, grading_t))
}

/// Lower half-disc with ring radii `radius * rs[i]` and angles `pi (1 + ts[j])` (`rs`, `ts`
/// increasing from 0 to 1). Same cells and sets as [`half_disc`].
pub fn half_disc_from_divisions(centre: Point2<f64>, radius: f64, rs: &[f64], ts: &[f64]) -> Result<Mesh2, MeshError> {
    check(radius > 0.0, "half-disc radius must be positive")?;
    check(rs.len() >= 2 && ts.len() >= 3, "half-disc needs at least one ring and two sectors")?;
    let nr = rs.len() - 1;
    let nt = ts.len() - 1;
    let mut m = Mesh2::default();
    m.nodes.push(centre);
    let id = |i: usize, j: usize| 1 + (i - 1) * (nt + 1) + j; // ring i >= 1, angle j
    for &s in rs.iter().skip(1) {
        let r = radius * s;
        for &u in ts {
            let t = std::f64::consts::PI * (1.0 + u);
            m.nodes.push(Point2::new(centre.x + r * t.cos(), centre.y + r * t.sin()));
        }
    }
    for j in 0..nt {
        m.cells.push(Cell::tri3(0, id(1, j), id(1, j + 1)));
    }
    for i in 1..nr {
        for j in 0..nt {
            m.cells.push(Cell::quad4(id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)));
        }
    }
    m.edge_sets.insert("arc".into(), (0..nt).map(|j| [id(nr, j), id(nr, j + 1)]).collect());
    let mut top: Vec<[usize; 2]> = (1..nr).map(|i| [id(i + 1, 0), id(i, 0)]).collect();
    top.push([id(1, 0), 0]);
    top.push([0, id(1, nt)]);
    top.extend((1..nr).map(|i| [id(i, nt), id(i + 1, nt)]));
    m.edge_sets.insert("top".into(), top);
    m.node_sets.insert("centre".into(), vec![0]);
    m.node_sets.insert("bottom".into(), vec![id(nr, nt / 2)]);
    m.orient_edge_sets()?;
    m.validate()?;
    Ok(m)
}

/// Full disc of radius `radius`: a polar grid of `nr` uniform rings and `nt` sectors, a fan of
/// `Tri3` at the centre and `Quad4` elsewhere. Sets: `arc` (the rim, counter-clockwise),
/// node set `centre`.
pub fn disc(centre: Point2<f64>, radius: f64, nr: usize, nt: usize) -> Result<Mesh2, MeshError> {
    check(radius > 0.0, "disc radius must be positive")?;
    check(nr >= 1 && nt >= 3, "disc needs nr >= 1 and nt >= 3")?;
    let mut m = Mesh2::default();
    m.nodes.push(centre);
    let id = |i: usize, j: usize| 1 + (i - 1) * nt + (j % nt);
    for i in 1..=nr {
        let r = radius * i as f64 / nr as f64;
        for j in 0..nt {
            let t = std::f64::consts::TAU * j as f64 / nt as f64;
            m.nodes.push(Point2::new(centre.x + r * t.cos(), centre.y + r * t.sin()));
        }
    }
    for j in 0..nt {
        m.cells.push(Cell::tri3(0, id(1, j), id(1, j + 1)));
    }
    for i in 1..nr {
        for j in 0..nt {
            m.cells.push(Cell::quad4(id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)));
        }
    }
    m.edge_sets.insert("arc".into(), (0..nt).map(|j| [id(nr, j), id(nr, j + 1)]).collect());
    m.node_sets.insert("centre".into(), vec![0]);
    m.orient_edge_sets()?;
    m.validate()?;
    Ok(m)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grading_hits_requested_ratio() {
        let g = graded(10, 5.0);
        let first = g[1] - g[0];
        let last = g[10] - g[9];
        assert!((last / first - 5.0).abs() < 1e-12);
        assert_eq!(g[0], 0.0);
        assert_eq!(g[10], 1.0);
    }

    #[test]
    fn centre_graded_block_is_finest_at_the_middle() {
        // 40 divisions, end/centre spacing ratio 10: the middle cells are 10x smaller.
        let g = graded_to_centre(40, 10.0);
        let (origin, size) = (Point2::new(-20.0, -20.0), Vector2::new(40.0, 20.0));
        let m = rectangle_from_divisions(origin, size, &g, &graded(20, 0.1), CellKind::Quad4).expect("valid block");
        let h_end = g[1] - g[0];
        let h_mid = g[21] - g[20];
        assert!((h_end / h_mid - 10.0).abs() < 1e-9, "ratio {}", h_end / h_mid);
        assert!((m.area() - 800.0).abs() < 1e-9);
        assert_eq!(m.edge_sets["top"].len(), 40);
    }

    #[test]
    fn half_disc_area_converges_to_pi_r2_over_2() {
        // A polygon with n_t uniform-ish chords: area deficit O(h^2); 64 chords give < 0.2%.
        let m = half_disc(Point2::new(0.0, 10.0), 10.0, 8, 64, 1.0, 1.0).expect("valid half-disc");
        let exact = 0.5 * std::f64::consts::PI * 100.0;
        assert!((m.area() - exact).abs() / exact < 2e-3);
        let b = m.node_sets["bottom"][0];
        assert!((m.nodes[b].x).abs() < 1e-12 && (m.nodes[b].y).abs() < 1e-12);
    }

    #[test]
    fn annulus_is_valid_and_oriented() {
        let m = annulus_sector(
            Sector { r_in: 1.0, r_out: 2.0, theta0: 0.0, theta1: std::f64::consts::FRAC_PI_2 },
            4,
            6,
            1.0,
        )
        .expect("valid annulus");
        for &e in &m.edge_sets["inner"] {
            let (n, _) = m.edge_normal(e);
            let mid = (m.nodes[e[0]].coords + m.nodes[e[1]].coords) * 0.5;
            assert!(n.dot(&mid) < 0.0, "inner normal must point to the axis");
        }
    }
}
