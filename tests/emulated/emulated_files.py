#!/usr/bin/python3
"""What must hold in the files an emulated machine brings back.

scripts/emulated-machine.sh boots a topology, runs lockstep commands inside
and brings back a directory: guest-kernel/topology.txt (the guest kernel's
own sysfs view of its CPUs, caches and NUMA nodes, one "path<TAB>content"
line a file), commands/<n>.command, .status, .stdout, .stderr, and results/
(what the commands wrote). These checks hold lockstep to the kernel and read
behaviour only, never a time:

- every command exited 0;
- `lockstep topology --out`: its packages, L3 domains, cores, PUs and SMT
  siblings are the kernel's (the same groups of CPUs, whatever their numbers);
- `lockstep run`: every entry measured (none skipped), and the machine it
  names has the kernel's CPUs; --allow-timing-stops lets pass, and lists,
  the entries stopped by the run's stall bound or call budget alone (a step
  that took too long: a time, which under emulation says nothing);
- `lockstep c2c`: every pair it planned from its --cores measured by each
  of its methods, each labelled as the kernel's topology relates the two
  CPUs.

Each check returns a list of problems, one line each; none means it holds.

    python3 tests/emulated/emulated_files.py [--allow-timing-stops] DIR [DIR ...]

exits 0 when every check holds over every directory, 1 otherwise (each
problem on a line), 2 when a directory is not one the script brought back.
"""

import json
import pathlib
import re
import shlex
import sys


def cpu_list(text):
    """The CPUs of a kernel CPU list ("0-3,8,10-11")."""
    cpus = set()
    for part in text.strip().split(","):
        if not part:
            continue
        low, _, high = part.partition("-")
        cpus.update(range(int(low), int(high or low) + 1))
    return frozenset(cpus)


def groups(mapping):
    """The groups of CPUs that share a value: {value: cpu} -> {frozenset}."""
    by_value = {}
    for cpu, value in mapping.items():
        by_value.setdefault(value, set()).add(cpu)
    return {frozenset(cpus) for cpus in by_value.values()}


def shown(partition):
    """Groups of CPUs for a message: "{0-1} {2-3}"."""
    def one(cpus):
        ordered = sorted(cpus)
        runs, start = [], ordered[0]
        for previous, cpu in zip(ordered, ordered[1:] + [None]):
            if cpu != previous + 1:
                runs.append(str(start) if start == previous else f"{start}-{previous}")
                start = cpu
        return "{" + ",".join(runs) + "}"
    return " ".join(one(cpus) for cpus in sorted(partition, key=min))


class KernelView:
    """The guest kernel's topology, from guest-kernel/topology.txt."""

    _cpu_file = re.compile(r"/sys/devices/system/cpu/cpu(\d+)/(.+)$")
    _node_file = re.compile(r"/sys/devices/system/node/node(\d+)/cpulist$")

    def __init__(self, text):
        self.files = {}
        for line in text.splitlines():
            path, _, content = line.partition("\t")
            self.files[path] = content
        per_cpu = {}
        self.nodes = {}
        for path, content in self.files.items():
            match = self._cpu_file.match(path)
            if match:
                per_cpu.setdefault(int(match[1]), {})[match[2]] = content
            match = self._node_file.match(path)
            if match:
                self.nodes[int(match[1])] = cpu_list(content)
        self.cpus = sorted(per_cpu)
        self.package = {cpu: int(files["topology/physical_package_id"]) for cpu, files in per_cpu.items()}
        self.die = {cpu: (self.package[cpu], int(files.get("topology/die_id", "0")))
                    for cpu, files in per_cpu.items()}
        self.core = {cpu: cpu_list(files["topology/thread_siblings_list"]) for cpu, files in per_cpu.items()}
        self.cluster = {cpu: cpu_list(files["topology/cluster_cpus_list"])
                        for cpu, files in per_cpu.items() if "topology/cluster_cpus_list" in files}
        self.caches = {}  # level -> {cpu: the CPUs sharing its cache of that level}
        for cpu, files in per_cpu.items():
            for name, level in files.items():
                match = re.match(r"cache/(index\d+)/level$", name)
                if not match or files.get(f"cache/{match[1]}/type") == "Instruction":
                    continue
                shared = files.get(f"cache/{match[1]}/shared_cpu_list")
                if shared is not None:
                    self.caches.setdefault(int(level), {})[cpu] = cpu_list(shared)

    @classmethod
    def read(cls, directory):
        return cls((pathlib.Path(directory) / "guest-kernel" / "topology.txt").read_text())

    def packages(self):
        return groups(self.package)

    def dies(self):
        return groups(self.die)

    def cores(self):
        return set(self.core.values())

    def clusters(self):
        return set(self.cluster.values())

    def cache_domains(self, level):
        return set(self.caches.get(level, {}).values())

    def relation(self, a, b):
        """How lockstep's c2c should label CPUs a and b (platform/topology.cpp)."""
        if a == b:
            return "same PU"
        if b in self.core[a]:
            return "SMT siblings"
        for level, label in ((2, "shared L2"), (3, "shared L3")):
            domain = self.caches.get(level, {}).get(a)
            if domain is not None and b in domain:
                return label
        if self.package[a] == self.package[b]:
            l3 = self.caches.get(3, {})
            return "same package" if a not in l3 and b not in l3 else "different L3"
        return "different package"

    def summary(self):
        smt = max(len(core) for core in self.cores())
        return (f"{len(self.cpus)} CPUs, {len(self.packages())} packages, {len(self.dies())} dies, "
                f"{len(self.cache_domains(3))} L3 domains, {len(self.cores())} cores ({smt} threads each), "
                f"{max(len(self.nodes), 1)} NUMA nodes")


