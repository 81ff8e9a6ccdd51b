"""Result records, and the tables of the docs rendered from them.

    python -m quadcos.results                 # rewrite the generated tables of the pages (PAGES)
    python -m quadcos.results --check         # exit 1 naming each table that differs from its records
    python -m quadcos.results record --name flat --claim "..." --device "NVIDIA H200" \\
        --command "bash experiments/run_gpu.sh flat" eval_s0.json eval_s1.json eval_s2.json
    python -m quadcos.results rebuild         # every record again from its sources, as recorded
    python -m quadcos.results compact JSON... # an evaluation / bench JSON as a summary, in place

A record (`results/NAME.json`) backs one claim: its name, the claim in one line, the command that
produced it, the commit, the device, the numbers and the evaluation or bench JSONs it summarises
(`quadcos.evaluate --out`, `quadcos.bench --out`), stripped of per-episode data and with floats
to SIGNIFICANT_DIGITS (`compact`: what `compact JSON...` makes of a JSON kept in the tree), so
that a record stands on its own once the JSONs are gone. `numbers` is every number of those
summaries, flat:
`SOURCE.path.to.value` (`SOURCE` the file's stem, or `FOLDER/STEM` for each source where two
share a stem; left out for a single source; list items by index). `--keep GLOB ...` keeps only the values whose path (without `SOURCE.`) matches one of
the globs, for a record of a few numbers out of large JSONs; the record lists them as `keep`.
`rebuild` rewrites records from their sources with their recorded name, claim, command, commit,
device and `keep`; `--check` also fails when a source still in the tree no longer gives its
record's summary.

A generated table, value or sentence in a page sits between `<!-- results:NAME -->` and
`<!-- /results:NAME -->`; `results/tables.json` lays out NAME: `columns`, `align` (`l`/`r` per
column), `rows` of cell templates, or `text`: a value or a sentence of prose (its marker pair
inside a paragraph, not at a line's start, so that Markdown renders the text between them). A template's fields
are `{RECORD:KEY|FORMAT}` (`RECORD:` may be left out for the table's `record`), `{A / B|FORMAT}`
(a ratio), `{min GLOB|FORMAT}`, `{max GLOB|FORMAT}` and `{count GLOB}` (0 where none matches)
over a record's keys (`fnmatch`). FORMAT is Python's, and a trailing `k`, `M` or `%` scales the
value by 1e-3, 1e-6 or 100 and appends the unit (`.0fk` → `505 k`).

Bad arguments, an unknown record or number: one line on stderr, exit status 2.
"""

import argparse
import fnmatch
import json
import math
import pathlib
import re
import subprocess
import sys
from collections.abc import Sequence
from typing import Any

from quadcos._util import cli

RESULTS_DIR = "results"
LAYOUT_FILE = "tables.json"
PAGES = ("README.md", "docs/*.md", "experiments/*/README.md")
PER_EPISODE_KEYS = ("episodes",)  # the list `quadcos.evaluate --out` writes, one item an episode
SIGNIFICANT_DIGITS = 6  # a summary's floats: the pages quote at most four
MARKER = re.compile(
    r"<!-- results:(?P<name>[\w.-]+) -->(?P<body>.*?)<!-- /results:(?P=name) -->", re.S
)
FIELD = re.compile(r"\{(?P<expression>[^{}|]+)(?:\|(?P<format>[^{}]*))?\}")
UNITS = {"k": (1e-3, " k"), "M": (1e-6, " M"), "%": (100.0, " %")}
AGGREGATES = {"min": min, "max": max, "count": len}


def strip_episodes(value: Any) -> Any:
    """`value` (a loaded evaluation or bench JSON) without its per-episode data."""
    if isinstance(value, dict):
        return {
            k: strip_episodes(v)
            for k, v in value.items()
            if not (k in PER_EPISODE_KEYS and isinstance(v, list))
        }
    if isinstance(value, list):
        return [strip_episodes(item) for item in value]
    return value


def compact(value: Any) -> Any:
    """`value` (a loaded evaluation or bench JSON) as a summary keeps it: without its
    per-episode data, every float rounded to SIGNIFICANT_DIGITS significant digits, or to units
    where it has more whole digits (idempotent)."""
    return _rounded(strip_episodes(value))


