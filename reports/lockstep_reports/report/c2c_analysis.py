"""What the report derives from a `lockstep c2c` file: the CPUs in topology order (those sharing a core or a cache
side by side, from each pair's relation) and the grid of one method's latencies in that order; figures.c2c_heatmap
draws the grid."""
from __future__ import annotations

from dataclasses import dataclass

# How close two CPUs are, by the relation `lockstep c2c` writes for their pair (closest first). A file says it
# itself (`relations_closest_first`, platform/topology.hpp's order), and that order wins; this table is for files
# written before it did: the labels the binary writes, then the words of older hand-made fixtures.
RELATION_RANK = {"same PU": 0, "SMT siblings": 1, "same core": 1, "shared L2": 2, "shared L3": 3, "same package": 4,
                 "different L3": 5, "same NUMA node": 5, "other NUMA node": 6, "different package": 7,
                 "cross package": 7, "other package": 7}
UNKNOWN_RELATION_RANK = 8


def relation_rank(relation: str, closest_first: tuple[str, ...] = ()) -> int:
    if closest_first:
        return closest_first.index(relation) if relation in closest_first else len(closest_first)
    return RELATION_RANK.get(relation, UNKNOWN_RELATION_RANK)


def relation_order(relation: str) -> tuple[int, str]:
    """Closest relation first, then by name."""
    return relation_rank(relation), relation


def topology_order(pairs, closest_first: tuple[str, ...] = ()) -> list[int]:
    """CPUs ordered so that those sharing closer caches sit together: group by each relation level,
    farthest first, keyed by the smallest CPU id of each group (c2c_reader.C2cPair); relations ranked by the
    file's own order when it gives one (relation_rank)."""
    cpus = sorted({pair.a for pair in pairs} | {pair.b for pair in pairs})
    ranks = sorted({relation_rank(pair.relation, closest_first) for pair in pairs}, reverse=True)
    keys = {cpu: [] for cpu in cpus}
    for level in ranks:
        parent = {cpu: cpu for cpu in cpus}

        def find(cpu):
            while parent[cpu] != cpu:
                parent[cpu] = parent[parent[cpu]]
                cpu = parent[cpu]
            return cpu

        for pair in pairs:
            if relation_rank(pair.relation, closest_first) < level:
                first, second = find(pair.a), find(pair.b)
                if first != second:
                    parent[max(first, second)] = min(first, second)
        for cpu in cpus:
            keys[cpu].append(find(cpu))
    return sorted(cpus, key=lambda cpu: (keys[cpu], cpu))


@dataclass(frozen=True)
class LatencyGrid:
    """The p50 one-way latency of every pair of one method (None: not measured, or no samples), both ways, CPUs
    in topology order."""
    label: str
    method: str | None
    cpus: tuple[int, ...]
    p50_ns: tuple[tuple[float | None, ...], ...]


def latency_grid(c2c_file, method: str | None = None) -> LatencyGrid:
    order = topology_order(c2c_file.pairs, c2c_file.relations_closest_first)
    index = {cpu: i for i, cpu in enumerate(order)}
    grid = [[None] * len(order) for _ in order]
    for pair in c2c_file.pairs:
        if (method is None or pair.method == method) and pair.p50_ns is not None:
            grid[index[pair.a]][index[pair.b]] = pair.p50_ns
            grid[index[pair.b]][index[pair.a]] = pair.p50_ns
    return LatencyGrid(c2c_file.label, method, tuple(order), tuple(tuple(row) for row in grid))
