"""Where the import seconds go, from `python3 -X importtime -c "import quadcos.train" 2> FILE`:
the cumulative time of each outside module that quadcos's own modules import first (with all it
imports in turn), and quadcos's own time; the rows sum to the whole import. Markdown on stdout.

    python benchmarks/import_table.py FILE [--top 8]
"""

import argparse
import collections
import pathlib
import re

LINE = re.compile(r"import time:\s+(\d+) \|\s+(\d+) \|( *)(\S+)")


def parse(text: str) -> list[tuple[str, int, float, float]]:
    """(module, depth, own s, cumulative s) in importtime's order (a module after its imports)."""
    return [
        (m.group(4), len(m.group(3)), int(m.group(1)) / 1e6, int(m.group(2)) / 1e6)
        for m in LINE.finditer(text)
    ]


def by_first_import(rows: list[tuple[str, int, float, float]], own: str = "quadcos") -> dict:
    """{outside module: cumulative s} for modules imported directly by an `own` module, and
    {own: its modules' own s}."""
    totals: dict[str, float] = collections.Counter()
    for index, (name, depth, own_s, cumulative_s) in enumerate(rows):
        parent = next((rows[j][0] for j in range(index + 1, len(rows)) if rows[j][1] < depth), None)
        is_own = name.split(".")[0] == own
        if is_own:
            totals[own] += own_s
        elif parent is not None and parent.split(".")[0] == own:
            totals[name] += cumulative_s
    return dict(totals)


def table(totals: dict[str, float], top: int) -> str:
    ranked = sorted(totals.items(), key=lambda item: -item[1])
    rest = sum(seconds for _, seconds in ranked[top:])
    lines = ["| imported by quadcos (with what it imports) | s |", "|---|---:|"]
    lines += [f"| {name} | {seconds:.2f} |" for name, seconds in ranked[:top]]
    if ranked[top:]:
        lines.append(f"| {len(ranked) - top} others | {rest:.2f} |")
    lines.append(f"| **all** | **{sum(totals.values()):.2f}** |")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("file", type=pathlib.Path)
    parser.add_argument("--top", type=int, default=8)
    args = parser.parse_args()
    print(table(by_first_import(parse(args.file.read_text())), args.top))


if __name__ == "__main__":
    main()