def check_commands(directory):
    """Every command came back with exit status 0."""
    problems = []
    commands = pathlib.Path(directory) / "commands"
    numbers = sorted(int(path.stem) for path in commands.glob("*.command"))
    if not numbers:
        return [f"{commands}: no command came back"]
    for number in numbers:
        line = (commands / f"{number}.command").read_text().strip()
        status_file = commands / f"{number}.status"
        status = status_file.read_text().strip() if status_file.exists() else "no status"
        if status != "0":
            problems.append(f"command {number} ({line}): {status}")
    return problems


def check_topology(kernel, topology):
    """lockstep topology's packages, L3 domains, cores, PUs and SMT siblings are the kernel's."""
    problems = []
    pus = {}
    package, l3 = {}, {}
    lockstep_cores = set()
    for core in topology["cores"]:
        lockstep_cores.add(frozenset(core["pus"]))
        for pu in core["pus"]:
            pus[pu] = core
            package[pu] = core["package"]
            if core.get("l3") is not None:
                l3[pu] = core["l3"]

    def compare(what, lockstep_groups, kernel_groups):
        if lockstep_groups != kernel_groups:
            problems.append(f"{what}: lockstep {shown(lockstep_groups) or 'none'}; "
                            f"the kernel {shown(kernel_groups) or 'none'}")

    if sorted(pus) != kernel.cpus or topology.get("topology_pus") != len(kernel.cpus):
        problems.append(f"PUs: lockstep {topology.get('topology_pus')} ({sorted(pus)}); "
                        f"the kernel {len(kernel.cpus)} ({kernel.cpus})")
    compare("packages", groups(package), kernel.packages())
    if topology.get("topology_packages") != len(kernel.packages()):
        problems.append(f"packages: lockstep counts {topology.get('topology_packages')}, "
                        f"the kernel {len(kernel.packages())}")
    compare("L3 domains", groups(l3), kernel.cache_domains(3))
    if topology.get("topology_l3") != len(kernel.cache_domains(3)):
        problems.append(f"L3 domains: lockstep counts {topology.get('topology_l3')}, "
                        f"the kernel {len(kernel.cache_domains(3))}")
    compare("cores (SMT siblings)", lockstep_cores, kernel.cores())
    if topology.get("topology_cores") != len(kernel.cores()):
        problems.append(f"cores: lockstep counts {topology.get('topology_cores')}, "
                        f"the kernel {len(kernel.cores())}")
    # Where lockstep records each CPU's NUMA node, hold it to kernel.nodes here.
    return problems


# A stop for a time bound: the run's stall bound (a step or episode longer
# than it) or its call budget, and the entries of that primitive skipped after
# it (bench/run/team_driver.cpp words them). Under emulation each vCPU waits
# for a host CPU, and a step can take that long for that alone: a time, not
# a behaviour. A lost wake-up is never one.
_TIMING_STOP = re.compile(r"^(an earlier call stopped: )?(stalled: one \w+ took|bounded: the call ran out"
                          r"|skipped: .* already stalled in)")


def timing_stop(message):
    return bool(_TIMING_STOP.match(message or "")) and "lost wake-ups" not in message


def skipped_entries(run):
    """{entry name: the first error message} of the entries the run did not measure whole."""
    skipped = {}
    for row in run.get("benchmarks", []):
        if row.get("error_occurred"):
            skipped.setdefault(row["name"], row.get("error_message", ""))
    return skipped


