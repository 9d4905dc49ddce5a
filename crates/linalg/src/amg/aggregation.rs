//! Node aggregates and the tentative prolongator: the strength-of-connection graph between node
//! blocks, greedy aggregation, and a thin QR of the near-null space on each aggregate.

use rayon::prelude::*;

use super::near_null::NearNullSpace;
use super::rows::{RowMatrix, Rows};
use crate::error::Result;

/// Strong neighbours of each node block: `neighbours[ptr[b]..ptr[b + 1]]` with the strength
/// ‖A_bc‖_F / √(‖A_bb‖_F·‖A_cc‖_F) of each connection.
pub(crate) struct StrengthGraph {
    ptr: Vec<usize>,
    neighbours: Vec<usize>,
    strength: Vec<f64>,
}

impl StrengthGraph {
    fn of(&self, b: usize) -> impl Iterator<Item = (usize, f64)> + '_ {
        let range = self.ptr[b]..self.ptr[b + 1];
        self.neighbours[range.clone()]
            .iter()
            .copied()
            .zip(self.strength[range].iter().copied())
    }
}

/// Keeps the block connections with ‖A_bc‖_F ≥ θ·√(‖A_bb‖_F·‖A_cc‖_F), c ≠ b (symmetric, as the
/// matrix is). `block_of` maps a DOF to its block.
pub(crate) fn strength_graph(
    a: Rows<'_, usize>,
    starts: &[usize],
    block_of: &[usize],
    theta: f64,
) -> StrengthGraph {
    let blocks = starts.len() - 1;
    // Squared Frobenius norms of the block row b against every block it touches.
    let block_rows: Vec<Vec<(usize, f64)>> = (0..blocks)
        .into_par_iter()
        .with_min_len(256)
        .map_init(
            || vec![usize::MAX; blocks],
            |marker, b| {
                let mut row: Vec<(usize, f64)> = Vec::new();
                for i in starts[b]..starts[b + 1] {
                    for k in a.ptr[i]..a.ptr[i + 1] {
                        let c = block_of[a.idx[k]];
                        let at = marker[c];
                        if at < row.len() && row[at].0 == c {
                            row[at].1 += a.val[k] * a.val[k];
                        } else {
                            marker[c] = row.len();
                            row.push((c, a.val[k] * a.val[k]));
                        }
                    }
                }
                row
            },
        )
        .collect();
    let diagonal: Vec<f64> = block_rows
        .iter()
        .enumerate()
        .map(|(b, row)| {
            row.iter()
                .find(|&&(c, _)| c == b)
                .map_or(0.0, |&(_, s)| s.sqrt())
        })
        .collect();
    let mut ptr = Vec::with_capacity(blocks + 1);
    ptr.push(0);
    let (mut neighbours, mut strength) = (Vec::new(), Vec::new());
    for (b, row) in block_rows.into_iter().enumerate() {
        let mut kept: Vec<(usize, f64)> = row
            .into_iter()
            .filter(|&(c, _)| c != b)
            .map(|(c, s)| (c, s.sqrt() / (diagonal[b] * diagonal[c]).sqrt()))
            .filter(|&(_, s)| s >= theta)
            .collect();
        kept.sort_unstable_by_key(|&(c, _)| c);
        for (c, s) in kept {
            neighbours.push(c);
            strength.push(s);
        }
        ptr.push(neighbours.len());
    }
    StrengthGraph {
        ptr,
        neighbours,
        strength,
    }
}

/// Greedy aggregation (Vaněk, Mandel & Brezina 1996) of the graph's nodes; returns the aggregate
/// of each node and the number of aggregates.
///
/// 1. A node whose strong neighbours are all unaggregated becomes a root: it and its
///    neighbourhood form an aggregate.
/// 2. Each leftover node joins the aggregate (from step 1) it is most strongly connected to.
/// 3. Nodes still left form new aggregates with their unaggregated neighbours.
pub(crate) fn aggregate(graph: &StrengthGraph) -> (Vec<usize>, usize) {
    const NONE: usize = usize::MAX;
    let nodes = graph.ptr.len() - 1;
    let mut aggregate_of = vec![NONE; nodes];
    let mut count = 0;
    for b in 0..nodes {
        if aggregate_of[b] == NONE && graph.of(b).all(|(c, _)| aggregate_of[c] == NONE) {
            aggregate_of[b] = count;
            for (c, _) in graph.of(b) {
                aggregate_of[c] = count;
            }
            count += 1;
        }
    }
    let roots_aggregates = aggregate_of.clone();
    for b in 0..nodes {
        if aggregate_of[b] == NONE {
            let best = graph
                .of(b)
                .filter(|&(c, _)| roots_aggregates[c] != NONE)
                .max_by(|x, y| x.1.total_cmp(&y.1));
            if let Some((c, _)) = best {
                aggregate_of[b] = roots_aggregates[c];
            }
        }
    }
    for b in 0..nodes {
        if aggregate_of[b] == NONE {
            aggregate_of[b] = count;
            for (c, _) in graph.of(b) {
                if aggregate_of[c] == NONE {
                    aggregate_of[c] = count;
                }
            }
            count += 1;
        }
    }
    (aggregate_of, count)
}

