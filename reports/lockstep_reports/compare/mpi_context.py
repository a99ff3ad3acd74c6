"""What differs between `lockstep mpi` files that ran on different hosts or transports (or rank counts), and
their exchanges side by side.

An exchange's entries carry the job in their names (mpi/exchange:p2p/ranks:2/hosts:1 against .../hosts:2),
so the comparison by name finds nothing in common between a one-host and a two-host file. These lines say
what the jobs were (ranks, hosts, transport) and, for each exchange both files measured, the
median step time of each and their ratio: a description of two different jobs, not a verdict (the noise
band and intervals are for the same benchmark measured twice).
"""

from __future__ import annotations

from ..common import statistics
from ..common.formatting import format_ns

JOB_FIELDS = ("ranks", "hosts", "transport")


def _job(run_file) -> dict[str, str]:
    mpi = run_file.mpi
    return {"ranks": str(mpi.ranks), "hosts": str(mpi.hosts), "transport": mpi.transport}


def _exchange_medians(run_file) -> dict[str, float]:
    """exchange[/sync] -> the median over rounds of its step time (ns)."""
    medians = {}
    for key, run in run_file.runs.items():
        exchange = key.get("exchange")
        if key.family != "mpi" or not exchange or run.errored:
            continue
        sync = key.get("sync")
        times = run.times_ns()
        if times:
            medians[f"{exchange}/{sync}" if sync else exchange] = statistics.median(times)
    return medians


def mpi_difference_lines(files) -> list[str]:
    """For two or more `lockstep mpi` files whose jobs differ (hosts, transport, ranks): the jobs, what
    differs, and each exchange's median step in every file with its ratio to the first. Nothing otherwise."""
    mpi_files = [(chr(ord("A") + index), f) for index, f in enumerate(files) if getattr(f, "mpi", None)]
    if len(mpi_files) < 2:
        return []
    jobs = [_job(f) for _, f in mpi_files]
    differing = [name for name in JOB_FIELDS if len({job[name] for job in jobs}) > 1]
    if not differing:
        return []
    out = [f"mpi jobs differ in {', '.join(differing)}: " + "; ".join(
        f"[{letter}] {job['ranks']} ranks on {job['hosts']} host{'s' if job['hosts'] != '1' else ''} "
        f"(transport {job['transport']})"
        for (letter, _), job in zip(mpi_files, jobs))]
    medians = [_exchange_medians(f) for _, f in mpi_files]
    first_letter = mpi_files[0][0]
    for exchange in sorted(set(medians[0]).intersection(*medians[1:])):
        base = medians[0][exchange]
        cells = [f"[{first_letter}] {format_ns(base)}"]
        for (letter, _), values in zip(mpi_files[1:], medians[1:]):
            ratio = f" ({values[exchange] / base:.2f}x)" if base > 0 else ""
            cells.append(f"[{letter}] {format_ns(values[exchange])}{ratio}")
        out.append(f"  exchange {exchange}, median step: " + ", ".join(cells))
    only = sorted(set().union(*medians) - set(medians[0]).intersection(*medians[1:]))
    if only:
        out.append("  measured in some files only: " + ", ".join(only))
    return out
