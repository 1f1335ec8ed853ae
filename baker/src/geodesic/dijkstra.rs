//! Shortest edge paths: Dijkstra's algorithm on the edge graph of the mesh (the thesis'
//! geodesic), with a binary heap and f64 lengths.

use std::cmp::Ordering;
use std::collections::BinaryHeap;

use crate::mesh::Topology;

/// The edge graph in compressed rows: the neighbours of `v` are
/// `targets[start[v]..start[v + 1]]`, at `lengths[..]` of the same range.
#[derive(Debug, Clone)]
pub(crate) struct Graph {
    start: Vec<usize>,
    targets: Vec<u32>,
    lengths: Vec<f64>,
}

impl Graph {
    /// The graph of `topology`'s edges, each edge weighted by its Euclidean length.
    pub(crate) fn new(topology: &Topology) -> Graph {
        let n = topology.neighbours.len();
        let mut start = vec![0usize; n + 1];
        for e in &topology.edges {
            start[e.a as usize + 1] += 1;
            start[e.b as usize + 1] += 1;
        }
        for v in 0..n {
            start[v + 1] += start[v];
        }
        let mut fill = start.clone();
        let mut targets = vec![0u32; start[n]];
        let mut lengths = vec![0.0; start[n]];
        for e in &topology.edges {
            for (from, to) in [(e.a, e.b), (e.b, e.a)] {
                let slot = &mut fill[from as usize];
                targets[*slot] = to;
                lengths[*slot] = e.length;
                *slot += 1;
            }
        }
        Graph {
            start,
            targets,
            lengths,
        }
    }

    /// The neighbours of `v` with the lengths of the edges to them.
    pub(crate) fn edges_of(&self, v: usize) -> impl Iterator<Item = (usize, f64)> + '_ {
        let range = self.start[v]..self.start[v + 1];
        self.targets[range.clone()]
            .iter()
            .zip(&self.lengths[range])
            .map(|(&t, &l)| (t as usize, l))
    }
}

/// A heap entry, a distance and a vertex (or any state numbered as one): smaller distances
/// first, then smaller numbers.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Entry(pub(crate) f64, pub(crate) u32);

impl Eq for Entry {}

impl Ord for Entry {
    fn cmp(&self, other: &Self) -> Ordering {
        other.0.total_cmp(&self.0).then(other.1.cmp(&self.1))
    }
}

impl PartialOrd for Entry {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

/// Relaxes `dist` from every vertex whose distance is finite (the seeds), never lowering a
/// vertex for which `fixed` is true. With `fixed` all false this is plain multi-source
/// Dijkstra; vertices no path reaches stay at `f64::INFINITY`.
pub(crate) fn relax(graph: &Graph, dist: &mut [f64], fixed: impl Fn(usize) -> bool) {
    let mut heap: BinaryHeap<Entry> = dist
        .iter()
        .enumerate()
        .filter(|(_, d)| d.is_finite())
        .map(|(v, &d)| Entry(d, v as u32))
        .collect();
    while let Some(Entry(d, v)) = heap.pop() {
        let v = v as usize;
        if d > dist[v] {
            continue;
        }
        for (w, len) in graph.edges_of(v) {
            let nd = d + len;
            if nd < dist[w] && !fixed(w) {
                dist[w] = nd;
                heap.push(Entry(nd, w as u32));
            }
        }
    }
}

/// Shortest edge-path distance from the seeds (`(vertex, starting distance)`) to every vertex.
pub(crate) fn distances(graph: &Graph, seeds: &[(u32, f64)]) -> Vec<f64> {
    let mut dist = vec![f64::INFINITY; graph.start.len() - 1];
    for &(v, d) in seeds {
        dist[v as usize] = dist[v as usize].min(d);
    }
    relax(graph, &mut dist, |_| false);
    dist
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn path_and_shortcut() {
        // A square 0-1-2-3 with diagonal 0-2 (two triangles) and a separate triangle 4-5-6.
        let pos = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
            [5.0, 0.0, 0.0],
            [6.0, 0.0, 0.0],
            [5.0, 1.0, 0.0],
        ];
        let tris = [[0, 1, 2], [0, 2, 3], [4, 5, 6]];
        let g = Graph::new(&Topology::new(&pos, &tris));
        let d = distances(&g, &[(1, 0.0)]);
        let s2 = 2f64.sqrt();
        let want = [
            1.0,
            0.0,
            1.0,
            2.0,
            f64::INFINITY,
            f64::INFINITY,
            f64::INFINITY,
        ];
        assert_eq!(d, want);
        // Seeded with offsets, as a point inside a triangle is: the diagonal is taken.
        let d = distances(&g, &[(0, 0.25), (1, 3.0)]);
        assert_eq!(d[..4], [0.25, 1.25, 0.25 + s2, 1.25]);
        // Fixed vertices keep their value; the others fill in from them.
        let mut d = [
            0.0,
            7.0,
            f64::INFINITY,
            2.0,
            0.0,
            f64::INFINITY,
            f64::INFINITY,
        ];
        relax(&g, &mut d, |v| v < 2 || v == 4);
        assert_eq!(d[..4], [0.0, 7.0, s2, 1.0]);
        assert_eq!(d[4..], [0.0, 1.0, 1.0]);
    }
}
