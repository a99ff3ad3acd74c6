"""The checks of tests/emulated/emulated_files.py over the files brought back
from each emulated machine (tests/fixtures/emulated/<topology>/, copied from
scripts/emulated-machine.sh's output), and over copies edited to break one
relation each: every check must hold on the files as they came back and fail
on the edit, naming what broke.

As in CTest emulated.two_socket_16, entries the run's stall bound stopped
are let pass and listed (allow_timing_stops): the fixtures hold some, from
machines whose vCPUs waited for a busy host's CPUs."""

import json
import pathlib
import shutil
import tempfile
import unittest

import emulated_files

FIXTURES = pathlib.Path(__file__).resolve().parents[1] / "fixtures" / "emulated"

# What each topology of scripts/emulated-machine.sh is, as its guest kernel
# showed it: CPUs, packages, dies, L3 domains, cores, threads a core, NUMA
# nodes (an arm64 guest's kernel sees no L3: QEMU describes none to it).
SHAPES = {
    "two-socket-16": (16, 2, 2, 2, 8, 2, 2),
    "ccd-16": (16, 1, 2, 2, 8, 2, 1),
    "two-socket-64": (64, 2, 2, 2, 32, 2, 2),
    "arm64-8": (8, 2, 2, 0, 8, 1, 2),
}


def fixture_directories():
    return sorted(path for path in FIXTURES.iterdir() if (path / "guest-kernel" / "topology.txt").is_file())


class EditedCopy:
    """A fixture copied to a temporary directory, to be edited."""

    def __init__(self, name):
        self.temporary = tempfile.TemporaryDirectory()
        self.path = pathlib.Path(self.temporary.name) / name
        shutil.copytree(FIXTURES / name, self.path)

    def __enter__(self):
        return self

    def __exit__(self, *exception):
        self.temporary.cleanup()

    def edit_json(self, name, edit):
        path = self.path / "results" / name
        document = json.loads(path.read_text())
        edit(document)
        path.write_text(json.dumps(document))


class FixturesHold(unittest.TestCase):
    def test_every_topology_has_a_fixture(self):
        self.assertEqual(sorted(SHAPES), sorted(path.name for path in fixture_directories()))

    def test_every_check_holds_on_the_files_brought_back(self):
        for directory in fixture_directories():
            with self.subTest(topology=directory.name):
                problems, checked, _ = emulated_files.check_machine(directory, allow_timing_stops=True)
                self.assertEqual([], problems)
                kinds = {entry.split(" ")[0] for entry in checked}
                self.assertTrue({"topology", "run", "c2c"} <= kinds, checked)

    def test_each_guest_kernel_shows_its_topology(self):
        for directory in fixture_directories():
            with self.subTest(topology=directory.name):
                kernel = emulated_files.KernelView.read(directory)
                threads = {len(core) for core in kernel.cores()}
                self.assertEqual(1, len(threads), "every core has as many threads")
                shape = (len(kernel.cpus), len(kernel.packages()), len(kernel.dies()),
                         len(kernel.cache_domains(3)), len(kernel.cores()), threads.pop(),
                         max(len(kernel.nodes), 1))
                self.assertEqual(SHAPES[directory.name], shape)


    def test_the_arm64_guest_sees_its_clusters(self):
        kernel = emulated_files.KernelView.read(FIXTURES / "arm64-8")
        self.assertEqual("{0-1} {2-3} {4-5} {6-7}", emulated_files.shown(kernel.clusters()))


