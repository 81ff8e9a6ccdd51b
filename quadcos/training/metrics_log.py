"""Metrics rows of a run: metrics.jsonl, metrics.csv and TensorBoard events."""

import csv
import io
import json
import logging
import math
import os
from pathlib import Path
from typing import Any

from quadcos._util import files, tensorboard

logger = logging.getLogger(__name__)

Row = dict[str, Any]

_LEADING_COLUMNS = ("step", "wall_time_s", "env_steps_per_s")


def read_rows(path: str | os.PathLike[str]) -> list[Row]:
    """Rows of a metrics.jsonl file; a torn last line (crash mid-write) is skipped."""
    path = Path(path)
    if not path.exists():
        return []
    rows = []
    for line in path.read_text(encoding="utf-8").splitlines():
        try:
            rows.append(json.loads(line))
        except json.JSONDecodeError:
            logger.warning("skipping an unreadable line of %s", path)
    return rows


class MetricsLog:
    """Appends one row per evaluation to the run's metric files.

    metrics.jsonl gets each row as one line in a single flushed write;
    metrics.csv is rewritten atomically from all rows (columns may be added
    as new metric names appear); TensorBoard scalars go to `tensorboard/`.
    """

    def __init__(self, run_dir: str | os.PathLike[str], keep_up_to: int | None):
        """Opens the log of `run_dir`.

        Args:
          run_dir: the run directory.
          keep_up_to: when resuming, the checkpoint's env step: rows after it are
            dropped so steps keep increasing. None starts an empty log.
        """
        run_dir = Path(run_dir)
        self._jsonl = run_dir / "metrics.jsonl"
        self._csv = run_dir / "metrics.csv"
        self.rows: list[Row] = []
        if keep_up_to is not None:
            self.rows = [row for row in read_rows(self._jsonl) if row["step"] <= keep_up_to]
        files.atomic_write_text(self._jsonl, "".join(map(_json_line, self.rows)))
        self._write_csv()
        self._tensorboard = tensorboard.ScalarWriter(
            run_dir / "tensorboard",
            purge_step=None if keep_up_to is None else keep_up_to + 1,
        )

    def append(self, row: Row) -> None:
        """Records one row; `row['step']` must exceed the previous row's."""
        if self.rows and row["step"] <= self.rows[-1]["step"]:
            raise ValueError(f"metrics step {row['step']} does not follow {self.rows[-1]['step']}")
        self.rows.append(row)
        with open(self._jsonl, "a", encoding="utf-8") as file:
            file.write(_json_line(row))
            file.flush()
            os.fsync(file.fileno())
        self._write_csv()
        for name, value in row.items():
            if name != "step" and isinstance(value, (int, float)):
                self._tensorboard.add_scalar(name, value, row["step"])
        self._tensorboard.flush()

    def close(self) -> None:
        self._tensorboard.close()

    def _write_csv(self) -> None:
        columns = list(_LEADING_COLUMNS)
        for row in self.rows:
            columns += [name for name in row if name not in columns]
        text = io.StringIO()
        writer = csv.DictWriter(text, fieldnames=columns, lineterminator="\n")
        writer.writeheader()
        writer.writerows(self.rows)
        files.atomic_write_text(self._csv, text.getvalue())


def _json_line(row: Row) -> str:
    # NaN/inf become null so that every line is standard JSON.
    clean = {
        name: None if isinstance(value, float) and not math.isfinite(value) else value
        for name, value in row.items()
    }
    return json.dumps(clean) + "\n"