/// The tentative prolongator and the coarse near-null space: on each aggregate, the thin QR
/// B_agg = Q·R with modified Gram–Schmidt (twice, for orthogonality to round-off), dropping
/// columns whose remainder is below 1e-10 of their norm (rank-deficient aggregates: fewer than
/// six DOFs, collinear nodes). Q is the aggregate's block of P_tent, R its rows of B_c, so that
/// P_tent·B_c = B and P_tentᵀ·P_tent = I.
pub(crate) fn tentative_prolongator(
    modes: &NearNullSpace,
    aggregate_of: &[usize],
    aggregates: usize,
) -> Result<(RowMatrix, NearNullSpace)> {
    let starts = modes.starts();
    let m = modes.modes();
    let b = modes.values();
    // DOFs of each aggregate, in ascending order (counting sort over the node blocks).
    let mut member_ptr = vec![0usize; aggregates + 1];
    for (node, &agg) in aggregate_of.iter().enumerate() {
        member_ptr[agg + 1] += starts[node + 1] - starts[node];
    }
    for a in 0..aggregates {
        member_ptr[a + 1] += member_ptr[a];
    }
    let mut next = member_ptr.clone();
    let mut members = vec![0usize; member_ptr[aggregates]];
    for (node, &agg) in aggregate_of.iter().enumerate() {
        for dof in starts[node]..starts[node + 1] {
            members[next[agg]] = dof;
            next[agg] += 1;
        }
    }
    // Per aggregate: Q (rows × kept, column-major) and R (kept × m, row-major).
    let factors: Vec<(Vec<f64>, Vec<f64>, usize)> = (0..aggregates)
        .into_par_iter()
        .with_min_len(64)
        .map(|a| {
            let dofs = &members[member_ptr[a]..member_ptr[a + 1]];
            let rows = dofs.len();
            let mut q: Vec<f64> = Vec::with_capacity(rows * m);
            let mut r = vec![0.0; m * m];
            let mut kept = 0;
            for col in 0..m {
                let mut v: Vec<f64> = dofs.iter().map(|&i| b[i * m + col]).collect();
                let norm0 = v.iter().map(|x| x * x).sum::<f64>().sqrt();
                let mut coefficients = vec![0.0; kept];
                for _ in 0..2 {
                    for k in 0..kept {
                        let qk = &q[k * rows..(k + 1) * rows];
                        let h: f64 = qk.iter().zip(&v).map(|(x, y)| x * y).sum();
                        coefficients[k] += h;
                        v.iter_mut().zip(qk).for_each(|(x, y)| *x -= h * y);
                    }
                }
                let norm = v.iter().map(|x| x * x).sum::<f64>().sqrt();
                for k in 0..kept {
                    r[k * m + col] = coefficients[k];
                }
                if norm > 1e-10 * norm0 && norm > 0.0 {
                    r[kept * m + col] = norm;
                    q.extend(v.iter().map(|x| x / norm));
                    kept += 1;
                }
            }
            r.truncate(kept * m);
            (q, r, kept)
        })
        .collect();
    let mut coarse_starts = Vec::with_capacity(aggregates + 1);
    coarse_starts.push(0);
    for f in &factors {
        coarse_starts.push(coarse_starts[coarse_starts.len() - 1] + f.2);
    }
    let nc = coarse_starts[aggregates];
    let n = modes.dim();
    // Row i of P_tent: its aggregate's kept columns, Q's row for i.
    let mut width = vec![0usize; n];
    let mut location = vec![(0usize, 0usize); n];
    for a in 0..aggregates {
        for (l, &i) in members[member_ptr[a]..member_ptr[a + 1]].iter().enumerate() {
            width[i] = factors[a].2;
            location[i] = (a, l);
        }
    }
    let mut row_ptr = Vec::with_capacity(n + 1);
    row_ptr.push(0);
    for &w in &width {
        row_ptr.push(row_ptr[row_ptr.len() - 1] + w);
    }
    let mut col_idx = Vec::with_capacity(row_ptr[n]);
    let mut values = Vec::with_capacity(row_ptr[n]);
    for i in 0..n {
        let (a, l) = location[i];
        let (q, _, kept) = &factors[a];
        let rows = member_ptr[a + 1] - member_ptr[a];
        for k in 0..*kept {
            // nc ≤ n ≤ MAX_COLUMNS (checked before the setup), so this cannot truncate.
            col_idx.push((coarse_starts[a] + k) as u32);
            values.push(q[k * rows + l]);
        }
    }
    let mut coarse_values = Vec::with_capacity(nc * m);
    for (_, r, _) in &factors {
        coarse_values.extend_from_slice(r);
    }
    // Aggregates that kept no column (all-zero modes) contribute no coarse block.
    let mut block_starts = vec![0];
    for a in 0..aggregates {
        if coarse_starts[a + 1] > coarse_starts[a] {
            block_starts.push(coarse_starts[a + 1]);
        }
    }
    Ok((
        RowMatrix::new(nc, row_ptr, col_idx, values)?,
        NearNullSpace::from_parts(block_starts, m, coarse_values)?,
    ))
}
