"""The shape of reports/ that review keeps: no function longer than longest_functions.LONGEST_LINES, and no
primitive's or layout's name in the tools' code outside the one module that maps names to words
(lockstep_reports/common/words.py): what the tools act on comes from the result file (docs/design.md, Traits and
registries). The names are the registries' own: every kName (and kAlternativeName) in sync/ and layouts/."""
import re
import unittest

from longest_functions import LONGEST_LINES, function_lengths
from support import REPORTS_DIR

REPOSITORY = REPORTS_DIR.parent
TOOLS = REPORTS_DIR / "lockstep_reports"
WORDS = TOOLS / "common" / "words.py"


def registry_names() -> set[str]:
    """The names the primitives and layouts declare: the text literals of their kName and kAlternativeName."""
    names = set()
    for folder in ("sync", "layouts"):
        for header in sorted((REPOSITORY / folder).glob("*.hpp")):
            for declaration in re.findall(r"\bk(?:Alternative)?Name\s*=\s*([^;]*);", header.read_text(encoding="utf-8")):
                names.update(re.findall(r'"([A-Za-z0-9_]+)"', declaration))
    return names


class Structure(unittest.TestCase):
    def test_no_function_is_longer_than_the_limit(self):
        too_long = [row for row in function_lengths([REPORTS_DIR]) if row[0] > LONGEST_LINES]
        self.assertEqual(too_long, [], f"functions longer than {LONGEST_LINES} lines: split them by job")

    def test_the_registries_names_are_found(self):
        names = registry_names()
        self.assertGreaterEqual(len(names), 15)
        self.assertTrue({"std_barrier", "packed"} <= names)  # one of each registry: the search reads them

    def test_no_name_outside_the_words_module(self):
        pattern = re.compile(r"(?<![A-Za-z0-9_])(" + "|".join(sorted(registry_names(), key=len, reverse=True))
                             + r")(?![A-Za-z0-9_])")
        found = []
        for path in sorted(list(TOOLS.rglob("*.py")) + list(TOOLS.rglob("*.j2")) + [REPORTS_DIR / "cli.py"]):
            if path == WORDS:
                continue
            for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), start=1):
                found += [f"{path.relative_to(REPORTS_DIR)}:{number}: {match}" for match in pattern.findall(line)]
        self.assertEqual(found, [], "a primitive's or layout's name outside lockstep_reports/common/words.py")


if __name__ == "__main__":
    unittest.main()
