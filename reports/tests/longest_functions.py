"""The longest Python functions under some folders, by lines from `def` to the function's last line (Python's ast
module: nested functions count inside their parent and on their own):

    /usr/bin/python3 reports/tests/longest_functions.py [FOLDER...] [--top N]      (default: reports, top 10)

test_structure.py holds reports/ to LONGEST_LINES."""
import argparse
import ast
import pathlib
import sys

# No function in reports/ is longer than this.
LONGEST_LINES = 100


def function_lengths(folders) -> list[tuple[int, str, str]]:
    """(lines, "path:line", name) of every function and method in the .py files under the folders."""
    rows = []
    for folder in folders:
        for path in sorted(pathlib.Path(folder).rglob("*.py")):
            for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), filename=str(path))):
                if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                    rows.append((node.end_lineno - node.lineno + 1, f"{path}:{node.lineno}", node.name))
    return sorted(rows, key=lambda row: (-row[0], row[1]))


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(description="The longest Python functions under the folders.")
    parser.add_argument("folders", nargs="*", default=["reports"])
    parser.add_argument("--top", type=int, default=10)
    options = parser.parse_args(argv)
    for lines, where, name in function_lengths(options.folders)[:options.top]:
        print(f"{lines:5d}  {name}  {where}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
