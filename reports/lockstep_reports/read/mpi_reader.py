"""What a `lockstep mpi` file holds beside its benchmark entries (docs/result-files.md, `lockstep mpi`): the
settings and each exchange's last round (run_reader.py reads the entries as a run file's)."""
from __future__ import annotations

from dataclasses import dataclass

from .checks import fail
from .schemas import shown


@dataclass(frozen=True)
class MpiExchange:
    """One exchange of a `lockstep mpi` file, its last round's details (the "exchanges" list)."""
    label: str      # "p2p", "shm_window/<primitive>"
    name: str       # its benchmark name, mpi/exchange:.../ranks:R/hosts:H
    stage: dict     # per-stage latency, ns: min, p50, p99, p999, max
    skew: dict      # per-stage arrival skew, ns: the same keys
    transfer: dict  # latest departure - latest arrival, ns (files before it: empty)
    slowest_counts: tuple[int, ...]  # per rank: stages where it arrived last


@dataclass(frozen=True)
class MpiDetails:
    ranks: int
    hosts: int
    transport: str
    model: str
    exchanges: tuple[MpiExchange, ...]
    not_applicable: tuple[tuple[str, str], ...]


MPI_DISTRIBUTION_KEYS = ("min", "p50", "p99", "p999", "max")


def read_mpi(path: str, document: dict) -> MpiDetails:
    settings = document["settings"]
    ranks, hosts = int(settings["ranks"]), int(settings["hosts"])
    exchanges, labels = [], {}
    for index, entry in enumerate(document["exchanges"]):
        exchange, sync = entry["exchange"], entry.get("sync") or ""
        # label and name: what `lockstep mpi` writes; a file that holds only exchange (and sync) gets them
        # as the writer makes them (bench/cli/mpi.cpp, exchange_name).
        label = entry.get("label") or (f"{exchange}/{sync}" if sync else exchange)
        name = entry.get("name") or (
            f"mpi/exchange:{exchange}" + (f"/sync:{sync}" if sync else "") + f"/ranks:{ranks}/hosts:{hosts}")
        if label in labels:
            fail(path, ("exchanges", index, "label"), f"{shown(label)} is also exchanges[{labels[label]}]'s: an "
                                                      "exchange appears once")
        labels[label] = index
        counts = entry["slowest_rank_counts"]
        if len(counts) != ranks:
            fail(path, ("exchanges", index, "slowest_rank_counts"), f"holds {len(counts)} counts for {ranks} ranks "
                                                                    "(settings): one per rank")
        exchanges.append(MpiExchange(label, name, *(
            {statistic: entry[key][statistic] for statistic in MPI_DISTRIBUTION_KEYS} if key in entry else {}
            for key in ("stage_latency_ns", "skew_ns", "transfer_ns")), tuple(int(count) for count in counts)))
    reasons = tuple(sorted(document.get("not_applicable", {}).items()))
    return MpiDetails(ranks, hosts, settings["transport"], settings["model"], tuple(exchanges), reasons)
