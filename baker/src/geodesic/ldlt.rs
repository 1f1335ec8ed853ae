//! Sparse LDLᵀ factorisation of symmetric positive definite matrices, with a geometric nested
//! dissection ordering.
//!
//! Written here rather than taken from a crate: the heat method needs one symmetric positive
//! definite factorisation per mesh and many triangular solves; an up-looking LDLᵀ (row by row,
//! each row's pattern found by walking the elimination tree) plus an ordering that cuts the
//! surface with planes through the median vertex fits in a few hundred lines, while the sparse
//! Cholesky crates bring large dense-algebra stacks to compile.

/// Why a factorisation failed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct NotPositiveDefinite {
    /// The vertex (original numbering) whose pivot was not positive.
    pub vertex: u32,
    /// The pivot found.
    pub pivot: f64,
}

/// `L D Lᵀ = P A Pᵀ` for a symmetric positive definite `A`.
#[derive(Debug, Clone)]
pub(crate) struct Ldlt {
    /// `perm[new] = old`.
    perm: Vec<u32>,
    /// Start of each column of the strictly lower triangle of `L` in `rows` / `values`.
    col_start: Vec<usize>,
    /// Row (new numbering) of each stored entry; rows increase within a column.
    rows: Vec<u32>,
    values: Vec<f64>,
    /// The pivots `D`.
    diag: Vec<f64>,
}

const NONE: u32 = u32::MAX;

impl Ldlt {
    /// Factors the `n × n` matrix with diagonal `diag` and off-diagonal entries `off`
    /// (`(i, j, a_ij)` with `i != j`, each unordered pair given once or split over several
    /// entries that are summed), eliminating the vertices in the order `perm` (`perm[new] = old`).
    ///
    /// # Panics
    /// If an index is beyond `n` or `perm` is not a permutation of `0..n` (internal callers only).
    pub(crate) fn new(
        diag: &[f64],
        off: &[(u32, u32, f64)],
        perm: Vec<u32>,
    ) -> Result<Ldlt, NotPositiveDefinite> {
        let n = diag.len();
        assert_eq!(perm.len(), n, "permutation length");
        let mut inv = vec![NONE; n];
        for (new, &old) in perm.iter().enumerate() {
            inv[old as usize] = new as u32;
        }
        // Strict upper triangle of P A Pᵀ by columns: column c holds the rows r < c.
        let mut start = vec![0usize; n + 1];
        for &(i, j, _) in off {
            let (a, b) = (inv[i as usize], inv[j as usize]);
            start[a.max(b) as usize + 1] += 1;
        }
        for c in 0..n {
            start[c + 1] += start[c];
        }
        let mut fill = start.clone();
        let mut upper = vec![(0u32, 0.0f64); off.len()];
        for &(i, j, v) in off {
            let (a, b) = (inv[i as usize], inv[j as usize]);
            let c = a.max(b) as usize;
            upper[fill[c]] = (a.min(b), v);
            fill[c] += 1;
        }
        let column = |k: usize| &upper[start[k]..start[k + 1]];

        // Symbolic: elimination tree and the number of entries in each column of L.
        let mut parent = vec![NONE; n];
        let mut flag = vec![NONE; n];
        let mut count = vec![0usize; n];
        for k in 0..n {
            flag[k] = k as u32;
            for &(row, _) in column(k) {
                let mut i = row as usize;
                while flag[i] != k as u32 {
                    if parent[i] == NONE {
                        parent[i] = k as u32;
                    }
                    count[i] += 1;
                    flag[i] = k as u32;
                    i = parent[i] as usize;
                }
            }
        }
        let mut col_start = vec![0usize; n + 1];
        for i in 0..n {
            col_start[i + 1] = col_start[i] + count[i];
        }
        let nnz = col_start[n];
        let mut rows = vec![0u32; nnz];
        let mut values = vec![0.0; nnz];

        // Numeric, row by row: row k of L solves L[..k, ..k] D y = A[..k, k].
        let mut d = vec![0.0; n];
        let mut y = vec![0.0; n];
        let mut pattern = vec![0u32; n];
        let mut filled = vec![0usize; n];
        flag.fill(NONE);
        for k in 0..n {
            let mut top = n;
            flag[k] = k as u32;
            y[k] = diag[perm[k] as usize];
            for &(row, a) in column(k) {
                let mut i = row as usize;
                y[i] += a;
                let mut len = 0;
                while flag[i] != k as u32 {
                    pattern[len] = i as u32;
                    len += 1;
                    flag[i] = k as u32;
                    i = parent[i] as usize;
                }
                while len > 0 {
                    len -= 1;
                    top -= 1;
                    pattern[top] = pattern[len];
                }
            }
            let mut dk = y[k];
            y[k] = 0.0;
            for &i in &pattern[top..n] {
                let i = i as usize;
                let yi = y[i];
                y[i] = 0.0;
                let (s, e) = (col_start[i], col_start[i] + filled[i]);
                for p in s..e {
                    y[rows[p] as usize] -= values[p] * yi;
                }
                let l = yi / d[i];
                dk -= l * yi;
                rows[e] = k as u32;
                values[e] = l;
                filled[i] += 1;
            }
            if !(dk > 0.0 && dk.is_finite()) {
                return Err(NotPositiveDefinite {
                    vertex: perm[k],
                    pivot: dk,
                });
            }
            d[k] = dk;
        }
        Ok(Ldlt {
            perm,
            col_start,
            rows,
            values,
            diag: d,
        })
    }