def _rounded(value: Any) -> Any:
    if isinstance(value, dict):
        return {k: _rounded(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_rounded(item) for item in value]
    if isinstance(value, float) and math.isfinite(value):
        whole = len(str(int(abs(value))))  # a rate of 1,195,864 keeps its units
        return float(f"{value:.{max(SIGNIFICANT_DIGITS, whole)}g}")
    return value


def compacted_text(path: pathlib.Path, text: str) -> str | None:
    """`text`, the JSON at `path`, `compact`ed in its layout (one line, or its indent; a record of
    results/ as `record_text` writes it); None where that would not make it smaller."""
    try:
        value = json.loads(text)
    except json.JSONDecodeError as error:
        raise ValueError(f"{path}: not a readable JSON file ({error})") from error
    small = compact(value)
    if isinstance(value, dict) and {"name", "claim", "numbers", "sources"} <= set(value):
        new = record_text(small)
    else:
        lines = text.splitlines()
        indent = len(lines[1]) - len(lines[1].lstrip(" ")) if len(lines) > 1 else 0
        new = json.dumps(
            small, indent=indent or None, ensure_ascii=text.isascii(),
            separators=None if indent else (",", ":"),
        ) + ("\n" if text.endswith("\n") else "")
    return new if len(new) < len(text) else None


def compact_files(paths: Sequence[pathlib.Path]) -> int:
    """Rewrites each JSON at `paths` as `compacted_text` makes it, once every one has been read
    (a bad one: ValueError, nothing written); returns the bytes saved."""
    texts = {path: pathlib.Path(path).read_text() for path in paths}
    smaller = {path: compacted_text(path, text) for path, text in texts.items()}
    for path, new in smaller.items():
        if new is not None:
            pathlib.Path(path).write_text(new)
    return sum(len(texts[path]) - len(new) for path, new in smaller.items() if new is not None)


def keep_only(value: Any, patterns: Sequence[str], prefix: str = "") -> Any:
    """`value` with only the leaves whose dotted path matches one of `patterns` (`fnmatch`), and
    the dicts and lists that hold them; None when nothing matches."""
    if isinstance(value, (dict, list)):
        items = value.items() if isinstance(value, dict) else enumerate(value)
        kept = {}
        for key, item in items:
            found = keep_only(item, patterns, f"{prefix}.{key}" if prefix else str(key))
            if found is not None:
                kept[key] = found
        if not kept:
            return None
        return kept if isinstance(value, dict) else [kept.get(i) for i in range(max(kept) + 1)]
    return value if any(fnmatch.fnmatchcase(prefix, pattern) for pattern in patterns) else None


def flat_numbers(value: Any, prefix: str = "") -> dict[str, float]:
    """Every number in `value`, keyed by its dotted path (list items by index; booleans are not
    numbers)."""
    if isinstance(value, dict):
        items = value.items()
    elif isinstance(value, list):
        items = ((str(index), item) for index, item in enumerate(value))
    elif isinstance(value, (int, float)) and not isinstance(value, bool):
        return {prefix: value}
    else:
        return {}
    found = {}
    for key, item in items:
        found.update(flat_numbers(item, f"{prefix}.{key}" if prefix else str(key)))
    return found


def labels(paths: Sequence[str | pathlib.PurePath]) -> list[str]:
    """Each source's prefix in a record's numbers: its file's stem, or for every source
    `FOLDER/STEM` where two sources share a stem."""
    stems = [pathlib.PurePath(path).stem for path in paths]
    if len(set(stems)) == len(stems):
        return stems
    found = [f"{pathlib.PurePath(path).parent.name}/{stem}" for path, stem in zip(paths, stems)]
    if len(set(found)) < len(found):
        raise ValueError(f"sources with the same folder and file name: {sorted(found)}")
    return found


def numbers_of(sources: Sequence[dict]) -> dict[str, float]:
    """A record's numbers from its sources: one source's paths as they are, several prefixed by
    each source's label (`labels`)."""
    if len(sources) == 1:
        return flat_numbers(sources[0]["summary"])
    found = {}
    for source, label in zip(sources, labels([source["path"] for source in sources])):
        found.update(flat_numbers(source["summary"], label))
    return found


def summarise(path: pathlib.Path, keep: Sequence[str] = ()) -> dict:
    """The JSON at `path` without per-episode data (and with only the `keep` globs' values)."""
    try:
        summary = compact(json.loads(pathlib.Path(path).read_text()))
    except (OSError, json.JSONDecodeError) as error:
        raise ValueError(f"{path}: not a readable JSON file ({error})") from error
    if keep:
        summary = keep_only(summary, keep)
        if summary is None:
            raise ValueError(f"{path}: no value matches --keep {' '.join(keep)}")
    return summary


def make_record(
    name: str,
    claim: str,
    command: str,
    commit: str,
    device: str,
    paths: Sequence[pathlib.Path],
    keep: Sequence[str] = (),
) -> dict:
    """The record of `claim`, from the evaluation or bench JSONs at `paths` (only the values the
    `keep` globs match, if any)."""
    if not re.fullmatch(r"[\w.-]+", name):
        raise ValueError(f"record name {name!r}: letters, digits, '_', '.', '-' only")
    labels(paths)
    sources = [{"path": str(path), "summary": summarise(path, keep)} for path in paths]
    if not sources:
        raise ValueError("a record needs at least one source JSON")
    record = {"name": name, "claim": claim, "command": command, "commit": commit, "device": device}
    if keep:
        record["keep"] = list(keep)
    return {**record, "numbers": numbers_of(sources), "sources": sources}


def rebuild(record: dict, root: pathlib.Path) -> dict:
    """`record` made again from its sources under `root`, with its recorded metadata."""
    paths = [pathlib.PurePath(source["path"]) for source in record["sources"]]
    for path in paths:
        if not (root / path).is_file():
            raise ValueError(f"{RESULTS_DIR}/{record['name']}.json: source {path} is not in the tree")
    remade = make_record(
        record["name"], record["claim"], record["command"], record["commit"], record["device"],
        [root / path for path in paths], record.get("keep", ()),
    )
    for source, path in zip(remade["sources"], paths):
        source["path"] = str(path)
    return remade


def record_text(record: dict) -> str:
    """`record` as JSON, small but diffable: a line per field, per number and per source."""

    def dump(value: Any) -> str:
        return json.dumps(value, ensure_ascii=False)

    lines = []
    for key, value in record.items():
        if key in ("numbers", "sources") and value:
            items = value.items() if key == "numbers" else enumerate(value)
            inner = ",\n".join(
                (f"  {dump(k)}: {dump(v)}" if key == "numbers" else f"  {dump(v)}") for k, v in items
            )
            brackets = "{}" if key == "numbers" else "[]"
            lines.append(f" {dump(key)}: {brackets[0]}\n{inner}\n {brackets[1]}")
        else:
            lines.append(f" {dump(key)}: {dump(value)}")
    return "{\n" + ",\n".join(lines) + "\n}\n"


def write_record(record: dict, root: pathlib.Path) -> pathlib.Path:
    path = root / RESULTS_DIR / f"{record['name']}.json"
    path.parent.mkdir(exist_ok=True)
    path.write_text(record_text(record))
    return path


def last_commit(path: pathlib.Path, root: pathlib.Path) -> str:
    """The commit that last changed `path` (HEAD's if git knows none)."""
    for command in (["git", "log", "-1", "--format=%H", "--", str(path)], ["git", "rev-parse", "HEAD"]):
        found = subprocess.run(command, cwd=root, capture_output=True, text=True).stdout.strip()
        if found:
            return found
    raise ValueError(f"{root} is not a git checkout: pass --commit")


def load_records(root: pathlib.Path) -> dict[str, dict]:
    """Every record under `root/results`, by name."""
    records = {}
    for path in sorted((root / RESULTS_DIR).glob("*.json")):
        if path.name != LAYOUT_FILE:
            record = json.loads(path.read_text())
            records[record["name"]] = record
    return records


def load_layout(root: pathlib.Path) -> dict[str, dict]:
    return json.loads((root / RESULTS_DIR / LAYOUT_FILE).read_text())


def _split_record(records: dict[str, dict], default: str | None, reference: str) -> tuple[dict, str]:
    """(the named record's numbers, the rest) of `[RECORD:]REST`."""
    match = re.match(r"([\w.-]+):(.*)", reference.strip())
    name, rest = (match[1], match[2]) if match else (default, reference.strip())
    if name not in records:
        raise ValueError(f"no record {name!r} (for {reference.strip()!r})")
    return records[name]["numbers"], rest


def _term(records: dict[str, dict], default: str | None, term: str) -> float:
    """A literal, a number of a record, or an aggregate over a record's numbers."""
    try:
        return float(term)
    except ValueError:
        pass
    numbers, rest = _split_record(records, default, term)
    head, _, pattern = rest.partition(" ")
    if head in AGGREGATES and pattern:
        found = [v for k, v in numbers.items() if fnmatch.fnmatchcase(k, pattern.strip())]
        if not found and head != "count":  # (a count of none is 0)
            raise ValueError(f"no number matches {term.strip()!r}")
        return AGGREGATES[head](found)
    if rest not in numbers:
        raise ValueError(f"no number {term.strip()!r}")
    return numbers[rest]


def _value(records: dict[str, dict], default: str | None, expression: str) -> float:
    """`TERM`, or terms divided left to right (`A / B / C`)."""
    first, *divisors = expression.split(" / ")
    value = _term(records, default, first)
    for divisor in divisors:
        value /= _term(records, default, divisor)
    return value


def format_number(value: float, spec: str) -> str:
    """`value` under a Python format spec, with `k`, `M` and `%` as units (see the module)."""
    if spec[-1:] in UNITS:
        scale, unit = UNITS[spec[-1]]
        return format(value * scale, spec[:-1]) + unit
    return format(value, spec)


def fill(template: str, records: dict[str, dict], default: str | None = None) -> str:
    """`template` with each field replaced by its number from `records`."""
    return FIELD.sub(
        lambda m: format_number(_value(records, default, m["expression"]), m["format"] or ""),
        template,
    )


def render(spec: dict, records: dict[str, dict]) -> str:
    """What stands between a marker pair: a Markdown table on lines of its own, or a value."""
    default = spec.get("record")
    if "text" in spec:
        return fill(spec["text"], records, default)
    align = spec.get("align", "l" * len(spec["columns"]))
    lines = [
        "| " + " | ".join(spec["columns"]) + " |",
        "|" + "|".join("---:" if a == "r" else "---" for a in align) + "|",
    ]
    for row in spec["rows"]:
        lines.append("| " + " | ".join(fill(cell, records, default) for cell in row) + " |")
    return "\n\n" + "\n".join(lines) + "\n\n"  # blank lines: Markdown ends the comment's block


def pages(root: pathlib.Path) -> list[pathlib.Path]:
    return [path for pattern in PAGES for path in sorted(root.glob(pattern))]


def _first_difference(page: str, record: str) -> str:
    for have, want in zip(page.splitlines(), record.splitlines()):
        if have != want:
            return f"page has {have.strip()!r}, records give {want.strip()!r}"
    return f"page has {len(page.splitlines())} lines, records give {len(record.splitlines())}"


def check(root: pathlib.Path) -> list[str]:
    """Each difference between the pages and the records, one line each (none: all agree)."""
    records, layout = load_records(root), load_layout(root)
    problems = [
        f"{RESULTS_DIR}/{name}.json: its numbers are not those of its sources"
        for name, record in records.items()
        if record["numbers"] != numbers_of(record["sources"])
    ]
    for name, record in records.items():
        keep = record.get("keep", ())
        for source in record["sources"]:
            path = root / source["path"]
            if path.is_file() and summarise(path, keep) != source["summary"]:
                problems.append(f"{RESULTS_DIR}/{name}.json: {source['path']} has changed (rebuild it)")
    used = set()
    for page in pages(root):
        relative = page.relative_to(root)
        for match in MARKER.finditer(page.read_text()):
            name = match["name"]
            used.add(name)
            if name not in layout:
                problems.append(f"{relative}: results:{name} has no table in {RESULTS_DIR}/{LAYOUT_FILE}")
                continue
            if "text" in layout[name] and match.string[match.start() - 1 : match.start()] in ("", "\n"):
                problems.append(f"{relative}: results:{name} starts a line (Markdown would not render its text)")
            try:
                wanted = render(layout[name], records)
            except ValueError as error:
                problems.append(f"{relative}: results:{name}: {error}")
                continue
            if match["body"] != wanted:
                difference = _first_difference(match["body"], wanted)
                problems.append(f"{relative}: results:{name} differs from its records: {difference}")
    problems += [f"{RESULTS_DIR}/{LAYOUT_FILE}: {name} is in no page" for name in sorted(set(layout) - used)]
    return problems


def write_pages(root: pathlib.Path) -> list[pathlib.Path]:
    """Renders every marker pair in the pages from the records; returns the pages changed."""
    records, layout = load_records(root), load_layout(root)
    changed = []
    for page in pages(root):
        text = page.read_text()

        def replace(match: re.Match) -> str:
            if match["name"] not in layout:
                raise ValueError(f"{page.relative_to(root)}: results:{match['name']} has no table")
            body = render(layout[match["name"]], records)
            return f"<!-- results:{match['name']} -->{body}<!-- /results:{match['name']} -->"

        new = MARKER.sub(replace, text)
        if new != text:
            page.write_text(new)
            changed.append(page)
    return changed


def _parser() -> argparse.ArgumentParser:
    parser = cli.raising(argparse.ArgumentParser(prog="python -m quadcos.results", description=__doc__.split("\n")[0]))
    parser.add_argument("--root", type=pathlib.Path, default=pathlib.Path("."), help="the repository")
    parser.add_argument("--check", action="store_true", help="compare the pages with the records")
    commands = parser.add_subparsers(dest="command")
    record = commands.add_parser("record", help="write results/NAME.json from evaluation/bench JSONs")
    cli.raising(record)
    record.add_argument("--name", required=True)
    record.add_argument("--claim", required=True, help="the claim, one line")
    record.add_argument("--command", required=True, dest="run_command", help="what produced the JSONs")
    record.add_argument("--device", required=True, help="e.g. 'NVIDIA H100 80GB HBM3', '2 CPU cores'")
    record.add_argument("--commit", help="default: the last commit that changed the first source")
    record.add_argument("--keep", nargs="+", default=[], metavar="GLOB", help="only these values")
    record.add_argument("sources", nargs="+", type=pathlib.Path)
    again = commands.add_parser("rebuild", help="every record (or NAME ...) again from its sources")
    cli.raising(again)
    again.add_argument("names", nargs="*", metavar="NAME")
    small = commands.add_parser("compact", help="rewrite evaluation / bench JSONs as summaries")
    cli.raising(small)
    small.add_argument("paths", nargs="+", type=pathlib.Path, metavar="JSON")
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """CLI entry point; returns the exit status."""
    try:
        args = _parser().parse_args(sys.argv[1:] if argv is None else list(argv))
        root = args.root
        if args.command in (None, "rebuild") and not (root / RESULTS_DIR).is_dir():
            where = root.absolute()
            raise ValueError(f"no {RESULTS_DIR}/ under {where}: run it in the repository or pass"
                             " --root")
        if args.command == "record":
            commit = args.commit or last_commit(args.sources[0], root)
            record = make_record(
                args.name, args.claim, args.run_command, commit, args.device, args.sources, args.keep
            )
            path = write_record(record, root)
            print(f"{path}: {len(record['numbers'])} numbers from {len(record['sources'])} sources")
            return cli.EXIT_OK
        if args.command == "rebuild":
            records = load_records(root)
            unknown = sorted(set(args.names) - set(records))
            if unknown:
                raise ValueError(f"no record {unknown[0]!r}; known: {', '.join(sorted(records))}")
            for name in args.names or sorted(records):
                path = write_record(rebuild(records[name], root), root)
                print(f"{path}: {len(records[name]['numbers'])} numbers")
            return cli.EXIT_OK
        if args.command == "compact":
            saved = compact_files(args.paths)
            print(f"{len(args.paths)} files compacted, {saved:,} bytes saved")
            return cli.EXIT_OK
        if args.check:
            problems = check(root)
            for problem in problems:
                print(problem)
            if not problems:
                print(f"{RESULTS_DIR}/: every page agrees with its records")
            return cli.EXIT_FAILURE if problems else cli.EXIT_OK
        for page in write_pages(root):
            print(f"rendered {page.relative_to(root)}")
        return cli.EXIT_OK
    except (ValueError, OSError, KeyError, json.JSONDecodeError) as error:
        cli.print_error("quadcos.results", error)
        return cli.EXIT_USAGE


if __name__ == "__main__":
    cli.exit_process(main())
