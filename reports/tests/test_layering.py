"""The layers of lockstep_reports/, held as the C++ folders are held by cmake/check_layering.cmake: each job is a
package, and a module imports only from its own package and the packages below it (LAYERS). Checked three ways:

- every import of a lockstep_reports module, wherever it stands in the file (the top, a function, a TYPE_CHECKING
  block), names a package its own may import from;
- no import of a lockstep_reports module stands inside a function (an import there hides a circle from the
  interpreter until the function runs) but the one the entry layer defers on purpose (DEFERRED, with its reason);
- the modules' imports make no circle, and each module imports alone in a fresh interpreter.
"""
import ast
import functools
import pathlib
import subprocess
import sys
import unittest

# Not support.REPORTS_DIR: support imports the package, and a circle in it would stop this test from loading.
REPORTS_DIR = pathlib.Path(__file__).resolve().parent.parent

PACKAGE = "lockstep_reports"
TOOLS = REPORTS_DIR / PACKAGE

# Each job's package and the packages it may import from (its own included), lowest first. The modules at the top of
# lockstep_reports/ (main.py: the command lines) may import from every package.
LAYERS = {
    "common": ("common",),                                # statistics, fields, names, words, formatting, text, output
    "read": ("read", "common"),                           # every result file read and checked: schemas, readers
    "analysis": ("analysis", "read", "common"),           # what one run file gives both tools
    "compare": ("compare", "analysis", "read", "common"),  # lockstep compare and its planner
    "report": ("report", "analysis", "read", "common"),    # lockstep report: sections, figures, pages
}
TOP = None  # the package of the modules at lockstep_reports/'s top

# (importing module, imported module) -> why the import waits inside a function.
DEFERRED = {
    ("main", "report.report"): "the report loads matplotlib and jinja2, a second or more that compare never needs",
}


@functools.lru_cache(maxsize=None)
def modules() -> dict[str, object]:
    """Every module of the package: its dotted name below lockstep_reports ("read.inputs", "main") -> its path."""
    found = {}
    for path in sorted(TOOLS.rglob("*.py")):
        parts = path.relative_to(TOOLS).with_suffix("").parts
        if parts[-1] == "__init__":
            parts = parts[:-1]
        if parts:
            found[".".join(parts)] = path
    return found


def package_of(module: str) -> str | None:
    return module.split(".")[0] if "." in module or module in LAYERS else TOP


def imports(module: str, path, text: str | None = None) -> list[tuple[int, str, bool]]:
    """(line, imported module below lockstep_reports, inside a function) of each import of a lockstep_reports
    module in the file (or in `text`, read as that file); `from . import x` names the module x where x is one."""
    known = modules()
    here = module.split(".")[:-1] if path.name != "__init__.py" else module.split(".")
    tree = ast.parse(path.read_text(encoding="utf-8") if text is None else text)
    found = []

    def visit(node, in_function: bool):
        for child in ast.iter_child_nodes(node):
            nested = in_function or isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda))
            if isinstance(child, ast.ImportFrom):
                if child.level:
                    base = here[:len(here) - (child.level - 1)] if child.level > 1 else here
                    target = ".".join(base + ([child.module] if child.module else []))
                elif (child.module or "").startswith(PACKAGE + "."):
                    target = child.module[len(PACKAGE) + 1:]
                else:
                    continue
                named = [f"{target}.{alias.name}".lstrip(".") for alias in child.names]
                hits = [name for name in named if name in known] or ([target] if target in known else [])
                found.extend((child.lineno, hit, nested) for hit in hits)
            elif isinstance(child, ast.Import):
                found.extend((child.lineno, alias.name[len(PACKAGE) + 1:], nested) for alias in child.names
                             if alias.name.startswith(PACKAGE + "."))
            visit(child, nested)

    visit(tree, False)
    return found


class Layering(unittest.TestCase):
    maxDiff = None

    def test_every_package_has_a_rule(self):
        packages = {package_of(module) for module in modules()} - {TOP}
        self.assertEqual(packages, set(LAYERS), "a package of lockstep_reports/ without a rule in LAYERS")

    def test_no_module_imports_from_a_job_above_its_own(self):
        wrong = []
        for module, path in modules().items():
            allowed = LAYERS.get(package_of(module))
            for line, imported, _ in imports(module, path):
                if allowed is not None and package_of(imported) not in allowed:
                    wrong.append(f"{path.relative_to(REPORTS_DIR)}:{line} imports {imported}: "
                                 f"{package_of(module)}/ may import from {', '.join(allowed)} only")
        self.assertEqual(wrong, [])

    def test_no_import_waits_inside_a_function_but_the_deferred_ones(self):
        waiting = [f"{path.relative_to(REPORTS_DIR)}:{line} imports {imported} inside a function"
                   for module, path in modules().items() for line, imported, inside in imports(module, path)
                   if inside and (module, imported) not in DEFERRED]
        self.assertEqual(waiting, [], "import at the top of the module; a circle it would make is a layering fault")

    def test_the_imports_make_no_circle(self):
        graph = {module: sorted({imported for _, imported, inside in imports(module, path)
                                 if not (inside and (module, imported) in DEFERRED) and imported != module})
                 for module, path in modules().items()}
        state, stack, circles = {}, [], []

        def walk(module):
            state[module] = "open"
            stack.append(module)
            for imported in graph.get(module, []):
                if state.get(imported) == "open":
                    circles.append(" -> ".join(stack[stack.index(imported):] + [imported]))
                elif imported not in state:
                    walk(imported)
            stack.pop()
            state[module] = "done"

        for module in sorted(graph):
            if module not in state:
                walk(module)
        self.assertEqual(circles, [])

    def test_each_module_imports_alone(self):
        """Each module imported first, in one fresh interpreter with lockstep_reports forgotten before each: an
        import that needs another module loaded before it fails here."""
        names = [f"{PACKAGE}.{module}" for module in modules()]
        script = ("import importlib, sys\n"
                  f"sys.path.insert(0, {str(REPORTS_DIR)!r})\n"
                  "failed = []\n"
                  f"for name in {names!r}:\n"
                  f"    for loaded in [m for m in sys.modules if m.split('.')[0] == {PACKAGE!r}]:\n"
                  "        del sys.modules[loaded]\n"
                  "    try:\n"
                  "        importlib.import_module(name)\n"
                  "    except Exception as error:\n"
                  "        failed.append(f'{name}: {type(error).__name__}: {error}')\n"
                  "print('\\n'.join(failed))\n")
        done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=240,
                              env={"PYTHONDONTWRITEBYTECODE": "1", "MPLBACKEND": "svg"})
        self.assertEqual(done.returncode, 0, done.stderr)
        self.assertEqual(done.stdout.strip(), "", "modules that do not import alone")

    def test_the_check_sees_a_planted_fault(self):
        """The import walk finds an upward import and one inside a function (the checks above rely on it)."""
        planted = "from ..read.inputs import read_document\n\ndef later():\n    from ..compare import planner\n"
        self.assertEqual(imports("common.planted", TOOLS / "common" / "planted.py", planted),
                         [(1, "read.inputs", False), (4, "compare.planner", True)])


if __name__ == "__main__":
    unittest.main()