    /// Number of stored off-diagonal entries of `L`.
    #[cfg(test)]
    pub(crate) fn factor_entries(&self) -> usize {
        self.rows.len()
    }

    /// Solves `A x = b` for `W` right-hand sides at once, in place (`b[vertex][rhs]`, original
    /// numbering). `work` is scratch space, resized as needed.
    pub(crate) fn solve<const W: usize>(&self, b: &mut [[f64; W]], work: &mut Vec<[f64; W]>) {
        let n = self.diag.len();
        work.clear();
        work.extend(self.perm.iter().map(|&old| b[old as usize]));
        let x = &mut work[..];
        for j in 0..n {
            let xj = x[j];
            for p in self.col_start[j]..self.col_start[j + 1] {
                let (r, l) = (self.rows[p] as usize, self.values[p]);
                for c in 0..W {
                    x[r][c] -= l * xj[c];
                }
            }
        }
        for (xj, &dj) in x.iter_mut().zip(&self.diag) {
            for v in xj.iter_mut() {
                *v /= dj;
            }
        }
        for j in (0..n).rev() {
            let mut xj = x[j];
            for p in self.col_start[j]..self.col_start[j + 1] {
                let (r, l) = (self.rows[p] as usize, self.values[p]);
                for c in 0..W {
                    xj[c] -= l * x[r][c];
                }
            }
            x[j] = xj;
        }
        for (new, &old) in self.perm.iter().enumerate() {
            b[old as usize] = x[new];
        }
    }
}

/// Vertices per leaf of the dissection: below this a region is ordered as it comes.
const LEAF: usize = 48;

