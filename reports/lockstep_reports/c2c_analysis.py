"""What the report derives from a `lockstep c2c` file: the CPUs in topology order (those sharing a core or a cache
side by side, from each pair's relation) and the grid of one method's latencies in that order; figures.c2c_heatmap
draws the grid."""
from __future__ import annotations

from dataclasses import dataclass

# How close two CPUs are, by the relation `lockstep c2c` writes for their pair (closest first).
RELATION_RANK = {"same core": 0, "shared L2": 1, "shared L3": 2, "same package": 3, "same NUMA node": 4,
                 "cross package": 5, "other package": 5}
UNKNOWN_RELATION_RANK = 6


def relation_rank(relation: str) -> int:
    return RELATION_RANK.get(relation, UNKNOWN_RELATION_RANK)


def relation_order(relation: str) -> tuple[int, str]:
    """Closest relation first, then by name."""
    return relation_rank(relation), relation


def topology_order(pairs) -> list[int]:
    """CPUs ordered so that those sharing closer caches sit together: group by each relation level,
    farthest first, keyed by the smallest CPU id of each group (c2c_reader.C2cPair)."""
    cpus = sorted({pair.a for pair in pairs} | {pair.b for pair in pairs})
    ranks = sorted({relation_rank(pair.relation) for pair in pairs}, reverse=True)
    keys = {cpu: [] for cpu in cpus}
    for level in ranks:
        parent = {cpu: cpu for cpu in cpus}

        def find(cpu):
            while parent[cpu] != cpu:
                parent[cpu] = parent[parent[cpu]]
                cpu = parent[cpu]
            return cpu

        for pair in pairs:
            if relation_rank(pair.relation) < level:
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
    order = topology_order(c2c_file.pairs)
    index = {cpu: i for i, cpu in enumerate(order)}
    grid = [[None] * len(order) for _ in order]
    for pair in c2c_file.pairs:
        if (method is None or pair.method == method) and pair.p50_ns is not None:
            grid[index[pair.a]][index[pair.b]] = pair.p50_ns
            grid[index[pair.b]][index[pair.a]] = pair.p50_ns
    return LatencyGrid(c2c_file.label, method, tuple(order), tuple(tuple(row) for row in grid))
