"""The reader of `lockstep c2c --out` files: one pair of CPUs per entry, each once, its one-way latency's p50."""
from __future__ import annotations

from dataclasses import dataclass

from ..common import fields
from .checks import fail, read_distribution


@dataclass(frozen=True)
class C2cPair:
    a: int
    b: int
    method: str
    relation: str
    p50_ns: float | None  # None: no samples


@dataclass
class C2cFile:
    path: str
    label: str
    pairs: list[C2cPair]
    sampled: bool
    relations_closest_first: tuple[str, ...] = ()  # the writer's ranking of its labels (older files: none)

    def methods(self) -> list[str]:
        """The measuring methods present (`lockstep c2c --method both` writes cas and store_load pairs)."""
        return sorted({pair.method for pair in self.pairs})


def read_c2c(path: str, label: str, document: dict) -> C2cFile:
    pairs, seen = [], {}
    for index, pair in enumerate(document["pairs"]):
        a, b, method = pair["a"], pair["b"], pair["method"]
        if a == b:
            fail(path, ("pairs", index, "b"), f"is {b}, the same CPU as a")
        identity = (min(a, b), max(a, b), method)
        if identity in seen:
            fail(path, ("pairs", index), f"repeats pairs[{seen[identity]}] (CPUs {a} and {b}, method {method})")
        seen[identity] = index
        p50 = read_distribution(path, ("pairs", index, "one_way_ns"), pair["one_way_ns"], ("p50",)).statistics["p50"]
        if p50 is not None and p50 < fields.SHORTEST_NS:
            fail(path, ("pairs", index, "one_way_ns", "p50"), f"is {p50:g} ns: a time is positive")
        pairs.append(C2cPair(int(a), int(b), method, pair["relation"], p50))
    return C2cFile(path=path, label=label, pairs=pairs, sampled=bool(document.get("sampled")),
                   relations_closest_first=tuple(document.get("relations_closest_first", ())))