/// A fill-reducing elimination order (`perm[new] = old`) for a matrix whose pattern is the
/// graph `neighbours` over vertices at `positions`: nested dissection by planes. Each region is
/// split at the median along its bounding box's longest axis; the vertices of the lower half
/// that touch the upper half form the separator, which is numbered after both halves.
pub(crate) fn nested_dissection(positions: &[[f64; 3]], neighbours: &[Vec<u32>]) -> Vec<u32> {
    let n = positions.len();
    let mut order = Vec::with_capacity(n);
    let mut label = vec![0u32; n];
    let mut next_label = 1u32;
    // Explicit stack of regions: Split(vertices) or Emit(separator) once both halves are done.
    enum Task {
        Split(Vec<u32>),
        Emit(Vec<u32>),
    }
    let mut stack = vec![Task::Split((0..n as u32).collect())];
    while let Some(task) = stack.pop() {
        let mut verts = match task {
            Task::Emit(sep) => {
                order.extend(sep);
                continue;
            }
            Task::Split(v) => v,
        };
        if verts.len() <= LEAF {
            order.extend(verts);
            continue;
        }
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for &v in &verts {
            for k in 0..3 {
                lo[k] = lo[k].min(positions[v as usize][k]);
                hi[k] = hi[k].max(positions[v as usize][k]);
            }
        }
        let axis = (0..3)
            .max_by(|&a, &b| (hi[a] - lo[a]).total_cmp(&(hi[b] - lo[b])))
            .unwrap_or(0);
        let mid = verts.len() / 2;
        verts.select_nth_unstable_by(mid, |&a, &b| {
            positions[a as usize][axis]
                .total_cmp(&positions[b as usize][axis])
                .then(a.cmp(&b))
        });
        let upper = verts.split_off(mid);
        let (low_label, high_label) = (next_label, next_label + 1);
        next_label += 2;
        for &v in &verts {
            label[v as usize] = low_label;
        }
        for &v in &upper {
            label[v as usize] = high_label;
        }
        let (sep, lower): (Vec<u32>, Vec<u32>) = verts.into_iter().partition(|&v| {
            neighbours[v as usize]
                .iter()
                .any(|&w| label[w as usize] == high_label)
        });
        stack.push(Task::Emit(sep));
        stack.push(Task::Split(upper));
        stack.push(Task::Split(lower));
    }
    order
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Positions, neighbour lists, diagonal and off-diagonal entries of a test matrix.
    type Problem = (Vec<[f64; 3]>, Vec<Vec<u32>>, Vec<f64>, Vec<(u32, u32, f64)>);

    /// A 2D grid Laplacian plus a diagonal shift: SPD, with a known product to test against.
    fn grid(nx: usize, ny: usize) -> Problem {
        let id = |x: usize, y: usize| (y * nx + x) as u32;
        let mut pos = Vec::new();
        let mut nb = vec![Vec::new(); nx * ny];
        let mut off = Vec::new();
        let mut diag = vec![0.1; nx * ny];
        for y in 0..ny {
            for x in 0..nx {
                pos.push([x as f64, y as f64, 0.0]);
                for (x2, y2) in [(x + 1, y), (x, y + 1)] {
                    if x2 < nx && y2 < ny {
                        let (a, b) = (id(x, y), id(x2, y2));
                        nb[a as usize].push(b);
                        nb[b as usize].push(a);
                        // Split each entry in two to check that duplicates are summed.
                        off.push((a, b, -0.5));
                        off.push((b, a, -0.5));
                        diag[a as usize] += 1.0;
                        diag[b as usize] += 1.0;
                    }
                }
            }
        }
        (pos, nb, diag, off)
    }

    fn multiply(diag: &[f64], off: &[(u32, u32, f64)], x: &[f64]) -> Vec<f64> {
        let mut y: Vec<f64> = diag.iter().zip(x).map(|(d, x)| d * x).collect();
        for &(i, j, a) in off {
            y[i as usize] += a * x[j as usize];
            y[j as usize] += a * x[i as usize];
        }
        y
    }

    #[test]
    fn solves_grid_system_in_any_order() {
        let (pos, nb, diag, off) = grid(30, 20);
        let n = diag.len();
        let want: Vec<f64> = (0..n)
            .map(|i| ((i * 7919) % 101) as f64 / 10.0 - 5.0)
            .collect();
        let b = multiply(&diag, &off, &want);
        let nd = nested_dissection(&pos, &nb);
        let mut sorted = nd.clone();
        sorted.sort_unstable();
        assert_eq!(sorted, (0..n as u32).collect::<Vec<_>>());
        let natural: Vec<u32> = (0..n as u32).collect();
        let mut fills = Vec::new();
        for perm in [nd, natural] {
            let f = Ldlt::new(&diag, &off, perm).unwrap();
            fills.push(f.factor_entries());
            let mut rhs: Vec<[f64; 2]> = b.iter().map(|&v| [v, 2.0 * v]).collect();
            f.solve(&mut rhs, &mut Vec::new());
            for (got, want) in rhs.iter().zip(&want) {
                assert!((got[0] - want).abs() < 1e-10, "{got:?} vs {want}");
                assert!((got[1] - 2.0 * want).abs() < 1e-10, "{got:?} vs {want}");
            }
        }
        // The dissection fills in less than the banded natural order (30 wide) does.
        assert!(fills[0] < fills[1], "{fills:?}");
    }

    #[test]
    fn rejects_indefinite_matrix() {
        // [[1, 2], [2, 1]] has eigenvalues 3 and -1.
        let err = Ldlt::new(&[1.0, 1.0], &[(0, 1, 2.0)], vec![0, 1]).unwrap_err();
        assert_eq!(err.vertex, 1);
        assert!(err.pivot < 0.0);
        let err = Ldlt::new(&[0.0], &[], vec![0]).unwrap_err();
        assert_eq!(err.pivot, 0.0);
    }
}