class EditsAreCaught(unittest.TestCase):
    """Each edit breaks one relation; the check that reads it names it."""

    def problems(self, copy, allow_timing_stops=True):
        return emulated_files.check_machine(copy.path, allow_timing_stops)[0]

    def assertCaught(self, problems, words):
        self.assertTrue(any(words in problem for problem in problems), problems)

    def test_a_pu_moved_to_another_core(self):
        with EditedCopy("two-socket-16") as copy:
            def move(document):
                first, second = document["cores"][0], document["cores"][1]
                second["pus"].append(first["pus"].pop())
            copy.edit_json("topology.json", move)
            self.assertCaught(self.problems(copy), "cores (SMT siblings): lockstep")

    def test_a_core_put_in_the_other_package(self):
        with EditedCopy("two-socket-16") as copy:
            def other_package(document):
                document["cores"][0]["package"] = document["cores"][-1]["package"]
            copy.edit_json("topology.json", other_package)
            self.assertCaught(self.problems(copy), "packages: lockstep")

    def test_one_l3_domain_where_the_dies_have_two(self):
        with EditedCopy("ccd-16") as copy:
            def one_l3(document):
                for core in document["cores"]:
                    core["l3"] = 0
            copy.edit_json("topology.json", one_l3)
            self.assertCaught(self.problems(copy), "L3 domains: lockstep")

    def test_a_command_that_failed(self):
        with EditedCopy("two-socket-16") as copy:
            (copy.path / "commands" / "2.status").write_text("1\n")
            self.assertCaught(self.problems(copy), "command 2 (")

    def test_a_skipped_entry(self):
        with EditedCopy("two-socket-16") as copy:
            def skip(document):
                row = next(row for row in document["benchmarks"] if row.get("run_type") == "iteration")
                row["error_occurred"] = True
            copy.edit_json("run.json", skip)
            self.assertCaught(self.problems(copy), "entries skipped")

    def test_an_entry_lost_to_an_error_is_no_timing_stop(self):
        with EditedCopy("two-socket-16") as copy:
            def lose(document):
                row = next(row for row in document["benchmarks"] if row.get("run_type") == "iteration")
                row["error_occurred"] = True
                row["error_message"] = "stalled: one step took 1000.4 ms (bound 100.0 ms): lost wake-ups (1 waits ended by timeout)"
            copy.edit_json("run.json", lose)
            self.assertCaught(self.problems(copy), "lost wake-ups")

    def test_a_stall_is_let_pass_and_listed_only_when_asked(self):
        with EditedCopy("two-socket-16") as copy:
            def stall(document):
                row = next(row for row in document["benchmarks"]
                           if row.get("run_type") == "iteration" and not row.get("error_occurred"))
                row["error_occurred"] = True
                row["error_message"] = "stalled: one step took 150.0 ms (bound 100.0 ms)"
                self.stalled = row["name"]
            copy.edit_json("run.json", stall)
            self.assertCaught(self.problems(copy, allow_timing_stops=False), self.stalled)
            self.assertEqual([], self.problems(copy))
            notes = emulated_files.check_machine(copy.path, allow_timing_stops=True)[2]
            self.assertTrue(any(self.stalled in note for note in notes), notes)

    def test_a_c2c_pair_mislabelled(self):
        with EditedCopy("two-socket-16") as copy:
            def relabel(document):
                pair = next(pair for pair in document["pairs"] if pair["relation"] == "different package")
                pair["relation"] = "shared L3"
            copy.edit_json("c2c.json", relabel)
            self.assertCaught(self.problems(copy), "the kernel makes them 'different package'")

    def test_a_c2c_pair_not_measured(self):
        with EditedCopy("two-socket-16") as copy:
            copy.edit_json("c2c.json", lambda document: document["pairs"].pop())
            self.assertCaught(self.problems(copy), "pairs planned but not measured")


class CpuLists(unittest.TestCase):
    def test_the_kernels_cpu_list_syntax(self):
        self.assertEqual({0, 1, 2, 3, 8, 10, 11}, emulated_files.cpu_list("0-3,8,10-11\n"))
        self.assertEqual("{0-3,8} {9}", emulated_files.shown({frozenset({0, 1, 2, 3, 8}), frozenset({9})}))


if __name__ == "__main__":
    unittest.main()