def check_run(kernel, run, allow_timing_stops=False):
    """Every entry of the run measured (none skipped), on the kernel's CPUs; with
    allow_timing_stops, entries stopped by a time bound alone are let pass."""
    problems = []
    context = run.get("context", {})
    if context.get("num_cpus") != len(kernel.cpus):
        problems.append(f"run: context num_cpus {context.get('num_cpus')}, the kernel {len(kernel.cpus)}")
    skipped = {name: message for name, message in skipped_entries(run).items()
               if not (allow_timing_stops and timing_stop(message))}
    if skipped:
        problems.append(f"run: {len(skipped)} entries skipped: "
                        + "; ".join(f"{name} ({message})" for name, message in sorted(skipped.items())))
    if not any(row.get("run_type") == "iteration" and not row.get("error_occurred")
               for row in run.get("benchmarks", [])):
        problems.append("run: no entry measured")
    # Where the run records each participant's CPU, hold the placements'
    # plans to the kernel here (compact fills an L3 domain and a node before
    # the next; scatter alternates packages and nodes).
    return problems


def check_c2c(kernel, c2c, cores=None):
    """Every pair c2c planned was measured by each of its methods, each
    labelled as the kernel relates its CPUs."""
    problems = []
    measured = set()
    for pair in c2c.get("pairs", []):
        measured.add((frozenset((pair["a"], pair["b"])), pair.get("method")))
        expected = kernel.relation(pair["a"], pair["b"])
        if pair["relation"] != expected:
            problems.append(f"c2c: CPUs {pair['a']} and {pair['b']} labelled '{pair['relation']}'; "
                            f"the kernel makes them '{expected}'")
    pairs = {pair for pair, _ in measured}
    methods = {method for _, method in measured}
    if cores is not None and not c2c.get("sampled"):
        planned = {(frozenset((a, b)), method) for a in cores for b in cores if a < b for method in methods}
        missing = sorted(planned - measured, key=lambda item: (sorted(item[0]), str(item[1])))
        if missing or not methods:
            problems.append("c2c: pairs planned but not measured: "
                            + (", ".join(f"{min(pair)}-{max(pair)} ({method})" for pair, method in missing)
                               or "every one"))
    if c2c.get("pairs_total") is not None and c2c["pairs_total"] != len(pairs) and not c2c.get("sampled"):
        problems.append(f"c2c: {len(pairs)} pairs measured of {c2c['pairs_total']}")
    return problems


def result_files(directory):
    """Each JSON file in results/ with the command that wrote it ((path, document, command words))."""
    directory = pathlib.Path(directory)
    commands = {}
    for path in (directory / "commands").glob("*.command"):
        words = shlex.split(path.read_text())
        if "--out" in words[:-1]:
            commands[words[words.index("--out") + 1]] = words
    for path in sorted((directory / "results").glob("*.json")):
        yield path, json.loads(path.read_text()), commands.get(path.name, [])


def option(words, name):
    return words[words.index(name) + 1] if name in words[:-1] else None


def check_machine(directory, allow_timing_stops=False):
    """Every check that applies to what the directory holds: (problems, what
    was checked, notes: the entries a time bound stopped, when let pass)."""
    kernel = KernelView.read(directory)
    problems = list(check_commands(directory))
    checked, notes = ["exit statuses"], []
    for path, document, words in result_files(directory):
        kind = document.get("kind", "run" if "benchmarks" in document else None)
        if kind == "topology":
            found = check_topology(kernel, document)
        elif kind == "run":
            found = check_run(kernel, document, allow_timing_stops)
            stopped = sorted(name for name, message in skipped_entries(document).items() if timing_stop(message))
            if allow_timing_stops and stopped:
                notes.append(f"{path.name}: {len(stopped)} entries stopped by a time bound (a time under "
                             f"emulation, not a behaviour): {', '.join(stopped)}")
        elif kind == "c2c":
            cores = option(words, "--cores")
            found = check_c2c(kernel, document, sorted(cpu_list(cores)) if cores else None)
        else:
            continue
        checked.append(f"{kind} ({path.name})")
        problems += [f"{path.name}: {problem}" for problem in found]
    return problems, checked, notes


def main(arguments):
    allow_timing_stops = "--allow-timing-stops" in arguments
    directories = [argument for argument in arguments if argument != "--allow-timing-stops"]
    if not directories or any(directory.startswith("-") for directory in directories):
        print("usage: emulated_files.py [--allow-timing-stops] DIR [DIR ...]", file=sys.stderr)
        return 2
    failed = False
    for directory in directories:
        if not (pathlib.Path(directory) / "guest-kernel" / "topology.txt").is_file():
            print(f"emulated_files: {directory} holds no guest-kernel/topology.txt "
                  "(not a directory scripts/emulated-machine.sh brought back)", file=sys.stderr)
            return 2
        problems, checked, notes = check_machine(directory, allow_timing_stops)
        for line in problems + notes:
            print(f"{directory}: {line}")
        failed = failed or bool(problems)
        verdict = f"{len(problems)} problems" if problems else "every check holds"
        print(f"{directory}: {KernelView.read(directory).summary()}; checked {', '.join(checked)}: {verdict}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
