"""compare's text laid out for a terminal: tables whose columns are as wide as their widest cell, and, in the
default text, no line wider than WIDTH (a cell too wide wraps within its column, a sentence onto the next lines)."""
from __future__ import annotations

import textwrap

# The widest line of compare's default text (its summary), in columns.
WIDTH = 120
GAP = "  "
# The narrowest a column is made to fit a table within its width.
NARROWEST = 12


def column_width(first: int, columns: int, width: int = WIDTH) -> int:
    """How wide each of `columns` equal columns can be beside a first column `first` wide within `width`."""
    return max(NARROWEST, (width - first - len(GAP) * columns) // max(columns, 1))


def _wrapped(text: str, width: int) -> list[str]:
    """A cell in lines of at most `width` columns, broken at spaces where it can be (a word longer than the
    column is cut); [""] for an empty cell."""
    if len(text) <= width:
        return [text]
    return textwrap.wrap(text, width, break_on_hyphens=False) or [""]


def _widths(headings: list[str], rows: list[list[str]], width: int | None) -> list[int]:
    """Each column's width: its widest cell; when the table is wider than `width`, the widest columns narrowed
    (never the first, which names the rows, nor below NARROWEST) until it fits."""
    widths = [len(h) for h in headings]
    for row in rows:
        widths = [max(w, len(cell)) for w, cell in zip(widths, row)]
    if width is None:
        return widths
    floors = [widths[0]] + [NARROWEST] * (len(widths) - 1)
    while sum(widths) + len(GAP) * (len(widths) - 1) > width:
        widest = max(range(len(widths)), key=lambda i: (widths[i] - floors[i], i))
        if widths[widest] <= floors[widest]:
            break
        widths[widest] -= 1
    return widths


def table(headings: list[str], rows: list[list[str]], right: set[int] | None = None,
          width: int | None = None) -> list[str]:
    """A table: the headings, a rule, the rows; columns in `right` aligned right. With `width`, no line wider:
    cells wrap within their column onto more lines (a row then takes several)."""
    right = right or set()
    widths = _widths(headings, rows, width)

    def lines(cells: list[str]) -> list[str]:
        parts = [_wrapped(cell, w) for cell, w in zip(cells, widths)]
        depth = max(len(part) for part in parts)
        out = []
        for line in range(depth):
            texts = [part[line] if line < len(part) else "" for part in parts]
            out.append(GAP.join(text.rjust(w) if i in right else text.ljust(w)
                                for i, (text, w) in enumerate(zip(texts, widths))).rstrip())
        return out

    result = lines(headings) + [GAP.join("-" * w for w in widths)]
    for row in rows:
        result += lines(row)
    return result


def wrap(line: str, width: int = WIDTH) -> list[str]:
    """A sentence (a line of prose) in lines of at most `width` columns, the ones after the first indented two
    more than it."""
    if len(line) <= width:
        return [line]
    indent = line[: len(line) - len(line.lstrip())]
    return textwrap.wrap(line, width, initial_indent="", subsequent_indent=indent + "  ", break_on_hyphens=False,
                         break_long_words=False) or [line]


def wrapped(lines: list[str], width: int = WIDTH) -> list[str]:
    """Every line wider than `width` wrapped as a sentence (wrap); the tables are laid out to fit already."""
    out = []
    for line in lines:
        for part in line.split("\n"):
            out += wrap(part, width)
    return out
